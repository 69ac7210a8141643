// Gear meshes through the pitch point (docs/mechanisms.md, "Tooth forces") against statics,
// kinematics (Willis) and the energy balance: the bearings carry the tooth forces.

#include <cmath>
#include <numbers>

#include <gtest/gtest.h>

#include "support/example_runner.h"
#include "support/text_edit.h"

#include "multibond/core/error.h"
#include "multibond/io/model_loader.h"

namespace multibond {
namespace {

using std::numbers::pi;
using testing::ExampleText;
using testing::Replaced;
using testing::RunExample;
using testing::RunModel;

const double kTan20 = std::tan(20 * pi / 180);

Eigen::Vector3d Last3(const RecordingObserver& rec, const std::string& name) {
  return {rec.Last(name + ".x"), rec.Last(name + ".y"), rec.Last(name + ".z")};
}

void ExpectVector(const Eigen::Vector3d& got, const Eigen::Vector3d& want, double tol, const std::string& what) {
  EXPECT_LT((got - want).norm(), tol) << what << ": got " << got.transpose() << ", want " << want.transpose();
}

void ExpectEnergyBalanced(const RecordingObserver& rec, double tol) {
  EXPECT_LT(std::abs(rec.Last("energy.residual")), tol * rec.Last("energy.work"));
}

// A 20-tooth pinion (r = 0.05 m) drives a 40-tooth wheel (r = 0.1 m) under 20 N m: the tooth force
// F_t = 200 N and its separating part F_t tan 20 deg load both bearings (pinion at the origin, the
// pitch point at +x: the wheel is pushed along -y by its load and +x by the teeth's flanks).
TEST(GearContactTest, SpurPairBearingsCarryTheToothForce) {
  const RecordingObserver rec = RunExample("gears/spur_pair.yaml");
  ASSERT_EQ(rec.summary().status, RunStatus::kOk) << rec.summary().message;
  const double ft = 20.0 / 0.1, fr = ft * kTan20;
  ExpectVector(Last3(rec, "pinion_bearing.F"), {fr, ft, 0}, 1e-6 * ft, "pinion bearing");
  ExpectVector(Last3(rec, "wheel_bearing.F"), {-fr, -ft, 0}, 1e-6 * ft, "wheel bearing");
  EXPECT_NEAR(rec.Last("mesh.F_t"), ft, 1e-7 * ft);
  EXPECT_NEAR(rec.Last("mesh.F_r"), fr, 1e-7 * ft);
  EXPECT_NEAR(rec.Last("mesh.b.F_r"), fr, 1e-7 * ft);
  EXPECT_NEAR(rec.Last("mesh.F_n"), ft / std::cos(20 * pi / 180), 1e-7 * ft);
  EXPECT_NEAR(rec.Last("mesh.F_a"), 0.0, 1e-9 * ft);
  EXPECT_NEAR(rec.Last("mesh.torque"), 0.05 * ft, 1e-7 * ft);
  EXPECT_NEAR(rec.Last("motor.torque"), 0.05 * ft, 1e-6 * ft);
  EXPECT_NEAR(rec.Last("wheel.omega.z"), -5.0, 1e-8);
  ExpectEnergyBalanced(rec, 1e-6);
}

// The paper's torque between the spins (contact: spin) is kept: the same pair's bearings then carry
// no tooth force at all, the wrong answer the pitch-point mesh corrects.
TEST(GearContactTest, SpinContactKeepsTheTorqueOnlyModel) {
  std::string text = Replaced(ExampleText("gears/spur_pair.yaml"), "contact: pitch", "contact: spin");
  text = Replaced(text, "pressure_angle_deg: 20, ", "");
  const LoadedModel lm = LoadModelString(text);
  const RecordingObserver rec = RunModel(lm, 2.0, 0.01, Method::kBdf, 1e-8, 1e-10);
  ASSERT_EQ(rec.summary().status, RunStatus::kOk) << rec.summary().message;
  EXPECT_NEAR(rec.Last("mesh.torque"), 10.0, 1e-6);
  EXPECT_LT(Last3(rec, "pinion_bearing.F").norm(), 1e-9);
  EXPECT_LT(Last3(rec, "wheel_bearing.F").norm(), 1e-9);
}

// A rigid mesh through the pitch point (an ideal constraint on the line of action) carries the same
// statics: its reaction is the normal force.
TEST(GearContactTest, RigidPitchMeshCarriesTheSameLoads) {
  const std::string text =
      Replaced(ExampleText("gears/spur_pair.yaml"), "pressure_angle_deg: 20, K: 2.0e4, R: 20}", "pressure_angle_deg: 20, rigid: true}");
  const LoadedModel lm = LoadModelString(text);
  const RecordingObserver rec = RunModel(lm, 2.0, 0.01, Method::kBdf, 1e-8, 1e-10);
  ASSERT_EQ(rec.summary().status, RunStatus::kOk) << rec.summary().message;
  const double ft = 20.0 / 0.1;
  ExpectVector(Last3(rec, "pinion_bearing.F"), {ft * kTan20, ft, 0}, 1e-6 * ft, "pinion bearing");
  EXPECT_NEAR(rec.Last("mesh.F_t"), ft, 1e-6 * ft);
  EXPECT_NEAR(rec.Last("wheel.omega.z"), -5.0, 1e-8);
  ExpectEnergyBalanced(rec, 1e-6);
}

// A planetary set (sun 20, planets 25, ring 70 teeth, module 4 mm; ring fixed, sun at 10 rad/s,
// carrier under 90 N m): Willis, the sun's torque, and each planet bearing's tangential load
// carrier torque / (3 planets x 0.09 m), with the planet's centripetal force radially.
TEST(GearContactTest, PlanetaryFollowsWillisAndPlanetBearingsCarryTorqueOverRadius) {
  const RecordingObserver rec = RunExample("gears/planetary.yaml");
  ASSERT_EQ(rec.summary().status, RunStatus::kOk) << rec.summary().message;
  const double ws = 10.0, wc = ws * 20.0 / 90.0;
  EXPECT_NEAR(rec.Last("carrier.omega.z"), wc, 1e-5 * wc);
  const double planet_mass = 7800 * pi * 0.05 * 0.05 * 0.02;
  Eigen::Matrix3d rc;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) rc(i, j) = rec.Last("carrier.R." + std::to_string(10 * (i + 1) + j + 1));
  for (int k = 0; k < 3; ++k) {
    const std::string p = "planet" + std::to_string(k + 1);
    EXPECT_NEAR(rec.Last(p + ".omega.z") - wc, -(20.0 / 25.0) * (ws - wc), 1e-5 * ws) << p;
    // The bearing's force on the planet in the carrier's frame, radial and tangential at its place.
    const double angle = 2 * pi * k / 3;
    const Eigen::Vector3d radial(std::cos(angle), std::sin(angle), 0), tangential(-std::sin(angle), std::cos(angle), 0);
    const Eigen::Vector3d f = rc.transpose() * Last3(rec, p + "_bearing.F");
    EXPECT_NEAR(f.dot(tangential), -90.0 / (3 * 0.09), 1e-5 * 333.0) << p;  // it holds the planet back against the teeth
    EXPECT_NEAR(f.dot(radial), -planet_mass * wc * wc * 0.09, 1e-4) << p;
    EXPECT_NEAR(rec.Last("sun_p" + std::to_string(k + 1) + ".F_t"), 90.0 / (6 * 0.09), 1e-5 * 166.0) << p;
  }
  EXPECT_NEAR(rec.Last("motor.torque"), 90.0 * 20.0 / 90.0, 1e-5 * 20);
  ExpectEnergyBalanced(rec, 1e-6);
}

// The planetary set with every mesh rigid (#44: a three-planet set's redundant rigid meshes were
// reported to share the load unevenly, 16.34 to 17.00 N against 16.667): the planets' tangential
// bearing loads and tooth forces follow statics at every output time of the settled half and are
// the same on the three planets, whichever rule shares them: the planet bearings' springs (they
// are compliant: nothing is redundant), their declared stiffnesses (rigid bearings that keep K:
// the redundant reactions split as couplings of that K would carry them), or, without any K, the
// constraints' mobilities. Each costs no more than a few times the compliant set's steps.
TEST(GearContactTest, RigidPlanetMeshesShareTheLoadAsStaticsSay) {
  const std::string example = ExampleText("gears/planetary.yaml");
  const LoadedModel compliant = LoadModelString(example);
  const RecordingObserver reference = RunModel(compliant, 3.0, 0.01, Method::kBdf, 1e-8, 1e-10);
  ASSERT_EQ(reference.summary().status, RunStatus::kOk) << reference.summary().message;
  std::string meshes = example;
  for (const char* k : {"K: 2.0e4, R: 20}", "K: 2.0e5, R: 200}"})
    for (int i = 0; i < 3; ++i) meshes = Replaced(meshes, std::string("pressure_angle_deg: 20, ") + k, std::string("pressure_angle_deg: 20, rigid: true, ") + k);
  std::string bearings = meshes;
  for (int i = 0; i < 3; ++i)
    bearings = Replaced(bearings, "translation: {K: 1.0e9, R: 5000}, rotation: {K: 1.0e5, R: 50}}", "translation: {K: 1.0e9, R: 5000}, rotation: {K: 1.0e5, R: 50}, rigid: true}");
  std::string bare = bearings;
  for (const char* k : {", K: 2.0e4, R: 20}", ", K: 2.0e5, R: 200}"})
    for (int i = 0; i < 3; ++i) bare = Replaced(bare, std::string("rigid: true") + k, "rigid: true}");
  for (int i = 0; i < 3; ++i)
    bare = Replaced(bare, "translation: {K: 1.0e9, R: 5000}, rotation: {K: 1.0e5, R: 50}, rigid: true}", "rigid: true}");
  struct Case {
    const char* what;
    std::string text;
  };
  for (const Case& c : {Case{"rigid meshes", meshes}, Case{"rigid meshes and bearings that keep K", bearings}, Case{"rigid without K", bare}}) {
    SCOPED_TRACE(c.what);
    const LoadedModel lm = LoadModelString(c.text);
    const RecordingObserver rec = RunModel(lm, 3.0, 0.01, Method::kBdf, 1e-8, 1e-10);
    ASSERT_EQ(rec.summary().status, RunStatus::kOk) << rec.summary().message;
    EXPECT_LT(rec.summary().stats.steps, 3 * reference.summary().stats.steps);
    const double wc = 10.0 * 20.0 / 90.0, ft = 90.0 / (6 * 0.09);
    for (double t = 1.5; t <= 3.0 + 1e-9; t += 0.25) {
      Eigen::Matrix3d rc;
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) rc(i, j) = rec.At("carrier.R." + std::to_string(10 * (i + 1) + j + 1), t);
      double first = 0.0;
      for (int k = 0; k < 3; ++k) {
        const std::string p = "planet" + std::to_string(k + 1);
        const double angle = 2 * pi * k / 3;
        const Eigen::Vector3d tangential(-std::sin(angle), std::cos(angle), 0);
        const Eigen::Vector3d f = rc.transpose() * Eigen::Vector3d(rec.At(p + "_bearing.F.x", t), rec.At(p + "_bearing.F.y", t), rec.At(p + "_bearing.F.z", t));
        const double load = -f.dot(tangential);
        EXPECT_NEAR(load, 2 * ft, 1e-6 * 2 * ft) << p << " at t = " << t;
        EXPECT_NEAR(rec.At("sun_p" + std::to_string(k + 1) + ".F_t", t), ft, 1e-6 * ft) << p << " at t = " << t;
        if (k == 0) first = load;
        else EXPECT_NEAR(load, first, 5e-7 * 2 * ft) << p << " at t = " << t;  // measured: 2e-7 of it at most
      }
      EXPECT_NEAR(rec.At("carrier.omega.z", t), wc, 1e-6 * wc);
    }
    ExpectEnergyBalanced(rec, 1e-6);
  }
}

