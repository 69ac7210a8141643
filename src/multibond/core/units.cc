#include "multibond/core/units.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <numeric>
#include <stdexcept>
#include <string_view>
#include <vector>

#include <fmt/format.h>

#include "multibond/core/identifier.h"

namespace multibond {

namespace {

/// A symbol of the grammar: its exponents of m, kg, s, A, K, mol, cd and its value in SI units.
struct SymbolRow {
  std::string_view symbol;
  std::array<int, kBaseUnits> dim;
  double scale;
};

// The SI's definitions (the SI Brochure, 9th edition, tables 2, 4 and 8).
constexpr std::array<SymbolRow, 38> kSymbols = {{
    {"m", {1, 0, 0, 0, 0, 0, 0}, 1.0},
    {"g", {0, 1, 0, 0, 0, 0, 0}, 1e-3},
    {"s", {0, 0, 1, 0, 0, 0, 0}, 1.0},
    {"A", {0, 0, 0, 1, 0, 0, 0}, 1.0},
    {"K", {0, 0, 0, 0, 1, 0, 0}, 1.0},
    {"mol", {0, 0, 0, 0, 0, 1, 0}, 1.0},
    {"cd", {0, 0, 0, 0, 0, 0, 1}, 1.0},
    {"rad", {0, 0, 0, 0, 0, 0, 0}, 1.0},
    {"sr", {0, 0, 0, 0, 0, 0, 0}, 1.0},
    {"Hz", {0, 0, -1, 0, 0, 0, 0}, 1.0},
    {"N", {1, 1, -2, 0, 0, 0, 0}, 1.0},
    {"Pa", {-1, 1, -2, 0, 0, 0, 0}, 1.0},
    {"J", {2, 1, -2, 0, 0, 0, 0}, 1.0},
    {"W", {2, 1, -3, 0, 0, 0, 0}, 1.0},
    {"C", {0, 0, 1, 1, 0, 0, 0}, 1.0},
    {"V", {2, 1, -3, -1, 0, 0, 0}, 1.0},
    {"F", {-2, -1, 4, 2, 0, 0, 0}, 1.0},
    {"ohm", {2, 1, -3, -2, 0, 0, 0}, 1.0},
    {"\u03a9", {2, 1, -3, -2, 0, 0, 0}, 1.0},
    {"S", {-2, -1, 3, 2, 0, 0, 0}, 1.0},
    {"Wb", {2, 1, -2, -1, 0, 0, 0}, 1.0},
    {"T", {0, 1, -2, -1, 0, 0, 0}, 1.0},
    {"H", {2, 1, -2, -2, 0, 0, 0}, 1.0},
    {"lm", {0, 0, 0, 0, 0, 0, 1}, 1.0},   // cd sr
    {"lx", {-2, 0, 0, 0, 0, 0, 1}, 1.0},  // lm/m^2
    {"Bq", {0, 0, -1, 0, 0, 0, 0}, 1.0},
    {"Gy", {2, 0, -2, 0, 0, 0, 0}, 1.0},
    {"Sv", {2, 0, -2, 0, 0, 0, 0}, 1.0},
    {"kat", {0, 0, -1, 0, 0, 1, 0}, 1.0},
    {"L", {3, 0, 0, 0, 0, 0, 0}, 1e-3},
    {"bar", {-1, 1, -2, 0, 0, 0, 0}, 1e5},
    {"eV", {2, 1, -2, 0, 0, 0, 0}, 1.602176634e-19},
    {"deg", {0, 0, 0, 0, 0, 0, 0}, std::numbers::pi / 180.0},
    {"min", {0, 0, 1, 0, 0, 0, 0}, 60.0},
    {"h", {0, 0, 1, 0, 0, 0, 0}, 3600.0},
    {"rev", {0, 0, 0, 0, 0, 0, 0}, 2.0 * std::numbers::pi},
    {"kg", {0, 1, 0, 0, 0, 0, 0}, 1.0},
    {"t", {0, 1, 0, 0, 0, 0, 0}, 1e3},
}};

struct PrefixRow {
  std::string_view prefix;
  double scale;
};
constexpr std::array<PrefixRow, 22> kPrefixes = {{{"Y", 1e24}, {"Z", 1e21}, {"E", 1e18}, {"P", 1e15}, {"T", 1e12},  {"G", 1e9},
                                                  {"M", 1e6},  {"k", 1e3},  {"h", 1e2},  {"da", 1e1}, {"d", 1e-1},  {"c", 1e-2},
                                                  {"m", 1e-3}, {"u", 1e-6}, {"\u00b5", 1e-6}, {"\u03bc", 1e-6}, {"n", 1e-9}, {"p", 1e-12},
                                                  {"f", 1e-15}, {"a", 1e-18}, {"z", 1e-21}, {"y", 1e-24}}};

const SymbolRow* FindSymbol(std::string_view s) {
  for (const SymbolRow& r : kSymbols)
    if (r.symbol == s) return &r;
  return nullptr;
}

/// A symbol, or a prefix followed by a symbol (a whole symbol first: "min" is a minute, "Pa" a
/// pascal): its value in SI units and its row; nullptr if neither.
const SymbolRow* FindPrefixedSymbol(std::string_view s, double* prefix) {
  *prefix = 1.0;
  if (const SymbolRow* r = FindSymbol(s)) return r;
  for (const PrefixRow& p : kPrefixes)
    if (s.size() > p.prefix.size() && s.substr(0, p.prefix.size()) == p.prefix)
      if (const SymbolRow* r = FindSymbol(s.substr(p.prefix.size()))) {
        *prefix = p.scale;
        return r;
      }
  return nullptr;
}

/// Multiplies `into` by `row`^`power` with the prefix `prefix`.
void Accumulate(Unit& into, const SymbolRow& row, double prefix, int power) {
  for (int i = 0; i < kBaseUnits; ++i) into.dim[i].num += static_cast<std::int64_t>(row.dim[i]) * power;
  into.scale *= std::pow(prefix * row.scale, power);
}

/// "" if `factor` is [prefix] symbol [^[-]d[d]]; adds it to `*out` (raised to `sign`) if given.
std::string ReadFactor(std::string_view factor, int sign, Unit* out) {
  std::string_view base = factor;
  int power = 1;
  if (const auto caret = factor.find('^'); caret != std::string_view::npos) {
    base = factor.substr(0, caret);
    std::string_view e = factor.substr(caret + 1);
    const bool negative = !e.empty() && e[0] == '-';
    if (negative) e.remove_prefix(1);
    const bool digits = !e.empty() && e.size() <= 2 && std::all_of(e.begin(), e.end(), [](char c) { return c >= '0' && c <= '9'; });
    if (!digits || e == "0" || e == "00")
      return fmt::format("'{}' has no whole exponent from 1 to 99 (write e.g. m^2, s^-1)", PrintableExcerpt(std::string(factor)));
    power = 0;
    for (const char c : e) power = power * 10 + (c - '0');
    if (negative) power = -power;
  }
  double prefix = 1.0;
  const SymbolRow* row = FindPrefixedSymbol(base, &prefix);
  if (!row) return fmt::format("'{}' is not a unit symbol (with an optional SI prefix)", PrintableExcerpt(std::string(base)));
  if (out) Accumulate(*out, *row, prefix, sign * power);
  return "";
}

/// "" if `product` is factors separated by single spaces or '*'; "1" alone if `one_ok`.
std::string ReadProduct(std::string_view product, bool one_ok, int sign, Unit* out) {
  if (product.empty()) return "a '/' needs a unit on both sides";
  if (one_ok && product == "1") return "";
  size_t start = 0;
  for (size_t i = 0; i <= product.size(); ++i) {
    if (i < product.size() && product[i] != ' ' && product[i] != '*') continue;
    const std::string_view factor = product.substr(start, i - start);
    if (factor.empty()) return "it has two separators in a row, or one at an end";
    if (std::string why = ReadFactor(factor, sign, out); !why.empty()) return why;
    start = i + 1;
  }
  return "";
}

/// UnitProblem, and the unit's meaning in `*out` if given and the unit is good.
std::string ReadUnit(const std::string& unit, Unit* out) {
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
  if (slash == std::string_view::npos) return ReadProduct(u, false, 1, out);
  if (u.find('/', slash + 1) != std::string_view::npos) return "it holds more than one '/' (everything after the '/' is the denominator: N/(m s) is N/m s)";
  if (std::string why = ReadProduct(u.substr(0, slash), true, 1, out); !why.empty()) return why;
  return ReadProduct(u.substr(slash + 1), false, -1, out);
}

// ---------------------------------------------------------------------------------------------
// Fractions of exponents, bounded: past the bound the analysis gives up on the formula (free).

constexpr std::int64_t kMaxExponentPart = 1'000'000'000;

struct Overflow {};

Exponent Normal(std::int64_t num, std::int64_t den) {
  if (den < 0) num = -num, den = -den;
  const std::int64_t g = std::gcd(num, den);
  if (g > 1) num /= g, den /= g;
  if (num > kMaxExponentPart || num < -kMaxExponentPart || den > kMaxExponentPart) throw Overflow{};
  return {num, den};
}

Exponent Add(const Exponent& a, const Exponent& b, int sign) {
  return Normal(a.num * b.den + sign * b.num * a.den, a.den * b.den);  // each part below 1e9: no overflow
}

Exponent Times(const Exponent& a, const Exponent& f) { return Normal(a.num * f.num, a.den * f.den); }

/// `v` as a fraction with a denominator of at most 100, if it is one.
std::optional<Exponent> AsFraction(double v) {
  if (!std::isfinite(v) || std::abs(v) > 1e6) return std::nullopt;
  for (std::int64_t den = 1; den <= 100; ++den) {
    const double x = v * static_cast<double>(den);
    const double r = std::round(x);
    if (std::abs(x - r) <= 1e-9 * std::max(1.0, std::abs(x))) return Normal(static_cast<std::int64_t>(r), den);
  }
  return std::nullopt;
}

bool SameScale(double a, double b) { return std::abs(a - b) <= 1e-9 * std::max(std::abs(a), std::abs(b)); }

std::string FormatExponent(const Exponent& e) {
  if (e.den == 1) return e.num == 1 ? "" : fmt::format("^{}", e.num);
  return fmt::format("^({}/{})", e.num, e.den);
}

// ---------------------------------------------------------------------------------------------
// The analysis: a walk over the tree; the first mismatch stops it.

struct Stop {
  UnitMismatch mismatch;
};

FormulaUnit Number() {
  FormulaUnit u;
  u.kind = FormulaUnit::Kind::kNumber;
  return u;
}

FormulaUnit Free() { return {}; }

/// A value without dimension of scale 1 (a sine, an angle in rad): a number that does not adapt.
FormulaUnit Dimensionless() {
  FormulaUnit u;
  u.kind = FormulaUnit::Kind::kUnit;
  return u;
}

bool IsUnit(const FormulaUnit& u) { return u.kind == FormulaUnit::Kind::kUnit; }

class Checker {
 public:
  Checker(std::string_view text, const std::function<std::optional<DeclaredUnit>(const std::string&)>& unit_of,
          const std::function<std::optional<double>(const std::string&)>& value_of)
      : text_(text), unit_of_(unit_of), value_of_(value_of) {}

