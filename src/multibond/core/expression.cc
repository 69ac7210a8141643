#include "multibond/core/expression.h"

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <system_error>
#include <utility>

#include <fmt/format.h>

#include "multibond/core/error.h"

namespace multibond::expr {

namespace {

// The value of every function and of `^`, written once: MB_EXPR_FUNCTIONS is compiled here (Apply
// and Power call these) and its text is what FunctionDefinitions() gives the code generator, so
// the interpreter and the generated code run the same bodies. This file is compiled with
// -ffp-contract=off (src/CMakeLists.txt), as the generated code is.
//   sign(x): -1, 0 or 1 (0 at both zeros; a NaN stays NaN).
//   min, max: the smaller / larger argument; a NaN in either gives NaN (std::fmin would hide it).
//   clamp(x, lo, hi): lo if x < lo, else hi if x > hi, else x.
//   smoothabs(x, eps) = sqrt(x*x + eps*eps); smoothsign(x, eps) = x / sqrt(x*x + eps*eps).
//   lt, le, gt, ge, eq, ne (a < b, ...): 1 or 0, as C++ compares (false where a side is NaN,
//   but a != b true); mb_true(x): the truth of a number, x != 0 and not NaN (NaN is false);
//   and, or, not: 1 or 0; if(c, a, b): a where c is true, else b, a select (the bits of the
//   branch taken, whatever the other holds).
// NOLINTBEGIN
#define MB_EXPR_FUNCTIONS                                                                                   \
  static inline double mb_sin(double x) { return std::sin(x); }                                            \
  static inline double mb_cos(double x) { return std::cos(x); }                                            \
  static inline double mb_tan(double x) { return std::tan(x); }                                            \
  static inline double mb_asin(double x) { return std::asin(x); }                                          \
  static inline double mb_acos(double x) { return std::acos(x); }                                          \
  static inline double mb_atan(double x) { return std::atan(x); }                                          \
  static inline double mb_atan2(double y, double x) { return std::atan2(y, x); }                           \
  static inline double mb_sinh(double x) { return std::sinh(x); }                                          \
  static inline double mb_cosh(double x) { return std::cosh(x); }                                          \
  static inline double mb_tanh(double x) { return std::tanh(x); }                                          \
  static inline double mb_exp(double x) { return std::exp(x); }                                            \
  static inline double mb_log(double x) { return std::log(x); }                                            \
  static inline double mb_sqrt(double x) { return std::sqrt(x); }                                          \
  static inline double mb_abs(double x) { return std::fabs(x); }                                           \
  static inline double mb_sign(double x) {                                                                 \
    return std::isnan(x) ? x : static_cast<double>((x > 0.0) - (x < 0.0));                                 \
  }                                                                                                        \
  static inline double mb_min(double a, double b) {                                                        \
    return std::isnan(a) || std::isnan(b) ? a + b : (b < a ? b : a);                                       \
  }                                                                                                        \
  static inline double mb_max(double a, double b) {                                                        \
    return std::isnan(a) || std::isnan(b) ? a + b : (a < b ? b : a);                                       \
  }                                                                                                        \
  static inline double mb_hypot(double x, double y) { return std::hypot(x, y); }                           \
  static inline double mb_clamp(double x, double lo, double hi) { return x < lo ? lo : (hi < x ? hi : x); } \
  static inline double mb_smoothabs(double x, double eps) { return std::sqrt(x * x + eps * eps); }         \
  static inline double mb_smoothsign(double x, double eps) { return x / std::sqrt(x * x + eps * eps); }    \
  static inline double mb_lt(double a, double b) { return a < b ? 1.0 : 0.0; }                             \
  static inline double mb_le(double a, double b) { return a <= b ? 1.0 : 0.0; }                            \
  static inline double mb_gt(double a, double b) { return a > b ? 1.0 : 0.0; }                             \
  static inline double mb_ge(double a, double b) { return a >= b ? 1.0 : 0.0; }                            \
  static inline double mb_eq(double a, double b) { return a == b ? 1.0 : 0.0; }                            \
  static inline double mb_ne(double a, double b) { return a != b ? 1.0 : 0.0; }                            \
  static inline bool mb_true(double x) { return x < 0.0 || x > 0.0; }                                      \
  static inline double mb_and(double a, double b) { return mb_true(a) && mb_true(b) ? 1.0 : 0.0; }         \
  static inline double mb_or(double a, double b) { return mb_true(a) || mb_true(b) ? 1.0 : 0.0; }          \
  static inline double mb_not(double a) { return mb_true(a) ? 0.0 : 1.0; }                                 \
  static inline double mb_if(double c, double a, double b) { return mb_true(c) ? a : b; }                  \
  static inline double mb_pow(double a, double b) {                                                        \
    if (b == 2.0) return a * a;                                                                            \
    if (b == 3.0) return a * a * a;                                                                        \
    if (b == -1.0) return 1.0 / a;                                                                         \
    return std::pow(a, b);                                                                                 \
  }
#define MB_EXPR_TEXT2(...) #__VA_ARGS__
#define MB_EXPR_TEXT(...) MB_EXPR_TEXT2(__VA_ARGS__)
// NOLINTEND

MB_EXPR_FUNCTIONS

/// The one table of functions, in the order of Fn.
constexpr std::array<FunctionInfo, kNumFns> kFunctions = {{
    {Fn::kSin, "sin", 1},
    {Fn::kCos, "cos", 1},
    {Fn::kTan, "tan", 1},
    {Fn::kAsin, "asin", 1},
    {Fn::kAcos, "acos", 1},
    {Fn::kAtan, "atan", 1},
    {Fn::kAtan2, "atan2", 2},
    {Fn::kSinh, "sinh", 1},
    {Fn::kCosh, "cosh", 1},
    {Fn::kTanh, "tanh", 1},
    {Fn::kExp, "exp", 1},
    {Fn::kLog, "log", 1},
    {Fn::kSqrt, "sqrt", 1},
    {Fn::kAbs, "abs", 1},
    {Fn::kSign, "sign", 1},
    {Fn::kMin, "min", 2},
    {Fn::kMax, "max", 2},
    {Fn::kHypot, "hypot", 2},
    {Fn::kClamp, "clamp", 3},
    {Fn::kSmoothAbs, "smoothabs", 2},
    {Fn::kSmoothSign, "smoothsign", 2},
    {Fn::kLt, "lt", 2, "<"},
    {Fn::kLe, "le", 2, "<="},
    {Fn::kGt, "gt", 2, ">"},
    {Fn::kGe, "ge", 2, ">="},
    {Fn::kEq, "eq", 2, "=="},
    {Fn::kNe, "ne", 2, "!="},
    {Fn::kAnd, "and", 2, "and"},
    {Fn::kOr, "or", 2, "or"},
    {Fn::kNot, "not", 1, "not"},
    {Fn::kIf, "if", 3},
}};

constexpr bool TableInEnumOrder() {
  for (int i = 0; i < kNumFns; ++i)
    if (static_cast<int>(kFunctions[static_cast<size_t>(i)].fn) != i) return false;
  return true;
}
static_assert(TableInEnumOrder(), "kFunctions must list the functions in the order of Fn");

/// Edit distance (insertions, deletions, substitutions), for the hint on an unknown function.
/// (io/did_you_mean.h has the loader's; core cannot use io.)
int EditDistance(std::string_view a, std::string_view b) {
  std::vector<int> prev(b.size() + 1), cur(b.size() + 1);
  for (size_t j = 0; j <= b.size(); ++j) prev[j] = static_cast<int>(j);
  for (size_t i = 1; i <= a.size(); ++i) {
    cur[0] = static_cast<int>(i);
    for (size_t j = 1; j <= b.size(); ++j)
      cur[j] = std::min({prev[j] + 1, cur[j - 1] + 1, prev[j - 1] + (a[i - 1] == b[j - 1] ? 0 : 1)});
    std::swap(prev, cur);
  }
  return prev[b.size()];
}

/// "did you mean 'sin'?" for a function name at most 2 edits away (1 for names of 1 or 2
/// letters), or "".
std::string FunctionHint(std::string_view word) {
  // Names other languages use.
  static constexpr std::pair<std::string_view, std::string_view> kOther[] = {
      {"ln", "write log(x) (the natural logarithm)"},
      {"log10", "write log(x)/log(10)"},
      {"pow", "write x^y"},
      {"sgn", "did you mean 'sign'?"},
      {"step", "write (1 + sign(x))/2 for a unit step of x"},
      {"heaviside", "write (1 + sign(x))/2 for a unit step of x"},
  };
  for (const auto& [name, hint] : kOther)
    if (word == name) return std::string(hint);
  const FunctionInfo* best = nullptr;
  int best_d = word.size() <= 2 ? 2 : 3;
  for (const FunctionInfo& f : kFunctions) {
    if (f.op) continue;
    const int d = EditDistance(word, f.name);
    if (d < best_d) {
      best_d = d;
      best = &f;
    }
  }
  return best ? fmt::format("did you mean '{}'?", best->name) : std::string();
}

std::shared_ptr<Node> NewNode(Node::Kind kind, int offset) {
  auto n = std::make_shared<Node>();
  n->kind = kind;
  n->offset = offset;
  return n;
}

bool IsBinary(Node::Kind k) {
  return k == Node::Kind::kAdd || k == Node::Kind::kSub || k == Node::Kind::kMul || k == Node::Kind::kDiv ||
         k == Node::Kind::kPow;
}

// ---------------------------------------------------------------------------------------------
// The parser: recursive descent over the grammar of expression.h, one function per rule.

struct Failure {
  ParseError error;
};

bool IsDigit(char c) { return c >= '0' && c <= '9'; }
bool IsIdentStart(char c) { return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || c == '_'; }
bool IsIdentChar(char c) { return IsIdentStart(c) || IsDigit(c); }

/// A character for a message: itself when printable ASCII, else its byte value.
std::string Shown(char c) {
  const auto u = static_cast<unsigned char>(c);
  if (u >= 0x21 && u <= 0x7e) return fmt::format("'{}'", c);
  return fmt::format("byte 0x{:02x}", u);
}

class Parser {
 public:
  explicit Parser(std::string_view text) : s_(text) {}

