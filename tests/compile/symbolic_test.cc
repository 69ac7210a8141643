// Symbolic work on formulas through GiNaC (compile/symbolic.h): a Duffing spring's law from its
// energy and back, a numerical energy of a law without a closed-form integral, the derivatives of
// the piecewise and smooth helpers against finite differences, simplification.

#include <cmath>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "multibond/compile/symbolic.h"
#include "multibond/core/expression.h"

namespace multibond::expr {
namespace {

using ::testing::HasSubstr;

NodePtr Tree(const std::string& text) {
  const ParseResult r = Parse(text);
  EXPECT_TRUE(r.root) << text << ": " << (r.error ? r.error->message : "");
  return r.root ? r.root : Number(0);
}

using Values = std::map<std::string, double>;

double At(const Node& n, const Values& v) {
  return Evaluate(n, [&](const std::string& name) -> std::optional<double> {
    const auto it = v.find(name);
    return it == v.end() ? std::nullopt : std::optional<double>(it->second);
  });
}

TEST(Symbolic, TheLawOfADuffingSpringFromItsEnergy) {
  const NodePtr energy = Tree("1/2*k1*q^2 + 1/4*k3*q^4");
  const NodePtr law = Differentiate(*energy, "q");
  for (const double q : {-2.0, -0.3, 0.0, 0.7, 1.9})
    for (const auto& [k1, k3] : std::vector<std::pair<double, double>>{{2.0, 0.5}, {1e3, -40.0}}) {
      const Values v = {{"q", q}, {"k1", k1}, {"k3", k3}};
      EXPECT_DOUBLE_EQ(At(*law, v), k1 * q + k3 * q * q * q) << Format(*law) << " at q = " << q;
    }
  EXPECT_TRUE(DependsOn(*law, "k1"));
  EXPECT_TRUE(DependsOn(*law, "q"));
  EXPECT_FALSE(DependsOn(*law, "k2"));
  // The names come back as they went in, readable.
  EXPECT_THAT(Format(*law), HasSubstr("k1*q"));
  EXPECT_THAT(Format(*law), HasSubstr("k3*q^3"));
}

TEST(Symbolic, TheEnergyOfADuffingSpringFromItsLaw) {
  const std::optional<NodePtr> energy = IntegrateFromZero(*Tree("k1*q + k3*q^3"), "q");
  ASSERT_TRUE(energy.has_value());
  for (const double q : {-2.0, -0.3, 0.0, 0.7, 1.9}) {
    const Values v = {{"q", q}, {"k1", 2.0}, {"k3", 0.5}};
    EXPECT_DOUBLE_EQ(At(**energy, v), 0.5 * 2.0 * q * q + 0.25 * 0.5 * q * q * q * q) << Format(**energy);
  }
  // The energy's derivative is the law again.
  const NodePtr law = Differentiate(**energy, "q");
  EXPECT_DOUBLE_EQ(At(*law, {{"q", 1.5}, {"k1", 2.0}, {"k3", 0.5}}), 2.0 * 1.5 + 0.5 * 1.5 * 1.5 * 1.5);
  // Numbers as written: 0.1 is a tenth.
  const std::optional<NodePtr> tenth = IntegrateFromZero(*Tree("0.1*q"), "q");
  ASSERT_TRUE(tenth.has_value());
  EXPECT_EQ(Format(**tenth), "q^2/20");
  // A constant law: a linear energy; nothing: zero.
  EXPECT_EQ(Format(**IntegrateFromZero(*Tree("F"), "q")), "F*q");
  EXPECT_EQ(Format(**IntegrateFromZero(*Tree("0"), "q")), "0");
}

TEST(Symbolic, NoClosedFormIsNoAnswer) {
  EXPECT_FALSE(IntegrateFromZero(*Tree("tanh(q)"), "q").has_value());
  EXPECT_FALSE(IntegrateFromZero(*Tree("c*sin(q^2)"), "q").has_value());
}

/// d/dq of f against a central difference at points away from the kinks.
void ExpectDerivative(const std::string& f, const std::vector<double>& points, const Values& params = {}) {
  const NodePtr tree = Tree(f);
  const NodePtr d = Differentiate(*tree, "q");
  for (const double q : points) {
    Values v = params;
    const double h = 1e-6;
    v["q"] = q + h;
    const double up = At(*tree, v);
    v["q"] = q - h;
    const double down = At(*tree, v);
    v["q"] = q;
    const double exact = At(*d, v), difference = (up - down) / (2 * h);
    EXPECT_NEAR(exact, difference, 1e-7 * std::max(1.0, std::abs(exact))) << "d/dq " << f << " = " << Format(*d) << " at q = " << q;
  }
}

TEST(Symbolic, DerivativesOfThePiecewiseAndSmoothFunctions) {
  const std::vector<double> points = {-2.3, -1.1, -0.4, 0.3, 0.8, 1.7, 2.9};
  ExpectDerivative("min(q^2, 2*q + 1)", points);
  ExpectDerivative("min(3, q)*q", points);
  ExpectDerivative("max(sin(q), q/3)", points);
  ExpectDerivative("max(q, -q)", points);
  ExpectDerivative("clamp(3*q, -1, 2)", points);
  ExpectDerivative("clamp(0.5, q, 2)", points);   // d/dlo
  ExpectDerivative("clamp(0.5, -1, q)", points);  // d/dhi
  ExpectDerivative("smoothabs(q^2 - 1, 0.1)", points);
  ExpectDerivative("smoothabs(0.5, q)", points);  // d/deps
  ExpectDerivative("smoothsign(q, 0.3)", points);
  ExpectDerivative("smoothsign(0.7, q)", points);
  ExpectDerivative("hypot(q, 2) + hypot(3, q^2)", points);
  ExpectDerivative("abs(q^2 - 1)", points);
  ExpectDerivative("sign(q)*q^2", points);
  ExpectDerivative("atan2(q, 2) + atan2(1, q)", points);
  ExpectDerivative("k*exp(-q/tau)*cos(2*pi*q)", points, {{"k", 2.0}, {"tau", 0.7}});
  ExpectDerivative("sqrt(q^2 + 1) + log(q^2) + tan(q/2) + asin(q/3) + acos(q/4) + atan(q)", points);
  ExpectDerivative("sinh(q) + cosh(q) + tanh(q) + abs(q)^1.5 + abs(q)^0.5^q", points);
}

TEST(Symbolic, KinksDifferentiateToSignsNotNaN) {
  // GiNaC's d|x|/dx is x/|x|; it comes back as sign(x): 0 at 0, not 0/0.
  const NodePtr d = Differentiate(*Tree("abs(q)"), "q");
  EXPECT_EQ(Format(*d), "sign(q)");
  EXPECT_EQ(At(*d, {{"q", 0.0}}), 0.0);
  EXPECT_EQ(At(*d, {{"q", -2.0}}), -1.0);
  EXPECT_EQ(Format(*Differentiate(*Tree("sign(q)*k"), "q")), "0");
  // min and max at a tie: half of each side.
  EXPECT_EQ(At(*Differentiate(*Tree("min(q, 1)"), "q"), {{"q", 1.0}}), 0.5);
  EXPECT_EQ(At(*Differentiate(*Tree("max(q, 1)"), "q"), {{"q", 3.0}}), 1.0);
  EXPECT_EQ(At(*Differentiate(*Tree("max(q, 1)"), "q"), {{"q", -3.0}}), 0.0);
}

TEST(Symbolic, Simplifies) {
  EXPECT_EQ(Format(*Simplify(*Tree("q - q + 2*x/x"))), "2");
  EXPECT_FALSE(DependsOn(*Tree("x - x + q"), "x"));
  EXPECT_FALSE(DependsOn(*Tree("(x^2 - 1)/(x - 1) - x"), "x"));
  EXPECT_TRUE(DependsOn(*Tree("sin(pi*t)"), "pi"));
  const NodePtr s = Simplify(*Tree("(q^2 - 1)/(q - 1)"));
  EXPECT_THAT(Format(*s), ::testing::Not(HasSubstr("/")));
  EXPECT_EQ(At(*s, {{"q", 3.0}}), 4.0);
  EXPECT_EQ(Format(*Simplify(*Tree("0.5*q + 1/4*q"))), "3*q/4");
  EXPECT_EQ(Format(*Simplify(*Tree("k/3"))), "k/3");
  EXPECT_EQ(Format(*Simplify(*Tree("-k*q"))), "-k*q");
  // Every function survives the trip through GiNaC with its value.
  const std::string all =
      "sin(q) + cos(q) + tan(q) + asin(q/3) + acos(q/3) + atan(q) + atan2(q, 2) + sinh(q) + cosh(q) + tanh(q) + "
      "exp(q) + log(q) + sqrt(q) + abs(q) + sign(q) + min(q, 1) + max(q, 1) + hypot(q, 1) + clamp(q, 0, 1) + "
      "smoothabs(q, 0.1) + smoothsign(q, 0.1) + q^2.5 + pi";
  const NodePtr back = Simplify(*Tree(all));
  for (const double q : {0.3, 0.9, 2.0})
    EXPECT_NEAR(At(*back, {{"q", q}}), At(*Tree(all), {{"q", q}}), 1e-13 * std::abs(At(*Tree(all), {{"q", q}}))) << Format(*back);
}

TEST(Symbolic, ComparisonsLogicAndIf) {
  // Comparisons and logic are piecewise constant: derivative 0.
  for (const char* f : {"q < 1", "q <= k", "q > 0", "q >= -q", "q == 2", "q != 2", "q > 0 and q < 1", "q < 0 or q > 1",
                        "not q > 0", "k*(q > 0 and not q == 3)"})
    EXPECT_EQ(Format(*Differentiate(*Tree(f), "q")), "0") << f;
  // if differentiates to the select of the branches' derivatives, not to a blend of them.
  EXPECT_EQ(Format(*Differentiate(*Tree("if(q > 0, k*q^2/2, c*q)"), "q")), "if(q > 0, k*q, c)");
  EXPECT_EQ(Format(*Differentiate(*Tree("if(q > 0 and q < 1, q^3, 0)"), "q")), "if(q > 0 and q < 1, 3*q^2, 0)");
  EXPECT_EQ(Format(*Differentiate(*Tree("2*if(not q <= 1, sqrt(q), 1)"), "q")), "2*if(not q <= 1, 1/(2*sqrt(q)), 0)");
  // The branch not taken may be NaN or infinite where the one taken is fine: it stays out.
  const NodePtr d = Differentiate(*Tree("if(q > 0, sqrt(q), 5*q)"), "q");
  EXPECT_EQ(At(*d, {{"q", 0.0}}), 5.0);
  EXPECT_EQ(At(*d, {{"q", -1.0}}), 5.0);
  EXPECT_EQ(At(*d, {{"q", 4.0}}), 0.25);
  ExpectDerivative("if(q > 0.5, q^2, -q) + q*(q < 0) + if(q >= 1 or q < -1, sin(q), cos(q))", {-2.3, -0.4, 0.3, 0.8, 1.7});
  // A select of equal branches is the branch; one of a known condition is the branch taken.
  EXPECT_EQ(Format(*Simplify(*Tree("if(q > 0, k*q, q*k)"))), "k*q");
  EXPECT_EQ(Format(*Simplify(*Tree("if(2 > 1, q, 0) + (1 == 1) + (3 < 2) + (1 and 0) + (0 or 2) + (not 0)"))), "3 + q");
  // Comparisons of a variable with itself are kept: at a NaN, q == q is false.
  EXPECT_EQ(Format(*Simplify(*Tree("q == q"))), "q == q");
  // Every operator comes back as itself, with its value.
  const std::string all = "(q < 1) + (q <= 1) + 2*(q > 1) + (q >= 1) + (q == 2) + (q != 2) + (q > 0 and q < 3) + (q < 0 or q > 1) + "
                          "(not q > 1) + if(q > 1, q^2, -q)";
  const NodePtr back = Simplify(*Tree(all));
  for (const double q : {-1.0, 0.5, 1.0, 2.0, 3.5}) EXPECT_EQ(At(*back, {{"q", q}}), At(*Tree(all), {{"q", q}})) << Format(*back);
  // A law with a switch has no closed-form energy here: numerical integration, no error.
  EXPECT_FALSE(IntegrateFromZero(*Tree("if(q > 0, k*q, 2*k*q)"), "q").has_value());
  EXPECT_FALSE(IntegrateFromZero(*Tree("k*q*(q > 0)"), "q").has_value());
  // (A law in which the switch does not depend on q integrates as before.)
  const std::optional<NodePtr> e = IntegrateFromZero(*Tree("if(k > 1, k, 1)*q"), "q");
  ASSERT_TRUE(e.has_value());
  EXPECT_EQ(At(**e, {{"q", 2.0}, {"k", 3.0}}), 6.0);
  EXPECT_EQ(At(**e, {{"q", 2.0}, {"k", 0.5}}), 2.0);
  EXPECT_TRUE(DependsOn(*Tree("if(q > 0, 1, 2)"), "q"));
  EXPECT_FALSE(DependsOn(*Tree("if(q > 0, x, x)"), "q"));
}

TEST(Symbolic, WhatFormulasCannotExpressIsAnError) {
  try {
    Simplify(*Tree("sqrt(-1)"));
    ADD_FAILURE() << "no error for the imaginary unit";
  } catch (const std::domain_error& e) {
    EXPECT_THAT(e.what(), HasSubstr("complex"));
  }
}

}  // namespace
}  // namespace multibond::expr
