// A table's vertices (where no integration step crosses): every corner of a coarse table, the
// sharp ones of a dense table, a few per bend of a finely sampled smooth curve, between two of
// which the table stays within the stated tolerance of a straight line; and which of them
// restart the integration (the sharp turns) and which only end a step (the gentle ones).

#include "multibond/core/time_function.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>
#include <vector>

#include <gtest/gtest.h>

namespace multibond {
namespace {

// Every vertex of a table, sharp (a restart) or gentle (a waypoint), ascending.
std::vector<double> Vertices(const TimeFunction& f) {
  const TimeFunction::Corners c = f.TableCorners();
  std::vector<double> out = c.restarts;
  out.insert(out.end(), c.waypoints.begin(), c.waypoints.end());
  std::sort(out.begin(), out.end());
  EXPECT_EQ(f.Breakpoints(), c.restarts);
  EXPECT_EQ(f.Waypoints(), c.waypoints);
  return out;
}

TimeFunction Sampled(int n, double t_end, double (*f)(double)) {
  std::vector<double> t(n), v(n);
  for (int i = 0; i < n; ++i) {
    t[i] = t_end * i / (n - 1);
    v[i] = f(t[i]);
  }
  return TimeFunction::Table(t, v);
}

// Between two corners the table stays within `tolerance` of a straight line from the first
// (some slope fits every row up to the second), so within twice it of their chord; every corner
// is a row of the table.
void ExpectWithinToleranceOfALine(const TimeFunction& f, const std::vector<double>& corners, double tolerance) {
  ASSERT_GE(corners.size(), 2u);
  EXPECT_EQ(corners.front(), f.table_t.front());
  EXPECT_EQ(corners.back(), f.table_t.back());
  EXPECT_TRUE(std::is_sorted(corners.begin(), corners.end()));
  const std::vector<double>& t = f.table_t;
  const std::vector<double>& v = f.table_v;
  double worst_chord = 0.0;
  size_t a = 0;
  for (size_t c = 1; c < corners.size(); ++c) {
    const size_t b = std::lower_bound(t.begin(), t.end(), corners[c]) - t.begin();
    ASSERT_LT(b, t.size());
    ASSERT_EQ(t[b], corners[c]);
    double lo = -HUGE_VAL, hi = HUGE_VAL;
    for (size_t i = a + 1; i <= b; ++i) {
      lo = std::max(lo, (v[i] - tolerance - v[a]) / (t[i] - t[a]));
      hi = std::min(hi, (v[i] + tolerance - v[a]) / (t[i] - t[a]));
      const double chord = v[a] + (v[b] - v[a]) * (t[i] - t[a]) / (t[b] - t[a]);
      worst_chord = std::max(worst_chord, std::abs(v[i] - chord));
    }
    EXPECT_LE(lo, hi + 1e-12 * std::abs(hi)) << "no line within the tolerance from t = " << t[a] << " to " << t[b];
    a = b;
  }
  EXPECT_LE(worst_chord, 2 * tolerance * (1 + 1e-9));
}

TEST(TimeFunction, ACoarseTableRestartsAtEveryCorner) {
  const TimeFunction f = TimeFunction::Table({0, 0.5, 1.0, 1.5}, {0, 2.0, 2.0, 0});
  EXPECT_EQ(f.Breakpoints(), (std::vector<double>{0, 0.5, 1.0, 1.5}));
  EXPECT_TRUE(f.Waypoints().empty());
}

TEST(TimeFunction, AConstantTableNeverRestartsAndAStraightOneOnlyAtItsEnds) {
  const TimeFunction flat = TimeFunction::Table({0, 1, 2, 3, 4}, {3, 3, 3, 3, 3});
  EXPECT_TRUE(flat.Breakpoints().empty());
  EXPECT_EQ(Vertices(flat), (std::vector<double>{0, 4}));
  const TimeFunction line = Sampled(100001, 10.0, [](double t) { return 2.0 - 0.3 * t; });
  EXPECT_EQ(line.Breakpoints(), (std::vector<double>{0, 10.0}));
  EXPECT_TRUE(line.Waypoints().empty());
}

TEST(TimeFunction, ADenseSmoothTableHasAFewVerticesPerBendAndRestartsOnlyWhereItTurns) {
  // A sine sampled a million times over one period: about a thousand vertices (the chord of a
  // segment of length h sags by h^2 |v''| / 8, so h ~ sqrt(8 tol / (2 pi)^2)), however fine;
  // restarts only near its two turning points (where the slope changes sign), and at its ends.
  const auto sine = [](double t) { return std::sin(2 * std::numbers::pi * t); };
  const TimeFunction f = Sampled(1000001, 1.0, sine);
  const std::vector<double> vertices = Vertices(f);
  EXPECT_GT(vertices.size(), 300u);
  EXPECT_LT(vertices.size(), 3000u);
  ExpectWithinToleranceOfALine(f, vertices, TimeFunction::kTableCornerTolerance * 2.0);
  const std::vector<double> restarts = f.Breakpoints();
  EXPECT_GE(restarts.size(), 3u);
  EXPECT_LE(restarts.size(), 2u + 2 * 4);
  EXPECT_EQ(restarts.front(), 0.0);
  EXPECT_EQ(restarts.back(), 1.0);
  for (size_t k = 1; k + 1 < restarts.size(); ++k)
    EXPECT_LT(std::min(std::abs(restarts[k] - 0.25), std::abs(restarts[k] - 0.75)), 0.01) << restarts[k];
  const TimeFunction coarser = Sampled(10001, 1.0, sine);
  EXPECT_NEAR(static_cast<double>(Vertices(coarser).size()), static_cast<double>(vertices.size()), 0.1 * vertices.size());
}

TEST(TimeFunction, ASharpCornerOrAOneRowPulseInADenseTableIsARestart) {
  const TimeFunction vee = Sampled(100001, 1.0, [](double t) { return std::abs(t - 0.5); });
  EXPECT_EQ(vee.Breakpoints(), (std::vector<double>{0, 0.5, 1.0}));
  EXPECT_TRUE(vee.Waypoints().empty());
  std::vector<double> t(100001), v(100001, 0.0);
  for (size_t i = 0; i < t.size(); ++i) t[i] = 1e-5 * static_cast<double>(i);
  v[70000] = 1.0;  // one row: a pulse 2e-5 s wide
  const TimeFunction pulse = TimeFunction::Table(t, v);
  EXPECT_EQ(pulse.Breakpoints(), (std::vector<double>{t[69999], t[70000], t[70001]}));
  EXPECT_EQ(pulse.Waypoints(), (std::vector<double>{t.front(), t.back()}));  // flat there
}

TEST(TimeFunction, AGentleCornerIsAWaypointAndASharpOneARestart) {
  // Slope 1, then 0.6 (a turn of 40 % of the steeper side: gentle), then -1 (sharp).
  const TimeFunction f = TimeFunction::Table({0, 1, 2, 3}, {0, 1, 1.6, 0.6});
  EXPECT_EQ(f.Breakpoints(), (std::vector<double>{0, 2, 3}));
  EXPECT_EQ(f.Waypoints(), (std::vector<double>{1}));
}

TEST(TimeFunction, ANoisyTableKeepsEveryRowThatLeavesTheTolerance) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::vector<double> t(20001), v(20001);
  for (size_t i = 0; i < t.size(); ++i) t[i] = 1e-3 * static_cast<double>(i), v[i] = u(rng);
  const TimeFunction f = TimeFunction::Table(t, v);
  const std::vector<double> vertices = Vertices(f);
  ExpectWithinToleranceOfALine(f, vertices, TimeFunction::kTableCornerTolerance * 2.0);
  EXPECT_GT(vertices.size(), t.size() * 99 / 100);
}

}  // namespace
}  // namespace multibond
