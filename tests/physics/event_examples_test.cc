// The event examples (examples/events/, docs/events.md) against their closed forms: the impacts
// of a bouncing ball and its rest, a block that sticks exactly, stick-slip on a belt, a clutch
// that locks; the energy account closing through every event.

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "multibond/compile/compiled_model.h"
#include "multibond/io/model_loader.h"
#include "multibond/sim/simulator.h"

namespace multibond {
namespace {

struct Run {
  std::shared_ptr<const CompiledModel> model;
  RecordingObserver rec;
};

std::unique_ptr<Run> Simulated(const std::string& example, double t_end, const std::string& solver = "bdf") {
  LoadedModel lm = LoadModelFile(std::string(MULTIBOND_SOURCE_DIR) + "/examples/events/" + example);
  auto run = std::make_unique<Run>();
  run->model = CompiledModel::Compile(std::move(lm.graph), lm.compile);
  RunOptions o;
  o.t_end = t_end;
  o.dt = 1e-3;
  o.integrator.method = ParseMethod(solver);
  o.integrator.rtol = 1e-10;
  o.integrator.atol = 1e-12;
  const RunSummary s = Simulate(*run->model, o, run->rec);
  EXPECT_EQ(s.status, RunStatus::kOk) << s.message;
  return run;
}

std::vector<EventRecord> OfKind(const RecordingObserver& rec, const std::string& kind) {
  std::vector<EventRecord> out;
  for (const EventRecord& e : rec.events())
    if (e.kind == kind) out.push_back(e);
  return out;
}

class BouncingBall : public ::testing::TestWithParam<const char*> {};

TEST_P(BouncingBall, ImpactsFollowTheClosedFormThenItRests) {
  const auto run = Simulated("bouncing_ball.yaml", 10.0, GetParam());
  const double g = 9.81, h0 = 1.0, e = 0.8;
  const double v1 = std::sqrt(2 * g * h0);
  // t1 = sqrt(2 h0 / g), t(k+1) = t(k) + 2 e^k v1 / g.
  const std::vector<EventRecord> impacts = OfKind(run->rec, "impact");
  ASSERT_GE(impacts.size(), 30u);
  double t = std::sqrt(2 * h0 / g);
  for (size_t k = 0; k < 15; ++k) {
    EXPECT_NEAR(impacts[k].time, t, 1e-8) << "impact " << k + 1;
    t += 2 * std::pow(e, static_cast<double>(k + 1)) * v1 / g;
  }
  // The accumulation point, and rest from there: one "contact" event, then nothing moves.
  const double t_inf = std::sqrt(2 * h0 / g) + 2 * e * v1 / (g * (1 - e));
  const std::vector<EventRecord> rest = OfKind(run->rec, "contact");
  ASSERT_EQ(rest.size(), 1u);
  EXPECT_NEAR(rest[0].time, t_inf, 1e-4);
  EXPECT_LT(rest[0].time, t_inf);
  EXPECT_EQ(run->rec.Last("velocity"), 0.0);
  EXPECT_LT(std::abs(run->rec.Last("height")), 1e-12);
  // The energy m g h0 ends dissipated in the impacts, to rounding.
  EXPECT_NEAR(run->rec.Last("energy.dissipated"), g * h0, 1e-8);
  EXPECT_LT(std::abs(run->rec.Last("energy.residual")), 1e-9);
  bool warned = false;
  for (const std::string& w : run->rec.summary().warnings) warned = warned || w.find("Zeno") != std::string::npos;
  EXPECT_TRUE(warned);
}

TEST(PlasticContact, ClosesAtTheFirstImpactWithoutBeingTakenForAccumulatingImpacts) {
  const std::string yaml = R"(
model: plastic_ball
domain: translation
elements:
  v:       {type: "1"}
  ball:    {type: I, inertia: 1.0}
  gravity: {type: Se, effort: -9.81}
  ground:  {type: Sf, flow: 0, contact: {gap: h, restitution: 0}}
states:
  h: {kind: integral, of: v, initial: 1.0}
bonds: [gravity -> v, v -> ball, ground -> v]
)";
  LoadedModel lm = LoadModelString(yaml);
  const auto model = CompiledModel::Compile(std::move(lm.graph), lm.compile);
  RunOptions o;
  o.t_end = 2.0;
  o.integrator.rtol = 1e-10;
  o.integrator.atol = 1e-12;
  RecordingObserver rec;
  ASSERT_EQ(Simulate(*model, o, rec).status, RunStatus::kOk);
  ASSERT_EQ(rec.events().size(), 1u);
  EXPECT_EQ(rec.events()[0].kind, "contact");
  EXPECT_FALSE(rec.events()[0].accumulated);
  EXPECT_NEAR(rec.events()[0].time, std::sqrt(2.0 / 9.81), 1e-9);
  EXPECT_TRUE(rec.summary().warnings.empty());  // no "impacts accumulated (Zeno)"
  EXPECT_NEAR(rec.Last("energy.dissipated"), 9.81, 1e-8);  // the whole drop, m g h0
}

INSTANTIATE_TEST_SUITE_P(Solvers, BouncingBall, ::testing::Values("bdf", "dopri5"));

TEST(CoulombBlock, SticksAtTheClosedFormTimeAndStaysExactlyStill) {
  const auto run = Simulated("coulomb_block.yaml", 2.0);
  const double g = 9.81, v0 = 3.0, mu_k = 0.4;
  const std::vector<EventRecord> stick = OfKind(run->rec, "stick");
  ASSERT_EQ(stick.size(), 1u);
  EXPECT_NEAR(stick[0].time, v0 / (mu_k * g), 1e-9);
  EXPECT_EQ(run->rec.events().size(), 1u);  // no chattering after it
  EXPECT_NEAR(run->rec.Last("position"), v0 * v0 / (2 * mu_k * g), 1e-9);
  for (const auto& row : run->rec.rows()) {
    if (row[0] > stick[0].time + 1e-3) {
      EXPECT_LE(std::abs(row[run->rec.Index("velocity")]), 1e-15) << row[0];
    }
  }
  EXPECT_NEAR(run->rec.Last("energy.dissipated"), 0.5 * 2.0 * v0 * v0, 1e-8);
  EXPECT_LT(std::abs(run->rec.Last("energy.residual")), 1e-9);
}

TEST(StickSlip, SlipAndStickLastWhatTheClosedFormSays) {
  const auto run = Simulated("stick_slip.yaml", 5.0);
  const double m = 1.0, k = 100.0, vb = 0.1, mu_s = 0.6, mu_k = 0.4, g = 9.81;
  const double w = std::sqrt(k / m), d = (mu_s - mu_k) * m * g / k;
  const double slip = (M_PI + 2 * std::atan(vb / (w * d))) / w, stick = 2 * d / vb;
  const std::vector<EventRecord>& ev = run->rec.events();
  ASSERT_GE(ev.size(), 8u);
  // Stuck from x = 0 until k x = mu_s m g, riding the belt.
  EXPECT_EQ(ev[0].kind, "slip");
  EXPECT_NEAR(ev[0].time, mu_s * m * g / k / vb, 1e-9);
  for (size_t i = 1; i < ev.size(); ++i) {
    EXPECT_EQ(ev[i].kind, i % 2 ? "stick" : "slip") << i;
    EXPECT_NEAR(ev[i].time - ev[i - 1].time, i % 2 ? slip : stick, 1e-8) << i;
  }
  EXPECT_LT(std::abs(run->rec.Last("energy.residual")), 1e-8);
}

TEST(Clutch, LocksAtTheClosedFormTimeAndSpeedHavingDissipatedTheEnergyLost) {
  const auto run = Simulated("clutch.yaml", 3.0);
  const std::vector<EventRecord>& ev = run->rec.events();
  ASSERT_EQ(ev.size(), 2u);
  EXPECT_EQ(ev[0].kind, "time");  // the capacity steps up at 0.1 s
  EXPECT_DOUBLE_EQ(ev[0].time, 0.1);
  EXPECT_EQ(ev[1].kind, "lock");
  EXPECT_NEAR(ev[1].time, 1.6, 1e-9);
  EXPECT_NEAR(run->rec.Last("w1"), 25.0, 1e-9);
  EXPECT_NEAR(run->rec.Last("w2"), 25.0, 1e-9);
  EXPECT_NEAR(run->rec.At("w1", 1.0), 100.0 - 50.0 * 0.9, 1e-8);
  EXPECT_NEAR(run->rec.Last("energy.dissipated"), 3750.0, 1e-6);
  EXPECT_LT(std::abs(run->rec.Last("energy.residual")), 1e-10);
}

TEST(DifferentialBacklash, TeethCrossThePlayAtEveryReversalAndTheEnergyAccountCloses) {
  // The rigid differential with 0.01 rad of play in the mesh GA, driven at 50 sin(2 pi t) rad/s.
  // With S2 free the mesh carries only the train's inertia torque, which reverses with the
  // acceleration at t = 0.25 s and 0.75 s: the flanks part there, the teeth cross the play and
  // strike the other flank (impacts of restitution 0.3, then rest as they accumulate).
  const auto run = Simulated("differential_backlash.yaml", 1.0);
  const std::vector<EventRecord> separations = OfKind(run->rec, "separation");
  ASSERT_EQ(separations.size(), 2u);
  EXPECT_NEAR(separations[0].time, 0.25, 1e-4);  // the drive coupling's lag: 1.2 microseconds here
  EXPECT_NEAR(separations[1].time, 0.75, 1e-4);
  EXPECT_EQ(separations[0].element, "mesh_GA.mesh.flank_pos");
  EXPECT_EQ(separations[1].element, "mesh_GA.mesh.flank_neg");
  const std::vector<EventRecord> impacts = OfKind(run->rec, "impact");
  ASSERT_GE(impacts.size(), 6u);
  int after_first_reversal = 0;
  for (const EventRecord& e : impacts)
    if (e.time > separations[0].time && e.time < separations[1].time) {
      ++after_first_reversal;
      EXPECT_EQ(e.element, "mesh_GA.mesh.flank_neg");
    }
  EXPECT_GE(after_first_reversal, 2);
  // While the teeth fly across the play the mesh carries nothing; in contact the deflection is
  // held at the flank, +-0.005 rad.
  const double flight_mid = 0.5 * (separations[0].time + OfKind(run->rec, "contact")[1].time);
  EXPECT_EQ(run->rec.At("mesh_GA.torque", flight_mid), 0.0);
  EXPECT_NEAR(run->rec.At("mesh_GA.mesh.q", 0.2), 0.005, 1e-9);
  EXPECT_NEAR(run->rec.At("mesh_GA.mesh.q", 0.6), -0.005, 1e-9);
  // Work in = stored + dissipated (the impacts' losses included) through every event.
  EXPECT_GT(run->rec.Last("mesh_GA.mesh.flank_pos.dissipated") + run->rec.Last("mesh_GA.mesh.flank_neg.dissipated"), 0.0);
  // (At the very start the energy that flowed is micro-joules: the residual is measured after the
  // first impacts, against the energy of the run, 1e-11 J at the start.)
  double worst = 0.0;
  for (const auto& row : run->rec.rows())
    if (row[0] > 0.05) worst = std::max(worst, std::abs(row[run->rec.Index("energy.residual")]));
  EXPECT_LT(worst, 1e-8);
}

/// The bar of docs/mechanisms/joint.yaml, on a rigid revolute joint with `extra` (limits or a
/// friction torque), the model's `parameters` section given, and `overrides` of them (as --set).
std::unique_ptr<Run> Hinge(const std::string& extra, double t_end, const std::string& parameters = "",
                           const std::vector<ParameterOverride>& overrides = {}) {
  const std::string yaml = R"(
model: hinge
gravity: [0, 0, -9.81]
)" + parameters + R"(
bodies:
  bar: {shape: {box: {size: [0.02, 0.02, 1.0]}}, density: 2700,
        position: [-0.25, 0, -0.4330127018922193], orientation: {axis: y, degrees: 30}}
joints:
  hinge: {type: revolute, parent: ground, child: bar, at: [0, 0, 0], child_at: [0, 0, 0.5], axis: y, rigid: true, )" +
                           extra + R"(}
)";
  LoadedModel lm = LoadModelString(yaml, "<string>", {}, overrides);
  auto run = std::make_unique<Run>();
  run->model = CompiledModel::Compile(std::move(lm.graph), lm.compile);
  RunOptions o;
  o.t_end = t_end;
  o.dt = 1e-3;
  o.integrator.rtol = 1e-10;
  o.integrator.atol = 1e-12;
  const RunSummary s = Simulate(*run->model, o, run->rec);
  EXPECT_EQ(s.status, RunStatus::kOk) << s.message;
  return run;
}