// Two helical stages (20/60 teeth at +20 deg, 20/50 at -15 deg, normal pressure angle 20 deg;
// 30 rad/s in, 75 N m out): speeds, and each shaft bearing's tangential, radial and axial loads
// from statics (F_a = F_t tan helix, F_r = F_t tan 20 deg / cos helix).
TEST(GearContactTest, HelicalGearboxBearingLoadsFromStatics) {
  const RecordingObserver rec = RunExample("gears/helical_gearbox.yaml");
  ASSERT_EQ(rec.summary().status, RunStatus::kOk) << rec.summary().message;
  EXPECT_NEAR(rec.Last("middle.omega.z"), -10.0, 1e-7);
  EXPECT_NEAR(rec.Last("output.omega.z"), 4.0, 1e-7);
  const double b1 = 20 * pi / 180, b2 = -15 * pi / 180;
  const double ft2 = 75.0 / 0.1, ft1 = ft2 * 0.04 / 0.12;
  // Stage 1: pitch point at +x of the input; t = +y. The teeth push the input back along -y, away
  // from the middle shaft (-x) and along -z (its bearing carries the opposite).
  const Eigen::Vector3d on_input(-ft1 * kTan20 / std::cos(b1), -ft1, -ft1 * std::tan(b1));
  // Stage 2: pitch point at +y of the middle shaft; t = -x; the middle shaft turns backwards.
  const Eigen::Vector3d on_output(ft2, ft2 * kTan20 / std::cos(b2), -ft2 * std::tan(b2));
  ExpectVector(Last3(rec, "input_bearing.F"), -on_input, 1e-6 * ft2, "input bearing");
  ExpectVector(Last3(rec, "output_bearing.F"), -on_output, 1e-6 * ft2, "output bearing");
  ExpectVector(Last3(rec, "middle_bearing.F"), on_input + on_output, 1e-6 * ft2, "middle bearing");  // both reactions
  EXPECT_NEAR(rec.Last("stage1.F_a"), -ft1 * std::tan(b1), 1e-6 * ft1);
  EXPECT_NEAR(rec.Last("stage2.b.F_a"), ft2 * std::tan(std::abs(b2)), 1e-6 * ft2);
  EXPECT_NEAR(rec.Last("motor.torque"), ft1 * 0.04, 1e-6 * ft2);
  ExpectEnergyBalanced(rec, 1e-6);
}

