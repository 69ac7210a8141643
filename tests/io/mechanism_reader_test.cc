// Drives whose value is a formula (io/mechanism_reader.cc, mech/expand_drive.cc): the formula is
// carried by the drive and becomes the source's value (a torque's or force's component k is
// axis[k] * formula); a formula of parameters only stays a constant time function; the formula
// may name model variables, signals and bare state names; its mistakes are located.

#include <cmath>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "support/example_runner.h"

namespace multibond {
namespace {

using ::testing::HasSubstr;

std::vector<Diagnostic> LoadErrors(const std::string& yaml) {
  try {
    (void)LoadModelString(yaml, "m.yaml");
  } catch (const ModelError& e) {
    return e.diagnostics();
  }
  ADD_FAILURE() << "expected a ModelError for:\n" << yaml;
  return {};
}

const Element& Find(const LoadedModel& lm, const std::string& name) { return lm.graph.element(lm.graph.Find(name)); }

/// A free body with the same moment of inertia J about every axis (no gravity, no joint), spun
/// from rest by a torque tau0 about n = (0, 0.6, 0.8) against a load -c w, w its speed about n:
/// omega = w(t) n with w(t) = tau0 / c (1 - exp(-t c / J)).
const char* kTilted = R"y(model: tilted
parameters: {J: 0.5, tau0: 2.0, c: 0.1}
signals:
  w: "0.6*b.omega.f.y + 0.8*b.omega.f.z"
bodies:
  b: {mass: 1.0, inertia: [J, J, J]}
drives:
  motor: {type: torque, body: b, axis: [0, 3, 4], value: tau0}
  load:  {type: torque, body: b, axis: [0, 3, 4], value: "-c*w"}
)y";

TEST(MechanismReader, ATorqueDrivesFormulaIsScaledByTheAxisPerComponent) {
  const LoadedModel lm = LoadModelString(kTilted, "m.yaml");
  ASSERT_EQ(lm.mechanism->drives().size(), 2u);
  const mech::Drive& load = lm.mechanism->drives()[1];
  ASSERT_TRUE(load.formula.given());
  EXPECT_EQ(load.formula.text, "-c*w");
  EXPECT_EQ(load.formula.where.line, 9);
  EXPECT_EQ(load.formula.where.column, 59);  // the formula's first character, inside the quotes
  const Element& src = Find(lm, "load.source");
  ASSERT_EQ(src.value.size(), 3u);
  EXPECT_FALSE(src.value[0].given());  // the axis has no x component: the constant 0
  EXPECT_EQ(src.source.components[0].value, 0.0);
  for (int k : {1, 2}) {
    ASSERT_TRUE(src.value[k].given());
    EXPECT_EQ(src.value[k].text, "-c*w");
    EXPECT_EQ(src.value[k].where.line, 9);
    const expr::Node& product = *src.value[k].root;
    ASSERT_EQ(product.kind, expr::Node::Kind::kMul);
    EXPECT_EQ(product.args[0]->kind, expr::Node::Kind::kNumber);
    EXPECT_EQ(product.args[0]->value, (k == 1 ? 3.0 : 4.0) / 5.0);
    EXPECT_EQ(product.args[1], load.formula.root);
  }
  // The motor's value is a parameter: a constant time function, as before.
  const mech::Drive& motor = lm.mechanism->drives()[0];
  EXPECT_FALSE(motor.formula.given());
  EXPECT_EQ(motor.value.kind, TimeFunction::Kind::kConstant);
  EXPECT_EQ(motor.value.value, 2.0);
  EXPECT_TRUE(Find(lm, "motor.source").value.empty());
}

TEST(MechanismReader, ATiltedSpeedDependentLoadFollowsTheClosedForm) {
  const LoadedModel lm = LoadModelString(kTilted, "m.yaml");
  const RecordingObserver rec = testing::RunModel(lm, 10.0, 0.05);
  ASSERT_EQ(rec.summary().status, RunStatus::kOk);
  const double J = 0.5, tau0 = 2.0, c = 0.1;
  for (const auto& row : rec.rows()) {
    const double w = tau0 / c * (1.0 - std::exp(-row[0] * c / J));
    EXPECT_NEAR(row[rec.Index("b.omega.x")], 0.0, 1e-12);
    EXPECT_NEAR(row[rec.Index("b.omega.y")], 0.6 * w, 1e-6 * tau0 / c) << "t = " << row[0];
    EXPECT_NEAR(row[rec.Index("b.omega.z")], 0.8 * w, 1e-6 * tau0 / c) << "t = " << row[0];
  }
  EXPECT_LT(testing::MaxEnergyResidual(rec), 1e-8);
}

/// A flywheel spun by an angular-velocity drive through its coupling, the drive's speed given as
/// a ramp or as the same ramp written as a formula.
std::string RampDrive(const std::string& value) {
  return R"y(model: ramp
bodies:
  b: {mass: 1.0, inertia: [0.1, 0.1, 0.2]}
drives:
  spin: {type: angular_velocity, body: b, axis: z, K: 100, R: 2, value: )y" +
         value + "}\n";
}

TEST(MechanismReader, AVelocityDrivesFormulaRunsAsTheSameTimeFunction) {
  const LoadedModel formula = LoadModelString(RampDrive("\"3*t\""), "m.yaml"), ramp = LoadModelString(RampDrive("{ramp: {slope: 3}}"), "m.yaml");
  ASSERT_TRUE(formula.mechanism->drives()[0].formula.given());
  ASSERT_EQ(Find(formula, "spin.source").value.size(), 1u);
  EXPECT_EQ(Find(formula, "spin.source").value[0].root, formula.mechanism->drives()[0].formula.root);
  const RecordingObserver a = testing::RunModel(formula, 2.0, 0.1), b = testing::RunModel(ramp, 2.0, 0.1);
  ASSERT_EQ(a.summary().status, RunStatus::kOk);
  ASSERT_EQ(a.rows().size(), b.rows().size());
  for (size_t k = 0; k < a.rows().size(); ++k) {
    const double t = a.rows()[k][0];
    EXPECT_EQ(a.rows()[k], b.rows()[k]) << "t = " << t;
  }
  EXPECT_GT(a.Last("b.omega.z"), 5.0);  // it follows the ramp (6 rad/s at 2 s, behind by the coupling's lag)
}

// A torsion spring made of a torque drive: -k times a state that integrates the flywheel's speed,
// named bare. From w0 at angle 0: angle = w0 / W sin(W t), W = sqrt(k / J).
TEST(MechanismReader, ADrivesFormulaNamesAStateBare) {
  const LoadedModel lm = LoadModelString(R"y(model: torsion
parameters: {J: 0.2, k: 5.0}
bodies:
  b: {mass: 1.0, inertia: [0.15, 0.15, J], omega: [0, 0, 2.0]}
states:
  angle: {kind: integral, rate: b.omega.f.z, unit: rad}
drives:
  spring: {type: torque, body: b, axis: z, value: "-k*angle"}
)y",
                                         "m.yaml");
  const RecordingObserver rec = testing::RunModel(lm, 3.0, 0.01);
  ASSERT_EQ(rec.summary().status, RunStatus::kOk);
  const double W = std::sqrt(5.0 / 0.2), amplitude = 2.0 / W;
  for (const auto& row : rec.rows()) EXPECT_NEAR(row[rec.Index("angle")], amplitude * std::sin(W * row[0]), 1e-6 * amplitude) << "t = " << row[0];
}

