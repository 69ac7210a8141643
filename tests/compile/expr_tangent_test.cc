// Directional derivatives of programs (compile/expr_tangent.cc, RunTangent): exact derivatives
// of formulas, and those of the piecewise-constant comparisons and logic (0) and of if (the
// chosen branch's, the other's NaN or infinity kept out).

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

}  // namespace
}  // namespace multibond::expr