// A straight bevel pair at 90 deg (crown 48 teeth r = 0.2 m about z, pinion 12 teeth r = 0.05 m
// about x, apex at (0, 0, 0.05)): the pinion's bearing carries F_t, the radial force
// F_t tan 20 deg cos d and the thrust F_t tan 20 deg sin d away from the apex, d = atan(12/48).
constexpr const char* kBevel = R"(
model: bevel
bodies:
  crown:  {shape: {disc: {diameter: 0.4, thickness: 0.01, axis: z}}, density: 2700, position: [0, 0, 0]}
  pinion: {shape: {disc: {diameter: 0.1, thickness: 0.01, axis: x}}, density: 2700, position: [-0.2, 0, 0.05]}
joints:
  crown_bearing:  {type: revolute, child: crown, axis: z, translation: {K: 1.0e7, R: 500}, rotation: {K: 1.0e5, R: 50}}
  pinion_bearing: {type: revolute, child: pinion, axis: x, translation: {K: 1.0e7, R: 500}, rotation: {K: 1.0e5, R: 50}}
gears:
  mesh: {contact: pitch, a: {body: crown, axis: z, teeth: 48}, b: {body: pinion, axis: x, teeth: 12}, pressure_angle_deg: 20, K: 2.0e4, R: 20}