  FormulaUnit Of(const expr::Node& n) {
    using K = expr::Node::Kind;
    auto chained = [](K k) { return k == K::kAdd || k == K::kSub || k == K::kMul || k == K::kDiv; };
    if (chained(n.kind)) {
      // A long sum or product nests to the left as deep as it is long (a thousand terms): its
      // left spine is walked in a loop, not by recursion. What nests to the right is bounded by
      // the parser (kMaxFormulaDepth).
      std::vector<const expr::Node*> spine;
      const expr::Node* x = &n;
      for (; chained(x->kind); x = x->args[0].get()) spine.push_back(x);
      FormulaUnit left = Of(*x);
      for (auto it = spine.rbegin(); it != spine.rend(); ++it) {
        const expr::Node& b = **it;
        const FormulaUnit right = Of(*b.args[1]);
        if (b.kind == K::kMul || b.kind == K::kDiv) left = Product(left, right, b.kind == K::kDiv);
        else left = Same(left, right, *b.args[0], *b.args[1], OperatorOffset(b), b.kind == K::kAdd ? "'+'" : "'-'", nullptr);
      }
      return left;
    }
    switch (n.kind) {
      case K::kNumber: return Number();
      case K::kName: {
        if (n.name == "pi") return Number();
        const std::optional<DeclaredUnit> d = unit_of_(n.name);
        if (!d) return Free();
        FormulaUnit u;
        u.kind = FormulaUnit::Kind::kUnit;
        u.unit = d->unit;
        if (d->text != "-" && d->text != "1") u.label = d->text;  // "a number" says more
        return u;
      }
      case K::kNeg: return Of(*n.args[0]);
      case K::kAdd:
      case K::kSub:
      case K::kMul:
      case K::kDiv: break;  // above
      case K::kPow: return Power(n);
      case K::kCall: return Call(n);
    }
    return Free();
  }

