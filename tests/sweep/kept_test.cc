// Kept quantities: expressions over result rows and their reductions, against closed forms.

#include "multibond/sweep/kept.h"

#include <cmath>

#include <gtest/gtest.h>

#include "multibond/core/diagnostic_codes.h"

namespace multibond::sweep {
namespace {

Keep K(const std::string& name, Keep::Take take, const std::string& of) {
  Keep k;
  k.name = name;
  k.take = take;
  k.of = of;
  k.expression = {"s.yaml", 4, 10};
  return k;
}

/// Feeds y = sin(t) * scale over [0, T] at `n` intervals into the observer.
void Feed(KeptObserver& o, double T, int n) {
  o.Reset();
  o.OnStart({{"time", "s"}, {"y", "m"}});
  for (int i = 0; i <= n; ++i) {
    const double t = T * i / n;
    o.OnSample({t, std::sin(t)});
  }
  o.OnFinish({});
}

TEST(Kept, ReductionsOfASine) {
  const std::vector<Keep> keep = {K("last", Keep::Take::kFinal, "y"),      K("peak", Keep::Take::kMax, "2*y"),
                                  K("low", Keep::Take::kMin, "y"),          K("mean", Keep::Take::kMean, "y"),
                                  K("rms", Keep::Take::kRms, "y"),          K("cross", Keep::Take::kCrossingTime, "y + 0*t"),
                                  K("event", Keep::Take::kEventTime, "impact")};
  Keep cross = keep[5];
  DiagnosticSink sink;
  std::vector<Keep> all = keep;
  all[5].level = 0.5;
  KeptQuantities q(all, {"time", "y"}, {"time", "y"}, sink);
  ASSERT_FALSE(sink.has_errors());
  KeptObserver o(q);
  const double T = 2 * M_PI;
  Feed(o, T, 20000);
  const auto v = o.Values();
  EXPECT_NEAR(v[0], 0.0, 1e-15);
  EXPECT_NEAR(v[1], 2.0, 1e-7);             // sampled peak of 2 sin
  EXPECT_NEAR(v[2], -1.0, 1e-7);
  EXPECT_NEAR(v[3], 0.0, 1e-12);            // the mean over a period
  EXPECT_NEAR(v[4], 1 / std::sqrt(2.0), 1e-7);  // the RMS of a sine
  EXPECT_NEAR(v[5], M_PI / 6, 1e-7);         // sin t = 0.5 first at pi/6
  EXPECT_TRUE(std::isnan(v[6]));             // no event
  o.OnEvent({1.25, "impact", "ball", "", false, true});
  o.OnEvent({2.5, "impact", "ball", "", false, true});
  EXPECT_EQ(o.Values()[6], 1.25);            // the first
  // A new run starts from nothing.
  o.Reset();
  EXPECT_TRUE(std::isnan(o.Values()[6]));
}

TEST(Kept, AWindowTakesTheSamplesAndEventsInIt) {
  // #43: a response that starts at its maximum (a spring released from x0) has its maximum at
  // t = 0; over a window after the release the maximum is its later peak. x = x0 e^(-s t) (cos
  // wd t + s/wd sin wd t) has its extrema at t = k pi / wd, x0 e^(-s k pi / wd) (-1)^k: the
  // maximum over [0.5 T, 1.5 T] (T = 2 pi / wd) is the one at T.
  const double s = 0.5, wd = 2 * M_PI, T = 1.0;
  std::vector<Keep> keep = {K("peak", Keep::Take::kMax, "y"), K("whole", Keep::Take::kMax, "y"), K("low", Keep::Take::kMin, "y"),
                            K("mean", Keep::Take::kMean, "t"), K("last", Keep::Take::kFinal, "t"), K("cross", Keep::Take::kCrossingTime, "y"),
                            K("event", Keep::Take::kEventTime, "impact"), K("none", Keep::Take::kMax, "y")};
  for (size_t k : {0u, 2u, 3u, 4u, 5u, 6u}) keep[k].from = 0.5 * T, keep[k].to = 1.5 * T;
  keep[5].level = 0.0;
  keep[7].from = 20.0;  // after the run's end: no sample
  DiagnosticSink sink;
  KeptQuantities q(keep, {"time", "y"}, {"time", "y"}, sink);
  ASSERT_FALSE(sink.has_errors());
  KeptObserver o(q);
  o.OnStart({{"time", "s"}, {"y", "m"}});
  o.OnEvent({0.25, "impact", "ball", "", false, true});  // before the window
  for (int i = 0; i <= 20000; ++i) {
    const double t = 10.0 * i / 20000;
    o.OnSample({t, std::exp(-s * t) * (std::cos(wd * t) + s / wd * std::sin(wd * t))});
    if (i == 12000) o.OnEvent({t, "impact", "ball", "", false, true});  // t = 6: after it
    if (i == 2000) o.OnEvent({t, "impact", "ball", "", false, true});   // t = 1: in it
  }
  const auto v = o.Values();
  EXPECT_NEAR(v[0], std::exp(-s * T), 1e-6);        // the peak at T, not the release
  EXPECT_EQ(v[1], 1.0);                             // over the whole run: the release
  EXPECT_NEAR(v[2], -std::exp(-s * T / 2), 1e-6);   // the trough at T/2, the window's first sample
  EXPECT_NEAR(v[3], T, 1e-12);                      // the mean of t over [T/2, 3T/2]
  EXPECT_EQ(v[4], 1.5 * T);                         // the window's last sample
  // The zeros of x: tan(wd t) = -wd/s, t = (pi - atan(wd/s))/wd + k T/2; the first in the window is k = 1.
  EXPECT_NEAR(v[5], (M_PI - std::atan(wd / s)) / wd + 0.5 * T, 1e-6);
  EXPECT_EQ(v[6], 1.0);                             // the event in the window
  EXPECT_TRUE(std::isnan(v[7]));                    // no sample in its window
}

TEST(Kept, SettlingTimeOfADecayingExponential) {
  // y = 1 - exp(-t): within 2% of its final value (~1) once exp(-t) < 0.02 (t = ln 50).
  std::vector<double> t, y;
  for (int i = 0; i <= 20000; ++i) {
    t.push_back(20.0 * i / 20000);
    y.push_back(1 - std::exp(-t.back()));
  }
  const double band = 0.02 * y.back();
  EXPECT_NEAR(SettlingTime(t, y, 0.02), -std::log(band + std::exp(-20.0)), 1e-6);
  // Never outside the band: settled from the start.
  EXPECT_EQ(SettlingTime({0, 1, 2}, {1, 1, 1}, 0.02), 0.0);
}

TEST(Kept, AnUnknownColumnIsLocatedWithADidYouMean) {
  DiagnosticSink sink;
  KeptQuantities q({K("x", Keep::Take::kMax, "2*spring.qq")}, {"time", "spring.q"}, {"time", "spring.q", "spring.e"}, sink);
  ASSERT_EQ(sink.diagnostics().size(), 1u);
  const Diagnostic& d = sink.diagnostics()[0];
  EXPECT_EQ(d.code, codes::kSweepKeep);
  EXPECT_EQ(d.where.line, 4);
  EXPECT_EQ(d.where.column, 12);  // the expression at column 10, the name at its offset 2
  EXPECT_EQ(d.hint, "did you mean 'spring.q'?");
}

TEST(Kept, AVariableBeyondTheDefaultColumnsAsksForAllVariables) {
  DiagnosticSink sink;
  KeptQuantities q({K("f", Keep::Take::kMax, "spring.e")}, {"time", "spring.q"}, {"time", "spring.q", "spring.e"}, sink);
  EXPECT_FALSE(sink.has_errors());
  EXPECT_TRUE(q.needs_all_variables());
  EXPECT_EQ(q.columns().size(), 3u);
}

}  // namespace
}  // namespace multibond::sweep
