// The kinks and switches of formulas as events (compile/kinks.h; docs/events.md, "Kinks and
// switches in formulas"), on the examples written the way other tools' users write them, each
// against its closed form under every solver with default options: a force pulse of time that
// BDF stepped over, a step that falls one rounding from an output time, a table with a corner at
// every output time, a one-sided spring whose contact is a kink of the state.

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>
#include <string>
#include <vector>

#include "multibond/compile/compiled_model.h"
#include "multibond/core/time_function.h"
#include "multibond/io/model_loader.h"
#include "multibond/sim/simulator.h"

namespace multibond {
namespace {

struct Run {
  std::shared_ptr<const CompiledModel> model;
  RecordingObserver rec;
  RunSummary summary;
};

/// The model run as `multibond run --solver solver` would, with the file's end time and output
/// interval and nothing else (rk4, which needs a step, with `--step step`).
std::unique_ptr<Run> RunWithDefaults(const LoadedModel& lm, const std::string& solver, double step = 0.0) {
  auto run = std::make_unique<Run>();
  run->model = CompiledModel::Compile(lm.graph, lm.compile);
  RunOptions o;  // IntegratorOptions' defaults are the command line's (rtol 1e-8, atol 1e-10)
  o.t_end = lm.simulation.t_end.value();
  o.dt = lm.simulation.dt.value();
  o.integrator.method = ParseMethod(solver);
  o.integrator.fixed_step = step;
  if (lm.simulation.rtol) o.integrator.rtol = *lm.simulation.rtol;
  if (lm.simulation.atol) o.integrator.atol = *lm.simulation.atol;
  run->summary = Simulate(*run->model, o, run->rec);
  return run;
}

std::unique_ptr<Run> RunExample(const std::string& file, const std::string& solver, double step = 0.0) {
  return RunWithDefaults(LoadModelFile(std::string(MULTIBOND_SOURCE_DIR) + "/examples/" + file), solver, step);
}

std::vector<EventRecord> OfKind(const RecordingObserver& rec, const std::string& kind) {
  std::vector<EventRecord> out;
  for (const EventRecord& e : rec.events())
    if (e.kind == kind) out.push_back(e);
  return out;
}

class EverySolver : public ::testing::TestWithParam<const char*> {
 protected:
  std::string solver() const { return GetParam(); }
  double step() const { return solver() == "rk4" ? 0.01 : 0.0; }  // rk4 needs one
};

INSTANTIATE_TEST_SUITE_P(Solvers, EverySolver, ::testing::Values("bdf", "adams", "dopri5", "bs3", "srk3", "rk4"));

TEST_P(EverySolver, AForcePulseOfTimeIsNeverSteppedOver) {
  const auto run = RunExample("events/force_pulse.yaml", solver(), step());
  ASSERT_EQ(run->summary.status, RunStatus::kOk) << run->summary.message;
  // The impulse 1 N s, and the position of a mass given 1 N s at the pulse's centre, 1.05 s. The
  // explicit methods meet it to 1e-9 at the default rtol of 1e-8; BDF and Adams, restarting at
  // order 1 on each of the four kinks, to their tolerance (1.2e-8 and 4.0e-9 measured), and to
  // 1e-9 from rtol 1e-10 (ThePulseToANanoUnderBdfAndAdams below).
  const bool implicit = solver() == "bdf" || solver() == "adams";
  EXPECT_NEAR(run->rec.Last("mass.p"), 1.0, implicit ? 2e-8 : 1e-9);
  EXPECT_NEAR(run->rec.Last("x"), 5.0 - 1.05, implicit ? 1e-7 : 1e-8);
  EXPECT_NEAR(run->rec.At("mass.p", 1.0), 0.05 + 0.4, implicit ? 2e-8 : 1e-9);  // on the plateau: 0.05 + (t - 0.6)
  // The four kinks, each a time event at its exact time.
  const std::vector<EventRecord> kinks = OfKind(run->rec, "kink");
  ASSERT_EQ(kinks.size(), 4u);
  const double at[] = {0.5, 0.6, 1.5, 1.6};
  for (size_t k = 0; k < 4; ++k) {
    EXPECT_NEAR(kinks[k].time, at[k], 1e-15 * 4) << k;
    EXPECT_EQ(kinks[k].element, "push");
    EXPECT_NE(kinks[k].description.find("clamp((t - "), std::string::npos) << kinks[k].description;
  }
  EXPECT_LT(std::abs(run->summary.energy_residual), 2e-8);  // the tolerance's level
}

TEST_P(EverySolver, ARectangularPulseWrittenWithComparisonsIsExact) {
  // 1 N from 0.5 s to 1.5 s, as a user of `if` writes it: the comparisons' time events at 0.5 and
  // 1.5 s, the force constant between them, so every solver integrates it to rounding.
  const auto run = RunWithDefaults(LoadModelString(R"yaml(model: rectangle
domain: translation
elements:
  push: {type: Se, effort: "if(t >= 0.5 and t < 1.5, 1, 0)"}
  v:    {type: "1"}
  mass: {type: I, inertia: 1.0}
bonds: [push -> v, v -> mass]
simulation: {t_end: 3, dt: 0.1}
)yaml"), solver(), step());
  ASSERT_EQ(run->summary.status, RunStatus::kOk) << run->summary.message;
  EXPECT_NEAR(run->rec.Last("mass.p"), 1.0, 1e-12);
  EXPECT_NEAR(run->rec.At("mass.p", 1.0), 0.5, 1e-12);
  const std::vector<EventRecord> kinks = OfKind(run->rec, "kink");
  ASSERT_EQ(kinks.size(), 2u);
  EXPECT_EQ(kinks[0].time, 0.5);
  EXPECT_EQ(kinks[1].time, 1.5);
}

TEST(FormulaEvents, TwoKinksOfOneElementThatChangeTogetherAreOneEvent) {
  // abs(t - 0.5) and max(t - 0.5, 0): two switching functions, written differently, one restart.
  const auto run = RunWithDefaults(LoadModelString(R"yaml(model: together
domain: translation
elements:
  push: {type: Se, effort: "abs(t - 0.5) + max(t - 0.5, 0)"}
  v:    {type: "1"}
  mass: {type: I, inertia: 1.0}
bonds: [push -> v, v -> mass]
simulation: {t_end: 1, dt: 0.1}
)yaml"), "bdf");
  ASSERT_EQ(run->summary.status, RunStatus::kOk) << run->summary.message;
  ASSERT_EQ(OfKind(run->rec, "kink").size(), 1u);
  EXPECT_EQ(OfKind(run->rec, "kink")[0].time, 0.5);
  // p = (t - 0.5)^2 / 2 + ... : 0.125 + 0.125 + 0.125 at t = 1 (abs: 0.125 before and after, max: 0.125).
  EXPECT_NEAR(run->rec.Last("mass.p"), 0.375, 1e-8);
}

TEST(FormulaEvents, ThePulseToANanoUnderBdfAndAdams) {
  for (const char* solver : {"bdf", "adams"}) {
    LoadedModel lm = LoadModelFile(std::string(MULTIBOND_SOURCE_DIR) + "/examples/events/force_pulse.yaml");
    lm.simulation.rtol = 1e-10;
    lm.simulation.atol = 1e-12;
    const auto run = RunWithDefaults(lm, solver);
    ASSERT_EQ(run->summary.status, RunStatus::kOk) << run->summary.message;
    EXPECT_NEAR(run->rec.Last("mass.p"), 1.0, 1e-9) << solver;
    EXPECT_LT(std::abs(run->summary.energy_residual), 1e-9) << solver;
  }
}

TEST_P(EverySolver, AStepOneRoundingFromAnOutputTimeRunsToTheEnd) {
  const auto run = RunExample("events/step_at_output_time.yaml", solver(), step());
  ASSERT_EQ(run->summary.status, RunStatus::kOk) << run->summary.message;
  EXPECT_EQ(run->summary.t_reached, 1.0);
  ASSERT_EQ(OfKind(run->rec, "time").size(), 1u);
  EXPECT_EQ(OfKind(run->rec, "time")[0].time, 0.3);
  // u_C = 1 - exp(-(t - 0.3)/RC), RC = 0.1 s (rk4 at 0.01 s: its own error, 6e-9 here).
  const double tol = 2e-8;
  EXPECT_NEAR(run->rec.Last("u_C"), 1.0 - std::exp(-7.0), tol);
  EXPECT_EQ(run->rec.At("u_C", 0.2), 0.0);
}

TEST_P(EverySolver, ATableWithACornerAtEveryOutputTimeRunsToTheEnd) {
  // A flow of 1, 0, 1, 0, ... switched by corners at every output time k/10 (written as decimals,
  // so that each is one rounding from k * 0.1 for many k), into an integral: its area exactly.
  std::string rows = "[0, 0]";
  double area = 0.0;
  for (int k = 1; k <= 20; ++k) {
    const double v = k % 2;
    rows += fmt::format(", [{}, {}]", k / 10.0, v);
    area += 0.05 * (v + (k - 1) % 2);  // trapezoids of 0.1 s
  }
  const std::string yaml = fmt::format(R"yaml(model: corners
domain: electrical
elements:
  feed: {{type: Sf, flow: {{table: [{}]}}}}
  node: {{type: "0"}}
  store: {{type: C, compliance: 1.0}}
bonds: [feed -> node, node -> store]
simulation: {{t_end: 2, dt: 0.1}}
)yaml", rows);
  const auto run = RunWithDefaults(LoadModelString(yaml), solver(), step() > 0 ? 0.1 : 0.0);
  ASSERT_EQ(run->summary.status, RunStatus::kOk) << run->summary.message;
  EXPECT_EQ(run->summary.t_reached, 2.0);
  EXPECT_NEAR(run->rec.Last("store.q"), area, 20 * 1e-8);  // rtol 1e-8 on each of 20 segments (6e-8 at worst, srk3)
  EXPECT_EQ(OfKind(run->rec, "time").size(), 19u);  // the corners inside (0, 2)
}

/// An effort source into a series L = 1 H, R = 1 Ohm, its value replaced by `table` after loading
/// (a million rows from the test, not 27 MB of model text).
LoadedModel SeriesRlDrivenBy(const TimeFunction& table, double t_end, double dt) {
  LoadedModel lm = LoadModelString(fmt::format(R"yaml(model: dense_table
domain: electrical
elements:
  src: {{type: Se, effort: {{table: [[0, 0], [1, 1]]}}}}
  L:   {{type: I, inertia: 1.0}}
  R:   {{type: R, resistance: 1.0}}
  j:   {{type: "1"}}
bonds: [src -> j, j -> L, j -> R]
simulation: {{t_end: {}, dt: {}}}
)yaml", t_end, dt));
  lm.graph.element(lm.graph.Find("src")).source.components = {table};
  return lm;
}

TEST_P(EverySolver, ADenseTableOfASineRunsAsTheSineWithAFewRestartsPerBend) {
  // sin(2 pi t) sampled a million times over 10 s (a row every 1e-5 s, a thousand per output
  // interval). i' = sin(w t) - i: i = (sin(w t) - w cos(w t) + w e^-t) / (1 + w^2). A restart at
  // each row was an event storm at t = 1 s, and a restart at each of the thousand vertices a
  // period left BDF 1.25e-6 from the closed form (each restart starts again at first order);
  // restarts at its turning points only: 1.35e-8, as the sine itself (2.4e-8).
  constexpr int n = 1000001;
  constexpr double w = 2 * std::numbers::pi;
  std::vector<double> t(n), v(n);
  for (int i = 0; i < n; ++i) t[i] = 10.0 * i / (n - 1), v[i] = std::sin(w * t[i]);
  const auto run = RunWithDefaults(SeriesRlDrivenBy(TimeFunction::Table(t, v), 10.0, 0.01), solver(), step());
  ASSERT_EQ(run->summary.status, RunStatus::kOk) << run->summary.message;
  const size_t restarts = OfKind(run->rec, "time").size();
  EXPECT_GE(restarts, 20u);   // two turning points a period
  EXPECT_LE(restarts, 100u);
  for (double at : {0.25, 2.5, 7.3, 10.0}) {
    const double closed = (std::sin(w * at) - w * std::cos(w * at) + w * std::exp(-at)) / (1 + w * w);
    // The table is the sine to (w h)^2 / 8 = 5e-9.
    EXPECT_NEAR(run->rec.At("L.p", at), closed, 5e-8) << at;
  }
  // Work in = stored + dissipated through every restart.
  EXPECT_LT(std::abs(run->rec.Last("energy.residual")), 1e-4);
}

TEST_P(EverySolver, AJaggedTablesRestartsAreNoEventStorm) {
  // 20,000 rows of noise over 1 s: nearly every row a sharp corner, 17,768 restarts, above the storm
  // limit (10,000 a second) that guards events the motion triggers; a table's corners are known
  // before the run and cannot chatter. i' = u - i with u linear on each row's interval is exact:
  // i(t0 + h) = u0 - s + s h + (i0 - u0 + s) e^-h.
  constexpr int n = 20001;
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> noise(-1.0, 1.0);
  std::vector<double> t(n), v(n);
  for (int i = 0; i < n; ++i) t[i] = i / double(n - 1), v[i] = noise(rng);
  double exact = 0.0;
  for (int i = 0; i + 1 < n; ++i) {
    const double h = t[i + 1] - t[i], s = (v[i + 1] - v[i]) / h;
    exact = v[i] - s + s * h + (exact - v[i] + s) * std::exp(-h);
  }
  const auto run = RunWithDefaults(SeriesRlDrivenBy(TimeFunction::Table(t, v), 1.0, 0.01), solver(), step() > 0 ? 5e-5 : 0.0);
  ASSERT_EQ(run->summary.status, RunStatus::kOk) << run->summary.message;
  EXPECT_GT(OfKind(run->rec, "time").size(), 15000u);  // 17,768: a turn between two rows of similar slope is gentle
  EXPECT_NEAR(run->rec.Last("L.p"), exact, 1e-7);
}

TEST_P(EverySolver, APulseInADenseTableIsNeverSteppedOver) {
  // 10 s of zeros a row every 1e-4 s but for a trapezoid of 1 s of height 1 (ramps of 0.01 s)
  // at t = 5: the charge through the circuit from rest is the impulse's response; without the
  // corners as events BDF grows its step over the zeros and can step over the pulse.
  constexpr int n = 100001;
  std::vector<double> t(n), v(n, 0.0);
  double area = 0.0;
  for (int i = 0; i < n; ++i) {
    t[i] = 1e-4 * i;
    v[i] = std::clamp((t[i] - 5.0) / 0.01, 0.0, 1.0) - std::clamp((t[i] - 6.0) / 0.01, 0.0, 1.0);
  }
  for (int i = 1; i < n; ++i) area += 0.5 * (v[i] + v[i - 1]) * (t[i] - t[i - 1]);
  const auto run = RunWithDefaults(SeriesRlDrivenBy(TimeFunction::Table(t, v), 10.0, 0.5), solver(), solver() == "rk4" ? 1e-3 : 0.0);
  ASSERT_EQ(run->summary.status, RunStatus::kOk) << run->summary.message;
  // i' = u - i, so the charge q = integral of i satisfies q(10) = area - i(10) exactly, and i
  // decays from the pulse's end as e^-(t - 6.01) (1 - e^-1) to first order in the ramps.
  EXPECT_NEAR(area, 1.0, 1e-9);
  const double i_end = run->rec.Last("L.p");
  EXPECT_NEAR(i_end, (1 - std::exp(-1.0)) * std::exp(-(10.0 - 6.0)), 2e-3);
  EXPECT_NEAR(run->rec.Last("R.dissipated") + run->rec.Last("L.energy"), run->rec.Last("src.work"), 1e-7);
  EXPECT_GE(OfKind(run->rec, "time").size(), 4u);
}

/// A 1 kg mass at 1 m/s, 0.1 m from a one-sided spring of 100 N/m whose effort law is `law`: it
/// touches at 0.1 s and leaves after half a period, pi/10 s, at -1 m/s.
std::unique_ptr<Run> RunOneSidedSpring(const std::string& law, const std::string& solver, double step) {
  return RunWithDefaults(LoadModelString(fmt::format(R"yaml(model: one_sided
domain: translation
elements:
  v:      {{type: "1"}}
  mass:   {{type: I, inertia: 1.0, p0: 1.0}}
  spring: {{type: C, effort: "{}", q0: -0.1}}
bonds: [v -> mass, v -> spring]
simulation: {{t_end: 1, dt: 0.01}}
)yaml", law)), solver, step);
}

TEST_P(EverySolver, AOneSidedSpringsContactIsAKinkOfTheState) {
  for (const char* law : {"100*max(q, 0)", "if(q > 0, 100*q, 0)"}) {
    SCOPED_TRACE(law);
    const auto run = RunOneSidedSpring(law, solver(), step() > 0 ? 1e-4 : 0.0);
    ASSERT_EQ(run->summary.status, RunStatus::kOk) << run->summary.message;
    const std::vector<EventRecord> kinks = OfKind(run->rec, "kink");
    ASSERT_EQ(kinks.size(), 2u);
    const double tol = solver() == "rk4" ? 1e-6 : 1e-5;
    EXPECT_NEAR(kinks[0].time, 0.1, tol);
    EXPECT_NEAR(kinks[1].time, 0.1 + std::numbers::pi / 10, tol);
    EXPECT_EQ(kinks[0].element, "spring");
    EXPECT_NEAR(run->rec.Last("mass.p"), -1.0, 1e-6);
    EXPECT_NEAR(run->rec.Last("spring.q"), -(1.0 - 0.1 - std::numbers::pi / 10), 1e-5);
    // A conservative motion: BDF's numerical damping at the default rtol 1e-8 (3.1e-7 measured;
    // 1.3e-9 at rtol 1e-10).
    EXPECT_LT(std::abs(run->summary.energy_residual), 1e-6);
  }
}

TEST_P(EverySolver, ASwitchedSourceSlidesOnItsSurface) {
  // BondGraphTools' switched source: e = 1 - sign(q - 1) into R = 1, C = 1: q = 2 (1 - exp(-t))
  // until q = 1 at ln 2, then held there by the sign's equivalent value 0 (e = q = 1 V).
  const auto run = RunExample("events/switched_source.yaml", solver(), step() > 0 ? 1e-3 : 0.0);
  ASSERT_EQ(run->summary.status, RunStatus::kOk) << run->summary.message;
  const std::vector<EventRecord> slides = OfKind(run->rec, "slide");
  ASSERT_EQ(slides.size(), 1u);
  EXPECT_NEAR(slides[0].time, std::log(2.0), solver() == "rk4" ? 1e-9 : 1e-7);
  EXPECT_EQ(slides[0].element, "source");
  EXPECT_TRUE(OfKind(run->rec, "kink").empty());
  EXPECT_TRUE(OfKind(run->rec, "leave").empty());
  EXPECT_NEAR(run->rec.At("C.q", 0.5), 2.0 * (1.0 - std::exp(-0.5)), 1e-7);
  for (const double t : {1.0, 2.0, 3.0}) {
    EXPECT_NEAR(run->rec.At("C.q", t), 1.0, 1e-7) << t;
    EXPECT_NEAR(run->rec.At("source_voltage", t), 1.0, 1e-7) << t;
  }
  // Held on the surface, the solvers step at their pace: 66 steps under BDF, 31 under dopri5
  // (rk4: its 3,000 fixed steps).
  EXPECT_LT(run->summary.stats.steps, solver() == "rk4" ? 3010 : 500);
  EXPECT_LT(std::abs(run->summary.energy_residual), 1e-7);
}

TEST_P(EverySolver, ASlidingSourceLeavesWhereItsEquivalentValueLeavesItsRange) {
  // The same source charging C through R with a drain d = 0.5 t out of the capacitor's node:
  // q' = e - q - d. Held at q = 1 the source must give e = 1 + d, the sign -d: it leaves at
  // d = 1, t = 2 s, and the charge falls: q' = 2 - q - d from q(2) = 1.
  const auto run = RunWithDefaults(LoadModelString(R"yaml(model: sliding_leaves
domain: electrical
elements:
  source: {type: Se, effort: "1 - sign(C.q - 1)"}
  R:      {type: R, resistance: 1.0}
  node:   {type: "0"}
  C:      {type: C, compliance: 1.0}
  drain:  {type: Sf, flow: {ramp: {slope: 0.5}}}
  loop:   {type: "1"}
bonds: [source -> loop, loop -> R, loop -> node, node -> C, node -> drain]
simulation: {t_end: 3, dt: 0.01}
)yaml"), solver(), step() > 0 ? 1e-3 : 0.0);
  ASSERT_EQ(run->summary.status, RunStatus::kOk) << run->summary.message;
  const std::vector<EventRecord> slides = OfKind(run->rec, "slide"), leaves = OfKind(run->rec, "leave");
  ASSERT_EQ(slides.size(), 1u);
  ASSERT_EQ(leaves.size(), 1u);
  // Until it slides: q = 2.5 - 0.5 t - 2.5 exp(-t), q = 1 at t1.
  auto q_before = [](double t) { return 2.5 - 0.5 * t - 2.5 * std::exp(-t); };
  double lo = 0.0, hi = 2.0;
  for (int i = 0; i < 200; ++i) (q_before(0.5 * (lo + hi)) < 1.0 ? lo : hi) = 0.5 * (lo + hi);
  EXPECT_NEAR(slides[0].time, lo, 1e-6);
  EXPECT_NEAR(leaves[0].time, 2.0, 1e-6);
  EXPECT_NEAR(run->rec.At("C.q", 1.5), 1.0, 1e-7);
  // After: q' + q = 2 - 0.5 t from q(2) = 1: q = 2.5 - 0.5 t + c exp(-(t - 2)), c = -0.5.
  EXPECT_NEAR(run->rec.Last("C.q"), 2.5 - 1.5 - 0.5 * std::exp(-1.0), 1e-6);
  EXPECT_LT(std::abs(run->summary.energy_residual), 1e-7);
}

}  // namespace
}  // namespace multibond
