// Formulas in models with ideal constraints (compile/constraint_solver.cc, CheckFormulas): a
// formula that only feeds outputs, signals or the efforts of storage is evaluated by the plan at
// zero multipliers like any other instruction; one that the constrained variables depend on is
// differentiated in time by the solver (forward mode) when it is a modulated transformer's,
// affine in the momenta and displacements, or reads none of them; one that reads a reaction is
// accepted when it is a modulated transformer's (the reaction passes it linearly) or feeds
// nothing of the motion. The rest is refused with `expr.unsupported`, located at the formula and
// naming the constraint.

#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "multibond/analysis/linearize.h"
#include "multibond/io/model_loader.h"
#include "support/compile_errors.h"
#include "support/example_runner.h"
#include "support/nonlinear_pair.h"
#include "support/rigid_gear_pair.h"
#include "support/rigid_pendulum.h"
#include "support/text_edit.h"

namespace multibond {
namespace {

using ::testing::HasSubstr;

// A pinion J1 = 0.01 and a wheel J2 = 0.04 at half its speed (a rigid TF: J2 is cut by an ideal
// constraint), the wheel on a hardening torsion spring k q + k3 q^3 (k = 2, k3 = 50) to the ground,
// wound by q0 = 0.3 rad at rest. J_eq = J1 + J2/4 = 0.02 on the pinion; the spring sees the
// wheel's angle, q' = w2 = w1/2. Conserved: E = J_eq w1^2/2 + k q^2/2 + k3 q^4/4; about q = 0
// the small oscillation has w^2 = (k/4)/J_eq = 25. `signals` are each case's signals.
std::string Gears(const std::string& signals, const std::string& ratio = "0.5") {
  return testing::RigidGearPair("rigid_gear_nonlinear_spring", "constraints: ideal\n", "0.0", ratio,
                                "{type: C, effort: \"2*q + 50*q^3\", q0: 0.3}", signals + "\n");
}

// Output-only signals: the kinetic energy from the pinion's speed and the phase angle
// atan2(w1, q); the columns they read are outputs too.
const char* kOutputSignals = R"yaml(signals:
  kinetic: "j1.f * j1.f * 0.01"
  phase:   "atan2(j1.f, spring.q)"
outputs: [kinetic, phase, {name: w1, variable: j1.f}])yaml";

RecordingObserver RunGears(const std::string& text, bool generate_code) {
  const testing::Built model = testing::CompileWith(LoadModelString(text, "<test>"), generate_code);
  return testing::RunCompiled(model, 2.0, 0.01, Method::kDormandPrince, 1e-10, 1e-12);
}

/// The first of the compiler's diagnostics for `text` (a test failure if it has none).
Diagnostic Refusal(const std::string& text) {
  const std::vector<Diagnostic> ds = testing::CompileErrors(text);
  if (!ds.empty()) return ds.front();
  ADD_FAILURE() << "no diagnostic";
  return {};
}

TEST(ConstraintFormulas, ANonlinearSpringAndOutputSignalsRunWithARigidGear) {
  const RecordingObserver rec = RunGears(Gears(kOutputSignals), /*generate_code=*/false);
  ASSERT_EQ(rec.summary().status, RunStatus::kOk) << rec.summary().message;
  const int w1 = rec.Index("w1"), q = rec.Index("spring.q"), kin = rec.Index("kinetic"), phase = rec.Index("phase");
  const double jeq = 0.02, k = 2.0, k3 = 50.0, q0 = 0.3;
  const double e0 = k * q0 * q0 / 2 + k3 * q0 * q0 * q0 * q0 / 4;
  double largest_w1 = 0.0, drift = 0.0;
  for (const auto& row : rec.rows()) {
    // The signals are the formulas of the columns, to the bit.
    EXPECT_EQ(row[kin], row[w1] * row[w1] * 0.01) << "t = " << row[0];
    EXPECT_EQ(row[phase], std::atan2(row[w1], row[q])) << "t = " << row[0];
    const double e = jeq * row[w1] * row[w1] / 2 + k * row[q] * row[q] / 2 + k3 * std::pow(row[q], 4) / 4;
    drift = std::max(drift, std::abs(e - e0));
    largest_w1 = std::max(largest_w1, std::abs(row[w1]));
  }
  EXPECT_LT(drift, 1e-8 * e0);  // conservative: the energy of the rigid pair on the hardening spring
  // Through q = 0 all of it is kinetic: w1 = sqrt(2 E / J_eq) (the largest sample, within 0.01 s).
  EXPECT_NEAR(largest_w1, std::sqrt(2 * e0 / jeq), 2e-3 * std::sqrt(2 * e0 / jeq));
  EXPECT_GT(largest_w1, 0.99 * std::sqrt(2 * e0 / jeq));
}

TEST(ConstraintFormulas, TheInterpreterAndTheGeneratedCodeGiveTheSameBits) {
  const RecordingObserver a = RunGears(Gears(kOutputSignals), /*generate_code=*/false);
  const RecordingObserver b = RunGears(Gears(kOutputSignals), /*generate_code=*/true);
  ASSERT_EQ(a.rows().size(), b.rows().size());
  for (size_t i = 0; i < a.rows().size(); ++i) EXPECT_EQ(a.rows()[i], b.rows()[i]) << "row " << i;
}

TEST(ConstraintFormulas, TheLinearisationOfTheNonlinearSpringGivesItsSmallOscillation) {
  LoadedModel lm = LoadModelString(Gears(kOutputSignals), "<test>");
  const auto model = CompiledModel::Compile(std::move(lm.graph), lm.compile);
  ASSERT_TRUE(model->has_constraints());
  // About q = 0 (the formula's slope k there): w = sqrt((k/4) / J_eq) = 5 rad/s.
  Eigen::VectorXd x = model->MakeInitialState();
  x.setZero();
  const linear::LinearModel lin = linear::Linearize(*model, 0.0, x);
  ASSERT_EQ(lin.states.size(), 2u);
  for (const auto& l : lin.A.eigenvalues()) {
    EXPECT_NEAR(l.real(), 0.0, 1e-12);
    EXPECT_NEAR(std::abs(l.imag()), 5.0, 1e-12);
  }
  // At q = 0.3 the stiffness is k + 3 k3 q^2 = 15.5: w^2 = (15.5/4) / 0.02.
  x = model->MakeInitialState();
  for (const auto& l : linear::Linearize(*model, 0.0, x).A.eigenvalues())
    EXPECT_NEAR(std::abs(l.imag()), std::sqrt(15.5 / 4 / 0.02), 1e-12 * std::sqrt(15.5 / 4 / 0.02));
}

// A gear whose ratio is a formula of time, r(t) = 0.5 + 0.1 sin(3 t), the pair coasting freely
// (no torque, no spring) from w1 = 2, w2 = r(0) w1 = 1: the cut holds w2 = r(t) w1, the TF conserves
// power at every instant, so E = (J1 + r^2 J2) w1^2 / 2 is constant and
// w1(t) = w1(0) sqrt((J1 + r(0)^2 J2) / (J1 + r(t)^2 J2)), J1 + r(0)^2 J2 = 0.02.
std::string CoastingGears() {
  return testing::Replaced(testing::Replaced(testing::RigidGearPair("modulated_gear", "constraints: ideal\n", "0.0",
                                                                    "\"0.5 + 0.1*sin(3*t)\"", "", ""),
                                             "inertia: 0.01}", "inertia: 0.01, p0: 0.02}"),
                           "inertia: 0.04}", "inertia: 0.04, p0: 0.04}");
}

TEST(ConstraintFormulas, AGearRatioOfTimeKeepsTheEnergyOfTheCoastingPair) {
  for (const bool generate_code : {false, true}) {
    SCOPED_TRACE(generate_code ? "generated" : "interpreted");
    const testing::Built model = testing::CompileWith(LoadModelString(CoastingGears(), "<test>"), generate_code);
    ASSERT_TRUE(model.model->has_constraints());
    if (generate_code) {
      ASSERT_TRUE(model.code->ready()) << model.engine();
    }
    const RecordingObserver rec = testing::RunCompiled(model, 4.0, 0.01, Method::kDormandPrince, 1e-11, 1e-13);
    ASSERT_EQ(rec.summary().status, RunStatus::kOk) << rec.summary().message;
    const int p1 = rec.Index("J1.p"), p2 = rec.Index("J2.p");
    double worst = 0.0, slip = 0.0, lowest = 2.0, highest = 0.0;
    for (const auto& row : rec.rows()) {
      const double t = row[0], r = 0.5 + 0.1 * std::sin(3 * t), w1 = row[p1] / 0.01, w2 = row[p2] / 0.04;
      const double expected = 2.0 * std::sqrt(0.02 / (0.01 + r * r * 0.04));
      worst = std::max(worst, std::abs(w1 - expected));
      slip = std::max(slip, std::abs(w2 - r * w1));  // the constraint, as a kinematic identity
      lowest = std::min(lowest, w1);
      highest = std::max(highest, w1);
    }
    EXPECT_LT(worst, 1e-9);
    EXPECT_LT(slip, 1e-10);
    // The closed form's range is met: r from 0.4 to 0.6, w1 from 2 sqrt(0.02/0.0244) to 2 sqrt(0.02/0.0164).
    EXPECT_NEAR(lowest, 2.0 * std::sqrt(0.02 / 0.0244), 1e-4);
    EXPECT_NEAR(highest, 2.0 * std::sqrt(0.02 / 0.0164), 1e-4);
    EXPECT_LT(testing::MaxEnergyResidual(rec), 1e-9);
  }
}

TEST(ConstraintFormulas, TheModulatedGearGivesTheSameBitsWithAndWithoutGeneratedCode) {
  const auto a = testing::CompileWith(LoadModelString(CoastingGears(), "<test>"), false);
  const auto b = testing::CompileWith(LoadModelString(CoastingGears(), "<test>"), true);
  ASSERT_TRUE(b.code->uses_generated_code()) << b.engine();
  const RecordingObserver ra = testing::RunCompiled(a, 1.0, 0.01, Method::kBdf, 1e-9, 1e-11);
  const RecordingObserver rb = testing::RunCompiled(b, 1.0, 0.01, Method::kBdf, 1e-9, 1e-11);
  ASSERT_EQ(ra.rows().size(), rb.rows().size());
  for (size_t i = 0; i < ra.rows().size(); ++i) ASSERT_EQ(ra.rows()[i], rb.rows()[i]) << "row " << i;
}

TEST(ConstraintFormulas, TheCoastingPairLinearisesToItsReducedEquation) {
  // On the constraint p2 = J2 r(t) p1 / J1, and (J1 + r^2 J2) dw1/dt = -r r' J2 w1. The
  // linearisation keeps one momentum as the coordinate (the other depends on it): in p1 its mode
  // is -r r' J2 / (J1 + r^2 J2); in p2, whose relation to p1 moves with r(t), it is
  // r' J1 / (r (J1 + r^2 J2)). Either needs the mixed second derivative of the constraint in the
  // state and the time (r' w1).
  LoadedModel lm = LoadModelString(CoastingGears(), "<test>");
  const auto model = CompiledModel::Compile(std::move(lm.graph), lm.compile);
  ASSERT_TRUE(model->can_linearize(nullptr));
  for (const double t : {0.0, 0.4, 1.3}) {
    SCOPED_TRACE(t);
    const double r = 0.5 + 0.1 * std::sin(3 * t), rate = 0.3 * std::cos(3 * t), j1 = 0.01, j2 = 0.04;
    Eigen::VectorXd x = model->MakeInitialState();
    x[0] = j1 * 2.0, x[1] = j2 * r * 2.0;  // w1 = 2 on the constraint at t
    const linear::LinearModel lin = linear::Linearize(*model, t, x);
    ASSERT_EQ(lin.A.rows(), 1);
    ASSERT_EQ(lin.states.size(), 1u);
    const double expected = lin.states[0] == "J1.p" ? -r * rate * j2 / (j1 + r * r * j2) : rate * j1 / (r * (j1 + r * r * j2));
    EXPECT_TRUE(lin.states[0] == "J1.p" || lin.states[0] == "J2.p") << lin.states[0];
    EXPECT_NEAR(lin.A(0, 0), expected, 1e-12);
  }
}

TEST(ConstraintFormulas, AGearRatioOfAMomentumIsRefused) {
  // r(p) ω: not linear in the momenta, so g is not affine along B (nor its B the adjoint).
  const Diagnostic d = Refusal(Gears(kOutputSignals, "\"0.5 + 0.1*J1.p\""));
  EXPECT_EQ(d.code, "expr.unsupported");
  EXPECT_EQ(d.element, "gear");
  EXPECT_THAT(d.message, HasSubstr("the formula of gear for 'gear.e1' cannot reach an ideal constraint"));
  EXPECT_THAT(d.message, HasSubstr("reads the effort of the ideal constraint 'J2.cut' (its reaction, which is solved for) and is "
                                   "not linear in it"));
  EXPECT_THAT(d.message, HasSubstr("I 'J2' is in derivative causality"));
  EXPECT_THAT(d.hint, HasSubstr("a modulus (MTF, MGY, TF, GY) may read time, parameters, signal states"));
  EXPECT_GT(d.where.line, 0);
}

TEST(ConstraintFormulas, AnOutputSignalOfAReactionIsItsFormula) {
  // The cut's reaction on the wheel, read by an output signal: evaluated with the reaction solved.
  const RecordingObserver rec = RunGears(Gears("signals:\n  load: \"abs(J2.cut.e)\"\noutputs: [load, J2.cut.e]"), false);
  ASSERT_EQ(rec.summary().status, RunStatus::kOk) << rec.summary().message;
  const int load = rec.Index("load"), reaction = rec.Index("J2.cut.e");
  double largest = 0.0;
  for (const auto& row : rec.rows()) {
    EXPECT_EQ(row[load], std::abs(row[reaction])) << "t = " << row[0];
    largest = std::max(largest, row[load]);
  }
  EXPECT_GT(largest, 0.1);  // the spring's torque reaches the pinion through the reaction
}

TEST(ConstraintFormulas, AReactionFedBackIntoTheMotionIsRefused) {
  // The pinion driven by a torque of the wheel's reaction: the multiplier would reach the
  // momenta through a formula that is no part of the junction structure.
  const std::string text = testing::RigidGearPair("reaction_feedback", "constraints: ideal\n", "\"-0.1*J2.cut.e\"", "0.5",
                                                  "{type: C, stiffness: 2.0, q0: 0.3}", "");
  const Diagnostic d = Refusal(text);
  EXPECT_EQ(d.code, "expr.unsupported");
  EXPECT_EQ(d.element, "torque");
  EXPECT_THAT(d.message, HasSubstr("reads the effort of the ideal constraint 'J2.cut' (its reaction, which is solved for) and "
                                   "feeds back into the motion"));
  EXPECT_GT(d.where.line, 0);
}

TEST(ConstraintFormulas, AModulusOfAStateThatAReactionDrivesIsRefused) {
  // The ratio reads the integral of the wheel's reaction: dg/dt would have a term in the
  // multiplier that W does not hold. The integral's rate formula, which reads the reaction and
  // feeds the modulus, is where it is refused.
  const std::string text = Gears("states:\n  impulse: {kind: integral, rate: \"J2.cut.e\"}\n", "\"0.5 + 0.01*impulse\"");
  const Diagnostic d = Refusal(text);
  EXPECT_EQ(d.code, "expr.unsupported");
  EXPECT_EQ(d.element, "impulse");
  EXPECT_THAT(d.message, HasSubstr("the rate formula of the state 'impulse' cannot reach an ideal constraint: it reads the effort "
                                   "of the ideal constraint 'J2.cut' (its reaction, which is solved for) and feeds back into the "
                                   "motion"));
  EXPECT_GT(d.where.line, 0);
}

TEST(ConstraintFormulas, AFormulaLawNextToACutCompliance) {
  // Two springs on one 0-junction: k2 is cut (a flow multiplier holds its effort equal to the
  // junction's), and the junction's effort is k1's formula law of its displacement: the
  // constraint depends on it nonlinearly (W = B^T H B would not be its Jacobian).
  const Diagnostic d = Refusal(testing::kNonlinearPair);
  EXPECT_EQ(d.code, "expr.unsupported");
  EXPECT_EQ(d.element, "k1");
  EXPECT_EQ(d.where.line, 9);
  EXPECT_THAT(d.message, HasSubstr("the formula of k1 for 'z.e' cannot reach an ideal constraint: it feeds the efforts 'k2.e', "
                                   "'z.e' that the ideal constraint 'k2.cut' holds, and reads a momentum or a displacement"));
  EXPECT_THAT(d.message, HasSubstr("without being a modulated transformer"));
  EXPECT_THAT(d.message, HasSubstr("C 'k2' is in derivative causality"));
  EXPECT_THAT(d.hint, HasSubstr("give C 'k2' a displacement of its own"));
}

// A bar of 1 m (CoM 0.5 m below the pivot) on a rigid hinge about y, released at rest from 30
// degrees (testing::kRigidPendulum), with two output signals: its angle from the
// position of its centre of mass, and its kinetic energy from its velocities (the hinge holds
// the angular velocity to y). m = 2700 * 0.02 * 0.02 * 1 = 1.08 kg, I_y = m (0.02^2 + 1^2) / 12.
TEST(ConstraintFormulas, OutputSignalsOfARigidPendulum) {
  const std::string text = std::string(testing::kRigidPendulum) + R"yaml(signals:
  angle:   "atan2(bar.r.x, -bar.r.z)"
  kinetic: "0.54*(bar.v.f.x*bar.v.f.x + bar.v.f.y*bar.v.f.y + bar.v.f.z*bar.v.f.z) + 0.045018*bar.omega.f.y*bar.omega.f.y"
outputs: [angle, kinetic]
)yaml";
  const RecordingObserver rec = testing::RunModelText(text, 2.0, 0.01, Method::kDormandPrince, 1e-10, 1e-12);
  ASSERT_EQ(rec.summary().status, RunStatus::kOk) << rec.summary().message;
  const int angle = rec.Index("angle"), x = rec.Index("bar.r.x"), z = rec.Index("bar.r.z");
  const int kinetic = rec.Index("kinetic"), energy = rec.Index("energy.kinetic");
  const double m = 1.08, g = 9.81, drop = 0.5 * (1 - std::cos(std::numbers::pi / 6));
  double lowest_angle = 1.0;
  for (const auto& row : rec.rows()) {
    EXPECT_EQ(row[angle], std::atan2(row[x], -row[z])) << "t = " << row[0];  // the formula of the columns, to the bit
    // The formula's kinetic energy is the account's (from the momenta), to the hinge's tolerance.
    EXPECT_NEAR(row[kinetic], row[energy], 1e-9 * m * g * drop) << "t = " << row[0];
    lowest_angle = std::min(lowest_angle, std::abs(row[angle]));
  }
  EXPECT_NEAR(rec.rows().front()[angle], -std::numbers::pi / 6, 1e-15);  // released at -30 degrees about y
  EXPECT_LT(lowest_angle, 0.05);  // it swings through the bottom
}

