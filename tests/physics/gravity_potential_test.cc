// Gravity's potential energy in a mechanism (docs/mechanisms.md, "Bodies"): stored, m |g| h with h
// the height against g from the start, not a source's work; a pendulum's account against its
// position and its closed forms.

#include <cmath>
#include <numbers>

#include <gtest/gtest.h>

#include "support/example_runner.h"
#include "support/rigid_pendulum.h"

#include "multibond/io/model_loader.h"

namespace multibond {
namespace {

// A bar of 1 m (CoM 0.5 m below the pivot) on an ideal hinge about y, released at rest from
// 30 degrees, no damping (testing::kRigidPendulum): the energy goes between kinetic and potential
// and nothing is worked.
TEST(GravityPotential, PendulumStoresMghAndBalancesWithoutWork) {
  const LoadedModel lm = LoadModelString(testing::kRigidPendulum);
  const RecordingObserver rec = testing::RunModel(lm, 2.0, 0.001, Method::kBdf, 1e-10, 1e-12);
  ASSERT_EQ(rec.summary().status, RunStatus::kOk) << rec.summary().message;
  const double m = 2700 * 0.02 * 0.02 * 1.0, g = 9.81, z0 = -0.4330127018922193;
  const int z = rec.Index("bar.r.z"), pot = rec.Index("energy.potential"), work = rec.Index("energy.work");
  const int kin = rec.Index("energy.kinetic"), res = rec.Index("energy.residual");
  double largest_pot = 0.0;
  for (const auto& row : rec.rows()) {
    // m g (z - z0): the height and the position integrate the same velocity, so they agree to rounding.
    EXPECT_NEAR(row[pot], m * g * (row[z] - z0), 1e-12 * m * g) << "t = " << row[0];
    // Gravity is not work; what is left is the ideal hinge's, its reaction times a flow held at 0
    // to the integrator's tolerance.
    EXPECT_NEAR(row[work], 0.0, 1e-8 * m * g * 0.5) << "t = " << row[0];
    EXPECT_NEAR(row[kin] + row[pot], 0.0, 1e-8 * m * g * 0.5) << "t = " << row[0];
    largest_pot = std::min(largest_pot, row[pot]);
  }
  EXPECT_LT(std::abs(rec.rows().back()[res]), 1e-8);
  // At the bottom the CoM has fallen 0.5 (1 - cos 30 deg): all of it is kinetic there.
  const double drop = 0.5 * (1 - std::cos(std::numbers::pi / 6));
  EXPECT_NEAR(largest_pot, -m * g * drop, 1e-3 * m * g * drop);  // the lowest sample, within 1 ms of the bottom
}

}  // namespace
}  // namespace multibond