// An ideal drive ('rigid: true', no K or R): the body's speed is the ramp exactly and the drive's
// torque is J dw/dt minus a constant braking torque's -tau (it supplies both).
TEST(MechanismReader, AnIdealDriveNeedsNoCouplingAndImposesItsSpeed) {
  const LoadedModel lm = LoadModelString(R"y(model: ideal_drive
bodies:
  b: {mass: 1.0, inertia: [0.1, 0.1, 0.2]}
drives:
  spin:  {type: angular_velocity, body: b, axis: z, rigid: true, value: {ramp: {slope: 3}}}
  brake: {type: torque, body: b, axis: z, value: -0.5}
)y",
                                         "m.yaml");
  ASSERT_TRUE(lm.mechanism->drives()[0].rigid);
  EXPECT_TRUE(Find(lm, "spin.source").constraint);
  const RecordingObserver rec = testing::RunModel(lm, 2.0, 0.1);
  ASSERT_EQ(rec.summary().status, RunStatus::kOk);
  for (const auto& row : rec.rows()) {
    EXPECT_NEAR(row[rec.Index("b.omega.z")], 3.0 * row[0], 1e-9) << "t = " << row[0];
    if (row[0] == 0.0) continue;  // the ramp's corner: its rate at t = 0 is the one before it
    EXPECT_NEAR(row[rec.Index("spin.torque")], 0.2 * 3.0 + 0.5, 1e-9) << "t = " << row[0];
  }
}