 private:
  std::string_view text_;
  const std::function<std::optional<DeclaredUnit>(const std::string&)>& unit_of_;
  const std::function<std::optional<double>(const std::string&)>& value_of_;

  [[noreturn]] static void Fail(int offset, std::string message, std::string hint) {
    throw Stop{UnitMismatch{offset, std::move(message), std::move(hint)}};
  }

  /// The offset of a binary node's operator: the last '+', '-', '*', '/' or '^' before its right
  /// operand that is not a sign of that operand (blanks, '(' and signs lie between).
  int OperatorOffset(const expr::Node& n) const {
    using K = expr::Node::Kind;
    const int right = n.args[1]->offset;
    if (right <= 0 || static_cast<size_t>(right) > text_.size()) return n.offset;
    const char op = n.kind == K::kMul ? '*' : n.kind == K::kDiv ? '/' : n.kind == K::kPow ? '^' : '\0';
    int found = -1;
    for (int i = right - 1; i >= 0; --i) {
      const char c = text_[static_cast<size_t>(i)];
      if (op != '\0' && c == op) return i;
      const bool sign = c == '+' || c == '-';
      if (op == '\0' && sign) found = i;  // the leftmost of the signs is the operator
      else if (!(c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '(' || sign)) break;
    }
    return found >= 0 ? found : n.offset;
  }