  NodePtr ParseAll() {
    NodePtr root = Expr();
    Space();
    if (pos_ < s_.size()) {
      if (s_[pos_] == ')') Fail(Here(), "')' without a matching '('");
      StrayOperator();
      Fail(Here(), fmt::format("unexpected {}", Shown(s_[pos_])),
           "an operator (+ - * / ^, a comparison, and, or) or the end was expected");
    }
    return root;
  }

 private:
  /// One level of nesting for the duration of a rule.
  class Nest {
   public:
    Nest(Parser& p, int offset) : p_(p) {
      if (++p_.depth_ > kMaxFormulaDepth)
        p_.Fail(offset, fmt::format("nested more than {} deep", kMaxFormulaDepth),
                "split the formula into parameters or simplify it");
    }
    ~Nest() { --p_.depth_; }
    Nest(const Nest&) = delete;
    Nest& operator=(const Nest&) = delete;

   private:
    Parser& p_;
  };

  [[noreturn]] void Fail(int offset, std::string message, std::string hint = {}) {
    throw Failure{ParseError{offset, std::move(message), std::move(hint)}};
  }
  int Here() const { return static_cast<int>(pos_); }
  void Space() {
    while (pos_ < s_.size() && (s_[pos_] == ' ' || s_[pos_] == '\t' || s_[pos_] == '\n' || s_[pos_] == '\r')) ++pos_;
  }
  /// The next character after blanks, or '\0' at the end.
  char Peek() {
    Space();
    return pos_ < s_.size() ? s_[pos_] : '\0';
  }

