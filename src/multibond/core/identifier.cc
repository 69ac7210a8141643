#include "multibond/core/identifier.h"

#include <fmt/format.h>

namespace multibond {

namespace {

bool Letter(char c) { return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || c == '_'; }
bool Digit(char c) { return c >= '0' && c <= '9'; }

std::string DescribeChar(char c) {
  const auto u = static_cast<unsigned char>(c);
  if (c == '.') return "'.' (it separates the parts of result column names, as in spring.q)";
  if (c == '-' || c == '>') return fmt::format("'{}' (a bond is written 'from -> to'; use '_' within a name)", c);
  if (c == ' ' || c == '\t') return "a space";
  if (u < 0x20 || u == 0x7f) return fmt::format("a control character (byte 0x{:02x})", u);
  if (u >= 0x80) return "a non-ASCII character";
  return fmt::format("'{}'", c);
}

}  // namespace

std::string IdentifierProblem(const std::string& name, bool digit_first) {
  if (name.empty()) return "is empty";
  if (name.size() > kMaxNameLength) return fmt::format("is {} characters long (at most {})", name.size(), kMaxNameLength);
  for (const char c : name)
    if (!Letter(c) && !Digit(c)) return "holds " + DescribeChar(c);
  if (!digit_first && Digit(name[0])) return "starts with a digit";
  return "";
}

std::string SuggestIdentifier(const std::string& name) {
  std::string s;
  for (const char c : name) {
    if (s.size() >= kMaxNameLength) break;
    const bool ok = Letter(c) || Digit(c);
    if (ok) s += c;
    else if (!s.empty() && s.back() != '_') s += '_';
  }
  while (!s.empty() && s.back() == '_' && s.size() > 1) s.pop_back();
  if (!s.empty() && Digit(s[0])) s.insert(s.begin(), '_');
  if (s.size() > kMaxNameLength) s.resize(kMaxNameLength);
  return s;
}

std::string PrintableExcerpt(const std::string& text, std::size_t max) {
  std::string out;
  for (const char c : text) {
    if (out.size() >= max) return out + "...";
    const auto u = static_cast<unsigned char>(c);
    out += u < 0x20 || u >= 0x7f ? '?' : c;
  }
  return out;
}

}  // namespace multibond