  /// The offset of the operator of a comparison, `and` or `or` (a call of the table written as
  /// an operator): its text just before its right operand, past blanks, '(' and '+' signs.
  int CallOperatorOffset(const expr::Node& n) const {
    const std::string_view op = expr::Info(n.fn).op;
    int i = n.args[1]->offset - 1;
    if (i < 0 || static_cast<size_t>(i) >= text_.size()) return n.offset;
    while (i >= 0) {
      const char c = text_[static_cast<size_t>(i)];
      if (!(c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '(' || c == '+')) break;
      --i;
    }
    const int begin = i - static_cast<int>(op.size()) + 1;
    if (begin >= 0 && text_.substr(static_cast<size_t>(begin), op.size()) == op) return begin;
    return n.offset;
  }

  /// `u`, an operand of and, or, not or the condition of if, is a truth value: a comparison, or
  /// a number without dimension (of any scale: x != 0 does not depend on it).
  void RequireTruth(const FormulaUnit& u, const expr::Node& arg, int offset, const char* op) const {
    if (!IsUnit(u) || IsDimensionless(u.unit.dim)) return;
    Fail(offset,
         std::string_view(op) == "if"
             ? fmt::format("the condition '{}' of if is {}: a condition is a truth value (a comparison, or a number without dimension)",
                           Excerpt(arg), DescribeUnit(u))
             : fmt::format("'{}', an operand of '{}', is {}: the operands of and, or and not are truth values (comparisons, or "
                           "numbers without dimension)",
                           Excerpt(arg), op, DescribeUnit(u)),
         fmt::format("compare it, as in {} > 0 or {} != 0", Excerpt(arg), Excerpt(arg)));
  }

