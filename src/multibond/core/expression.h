#pragma once
/// \file
/// Expressions in models (docs/model-format.md, "Expressions"): the one grammar, its syntax tree
/// and its table of functions. A formula in a model file is parsed once, here, into a tree;
/// everything else works on the tree: parameters are evaluated from it (io/), laws are
/// differentiated and integrated from it (compile/symbolic.h, GiNaC), and the right-hand side is
/// compiled from it into a flat program that the interpreter runs and the code generator writes
/// as C++ (compile/expr_program.h). Model text never reaches generated code: names become array
/// offsets and numbers become exact hexadecimal literals.
///
/// Grammar (precedence from low to high; `^` is right-associative, unary minus binds looser
/// than `^`, so -x^2 = -(x^2); comparisons do not chain: a < b < c is an error):
///   expr       = conjunct { "or" conjunct }
///   conjunct   = negation { "and" negation }
///   negation   = "not" negation | comparison
///   comparison = sum [ ("<" | "<=" | ">" | ">=" | "==" | "!=") sum ]
///   sum        = term { ("+" | "-") term }
///   term       = unary { ("*" | "/") unary }
///   unary      = ("-" | "+") unary | power
///   power      = primary [ "^" unary ]
///   primary    = number | name | name "(" [ expr { "," expr } ] ")" | "(" expr ")"
///   number     = digits [ "." digits ] [ ("e" | "E") [ "+" | "-" ] digits ]  (also ".5", "2.")
///   name       = ident { "." ( ident | digits ) }      ident = (letter | "_") { letter | digit | "_" }
/// Reserved names: `t` (time, s), `pi`, `e` is NOT reserved (it is a variable in a law). The
/// words `and`, `or` and `not` are operators, never names (IsReservedWord).
/// Comparisons and logic are calls of the table (Fn::kLt ... Fn::kNot), written as operators.

#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace multibond::expr {

/// Functions of the grammar. The table (expression.cc) gives each its name, its number of
/// arguments and its value; the interpreter, the code generator and the symbolic layer all read
/// that one table.
enum class Fn : unsigned char {
  kSin, kCos, kTan, kAsin, kAcos, kAtan, kAtan2, kSinh, kCosh, kTanh, kExp, kLog, kSqrt, kAbs,
  kSign, kMin, kMax,
  // helpers (documented in docs/model-format.md): hypot(x, y); clamp(x, lo, hi);
  // smoothabs(x, eps) = sqrt(x^2 + eps^2); smoothsign(x, eps) = x / sqrt(x^2 + eps^2)
  kHypot, kClamp, kSmoothAbs, kSmoothSign,
  // comparisons (a < b, ...: 1 or 0; false where a side is NaN, but != true), logic (a and b,
  // a or b, not a: 1 or 0, on truth values: x is true where x != 0, NaN is false), and
  // if(c, a, b): a where c is true, else b (a select: the other branch does not reach the value).
  // The comparisons and logic are written as operators (FunctionInfo::op), not as calls.
  kLt, kLe, kGt, kGe, kEq, kNe, kAnd, kOr, kNot, kIf,
};
inline constexpr int kNumFns = static_cast<int>(Fn::kIf) + 1;

struct FunctionInfo {
  Fn fn;
  const char* name;  ///< as written in a model: "atan2"; an operator's: "lt" (generated code's mb_lt)
  int arity;
  const char* op = nullptr;  ///< an operator's text ("<", "and", "not"), nullptr for a function
};
/// The row of a function called by name (not an operator's: FindFunction("lt") is nullptr), or
/// nullptr for an unknown name.
const FunctionInfo* FindFunction(std::string_view name);
const FunctionInfo& Info(Fn fn);
/// Every name of a function called by name (operators not included), for "did you mean" hints.
std::vector<std::string> FunctionNames();
/// True for the words of the grammar that are operators (`and`, `or`, `not`): no name may be one.
bool IsReservedWord(std::string_view word);
/// Whether fn is a comparison (kLt ... kNe).
inline constexpr bool IsComparison(Fn fn) { return fn >= Fn::kLt && fn <= Fn::kNe; }

