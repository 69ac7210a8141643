// Directional derivatives of programs (compile/expr_tangent.cc, RunTangent): exact derivatives
// of formulas, and those of the piecewise-constant comparisons and logic (0) and of if (the
// chosen branch's, the other's NaN or infinity kept out). Their mixed second derivatives
// (RunSecondTangent) against closed forms, and the degree of a program in chosen inputs (Degree).

#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>

#include <gtest/gtest.h>

#include "multibond/compile/expr_program.h"

namespace multibond::expr {
namespace {

std::uint64_t Bits(double v) { return std::bit_cast<std::uint64_t>(v); }

/// x0, x1 are states.
Input Resolve(const Node& n) {
  if (n.name == "t") return {Input::In::kTime, 0, 0.0};
  return {Input::In::kState, n.name[1] - '0', 0.0};
}

/// d(formula)/d(x0 * dx0 + x1 * dx1) at x, and its value.
struct Tangent {
  double value = 0.0;
  double derivative = 0.0;
};
Tangent At(const std::string& formula, double x0, double x1, double dx0 = 1.0, double dx1 = 0.0) {
  const ParseResult r = Parse(formula);
  EXPECT_TRUE(r.root) << formula;
  const Program p = CompileProgram(*r.root, Resolve);
  const double x[2] = {x0, x1}, dx[2] = {dx0, dx1};
  Tangent out;
  out.derivative = RunTangent(p, 0.0, x, nullptr, 0.0, dx, nullptr, &out.value);
  return out;
}

TEST(ExprTangent, ComparisonsAndLogicHaveDerivativeZero) {
  for (const char* f : {"x0 < x1", "x0 <= x1", "x0 > x1", "x0 >= x1", "x0 == x1", "x0 != x1", "x0 and x1", "x0 or x1",
                        "not x0", "not (x0 > 1) and x1 < x0^2"}) {
    const Tangent d = At(f, 0.5, 2.0, 1.0, 1.0);
    EXPECT_EQ(Bits(d.derivative), Bits(0.0)) << f;
  }
  EXPECT_EQ(At("x0 < x1", 0.5, 2.0).value, 1.0);
  EXPECT_EQ(At("x0 >= x1", 0.5, 2.0).value, 0.0);
  // 0, not NaN, even where the operands' derivatives are NaN or infinite (sqrt at 0).
  EXPECT_EQ(Bits(At("sqrt(x0) > 1", 0.0, 0.0).derivative), Bits(0.0));
  EXPECT_EQ(Bits(At("not sqrt(x0) and 1/x0 < 2", 0.0, 0.0).derivative), Bits(0.0));
  // A step times a law: the law's derivative where the step is 1, 0 where it is 0.
  EXPECT_EQ(At("3*x0^2*(x0 > 0)", 2.0, 0.0).derivative, 12.0);
  EXPECT_EQ(At("3*x0^2*(x0 > 0)", -2.0, 0.0).derivative, 0.0);
}

TEST(ExprTangent, IfTakesTheDerivativeOfTheBranchItChooses) {
  Tangent d = At("if(x0 > 0, x0^3, 5*x0)", 2.0, 0.0);
  EXPECT_EQ(d.value, 8.0);
  EXPECT_EQ(d.derivative, 12.0);
  d = At("if(x0 > 0, x0^3, 5*x0)", -2.0, 0.0);
  EXPECT_EQ(d.value, -10.0);
  EXPECT_EQ(d.derivative, 5.0);
  // Along x1: the condition moves, its derivative does not count.
  EXPECT_EQ(At("if(x1 > x0, x0*x1, 0)", 2.0, 3.0, 0.0, 1.0).derivative, 2.0);
  // The branch not taken has a NaN derivative (sqrt at 0, 1/x at 0): it does not leak.
  d = At("if(x0 > 0, sqrt(x0), 2*x0)", 0.0, 0.0);
  EXPECT_EQ(d.value, 0.0);
  EXPECT_EQ(d.derivative, 2.0);
  d = At("if(x0 <= 0, 7*x0, sqrt(x0)*log(x0))", 0.0, 0.0);
  EXPECT_EQ(d.derivative, 7.0);
  // A condition whose own derivative is NaN or infinite.
  EXPECT_EQ(At("if(sqrt(x0) < 1, 4*x0, 0)", 0.0, 0.0).derivative, 4.0);
  // The taken branch's infinite derivative does come through.
  EXPECT_EQ(At("if(x0 >= 0, sqrt(x0), 0)", 0.0, 0.0).derivative, std::numeric_limits<double>::infinity());
  // A NaN condition is false: the else branch's derivative.
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(At("if(x1, x0^2, 3*x0)", 1.0, nan).derivative, 3.0);
}

/// The mixed second derivative of a formula of x0, x1 and t along v = (dx0, dx1, dt) and
/// f = (fx0, fx1, ft), at (x0, x1, t).
double Mixed(const std::string& formula, const double x[2], double t, const double v[3], const double f[3]) {
  const ParseResult r = Parse(formula);
  EXPECT_TRUE(r.root) << formula;
  const Program p = CompileProgram(*r.root, Resolve);
  return RunSecondTangent(p, t, x, nullptr, Direction{v[2], v, nullptr}, Direction{f[2], f, nullptr}, nullptr);
}

TEST(ExprSecondTangent, MixedSecondDerivativesAreTheirClosedForms) {
  const double x[2] = {0.7, -1.3}, t = 0.4;
  const double e0[3] = {1, 0, 0}, e1[3] = {0, 1, 0}, et[3] = {0, 0, 1};
  const double a = x[0], b = x[1];
  struct Case {
    const char* formula;
    const double* v;
    const double* f;
    double expected;
  };
  const Case cases[] = {
      {"x0*x1", e0, e1, 1.0},
      {"x0^3", e0, e0, 6 * a},
      {"x0^2.5", e0, e0, 2.5 * 1.5 * std::pow(a, 0.5)},
      {"x0^x0", e0, e0, std::pow(a, a) * ((std::log(a) + 1) * (std::log(a) + 1) + 1 / a)},
      {"x0/x1", e0, e1, -1 / (b * b)},
      {"x0/x1", e1, e1, 2 * a / (b * b * b)},
      {"sin(x0*t)", e0, et, std::cos(a * t) - a * t * std::sin(a * t)},
      {"cos(x0)*x1", e0, e1, -std::sin(a)},
      {"tan(x0)", e0, e0, 2 * std::tan(a) * (1 + std::tan(a) * std::tan(a))},
      {"asin(x0)", e0, e0, a / std::pow(1 - a * a, 1.5)},
      {"acos(x0)", e0, e0, -a / std::pow(1 - a * a, 1.5)},
      {"atan(x0)", e0, e0, -2 * a / ((1 + a * a) * (1 + a * a))},
      {"atan2(x0, x1)", e0, e1, (a * a - b * b) / ((a * a + b * b) * (a * a + b * b))},
      {"atan2(x0, x1)", e0, e0, -2 * a * b / ((a * a + b * b) * (a * a + b * b))},
      {"atan2(x0, x1)", e1, e1, 2 * a * b / ((a * a + b * b) * (a * a + b * b))},
      {"sinh(x0)", e0, e0, std::sinh(a)},
      {"cosh(x0)", e0, e0, std::cosh(a)},
      {"tanh(x0)", e0, e0, -2 * std::tanh(a) * (1 - std::tanh(a) * std::tanh(a))},
      {"exp(x0*x1)", e0, e1, std::exp(a * b) * (1 + a * b)},
      {"log(x0)", e0, e0, -1 / (a * a)},
      {"sqrt(x0)", e0, e0, -0.25 / std::pow(a, 1.5)},
      {"hypot(x0, x1)", e0, e1, -a * b / std::pow(a * a + b * b, 1.5)},
      {"smoothabs(x0, x1)", e0, e0, b * b / std::pow(a * a + b * b, 1.5)},
      {"smoothsign(x0, x1)", e0, e0, -3 * a * b * b / std::pow(a * a + b * b, 2.5)},
      {"smoothsign(x0, x1)", e0, e1, b * (2 * a * a - b * b) / std::pow(a * a + b * b, 2.5)},
      {"smoothsign(x0, x1)", e1, e1, a * (2 * b * b - a * a) / std::pow(a * a + b * b, 2.5)},
      // Kinks have no second derivative; if takes its branch's.
      {"abs(x0)*x0", e0, e0, 2 * std::copysign(1.0, a)},
      {"max(x0, x1)^2", e0, e0, 2.0},
      {"clamp(x0, -1, 0.5)", e0, e0, 0.0},
      {"if(x0 > 0, x0^3, x1^3)", e0, e0, 6 * a},
      {"if(x0 < 0, x0^3, x1^3)", e1, e1, 6 * b},
  };
  for (const Case& c : cases) EXPECT_NEAR(Mixed(c.formula, x, t, c.v, c.f), c.expected, 1e-13 * (1 + std::abs(c.expected))) << c.formula;
}

TEST(ExprSecondTangent, IsSymmetricAndBilinearInItsDirections) {
  const double x[2] = {0.3, 0.9}, t = 1.1;
  const double v[3] = {0.2, -0.7, 0.5}, f[3] = {1.3, 0.4, -0.6}, v2[3] = {0.4, -1.4, 1.0};
  for (const char* formula : {"sin(x0*x1 + t)/(1 + x1^2)", "exp(x0)*atan2(x1, t)", "x0^x1 * hypot(x0, t)"}) {
    const double vf = Mixed(formula, x, t, v, f);
    EXPECT_NEAR(vf, Mixed(formula, x, t, f, v), 1e-14 * (1 + std::abs(vf))) << formula;
    EXPECT_NEAR(2 * vf, Mixed(formula, x, t, v2, f), 1e-14 * (1 + std::abs(vf))) << formula;
  }
}

TEST(ExprSecondTangent, ReadsTheSlotsMixedSecondDerivatives) {
  // A slot w0 that is itself a function of the directions: its mixed derivative enters linearly.
  const ParseResult r = Parse("3*w0 + w0^2");
  const Program p = CompileProgram(*r.root, [](const Node&) { return Input{Input::In::kSlot, 0, 0.0}; });
  const double w[1] = {2.0}, dv[1] = {0.5}, df[1] = {-1.5}, dd[1] = {0.25};
  // d2(3 w + w^2) = (3 + 2 w) dd + 2 dv df
  EXPECT_NEAR(RunSecondTangent(p, 0.0, nullptr, w, Direction{0.0, nullptr, dv}, Direction{0.0, nullptr, df}, dd),
              7.0 * 0.25 + 2.0 * 0.5 * -1.5, 1e-15);
}

TEST(ExprDegree, ClassifiesConstantAffineAndNonlinear) {
  auto degree = [](const std::string& formula) {
    const ParseResult r = Parse(formula);
    EXPECT_TRUE(r.root) << formula;
    const Program p = CompileProgram(*r.root, Resolve);
    return Degree(p, [](const Input& in) { return in.in == Input::In::kState && in.offset == 0; });  // x0 moves
  };
  EXPECT_EQ(degree("sin(x1) + t"), 0);
  EXPECT_EQ(degree("3"), 0);
  EXPECT_EQ(degree("x1 < 2"), 0);
  EXPECT_EQ(degree("x0"), 1);
  EXPECT_EQ(degree("cos(x1)*x0 - 2*x0/x1 + t"), 1);
  EXPECT_EQ(degree("-(x0*sin(t))"), 1);
  EXPECT_EQ(degree("if(x1 > 0, x0, 2*x0)"), 1);
  EXPECT_EQ(degree("x0*x0"), 2);
  EXPECT_EQ(degree("x1/x0"), 2);
  EXPECT_EQ(degree("sin(x0)"), 2);
  EXPECT_EQ(degree("x0^2"), 2);
  EXPECT_EQ(degree("x1^x0"), 2);
  EXPECT_EQ(degree("if(x0 > 0, 1, 2)"), 2);
  EXPECT_EQ(degree("abs(x0)"), 2);
  EXPECT_EQ(degree("x0 > 1"), 2);
}

}  // namespace
}  // namespace multibond::expr
