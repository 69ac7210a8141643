// A formula typeset as LaTeX (formula_latex.h).

#include "multibond/compile/formula_latex.h"

#include <array>
#include <cmath>
#include <string>

#include <fmt/format.h>

#include "multibond/core/expression.h"

namespace multibond {

namespace {

using expr::Fn;
using expr::Node;

/// Binding strength of what a node prints as: an operand weaker than its place needs brackets.
enum Level : int { kLogic = 0, kCompare = 1, kSum = 2, kProduct = 3, kNegation = 4, kPower = 5, kAtom = 6 };

constexpr std::array<const char*, 24> kGreek = {"alpha", "beta",  "gamma", "delta", "epsilon", "zeta",    "eta", "theta",
                                                "iota",  "kappa", "lambda", "mu",   "nu",      "xi",      "pi",  "rho",
                                                "sigma", "tau",   "upsilon", "phi", "chi",     "psi",     "omega", "varphi"};
constexpr std::array<const char*, 10> kCapitalGreek = {"Gamma", "Delta", "Theta", "Lambda", "Xi", "Pi", "Sigma", "Upsilon", "Phi", "Omega"};

bool IsGreek(std::string_view s) {
  for (const char* g : kGreek)
    if (s == g) return true;
  for (const char* g : kCapitalGreek)
    if (s == g) return true;
  return s == "Psi";
}

/// Characters of a name inside \mathrm{} (names are letters, digits, '_' and '.').
std::string Escaped(std::string_view s) {
  std::string out;
  for (const char c : s) {
    if (c == '_') out += "\\_";
    else if ((c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '.') out += c;
    // anything else cannot be in a name of the grammar; dropped rather than passed on
  }
  return out;
}

/// A name: a Greek one as its letter (omega_0: \omega_{0}), one letter in italics, else upright.
std::string NameLatex(const std::string& name) {
  if (name == "t") return "t";
  const size_t under = name.find('_');
  const std::string head = under == std::string::npos ? name : name.substr(0, under);
  if (IsGreek(head) && name.find('.') == std::string::npos) {
    if (under != std::string::npos && under + 1 < name.size()) return fmt::format("\\{}_{{\\mathrm{{{}}}}}", head, Escaped(name.substr(under + 1)));
    return fmt::format("\\{}", head);
  }
  if (name.size() == 1) return name;
  return fmt::format("\\mathrm{{{}}}", Escaped(name));
}

/// A number in its shortest form that reads back exactly; below 1e-3 or from 1e5 on (in
/// magnitude) as m \cdot 10^{e}.
std::string NumberLatex(double v) {
  const double a = std::abs(v);
  if (a == 0.0 || (a >= 1e-3 && a < 1e5)) return fmt::format("{}", v);
  std::string s;
  for (int digits = 0; digits <= 17; ++digits) {
    s = fmt::format("{:.{}e}", v, digits);
    if (std::stod(s) == v) break;
  }
  const size_t e = s.find('e');
  const int exponent = std::stoi(s.substr(e + 1));
  const std::string mantissa = s.substr(0, e);
  const std::string power = fmt::format("10^{{{}}}", exponent);
  if (mantissa == "1") return power;
  if (mantissa == "-1") return fmt::format("-{}", power);
  return fmt::format("{} \\cdot {}", mantissa, power);
}

struct Printed {
  std::string text;
  Level level;
};

Printed Print(const Node& n);

std::string Bracketed(const Printed& p, Level needed) { return p.level < needed ? fmt::format("\\left({}\\right)", p.text) : p.text; }

std::string Arguments(const Node& n) {
  std::string out;
  for (size_t k = 0; k < n.args.size(); ++k) {
    if (k) out += ", ";
    out += Print(*n.args[k]).text;
  }
  return out;
}

Printed Call(const Node& n) {
  const auto arg = [&](size_t k) { return Print(*n.args[k]); };
  const auto op = [&](const char* name) {  // \sin x, bracketed unless an atom
    return Printed{fmt::format("{}\\left({}\\right)", name, arg(0).text), kAtom};
  };
  const auto named = [&](const char* name) { return Printed{fmt::format("\\operatorname{{{}}}\\left({}\\right)", name, Arguments(n)), kAtom}; };
  const auto binary = [&](const char* sym, Level level) {
    return Printed{fmt::format("{} {} {}", Bracketed(arg(0), Level(level + 1)), sym, Bracketed(arg(1), Level(level + 1))), level};
  };
  switch (n.fn) {
    case Fn::kSin: return op("\\sin");
    case Fn::kCos: return op("\\cos");
    case Fn::kTan: return op("\\tan");
    case Fn::kAsin: return op("\\arcsin");
    case Fn::kAcos: return op("\\arccos");
    case Fn::kAtan: return op("\\arctan");
    case Fn::kSinh: return op("\\sinh");
    case Fn::kCosh: return op("\\cosh");
    case Fn::kTanh: return op("\\tanh");
    case Fn::kExp: return op("\\exp");
    case Fn::kLog: return op("\\ln");
    case Fn::kSqrt: return {fmt::format("\\sqrt{{{}}}", arg(0).text), kAtom};
    case Fn::kAbs: return {fmt::format("\\left|{}\\right|", arg(0).text), kAtom};
    case Fn::kSign: return named("sign");
    case Fn::kMin: return {fmt::format("\\min\\left({}\\right)", Arguments(n)), kAtom};
    case Fn::kMax: return {fmt::format("\\max\\left({}\\right)", Arguments(n)), kAtom};
    case Fn::kAtan2: return named("atan2");
    case Fn::kHypot: return named("hypot");
    case Fn::kClamp: return named("clamp");
    case Fn::kSmoothAbs: return named("smoothabs");
    case Fn::kSmoothSign: return named("smoothsign");
    case Fn::kLt: return binary("<", kCompare);
    case Fn::kLe: return binary("\\le", kCompare);
    case Fn::kGt: return binary(">", kCompare);
    case Fn::kGe: return binary("\\ge", kCompare);
    case Fn::kEq: return binary("=", kCompare);
    case Fn::kNe: return binary("\\ne", kCompare);
    case Fn::kAnd: return binary("\\land", kLogic);
    case Fn::kOr: return binary("\\lor", kLogic);
    case Fn::kNot: return {fmt::format("\\lnot {}", Bracketed(arg(0), kNegation)), kNegation};
    case Fn::kIf:
      return {fmt::format("\\begin{{cases}} {} & \\text{{if }} {} \\\\ {} & \\text{{otherwise}} \\end{{cases}}", arg(1).text, arg(0).text,
                          arg(2).text),
              kAtom};
  }
  return named("?");
}

Printed Print(const Node& n) {
  using K = Node::Kind;
  switch (n.kind) {
    case K::kNumber: {
      const std::string s = NumberLatex(n.value);
      return {s, s.find("\\cdot") != std::string::npos ? kProduct : (n.value < 0 ? kNegation : kAtom)};
    }
    case K::kName: return {NameLatex(n.name), kAtom};
    case K::kNeg: return {fmt::format("-{}", Bracketed(Print(*n.args[0]), kProduct)), kNegation};
    case K::kAdd: return {fmt::format("{} + {}", Print(*n.args[0]).text, Bracketed(Print(*n.args[1]), kProduct)), kSum};
    case K::kSub: return {fmt::format("{} - {}", Print(*n.args[0]).text, Bracketed(Print(*n.args[1]), kProduct)), kSum};
    case K::kMul: {
      const Printed a = Print(*n.args[0]), b = Print(*n.args[1]);
      const bool numbers = n.args[1]->kind == K::kNumber;  // 2 \cdot 3, not 23
      return {fmt::format("{}{}{}", Bracketed(a, kProduct), numbers ? " \\cdot " : " \\, ", Bracketed(b, kNegation)), kProduct};
    }
    case K::kDiv: return {fmt::format("\\frac{{{}}}{{{}}}", Print(*n.args[0]).text, Print(*n.args[1]).text), kAtom};
    case K::kPow: {
      const Printed base = Print(*n.args[0]);
      // A fraction or a function's value in brackets before its power; a name or number as it is.
      const bool plain = n.args[0]->kind == K::kName || (n.args[0]->kind == K::kNumber && base.level == kAtom);
      return {fmt::format("{}^{{{}}}", plain ? base.text : fmt::format("\\left({}\\right)", base.text), Print(*n.args[1]).text), kPower};
    }
    case K::kCall: return Call(n);
  }
  return {"?", kAtom};
}

}  // namespace

namespace {

bool IsName(std::string_view s) {
  const expr::ParseResult p = expr::Parse(s);
  return p.root && p.root->kind == Node::Kind::kName;
}

/// A law shown with the state it is evaluated at (compile/formulas.cc): "[-](LAW at q = S)", LAW
/// a formula of the element's own variable q or "d(ENERGY)/dq".
std::optional<std::string> LawAtState(std::string_view text) {
  std::string_view sign;
  if (!text.empty() && text.front() == '-') sign = "-", text.remove_prefix(1);
  if (text.size() < 2 || text.front() != '(' || text.back() != ')') return std::nullopt;
  text = text.substr(1, text.size() - 2);
  const size_t at = text.rfind(" at ");
  if (at == std::string_view::npos) return std::nullopt;
  const std::string_view law = text.substr(0, at), binding = text.substr(at + 4);
  const size_t eq = binding.find(" = ");
  if (eq == std::string_view::npos) return std::nullopt;
  const std::string own(binding.substr(0, eq)), state(binding.substr(eq + 3));
  if (!IsName(own) || !IsName(state)) return std::nullopt;
  std::string body;
  const std::string tail = ")/d" + own;
  if (law.size() > 2 + tail.size() && law.substr(0, 2) == "d(" && law.substr(law.size() - tail.size()) == tail) {
    const expr::ParseResult energy = expr::Parse(law.substr(2, law.size() - 2 - tail.size()));
    if (!energy.root) return std::nullopt;
    body = fmt::format("\\frac{{\\partial}}{{\\partial {}}}\\left({}\\right)", NameLatex(own), Print(*energy.root).text);
  } else {
    const expr::ParseResult parsed = expr::Parse(law);
    if (!parsed.root) return std::nullopt;
    body = Print(*parsed.root).text;
  }
  return fmt::format("{}\\left.{}\\right|_{{{} = {}}}", sign, body, NameLatex(own), NameLatex(state));
}

}  // namespace

std::optional<std::string> FormulaLatex(std::string_view text) {
  const expr::ParseResult parsed = expr::Parse(text);
  if (!parsed.root) return LawAtState(text);
  return Print(*parsed.root).text;
}

}  // namespace multibond