  /// The word that starts at the next token, if it is one of the grammar's (and, or, not): a
  /// bare word, not part of a dotted name. "" otherwise.
  std::string_view WordAhead() {
    Space();
    if (pos_ >= s_.size() || !IsIdentStart(s_[pos_])) return {};
    size_t end = pos_;
    while (end < s_.size() && IsIdentChar(s_[end])) ++end;
    if (end + 1 < s_.size() && s_[end] == '.' && IsIdentChar(s_[end + 1])) return {};
    const std::string_view word = s_.substr(pos_, end - pos_);
    return IsReservedWord(word) ? word : std::string_view();
  }

  /// A call of an operator of the table on its operands, at `offset`.
  static NodePtr Operator(Fn fn, std::vector<NodePtr> args, int offset) {
    auto n = NewNode(Node::Kind::kCall, offset);
    n->fn = fn;
    n->args = std::move(args);
    return n;
  }

  NodePtr Expr() {
    NodePtr left = Conjunct();
    while (WordAhead() == "or") {
      pos_ += 2;
      NodePtr right = Conjunct();
      left = Operator(Fn::kOr, {left, std::move(right)}, left->offset);
    }
    return left;
  }

  NodePtr Conjunct() {
    NodePtr left = Negation();
    while (WordAhead() == "and") {
      pos_ += 3;
      NodePtr right = Negation();
      left = Operator(Fn::kAnd, {left, std::move(right)}, left->offset);
    }
    return left;
  }

  NodePtr Negation() {
    if (WordAhead() != "not") return Comparison();
    const int at = Here();
    Nest nest(*this, at);
    pos_ += 3;
    return Operator(Fn::kNot, {Negation()}, at);
  }