TEST(JointStops, TheBarStrikesItsStopAtTheSpeedEnergyGivesAndLosesOneMinusESquared) {
  // Released 30 degrees from the vertical, it swings down 0.2 rad onto its lower stop:
  // m g (L/2) (cos th_hit - cos th0) = 1/2 I w^2, I = m (a^2 + 4 L^2) / 12 about the pivot.
  const auto run = Hinge("limits: {lower: -0.2, upper: 0.2, restitution: 0.5}", 1.0);
  const double a = 0.02, L = 1.0, m = 2700 * a * a * L, g = 9.81, e = 0.5;
  const double th0 = M_PI / 6, th_hit = th0 - 0.2;
  const double inertia = m * (a * a + 4 * L * L) / 12;
  const double kinetic = m * g * (L / 2) * (std::cos(th_hit) - std::cos(th0));
  const std::vector<EventRecord> limits = OfKind(run->rec, "limit");
  ASSERT_GE(limits.size(), 5u);
  EXPECT_EQ(limits[0].element, "hinge.lower");
  double lowest = 0.0;  // the stop holds: the angle never passes it
  for (const auto& row : run->rec.rows()) lowest = std::min(lowest, row[run->rec.Index("hinge.angle")]);
  EXPECT_GE(lowest, -0.2 - 1e-9);
  EXPECT_LT(lowest, -0.2 + 1e-3);
  // Between impacts nothing dissipates: the stop's account holds each impact's loss, (1 - e^2)
  // of the kinetic energy it meets: the first exactly so.
  const double t1 = limits[0].time, t2 = limits[1].time;
  EXPECT_NEAR(run->rec.At("hinge.lower.dissipated", 0.5 * (t1 + t2)), (1 - e * e) * kinetic, 1e-9);
  EXPECT_NEAR(kinetic, 0.5 * inertia * 1.55406 * 1.55406, 1e-5);  // 1.554 rad/s at the stop
  // The rebound: the next impact comes with e times the speed, so e^2 times the energy.
  const double second = run->rec.At("hinge.lower.dissipated", 0.5 * (t2 + limits[2].time)) - (1 - e * e) * kinetic;
  EXPECT_NEAR(second, (1 - e * e) * e * e * kinetic, 1e-9);
  EXPECT_LT(std::abs(run->rec.Last("energy.residual")), 1e-8);
}

