// The joint kinds cylindrical, planar, screw and universal (mech/joint_kinds.cc,
// mech/expand_joint.cc), compliant and rigid: their free directions keep a body's motion, their
// coupled directions hold a load at the deflection F / K (rigid: none) with the load as the
// reaction, the energy balances, and against closed forms: a nut falling on a vertical screw, a
// Cardan joint's output speed. Their keys and errors in a model file (io/mechanism_reader.cc).

#include <cmath>
#include <cstdio>
#include <numbers>
#include <string>
#include <utility>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "support/example_runner.h"
#include "support/joint_kind_models.h"
#include "support/load_errors.h"

#include "multibond/compile/compiled_model.h"
#include "multibond/mech/mechanism.h"
#include "multibond/sim/simulator.h"

namespace multibond::mech {
namespace {

using std::numbers::pi;
using ::testing::HasSubstr;
using namespace joint_kind_models;  // NOLINT(google-build-using-namespace): the models under test

RecordingObserver Simulated(const Mechanism& m, double t_end, double dt, double rtol = 1e-10, double atol = 1e-12) {
  RecordingObserver rec = testing::RunGraph(m.Build("test"), {}, t_end, dt, IntegratorOptions{}.method, rtol, atol);
  EXPECT_EQ(rec.summary().status, RunStatus::kOk) << rec.summary().message;
  return rec;
}

/// Each named column's last value is the value given, to `tol`.
void ExpectLast(const RecordingObserver& rec, const std::vector<std::pair<std::string, double>>& expected, double tol) {
  for (const auto& [column, value] : expected) EXPECT_NEAR(rec.Last(column), value, tol) << column;
}

/// Runs `m` (a cube on joint J to the ground, loaded by gravity `g` and a torque kT about
/// `torque_axis`, both across coupled directions) and checks the statics: the deflections are the
/// load over K (none when rigid) and the reactions J.F, J.M the load.
void ExpectHeldLoad(Mechanism m, const Eigen::Vector3d& g, const Eigen::Vector3d& torque_axis, bool rigid, double t_end,
                    RecordingObserver* out) {
  m.SetGravity(g);
  m.AddDrive(Torque("load", "cube", torque_axis, kT));
  *out = Simulated(m, t_end, 1e-3);
  ExpectHeldStatics(*out, g, torque_axis, rigid);
}

// --- cylindrical ---------------------------------------------------------------------------

TEST(Cylindrical, SlidesAlongAndTurnsAboutItsAxisFreelyAndHoldsTheRest) {
  for (bool rigid : {false, true}) {
    SCOPED_TRACE(rigid ? "rigid" : "compliant");
    RecordingObserver rec;
    // Weight along -x and a torque about y: both across the axis.
    ExpectHeldLoad(CylinderOnZ(rigid), {-kG, 0, 0}, Eigen::Vector3d::UnitY(), rigid, 1.0, &rec);
    // The free motion is kept: 0.5 m/s along z and 2 rad/s about z, and the sensors report it.
    ExpectLast(rec,
               {{"cube.v.z", 0.5}, {"cube.omega.z", 2.0}, {"J.slide", 0.5}, {"J.speed", 0.5}, {"J.angle", 2.0}, {"J.rate", 2.0}, {"cube.r.z", 0.5}},
               1e-9);
    // The rotation across the axis: the coupling's deflection about y is T / K_r (rigid: it has
    // none, and the spin stays on z). (The spinning cube carries its small tilt round with it, so
    // the orientation shows it turning about z; the coupling's state is the integral of the
    // relative angular velocity in the parent's frame.)
    if (rigid) {
      EXPECT_NEAR(rec.Last("cube.R.33"), 1.0, 1e-12);
    } else {
      EXPECT_NEAR(rec.Last("J.r.K.q.y"), kT / kKr, 1e-6 * kT / kKr);
      EXPECT_NEAR(rec.Last("J.r.K.q.x"), 0.0, 1e-6 * kT / kKr);
    }
    EXPECT_LT(testing::MaxEnergyResidual(rec), 1e-7);
  }
}

// --- planar --------------------------------------------------------------------------------

TEST(Planar, GlidesInThePlaneAndTurnsAboutTheNormalFreelyAndHoldsTheRest) {
  for (bool rigid : {false, true}) {
    SCOPED_TRACE(rigid ? "rigid" : "compliant");
    RecordingObserver rec;
    // Weight along -z (the normal) and a torque about x (in the plane).
    ExpectHeldLoad(PuckOnTheFloor(rigid), {0, 0, -kG}, Eigen::Vector3d::UnitX(), rigid, 1.0, &rec);
    ExpectLast(rec, {{"cube.v.x", 0.3}, {"cube.v.y", -0.2}, {"cube.omega.z", 1.5}}, 1e-9);
    // The slide along the plane's axes u = x, v = y (Perpendicular(z)), the turn about z.
    ExpectLast(rec,
               {{"J.slide.u", 0.3}, {"J.slide.v", -0.2}, {"J.speed.u", 0.3}, {"J.speed.v", -0.2}, {"J.angle", 1.5}, {"J.rate", 1.5}, {"cube.r.x", 0.5}},
               1e-9);
    // The tilt about x: T / K_r in the coupling (rigid: none, the spin stays on z).
    if (rigid) {
      EXPECT_NEAR(rec.Last("cube.R.33"), 1.0, 1e-12);
    } else {
      EXPECT_NEAR(rec.Last("J.r.K.q.x"), kT / kKr, 1e-6 * kT / kKr);
    }
    EXPECT_LT(testing::MaxEnergyResidual(rec), 1e-7);
  }
}

// --- screw ---------------------------------------------------------------------------------

TEST(Screw, ANutFallsWithTheEffectiveMassOfItsSpin) {
  for (bool rigid : {false, true}) {
    SCOPED_TRACE(rigid ? "rigid" : "compliant");
    const double t = 1.0;
    ExpectTheNutsFall(Simulated(Nut(rigid), t, 1e-3, 1e-11, 1e-13), rigid, t);
  }
}

// --- universal -----------------------------------------------------------------------------

TEST(Universal, TurnsFreelyAboutEitherYokeAndHoldsTheSpidersThirdAxis) {
  for (bool rigid : {false, true}) {
    SCOPED_TRACE(rigid ? "rigid" : "compliant");
    // About the ground's yoke (x): angle_a = t, angle_b = 0; about the cube's yoke (y): angle_b = t.
    ExpectLast(Simulated(CubeOnACross(rigid, {1.0, 0, 0}), 2.0, 1e-2),
               {{"cube.omega.x", 1.0}, {"J.angle_a", 2.0}, {"J.angle_b", 0.0}, {"J.rate_a", 1.0}}, 1e-9);
    ExpectLast(Simulated(CubeOnACross(rigid, {0, 1.0, 0}), 2.0, 1e-2),
               {{"cube.omega.y", 1.0}, {"J.angle_a", 0.0}, {"J.angle_b", 2.0}, {"J.rate_b", 1.0}}, 1e-9);
    // A torque about the spider's third axis (z) is held: weight along -z, the torque about z.
    RecordingObserver rec;
    ExpectHeldLoad(CubeOnACross(rigid, Eigen::Vector3d::Zero()), {0, 0, -kG}, Eigen::Vector3d::UnitZ(), rigid, 0.5, &rec);
    const double turn = rec.Last("cube.R.21");  // R(z, phi) has R21 = sin(phi)
    EXPECT_NEAR(turn, rigid ? 0.0 : kT / kKr, 2e-3 * kT / kKr + 1e-9);
    // The compliant coupling's deflection, the integral of n . (w_c - w_p), is -(R_p x) . (R_c y)
    // = -R12 = sin(phi): a function of the orientations, so the spring is conservative.
    if (!rigid) {
      EXPECT_NEAR(rec.Last("J.r.K.q"), -rec.Last("cube.R.12"), 1e-12);
    }
    EXPECT_LT(testing::MaxEnergyResidual(rec), 1e-7);
  }
}

TEST(Universal, CardanOutputSpeedFollowsTheClosedForm) {
  const double beta = 0.5, w1 = 2.0;
  for (bool rigid : {true, false}) {
    SCOPED_TRACE(rigid ? "rigid" : "compliant");
    const RecordingObserver rec = Simulated(Cardan(beta, w1, rigid), 2 * pi / w1, 1e-3, 1e-11, 1e-13);
    ExpectCardanSpeeds(rec, beta, w1, rigid);
    EXPECT_LT(testing::MaxEnergyResidual(rec), 1e-6);
  }
}

// --- model files ---------------------------------------------------------------------------

using testing::LoadErrors;

const std::string kHead = "model: j\nbodies:\n  a: {mass: 1.0, inertia: 0.1}\n  b: {mass: 1.0, inertia: 0.1}\njoints:\n";

TEST(JointKindsFile, EachTypeLoadsCompliantAndRigid) {
  const std::vector<std::string> joints = {
      "  J: {type: cylindrical, parent: a, child: b, axis: z, translation: {K: 1e6, R: 10}, rotation: {K: 1e3, R: 1}, sensors: true}\n",
      "  J: {type: planar, parent: a, child: b, normal: z, translation: {K: 1e6, R: 10}, rotation: {K: 1e3, R: 1}, sensors: true}\n",
      "  J: {type: screw, parent: a, child: b, axis: z, pitch: 0.005, translation: {K: 1e6, R: 10}, rotation: {K: 1e3, R: 1},\n"
      "      helix: {K: 1e7, R: 10}, sensors: true}\n",
      "  J: {type: universal, parent: a, child: b, axis: x, child_axis: y, translation: {K: 1e6, R: 10}, rotation: {K: 1e3, R: 1},\n"
      "      sensors: true}\n",
      "  J: {type: cylindrical, parent: a, child: b, axis: z, rigid: true}\n",
      "  J: {type: planar, parent: a, child: b, axis: z, rigid: true, sensors: true}\n",
      "  J: {type: screw, parent: a, child: b, axis: z, lead: -0.005, rigid: true}\n",
      "  J: {type: universal, parent: a, child: b, axis: x, child_axis: y, rigid: true}\n"};
  for (const std::string& j : joints) {
    SCOPED_TRACE(j);
    const LoadedModel lm = LoadModelString(kHead + j, "m.yaml");
    const bool rigid = j.find("rigid: true") != std::string::npos;
    EXPECT_EQ(lm.graph.Find("J.t.rigid") >= 0, rigid);
    EXPECT_EQ(lm.graph.Find("J.t.K") >= 0, !rigid);
    EXPECT_EQ(lm.graph.Find("J.r.rigid") >= 0, rigid);
    if (j.find("screw") != std::string::npos) {
      EXPECT_EQ(lm.graph.Find("J.h.rigid") >= 0, rigid);
      const Element& tf = lm.graph.element(lm.graph.Find("J.helix_lead"));
      EXPECT_NEAR(tf.param.scalar, (j.find("lead: -") != std::string::npos ? 0.005 : -0.005) / (2 * pi), 1e-15);
    }
    const bool sensors = j.find("sensors: true") != std::string::npos;
    if (j.find("universal") != std::string::npos) {
      EXPECT_EQ(lm.graph.FindAux("J.angle_a") >= 0, sensors);
    } else if (sensors) {
      EXPECT_GE(lm.graph.FindAux("J.slide"), 0);
    }
    (void)CompiledModel::Compile(lm.graph, lm.compile);  // compiles, rigid ones included
  }
}

TEST(JointKindsFile, ABadTypeOrAMissingAxisIsLocatedWithAHint) {
  // Each joint (the model's line 6) with the one diagnostic it gets: its code, a part of its
  // message, its hint, and whether its line is checked ("": not checked).
  const struct {
    const char* joint;
    const char* code;
    const char* message;
    const char* hint;
    bool located;
  } cases[] = {
      {"{type: cylindric, parent: a, child: b, axis: z, rigid: true}", "mech.joint_type", "", "did you mean 'cylindrical'?", true},
      {"{type: screw, parent: a, child: b, pitch: 0.01, rigid: true}", "mech.joint_axis", "'axis'", "", true},
      {"{type: planar, parent: a, child: b, rigid: true}", "mech.joint_axis", "'normal'", "", false},
      {"{type: universal, parent: a, child: b, axis: x, rigid: true}", "mech.joint_axis", "'child_axis'", "", false},
      {"{type: screw, parent: a, child: b, axis: z, rigid: true}", "mech.joint_axis", "'pitch'", "", false},
      // The yokes must be perpendicular as the bodies start: x and x are not.
      {"{type: universal, parent: a, child: b, axis: x, child_axis: x, rigid: true}", "mech.joint_axis", "perpendicular", "", true},
      // A key of another kind is unknown here.
      {"{type: cylindrical, parent: a, child: b, axis: z, pitch: 0.01, rigid: true}", "", "pitch", "", false},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.joint);
    const std::vector<Diagnostic> d = LoadErrors(kHead + "  J: " + c.joint + "\n");
    ASSERT_EQ(d.size(), 1u);
    if (*c.code) {
      EXPECT_EQ(d[0].code, c.code);
    }
    if (c.located) {
      EXPECT_EQ(d[0].where.line, 6);
    }
    if (*c.message) {
      EXPECT_THAT(d[0].message, HasSubstr(c.message));
    }
    if (*c.hint) {
      EXPECT_EQ(d[0].hint, c.hint);
    }
  }
}

}  // namespace
}  // namespace multibond::mech