  /// The comparison operator at the next token, and its length (0: none).
  std::pair<Fn, size_t> ComparisonAhead() {
    const char c = Peek();
    const char d = pos_ + 1 < s_.size() ? s_[pos_ + 1] : '\0';
    if (c == '<') return d == '=' ? std::pair{Fn::kLe, size_t{2}} : std::pair{Fn::kLt, size_t{1}};
    if (c == '>') return d == '=' ? std::pair{Fn::kGe, size_t{2}} : std::pair{Fn::kGt, size_t{1}};
    if (c == '=' && d == '=') return {Fn::kEq, 2};
    if (c == '!' && d == '=') return {Fn::kNe, 2};
    return {Fn::kLt, 0};
  }

  NodePtr Comparison() {
    Space();
    const size_t start = pos_;
    NodePtr left = Sum();
    const auto [fn, length] = ComparisonAhead();
    if (length == 0) return left;
    const size_t first = pos_;
    pos_ += length;
    if (Peek() == '>' && fn == Fn::kLt) Fail(static_cast<int>(first), "'<>' is not an operator", "'not equal' is written !=");
    NodePtr right = Sum();
    const size_t middle_end = pos_;
    if (const auto [fn2, length2] = ComparisonAhead(); length2 > 0) {
      // a < b < c: the hint writes it out with the formula's own operands where they read.
      const size_t second = pos_;
      pos_ += length2;
      const auto text = [&](size_t from, size_t to) {
        std::string_view v = s_.substr(from, to - from);
        while (!v.empty() && (v.back() == ' ' || v.back() == '\t' || v.back() == '\n' || v.back() == '\r')) v.remove_suffix(1);
        while (!v.empty() && (v.front() == ' ' || v.front() == '\t' || v.front() == '\n' || v.front() == '\r')) v.remove_prefix(1);
        return v;
      };
      std::string hint = "write a < b and b < c";
      try {
        Sum();
        const std::string_view a = text(start, first), b = text(first + length, middle_end), c = text(second + length2, pos_);
        if (a.size() + 2 * b.size() + c.size() <= 60)
          hint = fmt::format("write {} {} {} and {} {} {}", a, Info(fn).op, b, b, Info(fn2).op, c);
      } catch (const Failure&) {
      }
      Fail(static_cast<int>(second), fmt::format("comparisons do not chain: '{}' follows a comparison", Info(fn2).op), hint);
    }
    return Operator(fn, {left, std::move(right)}, left->offset);
  }

  /// A character that is no operator of the grammar but is one elsewhere (=, !, &, |, =<, =>):
  /// fails with the operator to write instead.
  void StrayOperator() {
    const char c = Peek();
    const char d = pos_ + 1 < s_.size() ? s_[pos_ + 1] : '\0';
    if (c == '=' && d == '<') Fail(Here(), "'=<' is not an operator", "'at most' is written <=");
    if (c == '=' && d == '>') Fail(Here(), "'=>' is not an operator", "'at least' is written >=");
    if (c == '=') Fail(Here(), "'=' is not an operator of formulas", "equality is written ==, as in a == b");
    if (c == '!') Fail(Here(), "'!' is not an operator", "the negation is written 'not', as in not (a < b); 'not equal' is !=");
    if (c == '&') Fail(Here(), "'&' is not an operator", "write 'and', as in a > 0 and b > 0");
    if (c == '|') Fail(Here(), "'|' is not an operator", "write 'or', as in a > 0 or b > 0");
  }

  NodePtr Sum() {
    NodePtr left = Term();
    for (char c = Peek(); c == '+' || c == '-'; c = Peek()) {
      ++pos_;
      left = Binary(c == '+' ? Node::Kind::kAdd : Node::Kind::kSub, left, Term(), left->offset);
    }
    return left;
  }

  NodePtr Term() {
    NodePtr left = Unary();
    for (char c = Peek(); c == '*' || c == '/'; c = Peek()) {
      ++pos_;
      left = Binary(c == '*' ? Node::Kind::kMul : Node::Kind::kDiv, left, Unary(), left->offset);
    }
    return left;
  }

  NodePtr Unary() {
    const char c = Peek();
    if (c != '-' && c != '+') return Power();
    const int at = Here();
    Nest nest(*this, at);
    ++pos_;
    NodePtr operand = Unary();
    if (c == '+') return operand;
    auto n = NewNode(Node::Kind::kNeg, at);
    n->args = {std::move(operand)};
    return n;
  }