  /// One past the last character of the node in the text.
  size_t End(const expr::Node& n) const {
    using K = expr::Node::Kind;
    switch (n.kind) {
      case K::kNumber: {
        size_t i = static_cast<size_t>(n.offset);
        auto digits = [&] {
          while (i < text_.size() && text_[i] >= '0' && text_[i] <= '9') ++i;
        };
        digits();
        if (i < text_.size() && text_[i] == '.') ++i, digits();
        if (i < text_.size() && (text_[i] == 'e' || text_[i] == 'E')) {
          ++i;
          if (i < text_.size() && (text_[i] == '+' || text_[i] == '-')) ++i;
          digits();
        }
        return i;
      }
      case K::kName: return static_cast<size_t>(n.offset) + n.name.size();
      case K::kCall: {
        if (expr::Info(n.fn).op) return End(*n.args.back());  // an operator: a < b, a and b, not a
        size_t i = text_.find('(', static_cast<size_t>(n.offset));
        for (int depth = 0; i < text_.size(); ++i) {
          if (text_[i] == '(') ++depth;
          if (text_[i] == ')' && --depth == 0) return i + 1;
        }
        return text_.size();
      }
      case K::kNeg: return End(*n.args[0]);
      default: return End(*n.args[1]);
    }
  }

  /// The text of a node for a message, with the parentheses it needs to read.
  std::string Excerpt(const expr::Node& n) const {
    size_t begin = std::min(static_cast<size_t>(std::max(n.offset, 0)), text_.size());
    size_t end = std::clamp(End(n), begin, text_.size());
    int balance = 0;
    for (size_t i = begin; i < end; ++i) balance += text_[i] == '(' ? 1 : text_[i] == ')' ? -1 : 0;
    while (balance < 0 && begin > 0) {
      --begin;
      if (text_[begin] == '(') ++balance;
    }
    while (balance > 0 && end < text_.size()) {
      if (text_[end] == ')') --balance;
      ++end;
    }
    return PrintableExcerpt(std::string(text_.substr(begin, end - begin)), 40);
  }

  /// The unit of the sides of a sum (or of the arguments of min, max, ...): one dimension, and one
  /// scale where both are known. `where`: "'+'", or nullptr for the arguments of `fn`.
  /// `what`, `hint`: the message's subject and the hint on different dimensions, instead of those
  /// said of where/fn (a comparison's, the branches of if).
  FormulaUnit Same(const FormulaUnit& a, const FormulaUnit& b, const expr::Node& na, const expr::Node& nb, int offset,
                   const char* where, const char* fn, const char* what_instead = nullptr, const char* hint_instead = nullptr) {
    if (!IsUnit(a) || !IsUnit(b)) {
      if (IsUnit(a)) return a;
      if (IsUnit(b)) return b;
      return a.kind == FormulaUnit::Kind::kFree || b.kind == FormulaUnit::Kind::kFree ? Free() : Number();
    }
    const std::string what = what_instead ? std::string(what_instead)
                             : where      ? fmt::format("the two sides of {}", where)
                                          : fmt::format("the arguments of {}", fn);
    const std::string sides = fmt::format("'{}' is {}, '{}' is {}", Excerpt(na), DescribeUnit(a), Excerpt(nb), DescribeUnit(b));
    if (a.unit.dim != b.unit.dim)
      Fail(offset, fmt::format("{} have different units: {}", what, sides),
           hint_instead ? std::string(hint_instead)
           : where      ? "the terms of a sum need one dimension; check the formula and the units of its parameters"
                        : fmt::format("{} needs one dimension in all its arguments; check the formula and the units of its parameters", fn));
    FormulaUnit u = a;
    if (a.scale_known && b.scale_known && !SameScale(a.unit.scale, b.unit.scale))
      Fail(offset, fmt::format("{} have units of one dimension but of different sizes: {} (values are not converted)", what, sides),
           "convert one of them with its factor (a number times a quantity takes the unit it needs: d/1000 for a d in mm "
           "is taken as m), or declare both in one unit");
    u.scale_known = a.scale_known && b.scale_known;
    if (a.label != b.label) u.label.clear();
    return u;
  }