// A formula that reaches the dynamics of a rigid mechanism: the bar of the pendulum above, without
// gravity, on a hardening torsion spring at its hinge, a torque drive of the hinge's angle
// sensor, -(k a + k3 a^3) (k = 2, k3 = 50), set swinging through a = 0 at w0 = 2 rad/s (the CoM's
// velocity w0 x r = (-1, 0, 0) m/s). About the pivot I = I_y + m 0.5^2 = 0.360036; conserved:
// I w^2/2 + k a^2/2 + k3 a^4/4 = I w0^2/2, so the swing's amplitude solves
// k a^2/2 + k3 a^4/4 = I w0^2/2; the small oscillation has w^2 = k / I.
TEST(ConstraintFormulas, ANonlinearTorsionSpringOnARigidHinge) {
  const char* text = R"yaml(
model: torsion_pendulum
bodies:
  bar: {shape: {box: {size: [0.02, 0.02, 1.0]}}, density: 2700, position: [0, 0, -0.5],
        velocity: [-1, 0, 0], omega: [0, 2, 0]}
joints:
  hinge: {type: revolute, parent: ground, child: bar, at: [0, 0, 0], child_at: [0, 0, 0.5], axis: y, rigid: true,
          sensors: true}
drives:
  spring: {type: torque, body: bar, axis: y, value: "-(2*hinge.angle + 50*hinge.angle^3)"}
)yaml";
  const LoadedModel lm = LoadModelString(text, "<test>");
  const auto model = CompiledModel::Compile(lm.graph, lm.compile);
  ASSERT_TRUE(model->has_constraints());
  const RecordingObserver rec = testing::RunCompiled(*model, 3.0, 0.005, Method::kDormandPrince, 1e-10, 1e-12);
  ASSERT_EQ(rec.summary().status, RunStatus::kOk) << rec.summary().message;
  const double inertia = 1.08 * (0.02 * 0.02 + 1.0) / 12 + 1.08 * 0.25, k = 2.0, k3 = 50.0, w0 = 2.0;
  const double e0 = inertia * w0 * w0 / 2;
  const double amplitude = std::sqrt((-k + std::sqrt(k * k + 4 * k3 * e0)) / k3);  // k3 a^4/4 + k a^2/2 = e0
  const int angle = rec.Index("hinge.angle"), kinetic = rec.Index("energy.kinetic");
  double drift = 0.0, largest = 0.0;
  for (const auto& row : rec.rows()) {
    const double a = row[angle];
    drift = std::max(drift, std::abs(row[kinetic] + k * a * a / 2 + k3 * a * a * a * a / 4 - e0));
    largest = std::max(largest, std::abs(a));
  }
  EXPECT_NEAR(rec.rows().front()[kinetic], e0, 1e-12 * e0);
  EXPECT_LT(drift, 1e-8 * e0);
  EXPECT_NEAR(largest, amplitude, 1e-3 * amplitude);  // the largest sample, within 5 ms of the turn
  EXPECT_GT(largest, 0.99 * amplitude);
  // The linearisation about the rest at a = 0 (the formula's slope k): +-i sqrt(k / I) and zeros.
  const LoadedModel rest =
      LoadModelString(testing::Replaced(text, "velocity: [-1, 0, 0], omega: [0, 2, 0]", "velocity: [0, 0, 0], omega: [0, 0, 0]"), "<test>");
  const auto still = CompiledModel::Compile(rest.graph, rest.compile);
  const linear::LinearModel lin = linear::Linearize(*still, 0.0, still->MakeInitialState());
  double fastest = 0.0;
  for (const auto& l : lin.A.eigenvalues()) fastest = std::max(fastest, std::abs(l.imag()));
  EXPECT_NEAR(fastest, std::sqrt(k / inertia), 1e-9 * std::sqrt(k / inertia));
}

}  // namespace
}  // namespace multibond