  NodePtr Power() {
    NodePtr base = Primary();
    const char c = Peek();
    if (c == '^') {
      Nest nest(*this, Here());
      ++pos_;
      return Binary(Node::Kind::kPow, base, Unary(), base->offset);
    }
    if (const std::string_view word = WordAhead(); word == "and" || word == "or") return base;
    else if (word == "not")
      Fail(Here(), "unexpected 'not': an operator or the end was expected",
           "'not' stands before what it negates, as in not (a < b); 'not equal' is written !=");
    if (IsIdentStart(c) || IsDigit(c) || c == '(' || c == '.')
      Fail(Here(), fmt::format("missing operator before {}", Shown(c)), "a product is written with '*', as in 2*x");
    return base;
  }

  NodePtr Primary() {
    const char c = Peek();
    const int at = Here();
    if (IsDigit(c) || (c == '.' && pos_ + 1 < s_.size() && IsDigit(s_[pos_ + 1]))) return Numeral();
    if (IsIdentStart(c)) return NameOrCall();
    if (c == '(') {
      Nest nest(*this, at);
      ++pos_;
      NodePtr inner = Expr();
      if (Peek() != ')') {
        if (pos_ < s_.size()) StrayOperator();
        Expected("')' to close the '(' at offset " + std::to_string(at));
      }
      ++pos_;
      return inner;
    }
    if (pos_ < s_.size()) StrayOperator();
    Expected("a number, a name or '('");
  }

  [[noreturn]] void Expected(const std::string& what) {
    if (pos_ >= s_.size()) Fail(Here(), "the formula ends early: " + what + " was expected");
    Fail(Here(), fmt::format("unexpected {}: {} was expected", Shown(s_[pos_]), what));
  }

  NodePtr Numeral() {
    const size_t start = pos_;
    while (pos_ < s_.size() && IsDigit(s_[pos_])) ++pos_;
    if (pos_ < s_.size() && s_[pos_] == '.') {
      ++pos_;
      while (pos_ < s_.size() && IsDigit(s_[pos_])) ++pos_;
    }
    if (pos_ < s_.size() && (s_[pos_] == 'e' || s_[pos_] == 'E')) {
      size_t p = pos_ + 1;
      if (p < s_.size() && (s_[p] == '+' || s_[p] == '-')) ++p;
      if (p >= s_.size() || !IsDigit(s_[p]))
        Fail(static_cast<int>(p), fmt::format("the exponent of '{}' has no digits", s_.substr(start, p - start)),
             fmt::format("write {}*{} for a product", s_.substr(start, pos_ - start), s_[pos_]));
      pos_ = p;
      while (pos_ < s_.size() && IsDigit(s_[pos_])) ++pos_;
    }
    const std::string_view lexeme = s_.substr(start, pos_ - start);
    double v = 0.0;
    const auto [end, ec] = std::from_chars(lexeme.data(), lexeme.data() + lexeme.size(), v);
    if (ec == std::errc::result_out_of_range || (ec == std::errc() && !std::isfinite(v)))
      Fail(static_cast<int>(start), fmt::format("the number {} is out of the range of double precision", lexeme));
    MB_ASSERT(ec == std::errc() && end == lexeme.data() + lexeme.size(), "a numeral the lexer accepted");
    auto n = NewNode(Node::Kind::kNumber, static_cast<int>(start));
    n->value = v;
    return n;
  }