  static FormulaUnit Product(const FormulaUnit& a, const FormulaUnit& b, bool divide) {
    using Kind = FormulaUnit::Kind;
    if (a.kind == Kind::kFree || b.kind == Kind::kFree) return Free();
    if (a.kind == Kind::kNumber && b.kind == Kind::kNumber) return Number();
    FormulaUnit u;
    u.kind = Kind::kUnit;
    u.scale_known = IsUnit(a) && IsUnit(b) && a.scale_known && b.scale_known;  // a number factor: a conversion, maybe
    const Unit one;
    const Unit& x = IsUnit(a) ? a.unit : one;
    const Unit& y = IsUnit(b) ? b.unit : one;
    try {
      for (int i = 0; i < kBaseUnits; ++i) u.unit.dim[i] = Add(x.dim[i], y.dim[i], divide ? -1 : 1);
    } catch (const Overflow&) {
      return Free();
    }
    u.unit.scale = divide ? x.scale / y.scale : x.scale * y.scale;
    return u;
  }

  /// `u` raised to the fraction `f` (the value `v`).
  static FormulaUnit Raise(const FormulaUnit& u, const Exponent& f, double v) {
    FormulaUnit r = u;
    r.label.clear();
    try {
      for (Exponent& e : r.unit.dim) e = Times(e, f);
    } catch (const Overflow&) {
      return Free();
    }
    r.unit.scale = std::pow(u.unit.scale, v);
    return r;
  }

  /// `u`, the argument of `fn` (or the exponent of a '^', fn = nullptr), is a number.
  void RequireNumber(const FormulaUnit& u, const expr::Node& arg, int offset, const char* fn) const {
    if (!IsUnit(u)) return;
    const std::string what = fn ? fmt::format("{} of '{}'", fn, Excerpt(arg)) : fmt::format("the exponent '{}'", Excerpt(arg));
    const std::string_view name = fn ? fn : "";
    const bool angle = name == "sin" || name == "cos" || name == "tan";
    if (!IsDimensionless(u.unit.dim))
      Fail(offset,
           !fn     ? fmt::format("{} is {}: an exponent is a number without dimension", what, DescribeUnit(u))
           : angle ? fmt::format("{}, which is {}: {} takes a number without dimension (an angle in rad)", what, DescribeUnit(u), fn)
                   : fmt::format("{}, which is {}: {} takes a number without dimension", what, DescribeUnit(u), fn),
           "divide it by a quantity of its unit (a ratio L/L0 is a number), or check the units of its parameters");
    if (u.scale_known && !SameScale(u.unit.scale, 1.0))
      Fail(offset,
           angle ? fmt::format("{}, which is {}: {} takes an angle in rad, and values are not converted", what, DescribeUnit(u), fn)
                 : fmt::format("{}, which is {}: {} a plain number, and values are not converted", what, DescribeUnit(u),
                               fn ? fmt::format("{} takes", fn) : std::string("an exponent is")),
           angle ? "multiply it by its factor (an angle in deg times pi/180 is taken as rad), or give the parameter in rad"
                 : "multiply it by its factor (a number times a quantity takes the unit it needs), or declare the parameters in units "
                   "of one size");
  }

