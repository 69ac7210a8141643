#include "multibond/compile/symbolic.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <mutex>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <fmt/format.h>
#include <ginac/ginac.h>

#include "multibond/core/error.h"

namespace multibond::expr {

namespace {

// ---------------------------------------------------------------------------------------------
// The functions of formulas that GiNaC does not have, as GiNaC functions with their derivatives
// (GiNaC's csgn has no derivative: sign is one of ours too). Their values at numbers are those of
// Apply (min/max of NaN aside: GiNaC has none).

DECLARE_FUNCTION_1P(mb_sign)
DECLARE_FUNCTION_2P(mb_min)
DECLARE_FUNCTION_2P(mb_max)
DECLARE_FUNCTION_2P(mb_hypot)
DECLARE_FUNCTION_3P(mb_clamp)
DECLARE_FUNCTION_2P(mb_smoothabs)
DECLARE_FUNCTION_2P(mb_smoothsign)
DECLARE_FUNCTION_2P(mb_lt)
DECLARE_FUNCTION_2P(mb_le)
DECLARE_FUNCTION_2P(mb_gt)
DECLARE_FUNCTION_2P(mb_ge)
DECLARE_FUNCTION_2P(mb_eq)
DECLARE_FUNCTION_2P(mb_ne)
DECLARE_FUNCTION_2P(mb_and)
DECLARE_FUNCTION_2P(mb_or)
DECLARE_FUNCTION_1P(mb_not)
DECLARE_FUNCTION_3P(mb_if)

bool IsReal(const GiNaC::ex& e) { return GiNaC::is_exactly_a<GiNaC::numeric>(e) && GiNaC::ex_to<GiNaC::numeric>(e).is_real(); }
const GiNaC::numeric& Num(const GiNaC::ex& e) { return GiNaC::ex_to<GiNaC::numeric>(e); }

GiNaC::ex SignOf(const GiNaC::numeric& x) { return x.is_zero() ? 0 : (x.is_positive() ? 1 : -1); }

/// (1 + s)/2 and (1 - s)/2 for s = sign(a - b): the derivative of min and max in one argument
/// (1 where that argument is the one chosen, 0 where it is not, 1/2 at a tie).
GiNaC::ex Half(int sign_of_s, const GiNaC::ex& a, const GiNaC::ex& b) {
  return (1 + sign_of_s * mb_sign(a - b)) / 2;
}

GiNaC::ex SignEval(const GiNaC::ex& x) {
  if (IsReal(x)) return SignOf(Num(x));
  return mb_sign(x).hold();
}
GiNaC::ex SignEvalf(const GiNaC::ex& x) {
  const GiNaC::ex v = x.evalf();
  return IsReal(v) ? SignOf(Num(v)) : mb_sign(v).hold();
}
GiNaC::ex SignDeriv(const GiNaC::ex&, unsigned) { return 0; }
REGISTER_FUNCTION(mb_sign, eval_func(SignEval).evalf_func(SignEvalf).derivative_func(SignDeriv))

GiNaC::ex MinEval(const GiNaC::ex& a, const GiNaC::ex& b) {
  if (IsReal(a) && IsReal(b)) return Num(b) < Num(a) ? b : a;
  if (a.is_equal(b)) return a;
  return mb_min(a, b).hold();
}
GiNaC::ex MinEvalf(const GiNaC::ex& a, const GiNaC::ex& b) { return MinEval(a.evalf(), b.evalf()); }
GiNaC::ex MinDeriv(const GiNaC::ex& a, const GiNaC::ex& b, unsigned i) { return i == 0 ? Half(-1, a, b) : Half(1, a, b); }
REGISTER_FUNCTION(mb_min, eval_func(MinEval).evalf_func(MinEvalf).derivative_func(MinDeriv))

GiNaC::ex MaxEval(const GiNaC::ex& a, const GiNaC::ex& b) {
  if (IsReal(a) && IsReal(b)) return Num(a) < Num(b) ? b : a;
  if (a.is_equal(b)) return a;
  return mb_max(a, b).hold();
}
GiNaC::ex MaxEvalf(const GiNaC::ex& a, const GiNaC::ex& b) { return MaxEval(a.evalf(), b.evalf()); }
GiNaC::ex MaxDeriv(const GiNaC::ex& a, const GiNaC::ex& b, unsigned i) { return i == 0 ? Half(1, a, b) : Half(-1, a, b); }
REGISTER_FUNCTION(mb_max, eval_func(MaxEval).evalf_func(MaxEvalf).derivative_func(MaxDeriv))

// hypot(x, y) = sqrt(x^2 + y^2), kept as a function (it does not overflow where x^2 would).
GiNaC::ex HypotEval(const GiNaC::ex& x, const GiNaC::ex& y) {
  if (IsReal(x) && IsReal(y)) return GiNaC::sqrt(x * x + y * y);
  return mb_hypot(x, y).hold();
}
GiNaC::ex HypotEvalf(const GiNaC::ex& x, const GiNaC::ex& y) {
  const GiNaC::ex a = x.evalf(), b = y.evalf();
  return IsReal(a) && IsReal(b) ? GiNaC::sqrt(a * a + b * b).evalf() : mb_hypot(a, b).hold();
}
GiNaC::ex HypotDeriv(const GiNaC::ex& x, const GiNaC::ex& y, unsigned i) { return (i == 0 ? x : y) / mb_hypot(x, y); }
REGISTER_FUNCTION(mb_hypot, eval_func(HypotEval).evalf_func(HypotEvalf).derivative_func(HypotDeriv))

// clamp(x, lo, hi): lo below lo, hi above hi, x between.
GiNaC::ex ClampEval(const GiNaC::ex& x, const GiNaC::ex& lo, const GiNaC::ex& hi) {
  if (IsReal(x) && IsReal(lo) && IsReal(hi)) return Num(x) < Num(lo) ? lo : (Num(hi) < Num(x) ? hi : x);
  return mb_clamp(x, lo, hi).hold();
}
GiNaC::ex ClampEvalf(const GiNaC::ex& x, const GiNaC::ex& lo, const GiNaC::ex& hi) {
  return ClampEval(x.evalf(), lo.evalf(), hi.evalf());
}
// d/dx = 1 strictly between the bounds: (sign(x - lo) + sign(hi - x))/2; d/dlo = 1 below lo:
// (1 - sign(x - lo))/2; d/dhi = 1 above hi: (1 - sign(hi - x))/2.
GiNaC::ex ClampDeriv(const GiNaC::ex& x, const GiNaC::ex& lo, const GiNaC::ex& hi, unsigned i) {
  if (i == 0) return (mb_sign(x - lo) + mb_sign(hi - x)) / 2;
  if (i == 1) return (1 - mb_sign(x - lo)) / 2;
  return (1 - mb_sign(hi - x)) / 2;
}
REGISTER_FUNCTION(mb_clamp, eval_func(ClampEval).evalf_func(ClampEvalf).derivative_func(ClampDeriv))

// smoothabs(x, eps) = sqrt(x^2 + eps^2): d/dx = x/smoothabs = smoothsign(x, eps), d/deps =
// smoothsign(eps, x).
GiNaC::ex SmoothAbsEval(const GiNaC::ex& x, const GiNaC::ex& eps) {
  if (IsReal(x) && IsReal(eps)) return GiNaC::sqrt(x * x + eps * eps);
  return mb_smoothabs(x, eps).hold();
}
GiNaC::ex SmoothAbsEvalf(const GiNaC::ex& x, const GiNaC::ex& eps) {
  const GiNaC::ex a = x.evalf(), b = eps.evalf();
  return IsReal(a) && IsReal(b) ? GiNaC::sqrt(a * a + b * b).evalf() : mb_smoothabs(a, b).hold();
}
GiNaC::ex SmoothAbsDeriv(const GiNaC::ex& x, const GiNaC::ex& eps, unsigned i) {
  return i == 0 ? mb_smoothsign(x, eps) : mb_smoothsign(eps, x);
}
REGISTER_FUNCTION(mb_smoothabs, eval_func(SmoothAbsEval).evalf_func(SmoothAbsEvalf).derivative_func(SmoothAbsDeriv))

// smoothsign(x, eps) = x / sqrt(x^2 + eps^2): d/dx = eps^2 / smoothabs^3, d/deps = -x eps / smoothabs^3.
GiNaC::ex SmoothSignEval(const GiNaC::ex& x, const GiNaC::ex& eps) {
  if (IsReal(x) && IsReal(eps) && !(Num(x).is_zero() && Num(eps).is_zero())) return x / GiNaC::sqrt(x * x + eps * eps);
  return mb_smoothsign(x, eps).hold();
}
GiNaC::ex SmoothSignEvalf(const GiNaC::ex& x, const GiNaC::ex& eps) {
  const GiNaC::ex a = x.evalf(), b = eps.evalf();
  if (IsReal(a) && IsReal(b) && !(Num(a).is_zero() && Num(b).is_zero())) return (a / GiNaC::sqrt(a * a + b * b)).evalf();
  return mb_smoothsign(a, b).hold();
}
GiNaC::ex SmoothSignDeriv(const GiNaC::ex& x, const GiNaC::ex& eps, unsigned i) {
  const GiNaC::ex cube = GiNaC::pow(mb_smoothabs(x, eps), 3);
  return i == 0 ? eps * eps / cube : -x * eps / cube;
}
REGISTER_FUNCTION(mb_smoothsign, eval_func(SmoothSignEval).evalf_func(SmoothSignEvalf).derivative_func(SmoothSignDeriv))

// Comparisons and logic: 1 or 0 (a truth value is a number other than 0), their derivative 0
// (piecewise constant). Evaluated at numbers only: x == x is not folded to 1 (a NaN, at run
// time, is equal to nothing).
template <bool (*Holds)(const GiNaC::numeric&, const GiNaC::numeric&)>
GiNaC::ex CompareAt(const GiNaC::ex& a, const GiNaC::ex& b, GiNaC::ex (*held)(const GiNaC::ex&, const GiNaC::ex&)) {
  if (IsReal(a) && IsReal(b)) return Holds(Num(a), Num(b)) ? 1 : 0;
  return held(a, b);
}
bool Truth(const GiNaC::numeric& x) { return !x.is_zero(); }
bool LtHolds(const GiNaC::numeric& a, const GiNaC::numeric& b) { return a < b; }
bool LeHolds(const GiNaC::numeric& a, const GiNaC::numeric& b) { return a <= b; }
bool GtHolds(const GiNaC::numeric& a, const GiNaC::numeric& b) { return a > b; }
bool GeHolds(const GiNaC::numeric& a, const GiNaC::numeric& b) { return a >= b; }
bool EqHolds(const GiNaC::numeric& a, const GiNaC::numeric& b) { return a == b; }
bool NeHolds(const GiNaC::numeric& a, const GiNaC::numeric& b) { return a != b; }
bool AndHolds(const GiNaC::numeric& a, const GiNaC::numeric& b) { return Truth(a) && Truth(b); }
bool OrHolds(const GiNaC::numeric& a, const GiNaC::numeric& b) { return Truth(a) || Truth(b); }
GiNaC::ex Zero2(const GiNaC::ex&, const GiNaC::ex&, const GiNaC::symbol&) { return 0; }

#define MB_SYMBOLIC_COMPARISON(NAME, HOLDS)                                                                        \
  GiNaC::ex NAME##Eval(const GiNaC::ex& a, const GiNaC::ex& b) {                                                  \
    return CompareAt<HOLDS>(a, b, [](const GiNaC::ex& x, const GiNaC::ex& y) -> GiNaC::ex { return NAME(x, y).hold(); }); \
  }                                                                                                               \
  GiNaC::ex NAME##Evalf(const GiNaC::ex& a, const GiNaC::ex& b) { return NAME##Eval(a.evalf(), b.evalf()); }      \
  REGISTER_FUNCTION(NAME, eval_func(NAME##Eval).evalf_func(NAME##Evalf).expl_derivative_func(Zero2))
MB_SYMBOLIC_COMPARISON(mb_lt, LtHolds)
MB_SYMBOLIC_COMPARISON(mb_le, LeHolds)
MB_SYMBOLIC_COMPARISON(mb_gt, GtHolds)
MB_SYMBOLIC_COMPARISON(mb_ge, GeHolds)
MB_SYMBOLIC_COMPARISON(mb_eq, EqHolds)
MB_SYMBOLIC_COMPARISON(mb_ne, NeHolds)
MB_SYMBOLIC_COMPARISON(mb_and, AndHolds)
MB_SYMBOLIC_COMPARISON(mb_or, OrHolds)
#undef MB_SYMBOLIC_COMPARISON

GiNaC::ex NotEval(const GiNaC::ex& a) {
  if (IsReal(a)) return Truth(Num(a)) ? 0 : 1;
  return mb_not(a).hold();
}
GiNaC::ex NotEvalf(const GiNaC::ex& a) { return NotEval(a.evalf()); }
GiNaC::ex NotDeriv(const GiNaC::ex&, const GiNaC::symbol&) { return 0; }
REGISTER_FUNCTION(mb_not, eval_func(NotEval).evalf_func(NotEvalf).expl_derivative_func(NotDeriv))

// if(c, a, b): a where c holds, else b. Its derivative is the select of the branches'
// derivatives, if(c, a', b'), not if(c, 1, 0) a' + if(c, 0, 1) b' as the chain rule would give
// (0 times the other branch's NaN or infinity is NaN).
GiNaC::ex IfEval(const GiNaC::ex& c, const GiNaC::ex& a, const GiNaC::ex& b) {
  if (IsReal(c)) return Truth(Num(c)) ? a : b;
  if (a.is_equal(b)) return a;
  return mb_if(c, a, b).hold();
}
GiNaC::ex IfEvalf(const GiNaC::ex& c, const GiNaC::ex& a, const GiNaC::ex& b) {
  const GiNaC::ex v = c.evalf();
  if (IsReal(v)) return Truth(Num(v)) ? a.evalf() : b.evalf();
  return mb_if(v, a.evalf(), b.evalf()).hold();
}
GiNaC::ex IfDeriv(const GiNaC::ex& c, const GiNaC::ex& a, const GiNaC::ex& b, const GiNaC::symbol& s) {
  return mb_if(c, a.diff(s), b.diff(s));
}
REGISTER_FUNCTION(mb_if, eval_func(IfEval).evalf_func(IfEvalf).expl_derivative_func(IfDeriv))

// ---------------------------------------------------------------------------------------------

/// GiNaC keeps global state (its registries, the cache of its numerical integration) and is not
/// thread-safe: every use is under this lock.
std::mutex& GinacLock() {
  static std::mutex m;
  return m;
}

/// The names of one conversion: each name one real symbol; `pi` is GiNaC's constant Pi.
class Symbols {
 public:
  GiNaC::ex Of(const std::string& name) {
    if (name == "pi") return GiNaC::Pi;
    return Symbol(name);
  }
  const GiNaC::realsymbol& Symbol(const std::string& name) {
    auto it = table_.find(name);
    if (it == table_.end()) it = table_.emplace(name, GiNaC::realsymbol(name)).first;
    return it->second;
  }

 private:
  std::map<std::string, GiNaC::realsymbol> table_;
};

/// A double as the exact rational its shortest decimal form reads (0.1 -> 1/10), so that 0.1*q
/// differentiates to 1/10 and comes back as the double 0.1.
GiNaC::ex FromDouble(double v) {
  if (!std::isfinite(v)) throw std::domain_error(fmt::format("the number {} has no symbolic form", v));
  if (v == 0.0) return 0;
  // The shortest form that reads back exactly: digits, a point, an exponent (fmt "{}").
  std::string text = fmt::format("{}", v);
  bool negative = false;
  if (text[0] == '-') {
    negative = true;
    text.erase(0, 1);
  }
  long exponent = 0;
  if (const size_t e = text.find('e'); e != std::string::npos) {
    exponent = std::stol(text.substr(e + 1));
    text.resize(e);
  }
  if (const size_t dot = text.find('.'); dot != std::string::npos) {
    exponent -= static_cast<long>(text.size() - dot - 1);
    text.erase(dot, 1);
  }
  const GiNaC::numeric digits(std::stol(text));  // at most 17 digits
  const GiNaC::numeric r = digits * GiNaC::numeric(10).power(GiNaC::numeric(exponent));
  return negative ? -r : r;
}

GiNaC::ex ToEx(const Node& n, Symbols& symbols) {
  const auto arg = [&](size_t i) { return ToEx(*n.args[i], symbols); };
  switch (n.kind) {
    case Node::Kind::kNumber: return FromDouble(n.value);
    case Node::Kind::kName: return symbols.Of(n.name);
    case Node::Kind::kNeg: return -arg(0);
    case Node::Kind::kAdd: return arg(0) + arg(1);
    case Node::Kind::kSub: return arg(0) - arg(1);
    case Node::Kind::kMul: return arg(0) * arg(1);
    case Node::Kind::kDiv: return arg(0) / arg(1);
    case Node::Kind::kPow: return GiNaC::pow(arg(0), arg(1));
    case Node::Kind::kCall:
      switch (n.fn) {
        case Fn::kSin: return GiNaC::sin(arg(0));
        case Fn::kCos: return GiNaC::cos(arg(0));
        case Fn::kTan: return GiNaC::tan(arg(0));
        case Fn::kAsin: return GiNaC::asin(arg(0));
        case Fn::kAcos: return GiNaC::acos(arg(0));
        case Fn::kAtan: return GiNaC::atan(arg(0));
        case Fn::kAtan2: return GiNaC::atan2(arg(0), arg(1));
        case Fn::kSinh: return GiNaC::sinh(arg(0));
        case Fn::kCosh: return GiNaC::cosh(arg(0));
        case Fn::kTanh: return GiNaC::tanh(arg(0));
        case Fn::kExp: return GiNaC::exp(arg(0));
        case Fn::kLog: return GiNaC::log(arg(0));
        case Fn::kSqrt: return GiNaC::sqrt(arg(0));
        case Fn::kAbs: return GiNaC::abs(arg(0));
        case Fn::kSign: return mb_sign(arg(0));
        case Fn::kMin: return mb_min(arg(0), arg(1));
        case Fn::kMax: return mb_max(arg(0), arg(1));
        case Fn::kHypot: return mb_hypot(arg(0), arg(1));
        case Fn::kClamp: return mb_clamp(arg(0), arg(1), arg(2));
        case Fn::kSmoothAbs: return mb_smoothabs(arg(0), arg(1));
        case Fn::kSmoothSign: return mb_smoothsign(arg(0), arg(1));
        case Fn::kLt: return mb_lt(arg(0), arg(1));
        case Fn::kLe: return mb_le(arg(0), arg(1));
        case Fn::kGt: return mb_gt(arg(0), arg(1));
        case Fn::kGe: return mb_ge(arg(0), arg(1));
        case Fn::kEq: return mb_eq(arg(0), arg(1));
        case Fn::kNe: return mb_ne(arg(0), arg(1));
        case Fn::kAnd: return mb_and(arg(0), arg(1));
        case Fn::kOr: return mb_or(arg(0), arg(1));
        case Fn::kNot: return mb_not(arg(0));
        case Fn::kIf: return mb_if(arg(0), arg(1), arg(2));
      }
  }
  MB_ASSERT(false, "a node kind");
}

/// x * abs(x)^-1 (GiNaC's derivative of abs, NaN at 0) as sign(x), in every product.
GiNaC::ex AbsQuotientsAsSigns(const GiNaC::ex& e) {
  const GiNaC::ex mapped = e.map(&AbsQuotientsAsSigns);
  if (!GiNaC::is_exactly_a<GiNaC::mul>(mapped)) return mapped;
  GiNaC::exvector factors(mapped.begin(), mapped.end());
  bool changed = false;
  for (GiNaC::ex& f : factors) {
    if (!GiNaC::is_exactly_a<GiNaC::power>(f) || !f.op(1).is_equal(-1) || !GiNaC::is_exactly_a<GiNaC::function>(f.op(0)) ||
        GiNaC::ex_to<GiNaC::function>(f.op(0)).get_serial() != GiNaC::abs_SERIAL::serial)
      continue;
    const GiNaC::ex inner = f.op(0).op(0);
    for (GiNaC::ex& g : factors)
      if (g.is_equal(inner)) {
        g = 1;
        f = mb_sign(inner);
        changed = true;
        break;
      }
  }
  if (!changed) return mapped;
  GiNaC::ex product = 1;
  for (const GiNaC::ex& f : factors) product *= f;
  return product;
}

/// The exact value of a double, as a rational m 2^e.
GiNaC::numeric DyadicOf(double d) {
  int e = 0;
  const double m = std::ldexp(std::frexp(d, &e), 53);  // an integer of 53 bits
  return GiNaC::numeric(static_cast<long>(m)) * GiNaC::numeric(2).power(GiNaC::numeric(e - 53));
}

constexpr double kExactInteger = 9007199254740992.0;  // 2^53: every integer up to it is a double

/// An exact integer as a number node, when it is a double.
bool IntegerNode(const GiNaC::numeric& n, NodePtr& out) {
  if (!n.is_integer() || GiNaC::abs(n) > GiNaC::numeric(kExactInteger)) return false;
  out = Number(n.to_double());
  return true;
}

/// A real number as a tree: integers and dyadic rationals exactly, other rationals p/q as the
/// quotient of two exact integers, floating-point values (GiNaC's evalf) as their double.
NodePtr FromNumeric(const GiNaC::numeric& n) {
  if (!n.is_real()) throw std::domain_error("GiNaC gives a complex number, which formulas cannot express");
  NodePtr node;
  if (IntegerNode(n, node)) return node;
  if (n.is_rational()) {
    const GiNaC::numeric p = n.numer(), q = n.denom();
    // A rational that is a double (1/2, 3/4): that double.
    if (const double d = n.to_double(); std::isfinite(d) && DyadicOf(d).is_equal(n)) return Number(d);
    NodePtr num, den;
    if (IntegerNode(p, num) && IntegerNode(q, den)) return Binary(Node::Kind::kDiv, num, den);
  }
  return Number(n.to_double());
}

NodePtr FromEx(const GiNaC::ex& e);

std::string Text(const GiNaC::ex& e) {
  std::ostringstream s;
  s << e;
  return s.str();
}

bool HasIntegral(const GiNaC::ex& e) {
  if (GiNaC::is_a<GiNaC::integral>(e)) return true;
  for (const GiNaC::ex& op : e)
    if (HasIntegral(op)) return true;
  return false;
}

/// Terms and factors in the order of their text: GiNaC orders them by hashes, which depend on the
/// order its symbols were made in; the same formula should read the same in every run.
void SortByText(std::vector<NodePtr>& nodes) {
  std::vector<std::pair<std::string, NodePtr>> keyed;
  for (NodePtr& n : nodes) keyed.emplace_back(Format(*n), std::move(n));
  std::stable_sort(keyed.begin(), keyed.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  for (size_t i = 0; i < nodes.size(); ++i) nodes[i] = std::move(keyed[i].second);
}

/// A product of factors (nullptr for none).
NodePtr Product(const std::vector<NodePtr>& factors) {
  NodePtr out;
  for (const NodePtr& f : factors) out = out ? Binary(Node::Kind::kMul, out, f) : f;
  return out;
}

/// a^e with e a number: square roots as sqrt, negative exponents as a quotient.
NodePtr PowerNode(const GiNaC::ex& base, const GiNaC::numeric& exponent) {
  if (exponent.is_negative()) return Binary(Node::Kind::kDiv, Number(1), PowerNode(base, -exponent));
  if (exponent.is_equal(GiNaC::numeric(1, 2))) return Call(Fn::kSqrt, {FromEx(base)});
  if (exponent.is_equal(1)) return FromEx(base);
  return Binary(Node::Kind::kPow, FromEx(base), FromNumeric(exponent));
}

NodePtr MulNode(const GiNaC::ex& e) {
  // coefficient * numerator factors / denominator factors, the coefficient's sign in front
  GiNaC::numeric coefficient = 1;
  std::vector<NodePtr> numerator, denominator;
  for (const GiNaC::ex& f : e) {
    if (GiNaC::is_exactly_a<GiNaC::numeric>(f)) {
      coefficient *= GiNaC::ex_to<GiNaC::numeric>(f);
    } else if (GiNaC::is_exactly_a<GiNaC::power>(f) && IsReal(f.op(1)) && Num(f.op(1)).is_negative()) {
      denominator.push_back(PowerNode(f.op(0), -Num(f.op(1))));
    } else {
      numerator.push_back(FromEx(f));
    }
  }
  SortByText(numerator);
  SortByText(denominator);
  if (!coefficient.is_real()) throw std::domain_error("GiNaC gives a complex number, which formulas cannot express");
  const bool negative = coefficient.is_negative();
  if (negative) coefficient = -coefficient;
  if (coefficient.is_rational() && !coefficient.is_integer()) {
    NodePtr p, q;
    if (IntegerNode(coefficient.numer(), p) && IntegerNode(coefficient.denom(), q)) {
      if (!coefficient.numer().is_equal(1)) numerator.insert(numerator.begin(), p);
      denominator.insert(denominator.begin(), q);
    } else {
      numerator.insert(numerator.begin(), FromNumeric(coefficient));
    }
  } else if (!coefficient.is_equal(1)) {
    numerator.insert(numerator.begin(), FromNumeric(coefficient));
  }
  if (numerator.empty()) numerator.push_back(Number(1));
  if (negative) numerator[0] = Unary(Node::Kind::kNeg, numerator[0]);  // -k*q rather than -(k*q)
  NodePtr out = Product(numerator);
  if (!denominator.empty()) out = Binary(Node::Kind::kDiv, out, Product(denominator));
  return out;
}

/// Whether a term of a sum reads with a minus sign (a negative number or coefficient).
bool NegativeTerm(const GiNaC::ex& t) {
  if (GiNaC::is_exactly_a<GiNaC::numeric>(t)) return Num(t).is_real() && Num(t).is_negative();
  if (GiNaC::is_exactly_a<GiNaC::mul>(t)) {
    const GiNaC::ex c = t.op(t.nops() - 1);  // GiNaC keeps a product's number last
    return IsReal(c) && Num(c).is_negative();
  }
  return false;
}

NodePtr AddNode(const GiNaC::ex& e) {
  // Positive terms first, so that the sum starts without a sign where it can; each group in the
  // order of its text.
  std::vector<NodePtr> plus, minus;
  for (const GiNaC::ex& t : e) {
    if (NegativeTerm(t)) minus.push_back(FromEx(-t));
    else plus.push_back(FromEx(t));
  }
  SortByText(plus);
  SortByText(minus);
  NodePtr out = plus.empty() ? nullptr : plus[0];
  for (size_t i = 1; i < plus.size(); ++i) out = Binary(Node::Kind::kAdd, out, plus[i]);
  for (const NodePtr& t : minus) out = out ? Binary(Node::Kind::kSub, out, t) : Unary(Node::Kind::kNeg, t);
  return out ? out : Number(0);
}

struct FunctionOfGinac {
  unsigned serial;
  Fn fn;
};

NodePtr FunctionNode(const GiNaC::function& f) {
  static const std::vector<FunctionOfGinac> table = {
      {GiNaC::sin_SERIAL::serial, Fn::kSin},         {GiNaC::cos_SERIAL::serial, Fn::kCos},
      {GiNaC::tan_SERIAL::serial, Fn::kTan},         {GiNaC::asin_SERIAL::serial, Fn::kAsin},
      {GiNaC::acos_SERIAL::serial, Fn::kAcos},       {GiNaC::atan_SERIAL::serial, Fn::kAtan},
      {GiNaC::atan2_SERIAL::serial, Fn::kAtan2},     {GiNaC::sinh_SERIAL::serial, Fn::kSinh},
      {GiNaC::cosh_SERIAL::serial, Fn::kCosh},       {GiNaC::tanh_SERIAL::serial, Fn::kTanh},
      {GiNaC::exp_SERIAL::serial, Fn::kExp},         {GiNaC::log_SERIAL::serial, Fn::kLog},
      {GiNaC::abs_SERIAL::serial, Fn::kAbs},         {GiNaC::csgn_SERIAL::serial, Fn::kSign},
      {mb_sign_SERIAL::serial, Fn::kSign},           {mb_min_SERIAL::serial, Fn::kMin},
      {mb_max_SERIAL::serial, Fn::kMax},             {mb_hypot_SERIAL::serial, Fn::kHypot},
      {mb_clamp_SERIAL::serial, Fn::kClamp},         {mb_smoothabs_SERIAL::serial, Fn::kSmoothAbs},
      {mb_smoothsign_SERIAL::serial, Fn::kSmoothSign},
      {mb_lt_SERIAL::serial, Fn::kLt},               {mb_le_SERIAL::serial, Fn::kLe},
      {mb_gt_SERIAL::serial, Fn::kGt},               {mb_ge_SERIAL::serial, Fn::kGe},
      {mb_eq_SERIAL::serial, Fn::kEq},               {mb_ne_SERIAL::serial, Fn::kNe},
      {mb_and_SERIAL::serial, Fn::kAnd},             {mb_or_SERIAL::serial, Fn::kOr},
      {mb_not_SERIAL::serial, Fn::kNot},             {mb_if_SERIAL::serial, Fn::kIf},
  };
  std::vector<NodePtr> args;
  for (const GiNaC::ex& a : f) args.push_back(FromEx(a));
  const unsigned serial = f.get_serial();
  for (const FunctionOfGinac& row : table)
    if (row.serial == serial) return Call(row.fn, std::move(args));
  // step(x) (GiNaC's Heaviside function, 1/2 at 0) = (1 + sign(x))/2
  if (serial == GiNaC::step_SERIAL::serial)
    return Binary(Node::Kind::kDiv, Binary(Node::Kind::kAdd, Number(1), Call(Fn::kSign, std::move(args))), Number(2));
  throw std::domain_error(fmt::format("GiNaC gives the function '{}', which formulas cannot express", f.get_name()));
}

NodePtr FromEx(const GiNaC::ex& e) {
  if (GiNaC::is_exactly_a<GiNaC::numeric>(e)) return FromNumeric(Num(e));
  if (GiNaC::is_a<GiNaC::symbol>(e)) return Name(GiNaC::ex_to<GiNaC::symbol>(e).get_name());
  if (GiNaC::is_exactly_a<GiNaC::constant>(e)) {
    if (e.is_equal(GiNaC::Pi)) return Name("pi");
    throw std::domain_error(fmt::format("GiNaC gives the constant '{}', which formulas cannot express", Text(e)));
  }
  if (GiNaC::is_exactly_a<GiNaC::add>(e)) return AddNode(e);
  if (GiNaC::is_exactly_a<GiNaC::mul>(e)) return MulNode(e);
  if (GiNaC::is_exactly_a<GiNaC::power>(e)) {
    if (IsReal(e.op(1))) return PowerNode(e.op(0), Num(e.op(1)));
    return Binary(Node::Kind::kPow, FromEx(e.op(0)), FromEx(e.op(1)));
  }
  if (GiNaC::is_exactly_a<GiNaC::function>(e)) return FunctionNode(GiNaC::ex_to<GiNaC::function>(e));
  throw std::domain_error(fmt::format("GiNaC gives '{}', which formulas cannot express", Text(e)));
}

/// GiNaC's normal form (a rational function over the functions' values), then back to a tree.
NodePtr Tidy(const GiNaC::ex& e) { return FromEx(AbsQuotientsAsSigns(e.normal())); }

}  // namespace

NodePtr Differentiate(const Node& root, const std::string& name) {
  std::lock_guard lock(GinacLock());
  Symbols symbols;
  const GiNaC::ex e = ToEx(root, symbols);
  return Tidy(e.diff(symbols.Symbol(name)));
}

std::optional<NodePtr> IntegrateFromZero(const Node& root, const std::string& name) {
  std::lock_guard lock(GinacLock());
  Symbols symbols;
  const GiNaC::ex f = ToEx(root, symbols);
  const GiNaC::realsymbol& q = symbols.Symbol(name);
  const GiNaC::realsymbol dummy(name + "'");  // the integration variable, apart from the upper limit
  const GiNaC::ex result = GiNaC::integral(dummy, 0, q, f.subs(q == dummy)).eval_integ();
  if (HasIntegral(result)) return std::nullopt;
  return Tidy(result);
}

bool DependsOn(const Node& root, const std::string& name) {
  std::lock_guard lock(GinacLock());
  Symbols symbols;
  const GiNaC::ex e = ToEx(root, symbols).normal();
  return name == "pi" ? e.has(GiNaC::Pi) : e.has(symbols.Symbol(name));
}

NodePtr Simplify(const Node& root) {
  std::lock_guard lock(GinacLock());
  Symbols symbols;
  return Tidy(ToEx(root, symbols));
}

}  // namespace multibond::expr