  NodePtr NameOrCall() {
    const size_t start = pos_;
    while (pos_ < s_.size() && IsIdentChar(s_[pos_])) ++pos_;
    bool dotted = false;
    while (pos_ + 1 < s_.size() && s_[pos_] == '.' && IsIdentChar(s_[pos_ + 1])) {
      dotted = true;
      ++pos_;
      if (IsDigit(s_[pos_])) {
        while (pos_ < s_.size() && IsDigit(s_[pos_])) ++pos_;
      } else {
        while (pos_ < s_.size() && IsIdentChar(s_[pos_])) ++pos_;
      }
    }
    if (pos_ < s_.size() && s_[pos_] == '.')
      Fail(Here(), fmt::format("'{}.' is cut short: a name or a number follows a '.' in a name",
                               s_.substr(start, pos_ - start)));
    const std::string_view word = s_.substr(start, pos_ - start);
    const int at = static_cast<int>(start);
    if (!dotted && IsReservedWord(word))
      Fail(at, fmt::format("unexpected '{}': a number, a name or '(' was expected", word),
           word == "not" ? "inside a sum, a product or a comparison a negation is put in parentheses: a < (not b)"
                         : fmt::format("'{}' joins two conditions, as in a > 0 {} b > 0", word, word));
    const FunctionInfo* f = dotted ? nullptr : FindFunction(word);
    if (Peek() != '(') {
      if (f) Fail(at, fmt::format("'{}' is a function", word), fmt::format("write {}(...)", word));
      auto n = NewNode(Node::Kind::kName, at);
      n->name = std::string(word);
      return n;
    }
    if (!f) Fail(at, fmt::format("unknown function '{}'", word), dotted ? std::string() : FunctionHint(word));
    Nest nest(*this, at);
    ++pos_;  // '('
    std::vector<NodePtr> args;
    if (Peek() != ')') {
      args.push_back(Expr());
      while (Peek() == ',') {
        ++pos_;
        args.push_back(Expr());
      }
      if (Peek() != ')') {
        if (pos_ < s_.size()) StrayOperator();
        Expected(fmt::format("',' or ')' in the arguments of {}", f->name));
      }
    }
    ++pos_;  // ')'
    if (static_cast<int>(args.size()) != f->arity)
      Fail(at, fmt::format("{} takes {} argument{}, not {}", f->name, f->arity, f->arity == 1 ? "" : "s", args.size()),
           fmt::format("{}", Usage(*f)));
    auto n = NewNode(Node::Kind::kCall, at);
    n->fn = f->fn;
    n->args = std::move(args);
    return n;
  }

  static std::string Usage(const FunctionInfo& f) {
    switch (f.fn) {
      case Fn::kAtan2: return "atan2(y, x)";
      case Fn::kMin: return "min(a, b)";
      case Fn::kMax: return "max(a, b)";
      case Fn::kHypot: return "hypot(x, y)";
      case Fn::kClamp: return "clamp(x, lo, hi)";
      case Fn::kSmoothAbs: return "smoothabs(x, eps)";
      case Fn::kSmoothSign: return "smoothsign(x, eps)";
      case Fn::kIf: return "if(condition, value where true, value where false)";
      default: return fmt::format("{}(x)", f.name);
    }
  }

  static NodePtr Binary(Node::Kind kind, NodePtr a, NodePtr b, int offset) {
    auto n = NewNode(kind, offset);
    n->args = {std::move(a), std::move(b)};
    return n;
  }