// At rest against its stop (e = 0) the bar is in statics: the stop holds gravity's torque about
// the pivot, m g (L/2) sin(30 deg - 0.2 rad) = 1.6845 N m, and the joint's moment J.M, all the
// joint exerts on the bar, carries it (the coupling across the axis carries none); the moment
// about the centre of mass, B.M, is zero with the pivot force's lever (a weight's worth of F up).
TEST(JointStops, AtRestOnItsStopTheJointsMomentIsGravitysTorque) {
  const auto run = Hinge("limits: {lower: -0.2, upper: 0.2, restitution: 0.0}", 1.0);
  const double a = 0.02, L = 1.0, m = 2700 * a * a * L, g = 9.81;
  const double torque = m * g * (L / 2) * std::sin(M_PI / 6 - 0.2);
  EXPECT_NEAR(run->rec.Last("hinge.angle"), -0.2, 1e-9);
  EXPECT_NEAR(run->rec.Last("hinge.M.y"), torque, 1e-9 * torque);
  EXPECT_NEAR(run->rec.Last("hinge.M.x"), 0.0, 1e-12);
  EXPECT_NEAR(run->rec.Last("hinge.M.z"), 0.0, 1e-12);
  EXPECT_NEAR(run->rec.Last("hinge.F.z"), m * g, 1e-9 * m * g);
  EXPECT_NEAR(run->rec.Last("bar.M.y"), 0.0, 1e-9 * torque);
  // A brake holding the bar where it was released carries gravity's torque at 30 degrees.
  const auto held = Hinge("friction: 3.0", 0.2);
  const double at_30 = m * g * (L / 2) * std::sin(M_PI / 6);
  EXPECT_NEAR(held->rec.Last("hinge.M.y"), at_30, 1e-9 * at_30);
}

