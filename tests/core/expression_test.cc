// Formulas (core/expression.h): the grammar's precedence and associativity, every function and its
// number of arguments, located errors with hints, the bounds, Format's round trip, evaluation and
// the functions' values.

#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <numbers>
#include <random>
#include <stdexcept>
#include <string>

#include <fmt/format.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "multibond/core/expression.h"

namespace multibond::expr {
namespace {

using ::testing::ElementsAre;
using ::testing::HasSubstr;

/// The tree in prefix form, every operator parenthesised: shows what the parser built.
std::string Dump(const Node& n) {
  switch (n.kind) {
    case Node::Kind::kNumber: return fmt::format("{}", n.value);
    case Node::Kind::kName: return n.name;
    case Node::Kind::kNeg: return fmt::format("(neg {})", Dump(*n.args[0]));
    case Node::Kind::kCall: {
      // (fmt::format, not "(" + std::string: GCC 12's false -Wrestrict)
      std::string s = fmt::format("({}", Info(n.fn).name);
      for (const auto& a : n.args) s += fmt::format(" {}", Dump(*a));
      return s + ")";
    }
    default: {
      const char* op = n.kind == Node::Kind::kAdd   ? "+"
                       : n.kind == Node::Kind::kSub ? "-"
                       : n.kind == Node::Kind::kMul ? "*"
                       : n.kind == Node::Kind::kDiv ? "/"
                                                    : "^";
      return fmt::format("({} {} {})", op, Dump(*n.args[0]), Dump(*n.args[1]));
    }
  }
}

std::string Tree(std::string_view text) {
  const ParseResult r = Parse(text);
  if (r.error) return fmt::format("error at {}: {}", r.error->offset, r.error->message);
  return Dump(*r.root);
}

ParseError ErrorOf(std::string_view text) {
  const ParseResult r = Parse(text);
  EXPECT_FALSE(r.root) << text;
  return r.error.value_or(ParseError{-1, "parsed", ""});
}

std::string Formatted(std::string_view text) {
  const ParseResult r = Parse(text);
  return r.root ? Format(*r.root) : fmt::format("error: {}", r.error->message);
}

double Eval(std::string_view text, const std::map<std::string, double>& values = {}) {
  const ParseResult r = Parse(text);
  EXPECT_TRUE(r.root) << text << ": " << (r.error ? r.error->message : "");
  return Evaluate(*r.root, [&](const std::string& name) -> std::optional<double> {
    const auto it = values.find(name);
    return it == values.end() ? std::nullopt : std::optional<double>(it->second);
  });
}

std::uint64_t Bits(double v) { return std::bit_cast<std::uint64_t>(v); }

TEST(Expression, SumsAndProductsAssociateToTheLeft) {
  EXPECT_EQ(Tree("a + b*c"), "(+ a (* b c))");
  EXPECT_EQ(Tree("a*b + c"), "(+ (* a b) c)");
  EXPECT_EQ(Tree("a - b - c"), "(- (- a b) c)");
  EXPECT_EQ(Tree("a / b / c"), "(/ (/ a b) c)");
  EXPECT_EQ(Tree("a / b * c"), "(* (/ a b) c)");
  EXPECT_EQ(Tree("(a + b)*c"), "(* (+ a b) c)");
  EXPECT_EQ(Tree("a - (b - c)"), "(- a (- b c))");
}

TEST(Expression, PowerIsRightAssociativeAndBindsTighterThanUnaryMinus) {
  EXPECT_EQ(Tree("a^b^c"), "(^ a (^ b c))");
  EXPECT_EQ(Tree("-x^2"), "(neg (^ x 2))");
  EXPECT_EQ(Tree("(-x)^2"), "(^ (neg x) 2)");
  EXPECT_EQ(Tree("2^-1"), "(^ 2 (neg 1))");
  EXPECT_EQ(Tree("x^-y^2"), "(^ x (neg (^ y 2)))");
  EXPECT_EQ(Tree("-2*x"), "(* (neg 2) x)");
  EXPECT_EQ(Tree("a*-b"), "(* a (neg b))");
  EXPECT_EQ(Tree("--x"), "(neg (neg x))");
  EXPECT_EQ(Tree("+x"), "x");
  EXPECT_EQ(Tree("2*x^3"), "(* 2 (^ x 3))");
  // The values agree: -2^2 = -4, 2^3^2 = 2^9.
  EXPECT_EQ(Eval("-2^2"), -4.0);
  EXPECT_EQ(Eval("2^3^2"), 512.0);
  EXPECT_EQ(Eval("(2^3)^2"), 64.0);
  EXPECT_EQ(Eval("10 - 4 - 3"), 3.0);
  EXPECT_EQ(Eval("64 / 4 / 2"), 8.0);
}

TEST(Expression, NumbersAndNames) {
  EXPECT_EQ(Eval(".5"), 0.5);
  EXPECT_EQ(Eval("2."), 2.0);
  EXPECT_EQ(Eval("1e3"), 1000.0);
  EXPECT_EQ(Eval("1.5E-3"), 1.5e-3);
  EXPECT_EQ(Eval("2e+2"), 200.0);
  EXPECT_EQ(Eval("0.1"), 0.1);
  EXPECT_EQ(Eval("4.9e-324"), std::numeric_limits<double>::denorm_min());
  EXPECT_EQ(Tree("spring.q + J.omega.z + body.1.x + _a1 + e"), "(+ (+ (+ (+ spring.q J.omega.z) body.1.x) _a1) e)");
  EXPECT_EQ(Tree(" \t a\n*\r\nb "), "(* a b)");  // blanks and line breaks (YAML block scalars)
}

TEST(Expression, EveryFunctionWithItsNumberOfArguments) {
  int operators = 0;
  for (int i = 0; i < kNumFns; ++i) operators += Info(static_cast<Fn>(i)).op != nullptr;
  EXPECT_EQ(operators, 9);  // < <= > >= == != and or not
  ASSERT_EQ(FunctionNames().size(), static_cast<size_t>(kNumFns - operators));
  for (int i = 0; i < kNumFns; ++i) {
    const FunctionInfo& f = Info(static_cast<Fn>(i));
    EXPECT_EQ(static_cast<int>(f.fn), i);
    if (f.op) {  // written as an operator, never called by name: lt(a, b) is no function
      EXPECT_EQ(FindFunction(f.name), nullptr) << f.name;
      EXPECT_THAT(FunctionNames(), ::testing::Not(::testing::Contains(f.name)));
      continue;
    }
    ASSERT_EQ(FindFunction(f.name), &f) << f.name;
    std::string args, more;
    for (int k = 0; k < f.arity; ++k) args += fmt::format("{}x{}", k ? ", " : "", k);
    const ParseResult r = Parse(fmt::format("{}({})", f.name, args));
    ASSERT_TRUE(r.root) << f.name;
    EXPECT_EQ(r.root->kind, Node::Kind::kCall);
    EXPECT_EQ(r.root->fn, f.fn);
    EXPECT_EQ(r.root->args.size(), static_cast<size_t>(f.arity));
    const ParseError over = ErrorOf(fmt::format("1 + {}({}, y)", f.name, args));
    EXPECT_EQ(over.offset, 4) << f.name;
    EXPECT_THAT(over.message, HasSubstr(fmt::format("{} takes {} argument", f.name, f.arity)));
    EXPECT_THAT(over.message, HasSubstr(fmt::format("not {}", f.arity + 1)));
    EXPECT_EQ(ErrorOf(fmt::format("{}()", f.name)).offset, 0) << f.name;
  }
  EXPECT_THAT(FunctionNames(), ::testing::Contains("smoothsign"));
  EXPECT_EQ(FindFunction("atan2")->arity, 2);
  EXPECT_EQ(FindFunction("clamp")->arity, 3);
  EXPECT_EQ(FindFunction("if")->arity, 3);
  EXPECT_EQ(FindFunction("nope"), nullptr);
  EXPECT_EQ(FindFunction("lt"), nullptr);
  EXPECT_EQ(FindFunction("and"), nullptr);
  // The enumerators of the operators, in the table's order after smoothsign.
  EXPECT_EQ(static_cast<int>(Fn::kLt), static_cast<int>(Fn::kSmoothSign) + 1);
  EXPECT_EQ(kNumFns, static_cast<int>(Fn::kIf) + 1);
  EXPECT_STREQ(Info(Fn::kLe).op, "<=");
  EXPECT_STREQ(Info(Fn::kNe).op, "!=");
  EXPECT_STREQ(Info(Fn::kNot).op, "not");
  EXPECT_EQ(Info(Fn::kIf).op, nullptr);
}

TEST(Expression, ComparisonsAndLogicHaveTheirPrecedence) {
  EXPECT_EQ(Tree("a < b"), "(lt a b)");
  EXPECT_EQ(Tree("a <= b"), "(le a b)");
  EXPECT_EQ(Tree("a > b"), "(gt a b)");
  EXPECT_EQ(Tree("a >= b"), "(ge a b)");
  EXPECT_EQ(Tree("a == b"), "(eq a b)");
  EXPECT_EQ(Tree("a != b"), "(ne a b)");
  EXPECT_EQ(Tree("a<-1"), "(lt a (neg 1))");  // no blanks needed
  // Comparisons bind looser than arithmetic, tighter than not, and, or.
  EXPECT_EQ(Tree("a + 1 < b*2"), "(lt (+ a 1) (* b 2))");
  EXPECT_EQ(Tree("-x^2 >= 0"), "(ge (neg (^ x 2)) 0)");
  EXPECT_EQ(Tree("not a < b"), "(not (lt a b))");
  EXPECT_EQ(Tree("not not a"), "(not (not a))");
  EXPECT_EQ(Tree("a < b and c > d"), "(and (lt a b) (gt c d))");
  EXPECT_EQ(Tree("a and b or c and d"), "(or (and a b) (and c d))");
  EXPECT_EQ(Tree("a or b and c"), "(or a (and b c))");
  EXPECT_EQ(Tree("not a and b"), "(and (not a) b)");
  EXPECT_EQ(Tree("not a or not b"), "(or (not a) (not b))");
  EXPECT_EQ(Tree("a and b and c"), "(and (and a b) c)");
  EXPECT_EQ(Tree("a or b or c"), "(or (or a b) c)");
  EXPECT_EQ(Tree("(a or b) and c"), "(and (or a b) c)");
  EXPECT_EQ(Tree("(a < b) < c"), "(lt (lt a b) c)");  // in parentheses, a comparison is an operand
  EXPECT_EQ(Tree("2*(x > 0)"), "(* 2 (gt x 0))");
  EXPECT_EQ(Tree("(x)or(y)"), "(or x y)");
  // if is a function of three arguments, each an expression of the whole grammar.
  EXPECT_EQ(Tree("if(x > 0 and y < 1, a, b + 1)"), "(if (and (gt x 0) (lt y 1)) a (+ b 1))");
  EXPECT_EQ(Tree("1 + if(c, a, b)"), "(+ 1 (if c a b))");
  // Words that only start like an operator are names; a dotted name is a name.
  EXPECT_EQ(Tree("order + android + note + not_ + and2 + x.and + or.q"), "(+ (+ (+ (+ (+ (+ order android) note) not_) and2) x.and) or.q)");
  // Offsets: an operator's node starts where its text does.
  const ParseResult r = Parse("x + 1 < y and not z");
  ASSERT_TRUE(r.root);
  EXPECT_EQ(r.root->offset, 0);                   // and
  EXPECT_EQ(r.root->args[0]->offset, 0);          // <
  EXPECT_EQ(r.root->args[1]->offset, 14);         // not
  EXPECT_EQ(r.root->args[1]->args[0]->offset, 18);
  EXPECT_EQ(Parse("  if(c, a, b)").root->offset, 2);
  EXPECT_TRUE(IsReservedWord("and"));
  EXPECT_TRUE(IsReservedWord("or"));
  EXPECT_TRUE(IsReservedWord("not"));
  EXPECT_FALSE(IsReservedWord("if"));
  EXPECT_FALSE(IsReservedWord("And"));
}

TEST(Expression, ComparisonsDoNotChain) {
  ParseError e = ErrorOf("0 < x < 1");
  EXPECT_EQ(e.offset, 6);
  EXPECT_EQ(e.message, "comparisons do not chain: '<' follows a comparison");
  EXPECT_EQ(e.hint, "write 0 < x and x < 1");
  e = ErrorOf("a <= b+1 >= (c)");
  EXPECT_EQ(e.offset, 9);
  EXPECT_EQ(e.hint, "write a <= b+1 and b+1 >= (c)");
  e = ErrorOf("a == b == ");  // the third operand does not read: the hint is the general one
  EXPECT_EQ(e.offset, 7);
  EXPECT_EQ(e.hint, "write a < b and b < c");
  EXPECT_TRUE(Parse("0 < x and x < 1").root);
}

TEST(Expression, OperatorsOfOtherLanguagesAreErrorsWithTheOneToWrite) {
  ParseError e = ErrorOf("a = b");
  EXPECT_EQ(e.offset, 2);
  EXPECT_EQ(e.message, "'=' is not an operator of formulas");
  EXPECT_EQ(e.hint, "equality is written ==, as in a == b");
  e = ErrorOf("min(a = b, c)");
  EXPECT_EQ(e.offset, 6);
  EXPECT_THAT(e.hint, HasSubstr("=="));
  EXPECT_EQ(ErrorOf("(a = b)").offset, 3);
  e = ErrorOf("a && b");
  EXPECT_EQ(e.offset, 2);
  EXPECT_EQ(e.hint, "write 'and', as in a > 0 and b > 0");
  EXPECT_EQ(ErrorOf("a || b").hint, "write 'or', as in a > 0 or b > 0");
  e = ErrorOf("!a");
  EXPECT_EQ(e.offset, 0);
  EXPECT_THAT(e.hint, HasSubstr("'not'"));
  EXPECT_EQ(ErrorOf("a <> b").hint, "'not equal' is written !=");
  EXPECT_EQ(ErrorOf("a =< b").hint, "'at most' is written <=");
  EXPECT_EQ(ErrorOf("a => b").hint, "'at least' is written >=");
  // The words in the wrong place.
  e = ErrorOf("a < not b");
  EXPECT_EQ(e.offset, 4);
  EXPECT_EQ(e.message, "unexpected 'not': a number, a name or '(' was expected");
  EXPECT_THAT(e.hint, HasSubstr("a < (not b)"));
  EXPECT_TRUE(Parse("a < (not b)").root);
  e = ErrorOf("and b");
  EXPECT_EQ(e.offset, 0);
  EXPECT_EQ(e.hint, "'and' joins two conditions, as in a > 0 and b > 0");
  EXPECT_EQ(ErrorOf("a or").offset, 4);
  EXPECT_EQ(ErrorOf("a and or b").offset, 6);
  e = ErrorOf("a not b");
  EXPECT_EQ(e.offset, 2);
  EXPECT_EQ(e.message, "unexpected 'not': an operator or the end was expected");
  EXPECT_EQ(ErrorOf("and(a, b)").offset, 0);
  e = ErrorOf("if(c, a)");
  EXPECT_EQ(e.message, "if takes 3 arguments, not 2");
  EXPECT_EQ(e.hint, "if(condition, value where true, value where false)");
  EXPECT_EQ(ErrorOf("if + 1").message, "'if' is a function");
  EXPECT_EQ(ErrorOf("lt(a, b)").message, "unknown function 'lt'");
}

TEST(Expression, ErrorsSayWhereAndWhat) {
  ParseError e = ErrorOf("2*(x+");
  EXPECT_EQ(e.offset, 5);
  EXPECT_THAT(e.message, HasSubstr("ends early"));
  e = ErrorOf("2*(x+1");
  EXPECT_EQ(e.offset, 6);
  EXPECT_THAT(e.message, HasSubstr("')' to close the '(' at offset 2"));
  e = ErrorOf("q*sinn(x)");
  EXPECT_EQ(e.offset, 2);
  EXPECT_EQ(e.message, "unknown function 'sinn'");
  EXPECT_EQ(e.hint, "did you mean 'sin'?");
  EXPECT_EQ(ErrorOf("smothabs(x, 1)").hint, "did you mean 'smoothabs'?");
  EXPECT_EQ(ErrorOf("frobnicate(x)").hint, "");
  EXPECT_EQ(ErrorOf("Sin(x)").hint, "did you mean 'sin'?");
  EXPECT_EQ(ErrorOf("arctan(x)").hint, "did you mean 'atan'?");
  EXPECT_EQ(ErrorOf("ln(x)").hint, "write log(x) (the natural logarithm)");
  EXPECT_EQ(ErrorOf("pow(x, 2)").hint, "write x^y");
  EXPECT_EQ(ErrorOf("spring.f(x)").message, "unknown function 'spring.f'");
  e = ErrorOf("1 + atan2(1)");
  EXPECT_EQ(e.offset, 4);
  EXPECT_EQ(e.message, "atan2 takes 2 arguments, not 1");
  EXPECT_EQ(e.hint, "atan2(y, x)");
  e = ErrorOf("1e");
  EXPECT_EQ(e.offset, 2);
  EXPECT_THAT(e.message, HasSubstr("exponent of '1e' has no digits"));
  EXPECT_EQ(e.hint, "write 1*e for a product");
  EXPECT_EQ(ErrorOf("1e+").offset, 3);
  e = ErrorOf("2 x");
  EXPECT_EQ(e.offset, 2);
  EXPECT_THAT(e.message, HasSubstr("missing operator before 'x'"));
  EXPECT_EQ(ErrorOf("2(x)").offset, 1);
  e = ErrorOf("x)");
  EXPECT_EQ(e.offset, 1);
  EXPECT_THAT(e.message, HasSubstr("')' without a matching '('"));
  EXPECT_EQ(ErrorOf("").offset, 0);
  EXPECT_EQ(ErrorOf("   ").offset, 3);
  e = ErrorOf("x $ y");
  EXPECT_EQ(e.offset, 2);
  EXPECT_THAT(e.message, HasSubstr("unexpected '$'"));
  e = ErrorOf("a*1e999");
  EXPECT_EQ(e.offset, 2);
  EXPECT_THAT(e.message, HasSubstr("out of the range"));
  EXPECT_EQ(ErrorOf("1e-999").offset, 0);
  e = ErrorOf("sin + 1");
  EXPECT_EQ(e.message, "'sin' is a function");
  EXPECT_EQ(e.hint, "write sin(...)");
  EXPECT_EQ(ErrorOf("a. + 1").offset, 1);
  EXPECT_EQ(ErrorOf("x*\xc3\xa9").message, "unexpected byte 0xc3: a number, a name or '(' was expected");
  EXPECT_EQ(ErrorOf("min(a b)").offset, 6);
  EXPECT_EQ(ErrorOf("min(a,)").offset, 6);
  EXPECT_EQ(ErrorOf("*x").offset, 0);
  EXPECT_EQ(ErrorOf("x^").offset, 2);
}

TEST(Expression, TextAndNestingAreBounded) {
  std::string sum = "1";
  while (sum.size() + 2 <= static_cast<size_t>(kMaxFormulaBytes)) sum += "+1";
  sum.resize(kMaxFormulaBytes - 1);
  sum += sum.back() == '+' ? "1" : " ";
  ASSERT_EQ(sum.size(), 4096u);
  EXPECT_TRUE(Parse(sum).root);
  const ParseError e = ErrorOf(sum + " ");
  EXPECT_EQ(e.offset, 4096);
  EXPECT_THAT(e.message, HasSubstr("longer than 4096 bytes"));

  const auto parens = [](int n) { return fmt::format("{}x{}", std::string(static_cast<size_t>(n), '('), std::string(static_cast<size_t>(n), ')')); };
  EXPECT_TRUE(Parse(parens(64)).root);
  EXPECT_EQ(ErrorOf(parens(65)).offset, 64);
  EXPECT_THAT(ErrorOf(parens(65)).message, HasSubstr("nested more than 64 deep"));
  EXPECT_TRUE(Parse(fmt::format("{}x", std::string(64, '-'))).root);
  EXPECT_EQ(ErrorOf(fmt::format("{}x", std::string(65, '-'))).offset, 64);
  std::string calls = "x";
  for (int i = 0; i < 65; ++i) calls = fmt::format("sin({})", calls);
  EXPECT_THAT(ErrorOf(calls).message, HasSubstr("nested"));
  std::string tower = "2";
  for (int i = 0; i < 64; ++i) tower += "^2";
  EXPECT_TRUE(Parse(tower).root);
  EXPECT_THAT(ErrorOf(fmt::format("{}^2", tower)).message, HasSubstr("nested"));
  // Deep text that is not nested is fine: a long sum is a loop, not a recursion.
  std::string terms = "x";
  for (int i = 0; i < 1000; ++i) terms += "+x";
  EXPECT_TRUE(Parse(terms).root);
}

TEST(Expression, FormatWritesTheFewestParentheses) {
  EXPECT_EQ(Formatted("k1*q + k3*q^3"), "k1*q + k3*q^3");
  EXPECT_EQ(Formatted("((a+b))*c"), "(a + b)*c");
  EXPECT_EQ(Formatted("a-(b-c)"), "a - (b - c)");
  EXPECT_EQ(Formatted("a-(b+c)"), "a - (b + c)");
  EXPECT_EQ(Formatted("(a-b)-c"), "a - b - c");
  EXPECT_EQ(Formatted("a+(b-c)"), "a + (b - c)");
  EXPECT_EQ(Formatted("(a^b)^c"), "(a^b)^c");
  EXPECT_EQ(Formatted("a^(b^c)"), "a^b^c");
  EXPECT_EQ(Formatted("(-a)^2"), "(-a)^2");
  EXPECT_EQ(Formatted("-(a^2)"), "-a^2");
  EXPECT_EQ(Formatted("-(a*b)"), "-(a*b)");
  EXPECT_EQ(Formatted("a/(b*c)"), "a/(b*c)");
  EXPECT_EQ(Formatted("a*(b/c)"), "a*(b/c)");
  EXPECT_EQ(Formatted("a*(-b)"), "a*-b");
  EXPECT_EQ(Formatted("a^(-b)"), "a^-b");
  EXPECT_EQ(Formatted("a - (-b)"), "a - -b");
  EXPECT_EQ(Formatted("atan2( y ,x+1 )"), "atan2(y, x + 1)");
  EXPECT_EQ(Formatted("1e-5 + 0.1 + 1e23 + 2.50"), "1e-05 + 0.1 + 1e+23 + 2.5");
  // Numbers built in code: a negative one is written as a sign, and parenthesised where needed.
  EXPECT_EQ(Format(*Binary(Node::Kind::kPow, Number(-2), Name("x"))), "(-2)^x");
  EXPECT_EQ(Format(*Binary(Node::Kind::kSub, Name("x"), Number(-0.0))), "x - -0");
  // Comparisons and logic, as operators.
  EXPECT_EQ(Formatted("a<b"), "a < b");
  EXPECT_EQ(Formatted("(x>0)and(y<1)"), "x > 0 and y < 1");
  EXPECT_EQ(Formatted("(a + 1) <= (b*c)"), "a + 1 <= b*c");
  EXPECT_EQ(Formatted("(a < b) == (c >= d)"), "(a < b) == (c >= d)");
  EXPECT_EQ(Formatted("(a and b) or c"), "a and b or c");
  EXPECT_EQ(Formatted("a and (b or c)"), "a and (b or c)");
  EXPECT_EQ(Formatted("a or (b or c)"), "a or (b or c)");
  EXPECT_EQ(Formatted("(a or b) or c"), "a or b or c");
  EXPECT_EQ(Formatted("a and (b and c)"), "a and (b and c)");
  EXPECT_EQ(Formatted("a and (not b)"), "a and not b");
  EXPECT_EQ(Formatted("(not a) or b"), "not a or b");
  EXPECT_EQ(Formatted("not (a or b)"), "not (a or b)");
  EXPECT_EQ(Formatted("-(a < b)"), "-(a < b)");
  EXPECT_EQ(Formatted("(a != b)^2"), "(a != b)^2");
  EXPECT_EQ(Formatted("k*(q > 0)"), "k*(q > 0)");
  EXPECT_EQ(Formatted("(not a) + 1"), "(not a) + 1");
  EXPECT_EQ(Formatted("a < (not b)"), "a < (not b)");
  EXPECT_EQ(Formatted("not a < (not (b < c))"), "not a < (not b < c)");
  // The operand of not: in parentheses only where the precedence needs them (more would nest the
  // text deeper than the formula it came from).
  EXPECT_EQ(Formatted("not (a < b)"), "not a < b");
  EXPECT_EQ(Formatted("not (x + 1)"), "not x + 1");
  EXPECT_EQ(Formatted("not (not a)"), "not not a");
  EXPECT_EQ(Formatted("not(done)"), "not done");
  EXPECT_EQ(Formatted("not -x^2"), "not -x^2");
  EXPECT_EQ(Formatted("not sign(x)"), "not sign(x)");
  EXPECT_EQ(Formatted("if( x>0 and y ,a,(b) )"), "if(x > 0 and y, a, b)");
  EXPECT_EQ(Format(*Call(Fn::kGe, {Number(-1), Name("x")})), "-1 >= x");
  EXPECT_EQ(Format(*Call(Fn::kNot, {Number(-1)})), "not -1");
  EXPECT_EQ(Format(*Call(Fn::kLt, {Call(Fn::kLt, {Name("a"), Name("b")}), Name("c")})), "(a < b) < c");
}

TEST(Expression, FormatNestsNoDeeperThanTheFormula) {
  // 64 nested negations of a comparison, and 32 negations each of a comparison in parentheses
  // whose right side is the next: as deep as a formula may be; formatted, they parse again.
  std::string nots;
  for (int i = 0; i < 64; ++i) nots += "not ";
  std::string chain = "x";
  for (int i = 0; i < 32; ++i) chain = fmt::format("not a < ({})", chain);
  for (const std::string& text : {nots + "x < y", nots + "x", chain}) {
    const ParseResult r = Parse(text);
    ASSERT_TRUE(r.root) << text.substr(0, 80) << ": " << r.error->message;
    const ParseResult again = Parse(Format(*r.root));
    ASSERT_TRUE(again.root) << Format(*r.root).substr(0, 80) << ": " << again.error->message;
    EXPECT_EQ(Dump(*again.root), Dump(*r.root));
  }
  EXPECT_FALSE(Parse("not " + nots + "x").root);  // 65
}

TEST(Expression, FormatOfAParsedFormulaParsesBackToTheSameTree) {
  for (const char* text : {"a < b", "not a < b and c or d", "x > 0 and y < 1", "not (a < b)", "a or (b or c)",
                           "(a < b) == (c >= d)", "if(not x, if(y != 0, 1, -1), q^2 <= 3 or t > 1)", "not not not a",
                           "2*(x > 0) - (x < 0)", "a and not b or not (c and d)", "-(x <= y)^2", "min(a < b, c) + (a == b)"}) {
    const ParseResult r = Parse(text);
    ASSERT_TRUE(r.root) << text;
    const std::string formatted = Format(*r.root);
    const ParseResult again = Parse(formatted);
    ASSERT_TRUE(again.root) << text << " -> " << formatted;
    EXPECT_EQ(Dump(*again.root), Dump(*r.root)) << text << " -> " << formatted;
  }
}

/// A random tree of every kind of node, with numbers of any sign and magnitude.
NodePtr RandomTree(std::mt19937_64& rng, int depth) {
  std::uniform_int_distribution<int> kind(0, depth > 0 ? 8 : 1);
  switch (kind(rng)) {
    case 0: {
      const double choices[] = {0.0, -0.0, 1.0, -2.5, 0.1, 1e-300, -3e250, 123456789.125, 1.0 / 3.0};
      return Number(choices[std::uniform_int_distribution<int>(0, 8)(rng)]);
    }
    case 1: {
      const char* names[] = {"q", "spring.q", "t", "pi", "J.omega.z", "e"};
      return Name(names[std::uniform_int_distribution<int>(0, 5)(rng)]);
    }
    case 2: return Unary(Node::Kind::kNeg, RandomTree(rng, depth - 1));
    case 3: return Binary(Node::Kind::kAdd, RandomTree(rng, depth - 1), RandomTree(rng, depth - 1));
    case 4: return Binary(Node::Kind::kSub, RandomTree(rng, depth - 1), RandomTree(rng, depth - 1));
    case 5: return Binary(Node::Kind::kMul, RandomTree(rng, depth - 1), RandomTree(rng, depth - 1));
    case 6: return Binary(Node::Kind::kDiv, RandomTree(rng, depth - 1), RandomTree(rng, depth - 1));
    case 7: return Binary(Node::Kind::kPow, RandomTree(rng, depth - 1), RandomTree(rng, depth - 1));
    default: {
      const Fn fn = static_cast<Fn>(std::uniform_int_distribution<int>(0, kNumFns - 1)(rng));
      std::vector<NodePtr> args;
      for (int k = 0; k < Info(fn).arity; ++k) args.push_back(RandomTree(rng, depth - 1));
      return Call(fn, std::move(args));
    }
  }
}

TEST(Expression, FormatReadsBackToTheSameTextAndValue) {
  std::mt19937_64 rng(20240611);
  const auto value = [](const std::string& name) -> std::optional<double> {
    if (name == "q") return 0.75;
    if (name == "spring.q") return -1.25;
    if (name == "t") return 2.0;
    if (name == "J.omega.z") return 3.5;
    if (name == "e") return 0.5;
    return std::nullopt;  // pi: M_PI
  };
  for (int i = 0; i < 2000; ++i) {
    const NodePtr tree = RandomTree(rng, 5);
    const std::string text = Format(*tree);
    const ParseResult again = Parse(text);
    ASSERT_TRUE(again.root) << text << ": " << again.error->message << " at " << again.error->offset;
    EXPECT_EQ(Format(*again.root), text);
    const double a = Evaluate(*tree, value), b = Evaluate(*again.root, value);
    EXPECT_TRUE(Bits(a) == Bits(b) || (std::isnan(a) && std::isnan(b))) << text << ": " << a << " vs " << b;
  }
}

// What fuzz/expression_fuzzer.cc checks, on random text and on valid formulas with random edits:
// a tree or a located error, and a tree formats to text that reads back to the same text.
TEST(Expression, RandomTextGivesATreeOrALocatedError) {
  std::mt19937_64 rng(99);
  const std::string alphabet = "0123456789.eE+-*/^(),_ abcpqtxz\t\n\x01\xc3\xa9#$<>=!&|";
  const std::vector<std::string> seeds = {"k1*q + k3*q^3", "-x^2^-y", "clamp(3*q, -1, 2)/(1e-3 + .5)",
                                          "atan2(spring.q, J.omega.z)", "smoothsign(f, 1e-3)*F_c + c*f",
                                          "if(q > 0 and not p <= 1, q, -q) + (t >= 2 or e != f)*(x == 1)"};
  int trees = 0, errors = 0;
  for (int i = 0; i < 20000; ++i) {
    std::string text;
    if (i % 2 == 0) {
      const int n = std::uniform_int_distribution<int>(0, 40)(rng);
      for (int k = 0; k < n; ++k) text += alphabet[std::uniform_int_distribution<size_t>(0, alphabet.size() - 1)(rng)];
    } else {
      text = seeds[static_cast<size_t>(i / 2) % seeds.size()];
      for (int edits = std::uniform_int_distribution<int>(1, 3)(rng); edits > 0; --edits) {
        const size_t at = std::uniform_int_distribution<size_t>(0, text.size())(rng);
        const char c = alphabet[std::uniform_int_distribution<size_t>(0, alphabet.size() - 1)(rng)];
        switch (std::uniform_int_distribution<int>(0, 2)(rng)) {
          case 0: text.insert(at, 1, c); break;
          case 1: if (at < text.size()) text.erase(at, 1); break;
          default: if (at < text.size()) text[at] = c;
        }
      }
    }
    const ParseResult r = Parse(text);
    if (!r.root) {
      ++errors;
      ASSERT_TRUE(r.error.has_value()) << text;
      EXPECT_FALSE(r.error->message.empty()) << text;
      EXPECT_GE(r.error->offset, 0) << text;
      EXPECT_LE(r.error->offset, static_cast<int>(text.size())) << text;
      continue;
    }
    ++trees;
    const std::string formatted = Format(*r.root);
    const ParseResult again = Parse(formatted);
    ASSERT_TRUE(again.root) << text << " -> " << formatted;
    EXPECT_EQ(Format(*again.root), formatted) << text;
  }
  EXPECT_GT(trees, 1000);
  EXPECT_GT(errors, 1000);
}

TEST(Expression, NamesInOrderOfFirstAppearance) {
  const ParseResult r = Parse("a*b + a*c + t + sin(pi*b)");
  ASSERT_TRUE(r.root);
  std::vector<std::string> names;
  std::vector<int> offsets;
  for (const Node* n : Names(*r.root)) {
    names.push_back(n->name);
    offsets.push_back(n->offset);
  }
  EXPECT_THAT(names, ElementsAre("a", "b", "c", "t", "pi"));
  EXPECT_THAT(offsets, ElementsAre(0, 2, 8, 12, 20));
  EXPECT_TRUE(Names(*Number(1)).empty());
}

TEST(Expression, Evaluates) {
  // The energy of a Duffing spring and its law.
  const std::map<std::string, double> v = {{"k1", 2.0}, {"k3", 0.5}, {"q", 3.0}};
  EXPECT_EQ(Eval("1/2*k1*q^2 + 1/4*k3*q^4", v), 0.5 * 2 * 9 + 0.25 * 0.5 * 81);
  EXPECT_EQ(Eval("k1*q + k3*q^3", v), 2.0 * 3 + 0.5 * 27);
  EXPECT_EQ(Eval("pi"), std::numbers::pi);
  EXPECT_EQ(Eval("pi", {{"pi", 3.0}}), 3.0);
  EXPECT_DOUBLE_EQ(Eval("atan2(1, -1)"), 3 * std::numbers::pi / 4);
  EXPECT_EQ(Eval("clamp(5, -1, 2) + clamp(-5, -1, 2) + clamp(0.5, -1, 2)"), 2.0 - 1.0 + 0.5);
  EXPECT_EQ(Eval("smoothabs(3, 4)"), 5.0);
  EXPECT_EQ(Eval("smoothsign(-3, 4)"), -0.6);
  EXPECT_EQ(Eval("hypot(5, 12)"), 13.0);
  EXPECT_EQ(Eval("min(2, -3) + max(2, -3)"), -1.0);
  EXPECT_DOUBLE_EQ(Eval("log(exp(1))"), 1.0);
  EXPECT_EQ(Eval("sqrt(16) + abs(-2) + sign(-0.5)"), 5.0);
  EXPECT_EQ(Eval("(1 < 2) + 10*(2 < 1) + 100*(2 <= 2) + 1000*(3 >= 4) + 1e4*(5 == 5) + 1e5*(5 != 5)"), 10101.0);
  EXPECT_EQ(Eval("if(x > 0, 10, 20) + if(not x > 0, 1, 2)", {{"x", 1.0}}), 12.0);
  EXPECT_EQ(Eval("if(x > 0, 10, 20) + if(not x > 0, 1, 2)", {{"x", -1.0}}), 21.0);
  EXPECT_EQ(Eval("(x > 0 and x < 1) + 2*(x < 0 or x > 1)", {{"x", 0.5}}), 1.0);
  EXPECT_EQ(Eval("(x > 0 and x < 1) + 2*(x < 0 or x > 1)", {{"x", 1.5}}), 2.0);
  EXPECT_EQ(Eval("if(x > 0, sqrt(x), sqrt(-x))", {{"x", -4.0}}), 2.0);  // the NaN of the other branch stays out
  try {
    Eval("k1*x", v);
    ADD_FAILURE() << "no error for an unknown name";
  } catch (const std::domain_error& e) {
    EXPECT_THAT(e.what(), HasSubstr("'x'"));
  }
}

TEST(Expression, TheFunctionsValues) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const auto apply = [](Fn fn, double a, double b = 0.0, double c = 0.0) {
    const double args[3] = {a, b, c};
    return Apply(fn, args);
  };
  EXPECT_EQ(apply(Fn::kSign, -3.0), -1.0);
  EXPECT_EQ(apply(Fn::kSign, 2e-300), 1.0);
  EXPECT_EQ(Bits(apply(Fn::kSign, 0.0)), Bits(0.0));
  EXPECT_EQ(Bits(apply(Fn::kSign, -0.0)), Bits(0.0));
  EXPECT_TRUE(std::isnan(apply(Fn::kSign, nan)));
  EXPECT_TRUE(std::isnan(apply(Fn::kMin, nan, 1.0)));
  EXPECT_TRUE(std::isnan(apply(Fn::kMin, 1.0, nan)));
  EXPECT_TRUE(std::isnan(apply(Fn::kMax, nan, 1.0)));
  EXPECT_TRUE(std::isnan(apply(Fn::kMax, 1.0, nan)));
  EXPECT_EQ(apply(Fn::kMin, 1.0, 2.0), 1.0);
  EXPECT_EQ(apply(Fn::kMax, 1.0, 2.0), 2.0);
  EXPECT_EQ(apply(Fn::kClamp, 3.0, 0.0, 1.0), 1.0);
  EXPECT_EQ(apply(Fn::kClamp, -3.0, 0.0, 1.0), 0.0);
  EXPECT_TRUE(std::isnan(apply(Fn::kClamp, nan, 0.0, 1.0)));
  EXPECT_EQ(apply(Fn::kSmoothAbs, 0.0, 1e-3), 1e-3);
  EXPECT_EQ(apply(Fn::kSmoothSign, 0.0, 1e-3), 0.0);
  EXPECT_EQ(apply(Fn::kSmoothSign, 1e6, 1e-3), 1.0);
  EXPECT_EQ(apply(Fn::kAtan2, 0.0, -1.0), std::numbers::pi);
  // ^: squares, cubes and reciprocals are products and a quotient; the rest is pow.
  for (const double x : {0.1, -1.7, 3.3e5, 1e-200}) {
    EXPECT_EQ(Bits(Power(x, 2.0)), Bits(x * x)) << x;
    EXPECT_EQ(Bits(Power(x, 3.0)), Bits(x * x * x)) << x;
    EXPECT_EQ(Bits(Power(x, -1.0)), Bits(1.0 / x)) << x;
    EXPECT_EQ(Bits(Power(x, 2.5)), Bits(std::pow(x, 2.5))) << x;
  }
  EXPECT_EQ(Power(0.0, 0.0), 1.0);
  // Comparisons: 1 or 0; a NaN compares false, but != true.
  const double inf = std::numeric_limits<double>::infinity();
  const struct {
    double a, b;
    double lt, le, gt, ge, eq, ne;
  } cases[] = {
      {1.0, 2.0, 1, 1, 0, 0, 0, 1},  {2.0, 1.0, 0, 0, 1, 1, 0, 1},  {1.0, 1.0, 0, 1, 0, 1, 1, 0},
      {0.0, -0.0, 0, 1, 0, 1, 1, 0}, {-inf, inf, 1, 1, 0, 0, 0, 1}, {nan, 1.0, 0, 0, 0, 0, 0, 1},
      {1.0, nan, 0, 0, 0, 0, 0, 1},  {nan, nan, 0, 0, 0, 0, 0, 1},
  };
  for (const auto& c : cases) {
    EXPECT_EQ(Bits(apply(Fn::kLt, c.a, c.b)), Bits(c.lt)) << c.a << " < " << c.b;
    EXPECT_EQ(Bits(apply(Fn::kLe, c.a, c.b)), Bits(c.le)) << c.a << " <= " << c.b;
    EXPECT_EQ(Bits(apply(Fn::kGt, c.a, c.b)), Bits(c.gt)) << c.a << " > " << c.b;
    EXPECT_EQ(Bits(apply(Fn::kGe, c.a, c.b)), Bits(c.ge)) << c.a << " >= " << c.b;
    EXPECT_EQ(Bits(apply(Fn::kEq, c.a, c.b)), Bits(c.eq)) << c.a << " == " << c.b;
    EXPECT_EQ(Bits(apply(Fn::kNe, c.a, c.b)), Bits(c.ne)) << c.a << " != " << c.b;
  }
  // Truth: a number other than 0 is true; 0, -0 and NaN are false. and, or, not give 1 or 0.
  for (const double x : {1.0, -2.0, 1e-300, inf, -inf}) {
    EXPECT_EQ(Bits(apply(Fn::kNot, x)), Bits(0.0)) << x;
    EXPECT_EQ(Bits(apply(Fn::kAnd, x, 3.0)), Bits(1.0)) << x;
    EXPECT_EQ(Bits(apply(Fn::kOr, x, 0.0)), Bits(1.0)) << x;
    EXPECT_EQ(Bits(apply(Fn::kIf, x, 7.0, 8.0)), Bits(7.0)) << x;
  }
  for (const double x : {0.0, -0.0, nan}) {
    EXPECT_EQ(Bits(apply(Fn::kNot, x)), Bits(1.0)) << x;
    EXPECT_EQ(Bits(apply(Fn::kAnd, x, 1.0)), Bits(0.0)) << x;
    EXPECT_EQ(Bits(apply(Fn::kAnd, 1.0, x)), Bits(0.0)) << x;
    EXPECT_EQ(Bits(apply(Fn::kOr, x, 0.0)), Bits(0.0)) << x;
    EXPECT_EQ(Bits(apply(Fn::kOr, 0.0, x)), Bits(0.0)) << x;
    EXPECT_EQ(Bits(apply(Fn::kOr, x, 2.0)), Bits(1.0)) << x;
    EXPECT_EQ(Bits(apply(Fn::kIf, x, 7.0, 8.0)), Bits(8.0)) << x;
  }
  // if is a select: the branch taken comes out with its bits (-0, NaN, inf), the other never leaks.
  EXPECT_EQ(Bits(apply(Fn::kIf, 1.0, -0.0, nan)), Bits(-0.0));
  EXPECT_EQ(Bits(apply(Fn::kIf, 0.0, inf, -0.0)), Bits(-0.0));
  EXPECT_EQ(Bits(apply(Fn::kIf, 0.0, nan, 2.5)), Bits(2.5));
  EXPECT_EQ(Bits(apply(Fn::kIf, 1.0, 2.5, -inf)), Bits(2.5));
  const double payload = std::bit_cast<double>(std::uint64_t{0x7ff8000000000123});
  EXPECT_EQ(Bits(apply(Fn::kIf, 1.0, payload, 0.0)), Bits(payload));
  const std::string text = FunctionDefinitions();
  for (int i = 0; i < kNumFns; ++i)
    EXPECT_THAT(text, HasSubstr(fmt::format("double mb_{}(", Info(static_cast<Fn>(i)).name)));
  EXPECT_THAT(text, HasSubstr("double mb_pow(double a, double b)"));
}

}  // namespace
}  // namespace multibond::expr
