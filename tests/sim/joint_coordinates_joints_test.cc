// The joint kinds cylindrical, planar, screw and universal in joint coordinates
// (sim/joint_coordinates.h), compliant and rigid: the tree joint and axis Mechanism::MakeJointTree
// takes for each, the same closed forms as tests/mech/joint_kinds_test.cc (on the same models,
// support/joint_kind_models.h), the run in inertial coordinates column by column, the energy
// balance, and, for a shaft spinning in a cylindrical joint, fewer steps than inertial
// coordinates.

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <string>

#include <gtest/gtest.h>

#include "support/example_runner.h"
#include "support/joint_kind_models.h"

#include "multibond/compile/compiled_model.h"
#include "multibond/mech/mechanism.h"
#include "multibond/sim/simulator.h"

namespace multibond::mech {
namespace {

using std::numbers::pi;
using namespace joint_kind_models;  // NOLINT(google-build-using-namespace): the models under test

/// One model run in both coordinates with the same settings.
struct Runs {
  JointTree tree;
  RecordingObserver inertial, joint;
  /// The largest difference of a column between the two runs over the column's scale
  /// (max(1, max |value|)), and that column.
  double agreement = 0.0;
  std::string worst_column;
};

Runs RunBoth(const Mechanism& m, double t_end, double dt, double rtol = 1e-10, double atol = 1e-12) {
  Runs r;
  r.tree = m.MakeJointTree();
  const auto model = CompiledModel::Compile(m.Build("test"), CompileOptions{});
  RunOptions o;
  o.t_end = t_end;
  o.dt = dt;
  o.integrator.rtol = rtol;
  o.integrator.atol = atol;
  Simulate(*model, o, r.inertial);
  o.joint_coordinates = r.tree;
  Simulate(*model, o, r.joint);
  EXPECT_EQ(r.inertial.summary().status, RunStatus::kOk) << r.inertial.summary().message;
  EXPECT_EQ(r.joint.summary().status, RunStatus::kOk) << r.joint.summary().message;
  EXPECT_EQ(r.inertial.columns().size(), r.joint.columns().size());
  EXPECT_EQ(r.inertial.rows().size(), r.joint.rows().size());
  if (r.inertial.columns().size() != r.joint.columns().size() || r.inertial.rows().size() != r.joint.rows().size()) return r;
  for (size_t c = 0; c < r.inertial.columns().size(); ++c) {
    EXPECT_EQ(r.inertial.columns()[c].name, r.joint.columns()[c].name);
    double scale = 1.0, worst = 0.0;
    for (size_t k = 0; k < r.inertial.rows().size(); ++k) {
      scale = std::max(scale, std::abs(r.inertial.rows()[k][c]));
      worst = std::max(worst, std::abs(r.inertial.rows()[k][c] - r.joint.rows()[k][c]));
    }
    if (worst / scale > r.agreement) r.agreement = worst / scale, r.worst_column = r.inertial.columns()[c].name;
  }
  return r;
}

/// The figures of a run pair, for the record.
void Report(const char* what, bool rigid, const Runs& r, double closed_form_error) {
  std::printf("%s (%s): closed form error %.3g, joint vs inertial %.3g (%s), steps %ld / %ld, recharts %ld, energy residual %.3g\n",
              what, rigid ? "rigid" : "compliant", closed_form_error, r.agreement, r.worst_column.c_str(),
              r.joint.summary().stats.steps, r.inertial.summary().stats.steps, r.joint.summary().recharts,
              testing::MaxEnergyResidual(r.joint));
}

/// The joint run agrees with the inertial one to the tolerances, and balances its energy.
void ExpectAgreementAndBalance(const Runs& r, double agreement, bool energy = true) {
  EXPECT_LT(r.agreement, agreement) << r.worst_column;
  if (energy) {
    EXPECT_LT(testing::MaxEnergyResidual(r.joint), 1e-7);
  }
  EXPECT_LT(r.joint.Last("cube.orthonormality"), 1e-12);
}


Mechanism Loaded(Mechanism m, const Eigen::Vector3d& g, const Eigen::Vector3d& torque_axis) {
  m.SetGravity(g);
  m.AddDrive(Torque("load", "cube", torque_axis, kT));
  return m;
}

// --- the tree ------------------------------------------------------------------------------

/// The one body's tree edge: from the ground, on J, about `axis` (either sense).
void ExpectEdge(const JointTree& tree, const Eigen::Vector3d& axis) {
  ASSERT_EQ(tree.size(), 1u);
  EXPECT_EQ(tree[0].name, "cube");
  EXPECT_EQ(tree[0].parent, "");
  EXPECT_EQ(tree[0].joint, "J");
  EXPECT_NEAR(std::abs(tree[0].axis.dot(axis)), 1.0, 1e-15) << tree[0].axis.transpose();
  EXPECT_TRUE(tree[0].bearing);  // the joint's free turn: kept, whatever the body's inertia
}

// The cylindrical and screw joints couple two rotation directions, the planar joint too (and one
// translation): the free turn is the body's axis, whatever the body's spin. The universal joint
// couples one: its axis is the yoke about which the body starts turning relative to its parent,
// the parent's yoke when it starts at rest. In the Cardan joint every shaft hangs from its
// bearing (two coupled rotation directions beat the cross's one), about the bearing's axis.
TEST(JointTree, TakesEachJointKindAndItsFreeTurnAsTheAxis) {
  for (bool rigid : {false, true}) {
    SCOPED_TRACE(rigid ? "rigid" : "compliant");
    ExpectEdge(CylinderOnZ(rigid).MakeJointTree(), Eigen::Vector3d::UnitZ());
    ExpectEdge(CylinderOnZ(rigid, 0.0).MakeJointTree(), Eigen::Vector3d::UnitZ());
    ExpectEdge(PuckOnTheFloor(rigid).MakeJointTree(), Eigen::Vector3d::UnitZ());
    ExpectEdge(Nut(rigid).MakeJointTree(), Eigen::Vector3d::UnitZ());
    ExpectEdge(CubeOnACross(rigid, {1.0, 0, 0}).MakeJointTree(), Eigen::Vector3d::UnitX());
    ExpectEdge(CubeOnACross(rigid, {0, 1.0, 0}).MakeJointTree(), Eigen::Vector3d::UnitY());
    ExpectEdge(CubeOnACross(rigid, {0.2, 1.0, 0.3}).MakeJointTree(), Eigen::Vector3d::UnitY());  // the nearer yoke
    ExpectEdge(CubeOnACross(rigid, Eigen::Vector3d::Zero()).MakeJointTree(), Eigen::Vector3d::UnitX());
    const double beta = 0.5;
    const JointTree cardan = Cardan(beta, 2.0, rigid).MakeJointTree();
    ASSERT_EQ(cardan.size(), 2u);
    EXPECT_EQ(cardan[0].name, "in");
    EXPECT_EQ(cardan[0].joint, "bearing_in");
    EXPECT_NEAR(std::abs(cardan[0].axis.x()), 1.0, 1e-15);
    EXPECT_EQ(cardan[1].name, "out");
    EXPECT_EQ(cardan[1].parent, "");
    EXPECT_EQ(cardan[1].joint, "bearing_out");
    EXPECT_NEAR(std::abs(cardan[1].axis.dot(Eigen::Vector3d(std::cos(beta), std::sin(beta), 0))), 1.0, 1e-15);
  }
}

// --- cylindrical ---------------------------------------------------------------------------

TEST(JointCoordinatesJoints, CylindricalSlidesAndTurnsFreelyAndHoldsTheRest) {
  for (bool rigid : {false, true}) {
    SCOPED_TRACE(rigid ? "rigid" : "compliant");
    const Runs r = RunBoth(Loaded(CylinderOnZ(rigid), {-kG, 0, 0}, Eigen::Vector3d::UnitY()), 1.0, 1e-3);
    const RecordingObserver& rec = r.joint;
    double error = ExpectHeldStatics(rec, {-kG, 0, 0}, Eigen::Vector3d::UnitY(), rigid);
    for (const auto& [column, expected] : {std::pair<const char*, double>{"cube.v.z", 0.5}, {"cube.omega.z", 2.0}, {"J.slide", 0.5},
                                           {"J.speed", 0.5}, {"J.angle", 2.0}, {"J.rate", 2.0}, {"cube.r.z", 0.5}}) {
      EXPECT_NEAR(rec.Last(column), expected, 1e-9) << column;
      error = std::max(error, std::abs(rec.Last(column) - expected));
    }
    if (rigid) {
      EXPECT_NEAR(rec.Last("cube.R.33"), 1.0, 1e-12);
    } else {
      EXPECT_NEAR(rec.Last("J.r.K.q.y"), kT / kKr, 1e-6 * kT / kKr);
      EXPECT_NEAR(rec.Last("J.r.K.q.x"), 0.0, 1e-6 * kT / kKr);
    }
    Report("Cylindrical", rigid, r, error);
    ExpectAgreementAndBalance(r, 1e-6);
  }
}

// A shaft spinning at 100 rad/s in a cylindrical joint (16 turns over the second), its weight
// across the axis: in inertial coordinates every component of its orientation and momentum turns
// with it; in joint coordinates only the angle grows, compliant or rigid, and the integrator
// takes a fraction of the steps (see the printout) for the same motion.
TEST(JointCoordinatesJoints, ASpinningCylindricalShaftTakesFewerStepsThanInInertialCoordinates) {
  const double spin = 100.0;
  for (bool rigid : {false, true}) {
    SCOPED_TRACE(rigid ? "rigid" : "compliant");
    Mechanism m = CylinderOnZ(rigid, spin);
    m.SetGravity({-kG, 0, 0});
    const Runs r = RunBoth(m, 1.0, 1e-2, 1e-8, 1e-10);
    const double error = std::max(std::abs(r.joint.Last("J.angle") - spin), std::abs(r.joint.Last("cube.omega.z") - spin));
    EXPECT_NEAR(r.joint.Last("J.angle"), spin, 1e-6 * spin);
    EXPECT_NEAR(r.joint.Last("cube.omega.z"), spin, 1e-6 * spin);
    Report("Cylindrical, spinning", rigid, r, error);
    EXPECT_LT(r.agreement, 1e-5) << r.worst_column;
    EXPECT_LT(3 * r.joint.summary().stats.steps, r.inertial.summary().stats.steps);
    EXPECT_EQ(r.joint.summary().recharts, 0);
  }
}

// The same shaft with a torque across the axis as well: the compliant coupling holds it at the
// tilt T / K_r, which the spinning shaft carries round with it (the coupling integrates the
// relative angular velocity in the parent's frame, so the steady spin is about the parent's z and
// the shaft's own axis cones about it at the spin, 5e-4 rad off). In joint coordinates that is the
// rotation off the axis turning at 100 rad/s, held to atol as a deflection is: fewer steps than in
// inertial coordinates still, but not by the factor of the free shaft. Rigid, there is no tilt.
TEST(JointCoordinatesJoints, ASpinningCylindricalShaftHeldTiltedCarriesItsTiltRound) {
  const double spin = 100.0;
  for (bool rigid : {false, true}) {
    SCOPED_TRACE(rigid ? "rigid" : "compliant");
    const Runs r = RunBoth(Loaded(CylinderOnZ(rigid, spin), {-kG, 0, 0}, Eigen::Vector3d::UnitY()), 1.0, 1e-2, 1e-8, 1e-10);
    const double error = ExpectHeldStatics(r.joint, {-kG, 0, 0}, Eigen::Vector3d::UnitY(), rigid);
    EXPECT_NEAR(r.joint.Last("J.angle"), spin, 1e-6 * spin);
    Report("Cylindrical, spinning, tilted", rigid, r, error);
    EXPECT_LT(r.agreement, 1e-5) << r.worst_column;
    EXPECT_LE(r.joint.summary().stats.steps, r.inertial.summary().stats.steps);
    if (rigid) {
      EXPECT_LT(3 * r.joint.summary().stats.steps, r.inertial.summary().stats.steps);
    }
  }
}

// A box of 0.1 x 0.2 x 0.3 m (three different moments) on a rigid cylindrical joint whose
// axis is 0.05 rad off the box's principal axis z, spinning at 100 rad/s: the joint holds it to
// the axis (the reactions turn with it, constant in the box's frame), so in joint coordinates only
// the angle grows. The axis is the bearing's, not moved to the principal axis next to it as a
// free body's spin is: about that, the rotation off the axis would turn at 100 rad/s.
TEST(JointCoordinatesJoints, AShaftOnABearingOffItsPrincipalAxisKeepsTheBearingsAxis) {
  const double spin = 100.0, tilt = 0.05;
  const Eigen::Vector3d axis(std::sin(tilt), 0, std::cos(tilt));
  Mechanism m;
  Body b;
  b.name = "cube";  // (the name the checks read)
  b.mass = MassProperties::Box(1000, {0.1, 0.2, 0.3});
  b.omega = spin * axis;
  m.AddBody(b);
  Joint j = MakeCylindrical("J", kGround, "cube", Eigen::Vector3d::Zero(), axis, kKt, kRt, kKr, kRr);
  j.sensors = true;
  MakeRigid(j);
  m.AddJoint(j);
  m.SetGravity({-kG, 0, 0});
  const Runs r = RunBoth(m, 1.0, 1e-2, 1e-8, 1e-10);
  ASSERT_EQ(r.tree.size(), 1u);
  EXPECT_TRUE(r.tree[0].bearing);
  EXPECT_NEAR(r.tree[0].axis.dot(axis), 1.0, 1e-15);
  EXPECT_NEAR(r.joint.Last("J.angle"), spin, 1e-6 * spin);
  EXPECT_NEAR(r.joint.Last("J.rate"), spin, 1e-6 * spin);
  Report("Cylindrical, off its principal axis", true, r, std::abs(r.joint.Last("J.angle") - spin));
  EXPECT_LT(r.agreement, 1e-5) << r.worst_column;
  EXPECT_LT(testing::MaxEnergyResidual(r.joint), 1e-7);
  EXPECT_LT(3 * r.joint.summary().stats.steps, r.inertial.summary().stats.steps);
}

// --- planar --------------------------------------------------------------------------------

TEST(JointCoordinatesJoints, PlanarGlidesAndTurnsAboutTheNormalAndHoldsTheRest) {
  for (bool rigid : {false, true}) {
    SCOPED_TRACE(rigid ? "rigid" : "compliant");
    const Runs r = RunBoth(Loaded(PuckOnTheFloor(rigid), {0, 0, -kG}, Eigen::Vector3d::UnitX()), 1.0, 1e-3);
    const RecordingObserver& rec = r.joint;
    double error = ExpectHeldStatics(rec, {0, 0, -kG}, Eigen::Vector3d::UnitX(), rigid);
    for (const auto& [column, expected] :
         {std::pair<const char*, double>{"cube.v.x", 0.3}, {"cube.v.y", -0.2}, {"cube.omega.z", 1.5}, {"J.slide.u", 0.3},
          {"J.slide.v", -0.2}, {"J.speed.u", 0.3}, {"J.speed.v", -0.2}, {"J.angle", 1.5}, {"J.rate", 1.5}, {"cube.r.x", 0.5}}) {
      EXPECT_NEAR(rec.Last(column), expected, 1e-9) << column;
      error = std::max(error, std::abs(rec.Last(column) - expected));
    }
    if (rigid) {
      EXPECT_NEAR(rec.Last("cube.R.33"), 1.0, 1e-12);
    } else {
      EXPECT_NEAR(rec.Last("J.r.K.q.x"), kT / kKr, 1e-6 * kT / kKr);
    }
    Report("Planar", rigid, r, error);
    ExpectAgreementAndBalance(r, 1e-6);
  }
}

// --- screw ---------------------------------------------------------------------------------

TEST(JointCoordinatesJoints, ANutFallsWithTheEffectiveMassOfItsSpin) {
  for (bool rigid : {false, true}) {
    SCOPED_TRACE(rigid ? "rigid" : "compliant");
    const double t = 1.0;
    const Runs r = RunBoth(Nut(rigid), t, 1e-3, 1e-11, 1e-13);
    // The closed form as in joint_kinds_test.cc, "Screw", in joint coordinates.
    Report("Screw", rigid, r, ExpectTheNutsFall(r.joint, rigid, t));
    // No work is done (gravity's is stored): the balance is the sum checked there, not the
    // residual relative to the work that MaxEnergyResidual takes.
    ExpectAgreementAndBalance(r, 1e-6, false);
  }
}

// --- universal -----------------------------------------------------------------------------

TEST(JointCoordinatesJoints, UniversalTurnsFreelyAboutEitherYokeAndHoldsTheThirdAxis) {
  for (bool rigid : {false, true}) {
    SCOPED_TRACE(rigid ? "rigid" : "compliant");
    for (int yoke : {0, 1}) {  // about the ground's yoke (x), then the cube's (y)
      SCOPED_TRACE(yoke == 0 ? "about x" : "about y");
      const Runs r = RunBoth(CubeOnACross(rigid, Eigen::Vector3d::Unit(yoke)), 2.0, 1e-2);
      const RecordingObserver& rec = r.joint;
      const char* a = yoke == 0 ? "J.angle_a" : "J.angle_b";
      const char* other = yoke == 0 ? "J.angle_b" : "J.angle_a";
      EXPECT_NEAR(rec.Last(yoke == 0 ? "cube.omega.x" : "cube.omega.y"), 1.0, 1e-9);
      EXPECT_NEAR(rec.Last(a), 2.0, 1e-9);
      EXPECT_NEAR(rec.Last(other), 0.0, 1e-9);
      EXPECT_NEAR(rec.Last(yoke == 0 ? "J.rate_a" : "J.rate_b"), 1.0, 1e-9);
      Report(yoke == 0 ? "Universal, about x" : "Universal, about y", rigid, r,
             std::max(std::abs(rec.Last(a) - 2.0), std::abs(rec.Last(other))));
      ExpectAgreementAndBalance(r, 1e-6);
      EXPECT_EQ(r.joint.summary().recharts, 0);  // 2 rad about the tree's axis: no re-chart
    }
    const Runs r = RunBoth(Loaded(CubeOnACross(rigid, Eigen::Vector3d::Zero()), {0, 0, -kG}, Eigen::Vector3d::UnitZ()), 0.5, 1e-3);
    const double error = ExpectHeldStatics(r.joint, {0, 0, -kG}, Eigen::Vector3d::UnitZ(), rigid);
    EXPECT_NEAR(r.joint.Last("cube.R.21"), rigid ? 0.0 : kT / kKr, 2e-3 * kT / kKr + 1e-9);
    if (!rigid) {
      EXPECT_NEAR(r.joint.Last("J.r.K.q"), -r.joint.Last("cube.R.12"), 1e-12);
    }
    Report("Universal, held", rigid, r, error);
    ExpectAgreementAndBalance(r, 1e-6);
  }
}

// A cube on the cross, at rest, spun up about the ground's yoke by a torque kT: theta_a = T t^2 /
// (2 I), 150 rad after 1 s. The tree's axis is that yoke (at rest, the parent's), so the angle is
// the one growing state and the chart holds to the end; about the spider's third axis, where the
// body has no free turn, the rotation off the axis would grow instead and pass the re-charting
// tilt every 1.5 rad.
TEST(JointCoordinatesJoints, UniversalSpunUpFromRestAboutTheParentsYokeKeepsItsChart) {
  const double inertia = 1.0 / 600, t = 1.0;
  for (bool rigid : {false, true}) {
    SCOPED_TRACE(rigid ? "rigid" : "compliant");
    Mechanism m = CubeOnACross(rigid, Eigen::Vector3d::Zero());
    m.AddDrive(Torque("motor", "cube", Eigen::Vector3d::UnitX(), kT));
    const Runs r = RunBoth(m, t, 1e-2, 1e-8, 1e-10);
    const double angle = kT * t * t / (2 * inertia), rate = kT * t / inertia;
    EXPECT_NEAR(r.joint.Last("J.angle_a"), angle, 1e-6 * angle);
    EXPECT_NEAR(r.joint.Last("J.rate_a"), rate, 1e-6 * rate);
    EXPECT_NEAR(r.joint.Last("J.angle_b"), 0.0, 1e-9);
    Report("Universal, spun up", rigid, r,
           std::max(std::abs(r.joint.Last("J.angle_a") - angle), std::abs(r.joint.Last("J.rate_a") - rate) * t));
    EXPECT_LT(r.agreement, 1e-5) << r.worst_column;
    EXPECT_LT(testing::MaxEnergyResidual(r.joint), 1e-7);
    EXPECT_EQ(r.joint.summary().recharts, 0);
    EXPECT_LT(3 * r.joint.summary().stats.steps, r.inertial.summary().stats.steps);
  }
}

TEST(JointCoordinatesJoints, CardanOutputSpeedFollowsTheClosedForm) {
  const double beta = 0.5, w1 = 2.0;
  for (bool rigid : {true, false}) {
    SCOPED_TRACE(rigid ? "rigid" : "compliant");
    const Runs r = RunBoth(Cardan(beta, w1, rigid), 2 * pi / w1, 1e-3, 1e-11, 1e-13);
    Report("Cardan", rigid, r, ExpectCardanSpeeds(r.joint, beta, w1, rigid));
    EXPECT_LT(r.agreement, 1e-6) << r.worst_column;
    EXPECT_LT(testing::MaxEnergyResidual(r.joint), 1e-6);
    for (const char* b : {"in", "out"}) EXPECT_LT(r.joint.Last(std::string(b) + ".orthonormality"), 1e-12) << b;
  }
}

}  // namespace
}  // namespace multibond::mech