drives:
  motor: {type: angular_velocity, body: crown, axis: z, value: 5, K: 1000, R: 20}
  load:  {type: torque, body: pinion, axis: x, value: 2}
)";

TEST(GearContactTest, BevelPairSeparatingForceFollowsTheCones) {
  const LoadedModel lm = LoadModelString(kBevel);
  const RecordingObserver rec = RunModel(lm, 2.0, 0.01, Method::kBdf, 1e-9, 1e-11);
  ASSERT_EQ(rec.summary().status, RunStatus::kOk) << rec.summary().message;
  EXPECT_NEAR(rec.Last("pinion.omega.x"), -20.0, 1e-7);
  const double ft = 2.0 / 0.05, d = std::atan(12.0 / 48.0);
  // On the pinion: the teeth push it along -y (t = -y at the pitch point (-0.2, 0, 0)) and apart:
  // up towards its axis and along -x, away from the apex.
  const Eigen::Vector3d on_pinion(-ft * kTan20 * std::sin(d), -ft, ft * kTan20 * std::cos(d));
  ExpectVector(Last3(rec, "pinion_bearing.F"), -on_pinion, 1e-6 * ft, "pinion bearing");
  ExpectVector(Last3(rec, "crown_bearing.F"), on_pinion, 1e-6 * ft, "crown bearing");
  EXPECT_NEAR(rec.Last("mesh.b.F_r"), ft * kTan20 * std::cos(d), 1e-7 * ft);
  EXPECT_NEAR(rec.Last("mesh.b.F_a"), -ft * kTan20 * std::sin(d), 1e-7 * ft);  // along -x: away from the apex
  EXPECT_NEAR(rec.Last("mesh.F_a"), -ft * kTan20 * std::cos(d), 1e-7 * ft);   // the crown pushed down, away from the apex
  ExpectEnergyBalanced(rec, 1e-6);
}

// A rack (a box on a prismatic joint along x) under the pinion (r = 0.05 m at the origin): it moves
// at r w, and a 100 N load gives the pinion's torque 5 N m and the rack's guide 100 tan 20 deg.
constexpr const char* kRack = R"(
model: rack
bodies:
  pinion: {shape: {disc: {diameter: 0.1, thickness: 0.02, axis: z}}, density: 7800, position: [0, 0, 0]}
  rack:   {shape: {box: {size: [0.4, 0.04, 0.02]}}, density: 7800, position: [0, -0.07, 0]}