  std::string_view s_;
  size_t pos_ = 0;
  int depth_ = 0;
};

// ---------------------------------------------------------------------------------------------
// Formatting: a node is written at a level of the grammar; an operand below the level its place
// needs is put in parentheses.

enum Level : int { kOr = 1, kAnd = 2, kNot = 3, kCompare = 4, kSum = 5, kProduct = 6, kSigned = 7, kPower = 8, kAtom = 9 };

int LevelOf(const Node& n) {
  switch (n.kind) {
    case Node::Kind::kNumber: return std::signbit(n.value) ? kSigned : kAtom;
    case Node::Kind::kName: return kAtom;
    case Node::Kind::kCall:
      if (IsComparison(n.fn)) return kCompare;
      if (n.fn == Fn::kAnd) return kAnd;
      if (n.fn == Fn::kOr) return kOr;
      if (n.fn == Fn::kNot) return kNot;
      return kAtom;
    case Node::Kind::kNeg: return kSigned;
    case Node::Kind::kAdd:
    case Node::Kind::kSub: return kSum;
    case Node::Kind::kMul:
    case Node::Kind::kDiv: return kProduct;
    case Node::Kind::kPow: return kPower;
  }
  return kAtom;
}

void FormatTo(const Node& n, int need, std::string& out) {
  const bool parens = LevelOf(n) < need;
  if (parens) out += '(';
  switch (n.kind) {
    case Node::Kind::kNumber: out += fmt::format("{}", n.value); break;
    case Node::Kind::kName: out += n.name; break;
    case Node::Kind::kNeg:
      out += '-';
      FormatTo(*n.args[0], kSigned, out);
      break;
    case Node::Kind::kAdd:
    case Node::Kind::kSub:
      FormatTo(*n.args[0], kSum, out);
      out += n.kind == Node::Kind::kAdd ? " + " : " - ";
      FormatTo(*n.args[1], kProduct, out);
      break;
    case Node::Kind::kMul:
    case Node::Kind::kDiv:
      FormatTo(*n.args[0], kProduct, out);
      out += n.kind == Node::Kind::kMul ? '*' : '/';
      FormatTo(*n.args[1], kSigned, out);
      break;
    case Node::Kind::kPow:
      FormatTo(*n.args[0], kAtom, out);
      out += '^';
      FormatTo(*n.args[1], kSigned, out);
      break;
    case Node::Kind::kCall: {
      const FunctionInfo& f = Info(n.fn);
      if (IsComparison(n.fn)) {  // not associative: an operand that is a comparison is in parentheses
        FormatTo(*n.args[0], kSum, out);
        out += fmt::format(" {} ", f.op);
        FormatTo(*n.args[1], kSum, out);
      } else if (n.fn == Fn::kAnd || n.fn == Fn::kOr) {  // from the left, as the parser groups them
        const int level = n.fn == Fn::kAnd ? kAnd : kOr;
        FormatTo(*n.args[0], level, out);
        out += fmt::format(" {} ", f.op);
        FormatTo(*n.args[1], level + 1, out);
      } else if (n.fn == Fn::kNot) {
        // `not a < b`, not `not (a < b)`: parentheses the precedence does not need would nest the
        // text deeper than the formula it was parsed from, beyond kMaxFormulaDepth at worst.
        out += "not ";
        FormatTo(*n.args[0], kNot, out);
      } else {
        out += f.name;
        out += '(';
        for (size_t i = 0; i < n.args.size(); ++i) {
          if (i > 0) out += ", ";
          FormatTo(*n.args[i], kOr, out);
        }
        out += ')';
      }
      break;
    }
  }
  if (parens) out += ')';
}

void CollectNames(const Node& n, std::vector<const Node*>& out) {
  if (n.kind == Node::Kind::kName) {
    if (std::none_of(out.begin(), out.end(), [&](const Node* m) { return m->name == n.name; })) out.push_back(&n);
    return;
  }
  for (const NodePtr& a : n.args) CollectNames(*a, out);
}

}  // namespace

// ---------------------------------------------------------------------------------------------

const FunctionInfo* FindFunction(std::string_view name) {
  for (const FunctionInfo& f : kFunctions)
    if (!f.op && name == f.name) return &f;
  return nullptr;
}

bool IsReservedWord(std::string_view word) { return word == "and" || word == "or" || word == "not"; }

const FunctionInfo& Info(Fn fn) {
  const int i = static_cast<int>(fn);
  MB_ASSERT(i >= 0 && i < kNumFns, "a function of the table");
  return kFunctions[static_cast<size_t>(i)];
}

std::vector<std::string> FunctionNames() {
  std::vector<std::string> out;
  for (const FunctionInfo& f : kFunctions)
    if (!f.op) out.emplace_back(f.name);
  return out;
}

NodePtr Number(double v) {
  auto n = NewNode(Node::Kind::kNumber, 0);
  n->value = v;
  return n;
}

NodePtr Name(std::string name) {
  MB_ASSERT(!name.empty(), "a name");
  auto n = NewNode(Node::Kind::kName, 0);
  n->name = std::move(name);
  return n;
}

NodePtr Unary(Node::Kind kind, NodePtr a) {
  MB_ASSERT(kind == Node::Kind::kNeg && a, "a negation of a node");
  auto n = NewNode(kind, 0);
  n->args = {std::move(a)};
  return n;
}

NodePtr Binary(Node::Kind kind, NodePtr a, NodePtr b) {
  MB_ASSERT(IsBinary(kind) && a && b, "a binary operator on two nodes");
  auto n = NewNode(kind, 0);
  n->args = {std::move(a), std::move(b)};
  return n;
}

NodePtr Call(Fn fn, std::vector<NodePtr> args) {
  MB_ASSERT(static_cast<int>(args.size()) == Info(fn).arity, fmt::format("{} arguments for {}", args.size(), Info(fn).name));
  for (const NodePtr& a : args) MB_ASSERT(a != nullptr, "an argument");
  auto n = NewNode(Node::Kind::kCall, 0);
  n->fn = fn;
  n->args = std::move(args);
  return n;
}

ParseResult Parse(std::string_view text) {
  ParseResult r;
  if (text.size() > static_cast<size_t>(kMaxFormulaBytes)) {
    r.error = ParseError{kMaxFormulaBytes, fmt::format("the formula is longer than {} bytes", kMaxFormulaBytes),
                         "split it into parameters"};
    return r;
  }
  try {
    r.root = Parser(text).ParseAll();
  } catch (Failure& f) {
    r.root = nullptr;
    r.error = std::move(f.error);
  }
  return r;
}

std::vector<const Node*> Names(const Node& root) {
  std::vector<const Node*> out;
  CollectNames(root, out);
  return out;
}

std::string Format(const Node& root) {
  std::string out;
  FormatTo(root, kOr, out);
  return out;
}

double Evaluate(const Node& root, const std::function<std::optional<double>(const std::string&)>& value) {
  switch (root.kind) {
    case Node::Kind::kNumber: return root.value;
    case Node::Kind::kName: {
      if (const std::optional<double> v = value(root.name)) return *v;
      if (root.name == "pi") return std::numbers::pi;
      throw std::domain_error(fmt::format("unknown name '{}'", root.name));
    }
    case Node::Kind::kNeg: return -Evaluate(*root.args[0], value);
    case Node::Kind::kAdd: return Evaluate(*root.args[0], value) + Evaluate(*root.args[1], value);
    case Node::Kind::kSub: return Evaluate(*root.args[0], value) - Evaluate(*root.args[1], value);
    case Node::Kind::kMul: return Evaluate(*root.args[0], value) * Evaluate(*root.args[1], value);
    case Node::Kind::kDiv: return Evaluate(*root.args[0], value) / Evaluate(*root.args[1], value);
    case Node::Kind::kPow: return Power(Evaluate(*root.args[0], value), Evaluate(*root.args[1], value));
    case Node::Kind::kCall: {
      std::array<double, 3> a{};
      MB_ASSERT(root.args.size() <= a.size(), "at most 3 arguments");
      for (size_t i = 0; i < root.args.size(); ++i) a[i] = Evaluate(*root.args[i], value);
      return Apply(root.fn, a.data());
    }
  }
  MB_ASSERT(false, "a node kind");
}

double Apply(Fn fn, const double* a) {
  switch (fn) {
    case Fn::kSin: return mb_sin(a[0]);
    case Fn::kCos: return mb_cos(a[0]);
    case Fn::kTan: return mb_tan(a[0]);
    case Fn::kAsin: return mb_asin(a[0]);
    case Fn::kAcos: return mb_acos(a[0]);
    case Fn::kAtan: return mb_atan(a[0]);
    case Fn::kAtan2: return mb_atan2(a[0], a[1]);
    case Fn::kSinh: return mb_sinh(a[0]);
    case Fn::kCosh: return mb_cosh(a[0]);
    case Fn::kTanh: return mb_tanh(a[0]);
    case Fn::kExp: return mb_exp(a[0]);
    case Fn::kLog: return mb_log(a[0]);
    case Fn::kSqrt: return mb_sqrt(a[0]);
    case Fn::kAbs: return mb_abs(a[0]);
    case Fn::kSign: return mb_sign(a[0]);
    case Fn::kMin: return mb_min(a[0], a[1]);
    case Fn::kMax: return mb_max(a[0], a[1]);
    case Fn::kHypot: return mb_hypot(a[0], a[1]);
    case Fn::kClamp: return mb_clamp(a[0], a[1], a[2]);
    case Fn::kSmoothAbs: return mb_smoothabs(a[0], a[1]);
    case Fn::kSmoothSign: return mb_smoothsign(a[0], a[1]);
    case Fn::kLt: return mb_lt(a[0], a[1]);
    case Fn::kLe: return mb_le(a[0], a[1]);
    case Fn::kGt: return mb_gt(a[0], a[1]);
    case Fn::kGe: return mb_ge(a[0], a[1]);
    case Fn::kEq: return mb_eq(a[0], a[1]);
    case Fn::kNe: return mb_ne(a[0], a[1]);
    case Fn::kAnd: return mb_and(a[0], a[1]);
    case Fn::kOr: return mb_or(a[0], a[1]);
    case Fn::kNot: return mb_not(a[0]);
    case Fn::kIf: return mb_if(a[0], a[1], a[2]);
  }
  MB_ASSERT(false, "a function of the table");
}

double Power(double base, double exponent) { return mb_pow(base, exponent); }

const char* FunctionDefinitions() {
  static const std::string text = [] {
    // The macro's text comes out on one line; one definition per line reads better.
    std::string s = MB_EXPR_TEXT(MB_EXPR_FUNCTIONS);
    std::string out;
    for (size_t i = 0; i < s.size(); ++i) {
      if (s.compare(i, 7, "static ") == 0 && !out.empty()) {
        while (out.back() == ' ') out.pop_back();
        out += '\n';
      }
      out += s[i];
    }
    return out + '\n';
  }();
  return text.c_str();
}

}  // namespace multibond::expr
