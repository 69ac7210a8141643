// Assembly of mechanisms (docs/mechanisms.md, "Assembly") against closed forms: the slider-crank's
// piston position, speed and crank torque (virtual work), the four-bar's output angle and rate
// (Freudenstein); an assembled mechanism left alone; impossible and contradictory assemblies refused.

#include <cmath>
#include <numbers>

#include <fmt/format.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "support/cli_runner.h"
#include "support/temp_dir.h"
#include "support/example_runner.h"
#include "support/load_errors.h"
#include "support/text_edit.h"

#include "multibond/core/error.h"
#include "multibond/io/model_loader.h"
#include "multibond/mech/assembly.h"

namespace multibond {
namespace {

using std::numbers::pi;
using ::testing::HasSubstr;
using testing::ExamplePath;
using testing::ExampleText;
using testing::Replaced;
using testing::MaxEnergyResidual;
using testing::RunModel;

const mech::Body& BodyOf(const LoadedModel& lm, const std::string& name) {
  for (const mech::Body& b : lm.mechanism->bodies())
    if (b.name == name) return b;
  throw std::out_of_range(name);
}

/// The angle of a body's x axis in the x-y plane.
double PlanarAngle(const mech::Body& b) { return std::atan2(b.orientation(1, 0), b.orientation(0, 0)); }

/// The diagnostic of `code` among `ds`, or nullptr.
const Diagnostic* Find(const std::vector<Diagnostic>& ds, const std::string& code) {
  for (const Diagnostic& d : ds)
    if (d.code == code) return &d;
  return nullptr;
}

/// The diagnostics of the model error loading `text` (read as "model.yaml") throws; a test
/// failure if it loads.
std::vector<Diagnostic> ErrorsOf(const std::string& text) { return testing::LoadErrors(text, "model.yaml"); }

// --- slider-crank: r = 0.1 m, l = 0.3 m ---------------------------------------------------------

constexpr double kR = 0.1, kL = 0.3;

double PistonX(double theta) { return kR * std::cos(theta) + std::sqrt(kL * kL - kR * kR * std::sin(theta) * std::sin(theta)); }
double PistonDxDtheta(double theta) {
  const double s = std::sin(theta), c = std::cos(theta);
  return -kR * s * (1.0 + kR * c / std::sqrt(kL * kL - kR * kR * s * s));
}

LoadedModel SliderCrank(double theta0_deg, double omega, const std::string& text = ExampleText("mechanisms/slider_crank.yaml")) {
  const std::vector<ParameterOverride> sets = {{"theta0", fmt::format("{:.17g}", theta0_deg)}, {"omega", fmt::format("{:.17g}", omega)}};
  return LoadModelString(text, "slider_crank.yaml", {}, sets);
}

TEST(AssemblySliderCrank, PistonPositionAndSpeedFromTheCrankAngle) {
  for (const double deg : {30.0, 75.0, 150.0, 230.0, 300.0}) {
    const double theta = deg * pi / 180, omega = 10.0;
    const LoadedModel lm = SliderCrank(deg, omega);
    const mech::Body& piston = BodyOf(lm, "piston");
    EXPECT_NEAR(piston.position.x(), PistonX(theta), 1e-10) << deg;
    EXPECT_NEAR(piston.position.y(), 0.0, 1e-10) << deg;
    EXPECT_NEAR(piston.position.z(), 0.0, 1e-10) << deg;
    EXPECT_NEAR(piston.velocity.x(), PistonDxDtheta(theta) * omega, 1e-10) << deg;
    EXPECT_NEAR(piston.velocity.y(), 0.0, 1e-10) << deg;
    EXPECT_NEAR(piston.omega.norm(), 0.0, 1e-10) << deg;
    const mech::Body& crank = BodyOf(lm, "crank");
    EXPECT_NEAR(std::remainder(PlanarAngle(crank) - theta, 2 * pi), 0.0, 1e-12) << deg;
    EXPECT_NEAR(crank.omega.z(), omega, 1e-12) << deg;  // the ideal motor's speed at t = 0
    // The rod: from the crank pin to the wrist pin.
    const mech::Body& rod = BodyOf(lm, "rod");
    const Eigen::Vector3d pin(kR * std::cos(theta), kR * std::sin(theta), 0.0);
    EXPECT_NEAR((rod.position - 0.5 * (pin + piston.position)).norm(), 0.0, 1e-10) << deg;
    // The report: the mech.assembled warning names the bodies that moved.
    const Diagnostic* d = Find(lm.warnings, "mech.assembled");
    ASSERT_NE(d, nullptr);
    EXPECT_EQ(d->where.line, 28);  // the key 'assembly'
    EXPECT_EQ(d->where.column, 1);
    EXPECT_THAT(d->message, HasSubstr("3 bodies moved"));
    ASSERT_EQ(d->details.size(), 3u);
    EXPECT_THAT(d->details[0], HasSubstr(fmt::format("crank: moved {:.6g} m, turned {:.6g} deg", (crank.position - Eigen::Vector3d(0.05, 0, 0)).norm(),
                                                     std::abs(std::remainder(deg, 360.0)))));
    EXPECT_EQ(Find(lm.warnings, "mech.initial_gap"), nullptr) << deg;
  }
}

TEST(AssemblySliderCrank, CrankTorqueUnderAGasForceIsByVirtualWork) {
  // Held by the ideal motor at zero speed, the mechanism is in static balance: the motor's torque
  // T and the gas force F do no work together, T dtheta + F dx = 0.
  const double f = -500.0;
  for (const double deg : {30.0, 100.0, 250.0}) {
    const double theta = deg * pi / 180;
    const LoadedModel lm = SliderCrank(deg, 0.0);
    const RecordingObserver rec = RunModel(lm, 0.05, 0.01);
    ASSERT_EQ(rec.summary().status, RunStatus::kOk);
    const double expected = -f * PistonDxDtheta(theta);
    for (double t : {0.0, 0.02, 0.05}) EXPECT_NEAR(rec.At("motor.torque", t), expected, 1e-9 * std::abs(expected)) << deg << " t = " << t;
    EXPECT_NEAR(rec.Last("piston.r.x"), PistonX(theta), 1e-10) << deg;
  }
}

TEST(AssemblySliderCrank, RunFromTheAssembledStateFollowsTheCrankAndKeepsItsEnergy) {
  const double deg = 30.0, omega = 10.0;
  const LoadedModel lm = SliderCrank(deg, omega);
  const RecordingObserver rec = RunModel(lm, 0.5, 0.01);
  ASSERT_EQ(rec.summary().status, RunStatus::kOk);
  for (double t : {0.1, 0.25, 0.5}) {
    const double theta = deg * pi / 180 + omega * t;
    EXPECT_NEAR(rec.At("piston.r.x", t), PistonX(theta), 1e-7) << t;
    EXPECT_NEAR(rec.At("piston.v.x", t), PistonDxDtheta(theta) * omega, 1e-6) << t;
  }
  EXPECT_LT(MaxEnergyResidual(rec), 1e-7);
}

// --- four-bar: ground d, crank a, coupler b, rocker c ------------------------------------------

constexpr double kA = 0.1, kB = 0.3, kC = 0.25, kD = 0.3;

/// The rocker's angle phi for the crank angle theta, from the Freudenstein equation
/// K1 cos phi - K2 cos theta + K3 = cos(theta - phi), i.e. P cos phi + Q sin phi + S = 0: the
/// branch with the coupler's far end above the ground line (as the example is drawn).
double Freudenstein(double theta) {
  const double k1 = kD / kA, k2 = kD / kC, k3 = (kA * kA - kB * kB + kC * kC + kD * kD) / (2 * kA * kC);
  const double p = k1 - std::cos(theta), q = -std::sin(theta), s = k3 - k2 * std::cos(theta);
  return std::atan2(q, p) + std::acos(-s / std::hypot(p, q));
}

/// dphi/dtheta of the same: -F_theta / F_phi of F = P cos phi + Q sin phi + S.
double FreudensteinRate(double theta, double phi) {
  const double k1 = kD / kA, k2 = kD / kC;
  const double f_theta = std::sin(theta) * std::cos(phi) - std::cos(theta) * std::sin(phi) + k2 * std::sin(theta);
  const double f_phi = -(k1 - std::cos(theta)) * std::sin(phi) - std::sin(theta) * std::cos(phi);
  return -f_theta / f_phi;
}

std::string FourBarAt(double deg, double rate) {
  return Replaced(ExampleText("mechanisms/four_bar.yaml"), "A: {degrees: 60, rate: 5}", fmt::format("A: {{degrees: {}, rate: {}}}", deg, rate));
}

TEST(AssemblyFourBar, OutputAngleAndRateFromFreudenstein) {
  for (const double deg : {20.0, 60.0, 135.0, 210.0, 320.0}) {
    const double theta = deg * pi / 180, omega = 5.0;
    const LoadedModel lm = LoadModelString(FourBarAt(deg, omega), "four_bar.yaml");
    const double phi = Freudenstein(theta);
    const mech::Body& rocker = BodyOf(lm, "rocker");
    EXPECT_NEAR(std::remainder(PlanarAngle(rocker) - phi, 2 * pi), 0.0, 1e-10) << deg;
    EXPECT_NEAR(rocker.omega.z(), FreudensteinRate(theta, phi) * omega, 1e-10) << deg;
    EXPECT_NEAR(rocker.omega.head<2>().norm(), 0.0, 1e-10) << deg;
    // The rocker's CoM halfway from D = (d, 0, 0), the crank's at a/2 along theta.
    EXPECT_NEAR((rocker.position - Eigen::Vector3d(kD + kC / 2 * std::cos(phi), kC / 2 * std::sin(phi), 0)).norm(), 0.0, 1e-10) << deg;
    EXPECT_NEAR((BodyOf(lm, "crank").position - Eigen::Vector3d(kA / 2 * std::cos(theta), kA / 2 * std::sin(theta), 0)).norm(), 0.0, 1e-10);
    EXPECT_EQ(Find(lm.warnings, "mech.initial_gap"), nullptr) << deg;
  }
}

TEST(AssemblyFourBar, TheFreeRunFromTheAssembledStateKeepsItsEnergyAndStartsUndeflected) {
  const std::string text = ExampleText("mechanisms/four_bar.yaml");
  // As drawn, without the assembly, the loop does not close: the joints start apart.
  const std::string drawn = Replaced(text, "assembly:\n  given:\n    A: {degrees: 60, rate: 5}\n", "");
  EXPECT_NE(Find(LoadModelString(drawn, "four_bar.yaml").warnings, "mech.initial_gap"), nullptr);
  const LoadedModel lm = LoadModelString(text, "four_bar.yaml");
  EXPECT_EQ(Find(lm.warnings, "mech.initial_gap"), nullptr);
  const RecordingObserver rec = RunModel(lm, 0.5, 0.01);
  ASSERT_EQ(rec.summary().status, RunStatus::kOk);
  EXPECT_LT(MaxEnergyResidual(rec), 1e-6);
  // The couplings start undeflected and with no deflection rate: at t = 0 they hold no energy.
  for (const char* j : {"A", "B", "C", "D"}) EXPECT_EQ(rec.rows().front()[rec.Index(std::string(j) + ".t.K.q.x")], 0.0) << j;
  // With velocities that close the loop, the joints only carry the links' inertia loads: they stay
  // within 1e-7 m over the run (measured 1.6e-8 m; K = 1e8 N/m).
  double deflection = 0.0;
  for (const char* j : {"A", "B", "C", "D"})
    for (const char* c : {"x", "y", "z"}) {
      const int k = rec.Index(fmt::format("{}.t.K.q.{}", j, c));
      for (const auto& row : rec.rows()) deflection = std::max(deflection, std::abs(row[k]));
    }
  EXPECT_LT(deflection, 1e-7);
  EXPECT_GT(rec.rows().front()[rec.Index("energy.kinetic")], 0.0);
}

TEST(AssemblySliderCrank, ThePistonSpeedGivenGivesTheCrankRate) {
  // A prismatic joint's speed instead of the motor's: the crank turns at v / (dx/dtheta).
  const double deg = 50.0, v = -0.8, theta = deg * pi / 180;
  std::string text = ExampleText("mechanisms/slider_crank.yaml");
  text = Replaced(text, "rigid: true, value: omega", "K: 1000, R: 5, value: omega");  // a compliant motor gives no speed
  text = Replaced(text, "crank_pivot: {degrees: theta0}", "crank_pivot: {degrees: theta0}\n    cylinder: {speed: -0.8}");
  const LoadedModel lm = SliderCrank(deg, 10.0, text);
  EXPECT_NEAR(BodyOf(lm, "piston").velocity.x(), v, 1e-12);
  EXPECT_NEAR(BodyOf(lm, "crank").omega.z(), v / PistonDxDtheta(theta), 1e-10);
  EXPECT_NEAR(BodyOf(lm, "piston").position.x(), PistonX(theta), 1e-10);
}

// --- gear meshes: the velocity level rolls ---------------------------------------------------------

TEST(AssemblyGears, AGivenBearingRateTurnsTheMeshingGearAtTheTeethRatio) {
  // A spin mesh (20 and 50 teeth, external: both axes z): rolling is 20 s_a + 50 s_b = 0.
  const char* text = R"(
model: gears
bodies:
  pinion: {shape: {disc: {diameter: 0.1, thickness: 0.02, axis: z}}, density: 7800}
  wheel:  {shape: {disc: {diameter: 0.25, thickness: 0.02, axis: z}}, density: 7800, position: [0.175, 0, 0]}
joints:
  pinion_bearing: {type: revolute, child: pinion, axis: z, rigid: true}
  wheel_bearing:  {type: revolute, child: wheel, axis: z, rigid: true}
gears:
  mesh: {a: {body: pinion, axis: z, teeth: 20}, b: {body: wheel, axis: z, teeth: 50}, K: 1.0e4, R: 1}
assembly:
  given:
    pinion_bearing: {rate: 10}
)";
  const LoadedModel lm = LoadModelString(text, "gears.yaml");
  EXPECT_NEAR(BodyOf(lm, "pinion").omega.z(), 10.0, 1e-12);
  EXPECT_NEAR(BodyOf(lm, "wheel").omega.z(), -4.0, 1e-12);
  EXPECT_NEAR(BodyOf(lm, "wheel").velocity.norm(), 0.0, 1e-12);
  // Through the pitch point (examples/gears/spur_pair.yaml, 20 and 40 teeth): the pitch points'
  // velocities along the line of action agree, with no slip (no mech.gear_slip).
  const std::string spur = Replaced(ExampleText("gears/spur_pair.yaml"), "\nsimulation:",
                                    "\nassembly:\n  given:\n    pinion_bearing: {rate: 10}\nsimulation:");
  const LoadedModel sp = LoadModelString(spur, "spur_pair.yaml");
  EXPECT_NEAR(BodyOf(sp, "wheel").omega.z(), -5.0, 1e-12);
  EXPECT_EQ(Find(sp.warnings, "mech.gear_slip"), nullptr);
}

TEST(AssemblyGears, APlanetarySetFromTheSunsRateFollowsWillis) {
  // examples/gears/planetary.yaml (sun 20, planets 25, ring 70 teeth, fixed; planets at 0.09 m),
  // meshes through the pitch point: omega_c = omega_s Zs / (Zs + Zr), the planets turn at
  // omega_c - (Zs / Zp)(omega_s - omega_c) and their centres move at omega_c x 0.09 m.
  const std::string text = ExampleText("gears/planetary.yaml") + "assembly: {given: {sun_bearing: {rate: 10}}}\n";
  const LoadedModel lm = LoadModelString(text, "planetary.yaml");
  const double ws = 10.0, wc = ws * 20.0 / 90.0, wp = wc - 20.0 / 25.0 * (ws - wc);
  EXPECT_NEAR(BodyOf(lm, "carrier").omega.z(), wc, 1e-12);
  EXPECT_NEAR(BodyOf(lm, "ring").omega.norm(), 0.0, 1e-12);
  for (const char* p : {"planet1", "planet2", "planet3"}) {
    const mech::Body& b = BodyOf(lm, p);
    EXPECT_NEAR(b.omega.z(), wp, 1e-12) << p;
    EXPECT_NEAR((b.velocity - Eigen::Vector3d::UnitZ().cross(b.position) * wc).norm(), 0.0, 1e-12) << p;
  }
  EXPECT_NEAR(wp, -4.0, 1e-12);
  EXPECT_EQ(Find(lm.warnings, "mech.gear_slip"), nullptr);
}

TEST(Assembly, ARotationCouplingHoldsTheDrawnRelativeRotationInEachFrame) {
  // A child welded by a rotation coupling of all three directions to a parent that a given turns:
  // the child turns with it, R_c = (R_p R_p0^T) R_c0, whichever frame the coupling is written in;
  // and with the coupling on two directions only, the relative turn left is about the third.
  const Eigen::Matrix3d rp0 = Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  const Eigen::Matrix3d rc0 = Eigen::AngleAxisd(-0.7, Eigen::Vector3d(2, -1, 0.5).normalized()).toRotationMatrix();
  const Eigen::Matrix3d turn = Eigen::AngleAxisd(0.9, Eigen::Vector3d(-1, 1, 2).normalized()).toRotationMatrix();
  for (const mech::Coupling::Frame frame : {mech::Coupling::Frame::kWorld, mech::Coupling::Frame::kParent, mech::Coupling::Frame::kChild}) {
    for (const int directions : {3, 2}) {
      mech::Mechanism m;
      mech::Body p, c;
      p.name = "P";
      p.mass = mech::MassProperties::Given(1.0, Eigen::Matrix3d::Identity());
      p.orientation = rp0;
      c = p;
      c.name = "C";
      c.orientation = rc0;
      c.position = Eigen::Vector3d(0.5, 0.2, -0.1);
      m.AddBody(p);
      m.AddBody(c);
      mech::Joint j;
      j.name = "weld";
      j.parent = "P";
      j.child = "C";
      mech::Coupling rot;
      rot.frame = frame;
      rot.directions = Eigen::MatrixXd::Identity(3, 3).topRows(directions);
      j.rotation = rot;
      m.AddJoint(j);
      mech::AssemblySpec spec;
      mech::AssemblySpec::Given g;
      g.kind = mech::AssemblySpec::Given::Kind::kBodyOrientation;
      g.part = "P";
      g.matrix = turn * rp0;
      spec.given.push_back(g);
      DiagnosticSink sink;
      ASSERT_TRUE(mech::Assemble(m, spec, sink).ok) << static_cast<int>(frame) << " " << directions;
      const Eigen::Matrix3d rp = m.bodies()[0].orientation, rc = m.bodies()[1].orientation;
      EXPECT_LE((rp - turn * rp0).norm(), 1e-12);
      // The relative rotation since the drawing, in the coupling's frame.
      const Eigen::Matrix3d rel = frame == mech::Coupling::Frame::kWorld    ? Eigen::Matrix3d(rc * rc0.transpose() * rp0 * rp.transpose())
                                  : frame == mech::Coupling::Frame::kParent ? Eigen::Matrix3d(rp.transpose() * rc * rc0.transpose() * rp0)
                                                                            : Eigen::Matrix3d(rc0.transpose() * rp0 * rp.transpose() * rc);
      const Eigen::AngleAxisd aa(rel);
      const Eigen::Vector3d v = aa.angle() * aa.axis();
      if (directions == 3) {
        EXPECT_LE((rc - turn * rc0).norm(), 1e-12) << static_cast<int>(frame);
      } else {
        EXPECT_LE(v.head<2>().norm(), 1e-12) << static_cast<int>(frame);
      }
    }
  }
}

// --- left alone, refused ----------------------------------------------------------------------

TEST(Assembly, AnAssembledMechanismIsLeftAsItIs) {
  const LoadedModel lm = SliderCrank(40.0, 10.0);
  mech::Mechanism m = *lm.mechanism;
  mech::AssemblySpec spec;
  mech::AssemblySpec::Given g;
  g.kind = mech::AssemblySpec::Given::Kind::kJointAngle;  // angles from the bodies as they are now
  g.part = "crank_pivot";
  g.value = 0.0;
  spec.given.push_back(g);
  DiagnosticSink sink;
  const mech::AssemblyReport r = mech::Assemble(m, spec, sink);
  ASSERT_TRUE(r.ok);
  EXPECT_EQ(r.iterations, 0);
  ASSERT_EQ(r.moves.size(), 3u);
  for (const auto& mv : r.moves) {
    EXPECT_LE(mv.displacement, 1e-15) << mv.body;
    EXPECT_LE(mv.rotation, 1e-15) << mv.body;
    EXPECT_LE(mv.velocity, 1e-15) << mv.body;
    EXPECT_LE(mv.omega, 1e-15) << mv.body;
  }
  ASSERT_EQ(sink.diagnostics().size(), 1u);
  EXPECT_THAT(sink.diagnostics()[0].message, HasSubstr("nothing moved"));
}

TEST(Assembly, ACrankLongerThanTheRodAllowsIsRefused) {
  // l = 0.08 m < r = 0.1 m: at 90 degrees the rod cannot reach the cylinder's axis.
  std::string text = ExampleText("mechanisms/slider_crank.yaml");
  text = Replaced(text, "child: rod, at: [0.05, 0, 0], child_at: [-0.15, 0, 0]", "child: rod, at: [0.05, 0, 0], child_at: [-0.04, 0, 0]");
  text = Replaced(text, "child: piston, at: [0.15, 0, 0]", "child: piston, at: [0.04, 0, 0]");
  text = Replaced(text, "theta0: {value: 30", "theta0: {value: 90");
  const std::vector<Diagnostic> ds = ErrorsOf(text);
  const Diagnostic* d = Find(ds, "mech.assembly");
  ASSERT_NE(d, nullptr);
  EXPECT_THAT(d->message, HasSubstr("no assembly satisfies the joints at the given coordinates"));
  EXPECT_THAT(d->message, HasSubstr(" is off by "));
  EXPECT_TRUE(d->where.known());
  EXPECT_EQ(d->where.file, "model.yaml");
  // The rod of 0.08 m misses the axis by r - l = 0.02 m, which the least squares share among the
  // joints of the loop: the worst of them by centimetres.
  EXPECT_THAT(d->message, ::testing::ContainsRegex("off by 0\\.0[1-9]"));
  // At 30 degrees it reaches it (r sin 30 = 0.05 < 0.08).
  EXPECT_NO_THROW(LoadModelString(Replaced(text, "theta0: {value: 90", "theta0: {value: 30"), "model.yaml"));
}

TEST(Assembly, ContradictoryGivensAreRefused) {
  const std::string text = ExampleText("mechanisms/slider_crank.yaml");
  // The crank's orientation and its joint's angle, two different turns.
  const std::vector<Diagnostic> ds =
      ErrorsOf(Replaced(text, "crank_pivot: {degrees: theta0}", "crank_pivot: {degrees: theta0}\n    crank: {orientation: {axis: z, degrees: 45}}"));
  const Diagnostic* d = Find(ds, "mech.assembly");
  ASSERT_NE(d, nullptr);
  EXPECT_THAT(d->message, HasSubstr("the given coordinates contradict each other"));
  EXPECT_THAT(d->where.line, ::testing::AnyOf(30, 31));  // at one of the two givens
  // The same turn twice is no contradiction.
  EXPECT_NO_THROW(LoadModelString(
      Replaced(text, "crank_pivot: {degrees: theta0}", "crank_pivot: {degrees: theta0}\n    crank: {orientation: {axis: z, degrees: 30}}"), "m.yaml"));
  // A joint rate against the ideal motor's speed at t = 0.
  const std::vector<Diagnostic> speeds = ErrorsOf(Replaced(text, "crank_pivot: {degrees: theta0}", "crank_pivot: {degrees: theta0, rate: 3}"));
  const Diagnostic* s = Find(speeds, "mech.assembly");
  ASSERT_NE(s, nullptr);
  EXPECT_THAT(s->message, HasSubstr("the given speeds contradict each other"));
}

TEST(Assembly, UnknownNamesAndKeysGetDidYouMean) {
  const std::string text = ExampleText("mechanisms/slider_crank.yaml");
  const std::vector<Diagnostic> ds = ErrorsOf(Replaced(text, "crank_pivot: {degrees: theta0}", "crank_pivt: {degrees: theta0}"));
  const Diagnostic* d = Find(ds, "mech.reference");
  ASSERT_NE(d, nullptr);
  EXPECT_EQ(d->hint, "did you mean 'crank_pivot'?");
  EXPECT_EQ(d->where.line, 30);
  EXPECT_EQ(d->where.column, 5);
  const std::vector<Diagnostic> keys = ErrorsOf(Replaced(text, "crank_pivot: {degrees: theta0}", "crank_pivot: {degree: theta0}"));
  ASSERT_FALSE(keys.empty());
  EXPECT_EQ(keys[0].hint, "did you mean 'degrees'?");
  const std::vector<Diagnostic> top = ErrorsOf(Replaced(text, "assembly:\n  given:", "assembly:\n  givne:"));
  ASSERT_FALSE(top.empty());
  EXPECT_EQ(top[0].hint, "did you mean 'given'?");
  // A joint without a coordinate, a drive without a speed.
  const std::vector<Diagnostic> kinds = ErrorsOf(Replaced(text, "crank_pivot: {degrees: theta0}", "gas: {speed: 1}"));
  ASSERT_NE(Find(kinds, "mech.assembly"), nullptr);
  EXPECT_THAT(Find(kinds, "mech.assembly")->message, HasSubstr("no speed to give"));
}

TEST(AssemblyCli, CheckAndRunSayWhatMovedAndCheckRefusesWhatCannotClose) {
  const testing::CliResult ok = testing::RunProgram({MULTIBOND_CLI, "check", ExamplePath("mechanisms/four_bar.yaml")});
  EXPECT_EQ(ok.code, 0) << ok.out;
  EXPECT_THAT(ok.out, HasSubstr("four_bar.yaml:28:1: warning: assembly: assembled in "));
  EXPECT_THAT(ok.out, HasSubstr("\n  rocker: moved "));
  EXPECT_THAT(ok.out, ::testing::Not(HasSubstr("apart at t = 0")));
  const testing::TempDir dir;
  const testing::CliResult run =
      testing::RunProgram({MULTIBOND_CLI, "run", ExamplePath("mechanisms/slider_crank.yaml"), "-o", (dir.path() / "out").string(), "--t-end", "0.02"});
  EXPECT_EQ(run.code, 0) << run.out;
  EXPECT_THAT(run.out, HasSubstr("warning: assembly: assembled in "));
  const testing::CliResult bad = testing::RunProgram({MULTIBOND_CLI, "check", MULTIBOND_SOURCE_DIR "/tests/models/bad/assembly_crank_too_long.yaml"});
  EXPECT_EQ(bad.code, 1) << bad.out;
  EXPECT_THAT(bad.out, HasSubstr("error: "));
  EXPECT_THAT(bad.out, HasSubstr("no assembly satisfies the joints at the given coordinates"));
}

}  // namespace
}  // namespace multibond
