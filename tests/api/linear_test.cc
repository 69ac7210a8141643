// The public Model's linear analysis (api/linear.cc), asserted on closed forms: the
// mass-spring-damper's matrices, its mode, an operating point later in the run and a steady state.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>

#include <multibond/multibond.h>

#include "api/msd.h"

namespace multibond {
namespace {

int IndexOf(const std::vector<std::string>& names, const std::string& name) {
  const auto it = std::find(names.begin(), names.end(), name);
  return it == names.end() ? -1 : static_cast<int>(it - names.begin());
}

// m x'' + c x' + k x = F with m = 1, c = 2, k = 100: q' = p / m, p' = F - k q - c p / m.
TEST(ApiLinear, MassSpringDamperMatricesAreTheEquations) {
  Model model = Model::FromString(test::MassSpringDamper());
  const LinearModel lm = model.Linearize();
  ASSERT_EQ(lm.A.rows, 2);
  ASSERT_EQ(lm.A.cols, 2);
  const int q = IndexOf(lm.states, "spring.q"), p = IndexOf(lm.states, "mass.p");
  ASSERT_GE(q, 0);
  ASSERT_GE(p, 0);
  EXPECT_NEAR(lm.A(q, q), 0.0, 1e-12);
  EXPECT_NEAR(lm.A(q, p), 1.0, 1e-12);
  EXPECT_NEAR(lm.A(p, q), -100.0, 1e-10);
  EXPECT_NEAR(lm.A(p, p), -2.0, 1e-12);
  const int u = IndexOf(lm.inputs, "force");
  ASSERT_GE(u, 0) << "inputs: " << ::testing::PrintToString(lm.inputs);
  EXPECT_NEAR(lm.B(q, u), 0.0, 1e-12);
  EXPECT_NEAR(lm.B(p, u), 1.0, 1e-12);
  const int y = IndexOf(lm.outputs, "velocity");
  ASSERT_GE(y, 0);
  EXPECT_NEAR(lm.C(y, p), 1.0, 1e-12);  // v = p / m
  EXPECT_NEAR(lm.C(y, q), 0.0, 1e-12);
  EXPECT_NEAR(lm.D(y, u), 0.0, 1e-12);
  EXPECT_FALSE(lm.steady);
  EXPECT_EQ(lm.at, 0.0);
}

TEST(ApiLinear, MassSpringDamperHasOneModeOfTheClosedForm) {
  Model model = Model::FromString(test::MassSpringDamper());
  const std::vector<Mode> modes = model.Modes();
  ASSERT_EQ(modes.size(), 1u);
  const Mode& m = modes[0];
  EXPECT_TRUE(m.conjugate_pair);
  EXPECT_NEAR(m.frequency_hz, 10.0 / (2 * std::numbers::pi), 1e-10);  // sqrt(k / m)
  EXPECT_NEAR(m.damping_ratio, 0.1, 1e-10);                            // c / (2 sqrt(k m))
  EXPECT_NEAR(m.eigenvalue.real(), -1.0, 1e-10);
  EXPECT_NEAR(m.eigenvalue.imag(), std::sqrt(99.0), 1e-10);
  EXPECT_NEAR(m.time_constant_s, 1.0, 1e-10);
  ASSERT_EQ(m.participation.size(), 2u);
  EXPECT_NEAR(m.participation[0].second + m.participation[1].second, 1.0, 1e-12);
}

TEST(ApiLinear, AnOperatingPointLaterInTheRunAndASteadyState) {
  Model model = Model::FromString(test::MassSpringDamper());
  OperatingPoint later;
  later.at = 0.5;
  const LinearModel at_half = model.Linearize(later);
  EXPECT_EQ(at_half.at, 0.5);
  EXPECT_NEAR(at_half.A(IndexOf(at_half.states, "mass.p"), IndexOf(at_half.states, "spring.q")), -100.0, 1e-10);  // linear: the same A
  OperatingPoint steady;
  steady.steady = true;
  EXPECT_TRUE(model.Linearize(steady).steady);
  OperatingPoint outside;
  outside.at = 5.0;  // the run ends at 2 s
  EXPECT_THROW(model.Linearize(outside), std::invalid_argument);
}

}  // namespace
}  // namespace multibond