  FormulaUnit Power(const expr::Node& n) {
    const int offset = OperatorOffset(n);
    const FormulaUnit base = Of(*n.args[0]);
    const FormulaUnit exponent = Of(*n.args[1]);
    RequireNumber(exponent, *n.args[1], offset, nullptr);
    if (!IsUnit(base)) return base;
    std::optional<double> v;
    try {
      v = expr::Evaluate(*n.args[1], [&](const std::string& id) -> std::optional<double> {
        return id == "pi" ? std::optional<double>(std::numbers::pi) : value_of_(id);
      });
    } catch (const std::domain_error&) {
      v.reset();
    }
    if (IsDimensionless(base.unit.dim)) {  // a number of some scale: only its scale changes
      FormulaUnit r = base;
      r.label.clear();
      if (v) r.unit.scale = std::pow(base.unit.scale, *v);
      else r.scale_known = r.scale_known && SameScale(base.unit.scale, 1.0);
      return r;
    }
    if (!v)
      Fail(offset, fmt::format("'{}' ({}) raised to '{}', which is not a constant: a quantity with a unit has a constant exponent",
                               Excerpt(*n.args[0]), DescribeUnit(base), Excerpt(*n.args[1])),
           "divide the base by a quantity of its unit first (a ratio L/L0 is a number)");
    const std::optional<Exponent> f = AsFraction(*v);
    if (!f)
      Fail(offset, fmt::format("'{}' ({}) raised to {:g}: the exponent of a quantity with a unit is a whole number or a fraction "
                               "(at most /100)", Excerpt(*n.args[0]), DescribeUnit(base), *v),
           "divide the base by a quantity of its unit first (a ratio L/L0 is a number)");
    return Raise(base, *f, *v);
  }