joints:
  pinion_bearing: {type: revolute, child: pinion, axis: z, translation: {K: 1.0e7, R: 500}, rotation: {K: 1.0e5, R: 50}}
  guide:          {type: prismatic, child: rack, axis: x, translation: {K: 1.0e7, R: 500}, rotation: {K: 1.0e5, R: 50}}
gears:
  mesh: {contact: pitch, a: {body: pinion, axis: z, teeth: 20, radius: 0.05}, b: {body: rack, rack: true}, pressure_angle_deg: 20, K: 2.0e4, R: 20}
drives:
  motor: {type: angular_velocity, body: pinion, axis: z, value: 4, K: 1000, R: 20}
  load:  {type: force, body: rack, axis: x, value: -100}
)";

TEST(GearContactTest, RackMovesAtPitchRadiusTimesSpeed) {
  const LoadedModel lm = LoadModelString(kRack);
  const RecordingObserver rec = RunModel(lm, 2.0, 0.01, Method::kBdf, 1e-9, 1e-11);
  ASSERT_EQ(rec.summary().status, RunStatus::kOk) << rec.summary().message;
  EXPECT_NEAR(rec.Last("rack.v.x"), 0.05 * 4, 1e-8);
  EXPECT_NEAR(rec.Last("motor.torque"), 0.05 * 100, 1e-6);
  ExpectVector(Last3(rec, "guide.F"), {0, 100 * kTan20, 0}, 1e-5, "rack guide");
  ExpectVector(Last3(rec, "pinion_bearing.F"), {100, -100 * kTan20, 0}, 1e-5, "pinion bearing");
  ExpectEnergyBalanced(rec, 1e-6);
}

// A wrong axis sign cannot pass silently: the wheel's axis -z does not roll with the pinion's z.
TEST(GearContactTest, WrongAxisIsALocatedErrorThatNamesTheRightOne) {
  const std::string text =
      Replaced(ExampleText("gears/spur_pair.yaml"), "b: {body: wheel, axis: z", "b: {body: wheel, axis: -z");
  try {
    LoadModelString(text, "spur.yaml");
    FAIL() << "a wrong axis was accepted";
  } catch (const ModelError& e) {
    ASSERT_EQ(e.diagnostics().size(), 1u);
    const Diagnostic& d = e.diagnostics()[0];
    EXPECT_EQ(d.code, "mech.gear_geometry");
    EXPECT_EQ(d.element, "mesh");
    EXPECT_EQ(d.where.file, "spur.yaml");
    EXPECT_GT(d.where.line, 0);
    EXPECT_NE(d.hint.find("[0, 0, 1]"), std::string::npos) << d.hint;
  }
  // Pitch radii out of the teeth ratio (a pitch point that the teeth do not put there).
  const std::string radii = Replaced(ExampleText("gears/helical_gearbox.yaml"), "pitch_point: [0.16, 0.04, 0]",
                                     "pitch_point: [0.16, 0.05, 0]");
  try {
    LoadModelString(radii, "gearbox.yaml");
    FAIL() << "pitch radii out of the teeth ratio were accepted";
  } catch (const ModelError& e) {
    EXPECT_EQ(e.diagnostics().at(0).code, "mech.gear_geometry");
  }
}

// Initial speeds that do not roll are a warning with the slip speed.
TEST(GearContactTest, SlipAtTheStartIsWarned) {
  const std::string text = Replaced(ExampleText("gears/spur_pair.yaml"), "position: [0.15, 0, 0]}",
                                    "position: [0.15, 0, 0], omega: [0, 0, 3]}");
  const LoadedModel lm = LoadModelString(text);
  ASSERT_EQ(lm.warnings.size(), 1u);
  EXPECT_EQ(lm.warnings[0].code, "mech.gear_slip");
  EXPECT_NE(lm.warnings[0].message.find("-0.3"), std::string::npos) << lm.warnings[0].message;  // 0 - 0.1 m x 3 rad/s
  // Rolling speeds (the wheel at -w_pinion / 2) are quiet.
  const std::string rolling = Replaced(Replaced(ExampleText("gears/spur_pair.yaml"), "position: [0.15, 0, 0]}",
                                                "position: [0.15, 0, 0], omega: [0, 0, -3]}"),
                                       "position: [0, 0, 0]}", "position: [0, 0, 0], omega: [0, 0, 6]}");
  EXPECT_TRUE(LoadModelString(rolling).warnings.empty());
}

}  // namespace
}  // namespace multibond