TEST(JointFriction, ABrakeStrongerThanGravityHoldsTheBarExactlyAWeakerOneStopsIt) {
  // Gravity's torque about the pivot at 30 degrees: m g (L/2) sin 30 = 2.649 N m.
  const auto held = Hinge("friction: 3.0", 1.0);
  EXPECT_TRUE(held->rec.events().empty());
  for (const char* h : {"bar.h.x", "bar.h.y", "bar.h.z"}) EXPECT_LE(std::abs(held->rec.Last(h)), 1e-12) << h;
  const auto slowed = Hinge("friction: 2.0", 2.0);
  const std::vector<EventRecord> locks = OfKind(slowed->rec, "lock");
  ASSERT_EQ(locks.size(), 1u);
  const double t = locks[0].time;
  for (const auto& row : slowed->rec.rows()) {
    if (row[0] > t + 1e-3) {
      EXPECT_LE(std::abs(row[slowed->rec.Index("bar.h.y")]), 1e-12) << row[0];
    }
  }
  EXPECT_LT(std::abs(slowed->rec.Last("energy.residual")), 1e-8);
}

// A brake's torque may be a model parameter (a name that is no signal's), and a sweep or --set
// changes it: 3 N m holds the bar against gravity's 2.649 N m, 2 N m lets it swing and lock.
TEST(JointFriction, ABrakesTorqueMayBeAParameter) {
  const std::string parameters = "parameters:\n  brake: {value: 3.0, description: \"the brake's Coulomb torque [N m]\"}\n";
  for (const double brake : {3.0, 2.0}) {
    SCOPED_TRACE(brake);
    const auto run = Hinge("friction: brake", 2.0, parameters, {ParameterOverride{"brake", fmt::format("{}", brake)}});
    if (brake > 2.649) {
      EXPECT_TRUE(run->rec.events().empty());
      EXPECT_LE(std::abs(run->rec.Last("bar.h.y")), 1e-12);
    } else {
      EXPECT_EQ(OfKind(run->rec, "lock").size(), 1u);
    }
  }
}

}  // namespace
}  // namespace multibond
