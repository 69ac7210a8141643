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
  ASSERT_EQ(FunctionNames().size(), static_cast<size_t>(kNumFns));
  for (int i = 0; i < kNumFns; ++i) {
    const FunctionInfo& f = Info(static_cast<Fn>(i));
    EXPECT_EQ(static_cast<int>(f.fn), i);
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
  EXPECT_EQ(FindFunction("nope"), nullptr);
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
  const std::string text = FunctionDefinitions();
  for (int i = 0; i < kNumFns; ++i)
    EXPECT_THAT(text, HasSubstr(fmt::format("double mb_{}(", Info(static_cast<Fn>(i)).name)));
  EXPECT_THAT(text, HasSubstr("double mb_pow(double a, double b)"));
}

}  // namespace
}  // namespace multibond::expr