// Joint sensors are off by default; 'sensors: true' on a joint or gear mesh, or the model's
// 'sensors: all | [names]', turns them on; a misspelt name in the list is located.
TEST(MechanismReader, SensorsAreOptInPerPartOrForTheModel) {
  const std::string body = R"y(bodies:
  a: {mass: 1.0, inertia: 0.1}
  b: {mass: 1.0, inertia: 0.1, position: [0.1, 0, 0]}
joints:
  ha: {type: revolute, child: a, axis: z, rigid: true}
  hb: {type: revolute, child: b, axis: z, rigid: true}
)y";
  const LoadedModel off = LoadModelString("model: s\n" + body, "m.yaml");
  EXPECT_FALSE(off.mechanism->joints()[0].sensors);
  EXPECT_LT(off.graph.FindAux("ha.angle"), 0);
  const LoadedModel all = LoadModelString("model: s\nsensors: all\n" + body, "m.yaml");
  EXPECT_GE(all.graph.FindAux("ha.angle"), 0);
  EXPECT_GE(all.graph.FindAux("hb.angle"), 0);
  const LoadedModel listed = LoadModelString("model: s\nsensors: [hb]\n" + body, "m.yaml");
  EXPECT_LT(listed.graph.FindAux("ha.angle"), 0);
  EXPECT_GE(listed.graph.FindAux("hb.angle"), 0);
  std::string one = body;
  one.replace(one.find("rigid: true}"), 12, "rigid: true, sensors: true}");
  const LoadedModel per_joint = LoadModelString("model: s\n" + one, "m.yaml");
  EXPECT_GE(per_joint.graph.FindAux("ha.angle"), 0);
  EXPECT_LT(per_joint.graph.FindAux("hb.angle"), 0);
  const std::vector<Diagnostic> d = LoadErrors("model: s\nsensors: [hx]\n" + body);
  ASSERT_EQ(d.size(), 1u);
  EXPECT_EQ(d[0].code, "mech.reference");
  EXPECT_EQ(d[0].where.line, 2);
  EXPECT_THAT(d[0].message, HasSubstr("'sensors'"));
}

TEST(MechanismReader, ADrivesFormulaIsCheckedWhereItIsWritten) {
  const std::string head = "model: bad\nparameters: {c: 0.1}\nbodies:\n  b: {mass: 1.0, inertia: 0.1}\ndrives:\n";
  // A syntax error at its character.
  std::vector<Diagnostic> d = LoadErrors(head + "  load: {type: torque, body: b, axis: z, value: \"-c*b.omega.f.z +\"}\n");
  ASSERT_EQ(d.size(), 1u);
  EXPECT_EQ(d[0].code, "expr.syntax");
  EXPECT_EQ(d[0].element, "load");
  EXPECT_EQ(d[0].where.line, 6);
  EXPECT_EQ(d[0].where.column, 50 + 16);  // just past the formula's end
  // An unknown parameter, with a did-you-mean.
  d = LoadErrors(head + "  load: {type: torque, body: b, axis: z, value: \"-cc*b.omega.f.z\"}\n");
  ASSERT_EQ(d.size(), 1u);
  EXPECT_EQ(d[0].code, "param.unknown");
  EXPECT_EQ(d[0].where.column, 51);
  EXPECT_EQ(d[0].hint, "did you mean 'c'?");
  // A formula of parameters that is no number.
  d = LoadErrors(head + "  load: {type: torque, body: b, axis: z, value: \"c/0\"}\n");
  ASSERT_EQ(d.size(), 1u);
  EXPECT_EQ(d[0].code, "param.range");
  EXPECT_THAT(d[0].message, HasSubstr("gives inf: not a finite number"));
  // A variable the model does not have: when it is compiled, at the name.
  const LoadedModel lm = LoadModelString(head + "  load: {type: torque, body: b, axis: z, value: \"-c*b.omega.q.z\"}\n", "m.yaml");
  try {
    CompiledModel::Compile(lm.graph, lm.compile);
    ADD_FAILURE() << "compiled";
  } catch (const ModelError& e) {
    ASSERT_FALSE(e.diagnostics().empty());
    EXPECT_EQ(e.diagnostics()[0].where.line, 6);
    EXPECT_EQ(e.diagnostics()[0].where.column, 53);
    EXPECT_THAT(e.diagnostics()[0].message, HasSubstr("b.omega.q.z"));
  }
}

}  // namespace
}  // namespace multibond