  FormulaUnit Call(const expr::Node& n) {
    using expr::Fn;
    const char* name = expr::Info(n.fn).name;
    std::vector<FormulaUnit> args;
    for (const expr::NodePtr& a : n.args) args.push_back(Of(*a));
    switch (n.fn) {
      case Fn::kSin: case Fn::kCos: case Fn::kTan: case Fn::kAsin: case Fn::kAcos: case Fn::kAtan:
      case Fn::kSinh: case Fn::kCosh: case Fn::kTanh: case Fn::kExp: case Fn::kLog:
        RequireNumber(args[0], *n.args[0], n.offset, name);
        return Dimensionless();
      case Fn::kSqrt:
        if (!IsUnit(args[0])) return args[0];
        return Raise(args[0], Exponent{1, 2}, 0.5);
      case Fn::kAbs: return args[0];
      case Fn::kSign: return Dimensionless();
      case Fn::kMin: case Fn::kMax: case Fn::kHypot: case Fn::kSmoothAbs:
        return Same(args[0], args[1], *n.args[0], *n.args[1], n.offset, nullptr, name);
      case Fn::kClamp: {
        const FormulaUnit lo = Same(args[0], args[1], *n.args[0], *n.args[1], n.offset, nullptr, name);
        // The upper bound against the bound or the value that gave the unit.
        const expr::Node& with = IsUnit(args[0]) ? *n.args[0] : *n.args[1];
        return Same(lo, args[2], with, *n.args[2], n.offset, nullptr, name);
      }
      case Fn::kAtan2: case Fn::kSmoothSign:
        (void)Same(args[0], args[1], *n.args[0], *n.args[1], n.offset, nullptr, name);
        return Dimensionless();
      case Fn::kLt: case Fn::kLe: case Fn::kGt: case Fn::kGe: case Fn::kEq: case Fn::kNe: {
        const std::string where = fmt::format("'{}'", expr::Info(n.fn).op);
        (void)Same(args[0], args[1], *n.args[0], *n.args[1], CallOperatorOffset(n), where.c_str(), nullptr, nullptr,
                   "the sides of a comparison need one dimension; check the formula and the units of its parameters");
        return Dimensionless();
      }
      case Fn::kAnd: case Fn::kOr:
        RequireTruth(args[0], *n.args[0], CallOperatorOffset(n), expr::Info(n.fn).op);
        RequireTruth(args[1], *n.args[1], CallOperatorOffset(n), expr::Info(n.fn).op);
        return Dimensionless();
      case Fn::kNot:
        RequireTruth(args[0], *n.args[0], n.offset, "not");
        return Dimensionless();
      case Fn::kIf:
        RequireTruth(args[0], *n.args[0], n.offset, "if");
        return Same(args[1], args[2], *n.args[1], *n.args[2], n.offset, nullptr, name, "the two branches of if",
                    "the value where the condition holds and the value where it does not need one dimension; check the formula "
                    "and the units of its parameters");
    }
    return Free();
  }
};

}  // namespace

std::string UnitProblem(const std::string& unit) { return ReadUnit(unit, nullptr); }

std::string TimeIntegralUnit(const std::string& unit) {
  if (unit.empty()) return "";
  if (unit == "-" || unit == "1") return "s";
  if (unit == "1/s") return "-";
  const std::size_t slash = unit.find('/');
  if (slash == std::string::npos) return unit + " s";
  const std::string num = unit.substr(0, slash), den = unit.substr(slash + 1);
  if (den == "s") return num == "1" ? "-" : num;
  return (num == "1" ? std::string("s") : num + " s") + "/" + den;
}

std::optional<Unit> ParseUnit(const std::string& unit) {
  Unit u;
  if (!ReadUnit(unit, &u).empty()) return std::nullopt;
  return u;
}

bool IsDimensionless(const Dimension& d) {
  return std::all_of(d.begin(), d.end(), [](const Exponent& e) { return e.num == 0; });
}

std::string FormatDimension(const Dimension& d) {
  std::string up, down;
  for (int i = 0; i < kBaseUnits; ++i) {
    const Exponent& e = d[i];
    if (e.num == 0) continue;
    std::string& side = e.num > 0 ? up : down;
    if (!side.empty()) side += ' ';
    side += kBaseUnitSymbols[i];
    side += FormatExponent({e.num > 0 ? e.num : -e.num, e.den});
  }
  if (down.empty()) return up.empty() ? std::string("1") : up;
  return fmt::format("{}/{}", up.empty() ? std::string("1") : up, down);
}

std::string DescribeUnit(const FormulaUnit& u) {
  switch (u.kind) {
    case FormulaUnit::Kind::kFree: return "of any unit";
    case FormulaUnit::Kind::kNumber: return "a number";
    case FormulaUnit::Kind::kUnit: break;
  }
  if (!u.label.empty()) return u.label;
  const bool none = IsDimensionless(u.unit.dim);
  const std::string dim = none ? "a number" : FormatDimension(u.unit.dim);
  if (!u.scale_known || SameScale(u.unit.scale, 1.0)) return dim;
  return none ? fmt::format("a number in units of {:g}", u.unit.scale) : fmt::format("{:g} {}", u.unit.scale, dim);
}

UnitMatch MatchUnit(const FormulaUnit& got, const Unit& want) {
  if (got.kind != FormulaUnit::Kind::kUnit) return UnitMatch::kSame;
  if (got.unit.dim != want.dim) return UnitMatch::kDimension;
  if (got.scale_known && !SameScale(got.unit.scale, want.scale)) return UnitMatch::kScale;
  return UnitMatch::kSame;
}

FormulaUnits CheckFormulaUnits(const expr::Node& root, std::string_view text,
                               const std::function<std::optional<DeclaredUnit>(const std::string&)>& unit_of,
                               const std::function<std::optional<double>(const std::string&)>& value_of) {
  FormulaUnits out;
  try {
    out.unit = Checker(text, unit_of, value_of).Of(root);
  } catch (const Stop& s) {
    out.mismatch = s.mismatch;
  }
  return out;
}

}  // namespace multibond