/// One node of the tree. Immutable once built; shared between trees.
struct Node;
using NodePtr = std::shared_ptr<const Node>;
struct Node {
  enum class Kind : unsigned char { kNumber, kName, kNeg, kAdd, kSub, kMul, kDiv, kPow, kCall };
  Kind kind = Kind::kNumber;
  double value = 0.0;         ///< kNumber
  std::string name;           ///< kName: "L", "spring.q", "J.omega.z", "t", "pi"
  Fn fn = Fn::kSin;           ///< kCall
  std::vector<NodePtr> args;  ///< operands (1 for kNeg, 2 for binary, the call's arguments)
  int offset = 0;             ///< byte offset of the node's first character in the formula's text
};

/// Building trees in code (laws derived by the engine, a lag's rate, a transformer's equation).
NodePtr Number(double v);
NodePtr Name(std::string name);
NodePtr Unary(Node::Kind kind, NodePtr a);  ///< kNeg
NodePtr Binary(Node::Kind kind, NodePtr a, NodePtr b);
NodePtr Call(Fn fn, std::vector<NodePtr> args);

/// A syntax error: where in the text (byte offset), what, and a hint ("did you mean 'sqrt'?").
struct ParseError {
  int offset = 0;
  std::string message;
  std::string hint;
};

/// Parses one formula. Returns the tree, or the first error. Bounded: at most 4096 bytes of text
/// and a nesting depth of 64 (an error beyond either). Unknown functions and wrong numbers of
/// arguments are errors here; names are not resolved here (see Names).
struct ParseResult {
  NodePtr root;                       ///< null on error
  std::optional<ParseError> error;
};
ParseResult Parse(std::string_view text);
inline constexpr int kMaxFormulaBytes = 4096;
/// Parentheses, calls, signs and exponents nested in one another.
inline constexpr int kMaxFormulaDepth = 64;

/// The distinct names a tree refers to, in order of first appearance (with the node of the first
/// appearance, for its offset). `t` and `pi` are included when used.
std::vector<const Node*> Names(const Node& root);

/// The tree as a formula, fully readable and parseable again ("k1*q + k3*q^3"), with the fewest
/// parentheses the precedence needs; numbers in the shortest form that reads back exactly.
std::string Format(const Node& root);

/// Evaluates a tree whose names are all given by `value` (nullopt: unknown name). `t` and `pi`
/// are passed to `value` like any name (pi is then M_PI unless `value` says otherwise).
/// Throws std::domain_error naming the unknown name.
double Evaluate(const Node& root, const std::function<std::optional<double>(const std::string&)>& value);

/// The value of f at its arguments: the one definition every engine uses (the interpreter calls
/// it; the generated code calls functions with the same bodies, see expr_program.h).
double Apply(Fn fn, const double* args);

/// The value of base^exponent, the `^` operator, in every engine: an exponent of exactly 2 or 3
/// is a product (x*x, (x*x)*x), -1 a quotient (1/x), anything else std::pow. A compiler turns
/// pow(x, 2.0) and pow(x, -1.0) into x*x and 1/x by itself, which can differ from the library's
/// pow in the last bit; writing them so in both engines keeps the interpreter and the generated
/// code equal (and saves a call on the common q^2, q^3).
double Power(double base, double exponent);

/// C++ text defining mb_<name> for every function (mb_sin, ..., mb_smoothsign, mb_lt, ..., mb_if) and mb_pow: the
/// very definitions Apply and Power run (one macro is both compiled and written out), for the
/// top of generated code (compile/expr_program.h, ProgramPreamble). Needs <cmath>.
const char* FunctionDefinitions();

}  // namespace multibond::expr
