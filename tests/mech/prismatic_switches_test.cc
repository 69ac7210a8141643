// End stops and Coulomb friction on a prismatic joint's slide (docs/mechanisms.md, "End stops and
// friction"; docs/events.md): a slider against its stops (impact times, rebound speeds, the losses
// (1 - e^2) 1/2 m v^2 in the energy account, the stop's reaction at rest), between two bodies
// (the reduced mass), under friction (the stopping distance and time, stuck or sliding under a
// push), the refused models, and examples/mechanisms/slider_stops.yaml.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "support/example_runner.h"
#include "support/load_errors.h"

#include "multibond/io/model_loader.h"
#include "multibond/sim/simulator.h"

namespace multibond {
namespace {

// The slider: a steel box 0.1 x 0.05 x 0.05 m at 8000 kg/m^3, 2 kg.
constexpr double kMass = 2.0;
constexpr const char* kSlider = "slider: {shape: {box: {size: [0.1, 0.05, 0.05]}}, density: 8000";

/// The guide's couplings across its axis: rigid, or compliant (springs and dampers).
const char* Couplings(bool rigid) {
  return rigid ? "rigid: true" : "translation: {K: 1.0e6, R: 100}, rotation: {K: 1.0e4, R: 10}";
}

/// A slider on a prismatic joint `guide` along x to the ground, launched at `v0` along x, with
/// the joint's `extra` keys, under `gravity`; `more` adds to the model (drives).
std::string SliderModel(bool rigid, double v0, const std::string& extra, const std::string& gravity = "[0, 0, 0]",
                        const std::string& more = "") {
  return "model: slider\ngravity: " + gravity + "\nbodies:\n  " + kSlider + ", velocity: [" + std::to_string(v0) +
         ", 0, 0]}\njoints:\n  guide: {type: prismatic, child: slider, axis: x, " + Couplings(rigid) + ", sensors: true, " + extra +
         "}\n" + more;
}

std::vector<EventRecord> OfKind(const RecordingObserver& rec, const std::string& kind) {
  std::vector<EventRecord> out;
  for (const EventRecord& e : rec.events())
    if (e.kind == kind) out.push_back(e);
  return out;
}

class PrismaticStops : public ::testing::TestWithParam<bool> {};  // rigid or compliant across the axis

TEST_P(PrismaticStops, TheSliderStrikesAtLOverV0LeavesAtMinusEV0AndLosesOneMinusESquared) {
  const double v0 = 1.5, upper = 0.3, lower = -0.5, e = 0.6;
  const RecordingObserver rec = testing::RunModelText(
      SliderModel(GetParam(), v0, "limits: {lower: -0.5, upper: 0.3, restitution: 0.6}"), 2.0, 1e-2);
  const std::vector<EventRecord> limits = OfKind(rec, "limit");
  ASSERT_EQ(limits.size(), 2u);
  // Free flight to the upper stop, back at e v0 to the lower one.
  EXPECT_EQ(limits[0].element, "guide.upper");
  EXPECT_NEAR(limits[0].time, upper / v0, 1e-12);
  EXPECT_EQ(limits[1].element, "guide.lower");
  EXPECT_NEAR(limits[1].time, upper / v0 + (upper - lower) / (e * v0), 1e-10);
  EXPECT_NEAR(rec.At("guide.speed", 0.5), -e * v0, 1e-12);
  EXPECT_NEAR(rec.At("slider.v.x", 0.5), -e * v0, 1e-12);
  EXPECT_NEAR(rec.Last("guide.speed"), e * e * v0, 1e-12);
  double highest = 0.0, lowest = 0.0;  // the stops hold
  for (const auto& row : rec.rows()) {
    highest = std::max(highest, row[rec.Index("guide.slide")]);
    lowest = std::min(lowest, row[rec.Index("guide.slide")]);
  }
  EXPECT_LE(highest, upper + 1e-12);
  EXPECT_GE(lowest, lower - 1e-12);
  // Each impact's loss, 1/2 m v^2 (1 - e^2), is the stop's and the model's dissipation.
  const double first = 0.5 * kMass * v0 * v0 * (1 - e * e), second = 0.5 * kMass * e * e * v0 * v0 * (1 - e * e);
  EXPECT_NEAR(rec.At("guide.upper.dissipated", 0.5), first, 1e-12);
  EXPECT_NEAR(rec.At("energy.dissipated", 0.5), first, 1e-12);
  EXPECT_NEAR(rec.Last("guide.lower.dissipated"), second, 1e-12);
  EXPECT_NEAR(rec.Last("energy.dissipated") + rec.Last("energy.kinetic"), 0.5 * kMass * v0 * v0, 1e-12);
  EXPECT_LT(std::abs(rec.Last("energy.residual")), 1e-9);
  // Free flight: nothing pushes along the axis.
  EXPECT_NEAR(rec.At("guide.F.x", 0.5), 0.0, 1e-9);
}

TEST_P(PrismaticStops, WithoutRestitutionItRestsAgainstTheStopThatHoldsMG) {
  // Gravity g = 2 m/s^2 along the axis: v0 t + g t^2 / 2 = L at t = (sqrt(v0^2 + 2 g L) - v0) / g,
  // closing at v1 = sqrt(v0^2 + 2 g L); all of 1/2 m v1^2 is lost, and the stop then holds m g.
  const double v0 = 1.5, upper = 0.3, g = 2.0;
  const RecordingObserver rec = testing::RunModelText(
      SliderModel(GetParam(), v0, "limits: {lower: -0.5, upper: 0.3, restitution: 0}", "[2.0, 0, 0]"), 1.0, 1e-2);
  const double v1 = std::sqrt(v0 * v0 + 2 * g * upper);
  const std::vector<EventRecord> limits = OfKind(rec, "limit");
  ASSERT_EQ(limits.size(), 1u);
  EXPECT_EQ(limits[0].element, "guide.upper");
  EXPECT_NEAR(limits[0].time, (v1 - v0) / g, 1e-10);
  EXPECT_NEAR(rec.Last("guide.upper.dissipated"), 0.5 * kMass * v1 * v1, 1e-9);
  EXPECT_NEAR(rec.Last("guide.slide"), upper, 1e-12);
  EXPECT_NEAR(rec.Last("guide.speed"), 0.0, 1e-12);
  EXPECT_NEAR(rec.Last("guide.F.x"), -kMass * g, 1e-9);  // the stop's reaction on the slider
  EXPECT_NEAR(rec.Last("slider.F.x"), -kMass * g, 1e-9);
  EXPECT_LT(std::abs(rec.Last("energy.residual")), 1e-9);
}

INSTANTIATE_TEST_SUITE_P(Couplings, PrismaticStops, ::testing::Bool(),
                         [](const ::testing::TestParamInfo<bool>& i) { return i.param ? "Rigid" : "Compliant"; });

TEST(PrismaticStops, BetweenTwoBodiesTheImpactLosesTheReducedMassShareAndKeepsTheMomentum) {
  // A carriage (10 kg) on a rail along x, the slider (2 kg) on the carriage along x at v0: the
  // impact at t = L / v0 reverses the relative speed to -e v0, keeping the momentum m v0, and
  // loses 1/2 mu v0^2 (1 - e^2), mu = m M / (m + M). Both joints carry the weights.
  const double v0 = 1.5, e = 0.6, big = 10.0, g = 9.81;
  const std::string yaml = std::string("model: carriage\ngravity: [0, 0, -9.81]\nbodies:\n") +
                           "  carriage: {shape: {box: {size: [0.4, 0.1, 0.05]}}, density: 5000}\n  " + kSlider +
                           ", position: [0, 0, 0.05], velocity: [1.5, 0, 0]}\njoints:\n"
                           "  rail: {type: prismatic, child: carriage, axis: x, rigid: true}\n"
                           "  guide: {type: prismatic, parent: carriage, child: slider, axis: x, rigid: true, sensors: true,\n"
                           "          limits: {lower: -0.5, upper: 0.3, restitution: 0.6}}\n";
  const RecordingObserver rec = testing::RunModelText(yaml, 1.0, 1e-2);
  const std::vector<EventRecord> limits = OfKind(rec, "limit");
  ASSERT_EQ(limits.size(), 1u);
  EXPECT_NEAR(limits[0].time, 0.3 / v0, 1e-12);
  const double mu = kMass * big / (kMass + big);
  EXPECT_NEAR(rec.Last("guide.upper.dissipated"), 0.5 * mu * v0 * v0 * (1 - e * e), 1e-12);
  EXPECT_NEAR(rec.Last("guide.speed"), -e * v0, 1e-12);
  EXPECT_NEAR(big * rec.Last("carriage.v.x") + kMass * rec.Last("slider.v.x"), kMass * v0, 1e-12);
  EXPECT_NEAR(rec.Last("rail.F.z"), (big + kMass) * g, 1e-9);
  EXPECT_NEAR(rec.Last("guide.F.z"), kMass * g, 1e-9);
  EXPECT_NEAR(rec.Last("energy.dissipated") + rec.Last("energy.kinetic"), 0.5 * kMass * v0 * v0, 1e-12);
  EXPECT_LT(std::abs(rec.Last("energy.residual")), 1e-9);
}

TEST(PrismaticFriction, TheSliderDeceleratesAtFOverMAndStopsAtMV0SquaredOver2F) {
  const double v0 = 1.5, f = 3.0;
  const RecordingObserver rec = testing::RunModelText(SliderModel(true, v0, "friction: 3.0"), 2.0, 1e-2);
  const std::vector<EventRecord> locks = OfKind(rec, "lock");
  ASSERT_EQ(locks.size(), 1u);
  ASSERT_EQ(rec.events().size(), 1u);
  EXPECT_NEAR(locks[0].time, kMass * v0 / f, 1e-10);
  EXPECT_NEAR(rec.At("guide.speed", 0.4), v0 - f / kMass * 0.4, 1e-12);
  EXPECT_NEAR(rec.At("guide.F.x", 0.4), -f, 1e-12);  // the friction force on the slider
  EXPECT_NEAR(rec.Last("guide.slide"), kMass * v0 * v0 / (2 * f), 1e-9);
  EXPECT_NEAR(rec.Last("slider.r.x"), kMass * v0 * v0 / (2 * f), 1e-9);
  EXPECT_EQ(rec.Last("guide.speed"), 0.0);
  EXPECT_NEAR(rec.Last("guide.friction.dissipated"), 0.5 * kMass * v0 * v0, 1e-9);
  EXPECT_LT(std::abs(rec.Last("energy.residual")), 1e-9);
}

TEST(PrismaticFriction, APushBelowFKeepsItStuckAPushAboveSlidesItAtPMinusFOverM) {
  const double f = 3.0;
  auto pushed = [&](double p) {
    return testing::RunModelText(
        SliderModel(true, 0.0, "friction: 3.0", "[0, 0, 0]",
                    "drives:\n  push: {type: force, body: slider, axis: x, value: " + std::to_string(p) + "}\n"),
        1.0, 1e-2);
  };
  const RecordingObserver held = pushed(0.8 * f);
  EXPECT_TRUE(held.events().empty());
  EXPECT_EQ(held.Last("guide.slide"), 0.0);
  EXPECT_NEAR(held.Last("guide.F.x"), -0.8 * f, 1e-12);
  const double p = 1.5 * f;
  const RecordingObserver slid = pushed(p);
  EXPECT_NEAR(slid.Last("guide.speed"), (p - f) / kMass, 1e-12);
  EXPECT_NEAR(slid.Last("guide.slide"), (p - f) / (2 * kMass), 1e-9);
  EXPECT_NEAR(slid.Last("guide.F.x"), -f, 1e-12);
  EXPECT_LT(std::abs(slid.Last("energy.residual")), 1e-9);
}

TEST(PrismaticSwitches, OtherJointsAreRefusedAndTheStopsAreInMetres) {
  const std::string spherical = std::string("model: m\nbodies:\n  ") + kSlider +
                                "}\njoints:\n  ball: {type: spherical, child: slider, rigid: true, limits: {lower: -0.1, upper: 0.1}}\n";
  std::vector<Diagnostic> d = testing::LoadErrors(spherical);
  ASSERT_EQ(d.size(), 1u);
  EXPECT_EQ(d[0].code, "event.unsupported");
  EXPECT_EQ(d[0].element, "ball");
  EXPECT_EQ(d[0].where.line, 5);
  EXPECT_NE(d[0].message.find("a revolute or prismatic joint's free axis"), std::string::npos) << d[0].message;
  EXPECT_NE(d[0].hint.find("type: prismatic"), std::string::npos) << d[0].hint;

  d = testing::LoadErrors(SliderModel(true, 0.0, "limits: {lower: 0, upper: 0.3}"));
  ASSERT_EQ(d.size(), 1u);
  EXPECT_EQ(d[0].code, "param.range");
  EXPECT_EQ(d[0].element, "guide");
  EXPECT_NE(d[0].message.find("lower < 0 < upper (got 0 and 0.3), in m from it"), std::string::npos) << d[0].message;
  EXPECT_NE(d[0].hint.find("in m along the axis"), std::string::npos) << d[0].hint;

  d = testing::LoadErrors(SliderModel(true, 0.0, "friction: -1"));
  ASSERT_EQ(d.size(), 1u);
  EXPECT_EQ(d[0].code, "param.range");
  EXPECT_NE(d[0].message.find("a friction force [N] must be >= 0 (got -1)"), std::string::npos) << d[0].message;

  d = testing::LoadErrors(SliderModel(true, 0.0, "limits: {upper: 0.3}"));
  ASSERT_EQ(d.size(), 1u);
  EXPECT_NE(d[0].message.find("'lower' and 'upper' (m, from the assembled position)"), std::string::npos) << d[0].message;
}

TEST(SliderStopsExample, StrikesReboundsAndLocksWhereItsClosedFormsSay) {
  // examples/mechanisms/slider_stops.yaml (its header): a = F / m, v1 = sqrt(v0^2 - 2 a L).
  const double v0 = 2.0, f = 3.0, L = 0.5, e = 0.5, g = 9.81, a = f / kMass;
  const RecordingObserver rec = testing::RunExample("mechanisms/slider_stops.yaml");
  const double v1 = std::sqrt(v0 * v0 - 2 * a * L), t1 = (v0 - v1) / a, t2 = t1 + e * v1 / a;
  ASSERT_EQ(rec.events().size(), 3u);
  EXPECT_EQ(rec.events()[0].kind, "limit");
  EXPECT_EQ(rec.events()[0].element, "guide.upper");
  EXPECT_NEAR(rec.events()[0].time, t1, 1e-10);
  // The rebound reverses the friction's slip at the same instant (no zero crossing to find).
  EXPECT_EQ(rec.events()[1].kind, "slip");
  EXPECT_EQ(rec.events()[1].element, "guide.friction");
  EXPECT_EQ(rec.events()[1].time, rec.events()[0].time);
  EXPECT_EQ(rec.events()[2].kind, "lock");
  EXPECT_NEAR(rec.events()[2].time, t2, 1e-9);
  EXPECT_NEAR(rec.At("guide.speed", 0.5), -e * v1 + a * (0.5 - t1), 1e-9);  // decelerating on the way back
  EXPECT_NEAR(rec.Last("guide.slide"), L - (e * v1) * (e * v1) / (2 * a), 1e-9);
  EXPECT_EQ(rec.Last("guide.speed"), 0.0);
  EXPECT_NEAR(rec.Last("guide.upper.dissipated"), 0.5 * kMass * v1 * v1 * (1 - e * e), 1e-9);
  EXPECT_NEAR(rec.Last("guide.friction.dissipated"), f * (L + (e * v1) * (e * v1) / (2 * a)), 1e-8);
  EXPECT_NEAR(rec.Last("energy.dissipated"), 0.5 * kMass * v0 * v0, 1e-8);
  EXPECT_NEAR(rec.Last("guide.F.z"), kMass * g, 1e-9);
  EXPECT_LT(std::abs(rec.Last("energy.residual")), 1e-9);
}

}  // namespace
}  // namespace multibond
