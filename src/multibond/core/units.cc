#include "multibond/core/units.h"

#include <algorithm>
#include <array>
#include <string_view>

#include <fmt/format.h>

#include "multibond/core/identifier.h"

namespace multibond {

namespace {

constexpr std::array<std::string_view, 38> kSymbols = {
    "m", "g", "s", "A", "K", "mol", "cd", "rad", "sr", "Hz", "N", "Pa", "J", "W", "C", "V", "F", "ohm", "\u03a9",
    "S", "Wb", "T", "H", "lm", "lx", "Bq", "Gy", "Sv", "kat", "L", "bar", "eV", "deg", "min", "h", "rev", "kg", "t"};
constexpr std::array<std::string_view, 22> kPrefixes = {"Y", "Z", "E", "P", "T", "G", "M", "k", "h", "da", "d",
                                                        "c", "m", "u", "\u00b5", "\u03bc", "n", "p", "f", "a", "z", "y"};

bool IsSymbol(std::string_view s) { return std::find(kSymbols.begin(), kSymbols.end(), s) != kSymbols.end(); }

/// A symbol, or a prefix followed by a symbol.
bool IsPrefixedSymbol(std::string_view s) {
  if (IsSymbol(s)) return true;
  for (const std::string_view p : kPrefixes)
    if (s.size() > p.size() && s.substr(0, p.size()) == p && IsSymbol(s.substr(p.size()))) return true;
  return false;
}

/// "" if `factor` is [prefix] symbol [^[-]d[d]].
std::string FactorProblem(std::string_view factor) {
  std::string_view base = factor;
  if (const auto caret = factor.find('^'); caret != std::string_view::npos) {
    base = factor.substr(0, caret);
    std::string_view e = factor.substr(caret + 1);
    if (!e.empty() && e[0] == '-') e.remove_prefix(1);
    const bool digits = !e.empty() && e.size() <= 2 && std::all_of(e.begin(), e.end(), [](char c) { return c >= '0' && c <= '9'; });
    if (!digits || e == "0" || e == "00")
      return fmt::format("'{}' has no whole exponent from 1 to 99 (write e.g. m^2, s^-1)", PrintableExcerpt(std::string(factor)));
  }
  if (!IsPrefixedSymbol(base)) return fmt::format("'{}' is not a unit symbol (with an optional SI prefix)", PrintableExcerpt(std::string(base)));
  return "";
}

/// "" if `product` is factors separated by single spaces or '*'; "1" alone if `one_ok`.
std::string ProductProblem(std::string_view product, bool one_ok) {
  if (product.empty()) return "a '/' needs a unit on both sides";
  if (one_ok && product == "1") return "";
  size_t start = 0;
  for (size_t i = 0; i <= product.size(); ++i) {
    if (i < product.size() && product[i] != ' ' && product[i] != '*') continue;
    const std::string_view factor = product.substr(start, i - start);
    if (factor.empty()) return "it has two separators in a row, or one at an end";
    if (std::string why = FactorProblem(factor); !why.empty()) return why;
    start = i + 1;
  }
  return "";
}

}  // namespace

std::string UnitProblem(const std::string& unit) {
  if (unit.empty()) return "it is empty (write '-' for a quantity without unit)";
  if (unit.size() > kMaxUnitLength) return fmt::format("it is {} bytes long (at most {})", unit.size(), kMaxUnitLength);
  if (unit == "-" || unit == "1") return "";
  for (const char c : unit) {
    const auto u = static_cast<unsigned char>(c);
    if (u < 0x20 || u == 0x7f) return fmt::format("it holds a control character (byte 0x{:02x}, e.g. a line break)", u);
    if (c == '`' || c == '"' || c == '\'' || c == '\\' || c == '$' || c == '<' || c == '>' || c == '&' || c == ';' || c == '(' || c == ')')
      return fmt::format("it holds '{}', which no unit has", c);
  }
  const std::string_view u = unit;
  const auto slash = u.find('/');
  if (slash == std::string_view::npos) return ProductProblem(u, false);
  if (u.find('/', slash + 1) != std::string_view::npos) return "it holds more than one '/' (everything after the '/' is the denominator: N/(m s) is N/m s)";
  if (std::string why = ProductProblem(u.substr(0, slash), true); !why.empty()) return why;
  return ProductProblem(u.substr(slash + 1), false);
}

}  // namespace multibond
