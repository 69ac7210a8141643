// CompareRecordings: the column-by-column difference of two runs (`multibond compare`).

#include "multibond/sim/compare.h"

#include <cmath>
#include <limits>
#include <stdexcept>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "multibond/io/model_loader.h"
#include "support/example_runner.h"
#include "support/temp_dir.h"

namespace multibond {
namespace {

using ::testing::ElementsAre;

std::string MassSpringDamper() { return testing::ReadFile(testing::ExamplePath("mass_spring_damper.yaml")); }

std::string Replace(std::string text, const std::string& from, const std::string& to) {
  const size_t at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  if (at != std::string::npos) text.replace(at, from.size(), to);
  return text;
}

RecordingObserver RunText(const std::string& yaml, double t_end, double dt) {
  return testing::RunModelText(yaml, t_end, dt, IntegratorOptions{}.method, 1e-11, 1e-13);
}

const ColumnComparison& Find(const ComparisonReport& r, const std::string& name) {
  for (const auto& c : r.columns)
    if (c.name == name) return c;
  throw std::out_of_range(name);
}

/// m x'' + c x' + k x = F from rest, F a step at t = 0 (underdamped): displacement and velocity.
struct Oscillator {
  double m, c, k, F;
  double wn() const { return std::sqrt(k / m); }
  double zeta() const { return c / (2 * std::sqrt(k * m)); }
  double wd() const { return wn() * std::sqrt(1 - zeta() * zeta()); }
  double x(double t) const {
    const double z = zeta();
    return F / k * (1 - std::exp(-z * wn() * t) * (std::cos(wd() * t) + z / std::sqrt(1 - z * z) * std::sin(wd() * t)));
  }
  double v(double t) const { return F / (m * wd()) * std::exp(-zeta() * wn() * t) * std::sin(wd() * t); }
};

TEST(CompareRecordings, TheSameModelTwiceHasNoDifference) {
  const RecordingObserver a = RunText(MassSpringDamper(), 1.0, 0.01), b = RunText(MassSpringDamper(), 1.0, 0.01);
  const ComparisonReport r = CompareRecordings(a, b);
  EXPECT_EQ(r.samples, 101);
  EXPECT_DOUBLE_EQ(r.t_first, 0.0);
  EXPECT_DOUBLE_EQ(r.t_last, 1.0);
  EXPECT_EQ(r.columns.size(), a.columns().size() - 1);  // every column but time
  EXPECT_TRUE(r.only_in_a.empty());
  EXPECT_TRUE(r.only_in_b.empty());
  for (const auto& c : r.columns) {
    EXPECT_EQ(c.max_abs_diff, 0.0) << c.name;
    EXPECT_EQ(c.relative, 0.0) << c.name;
    EXPECT_EQ(c.unit, c.unit_b) << c.name;
  }
  EXPECT_GT(Find(r, "spring.q").scale, 0.0);
  EXPECT_DOUBLE_EQ(Find(r, "spring.q").scale, [&] {
    double s = 0;
    for (const auto& row : a.rows()) s = std::max(s, std::abs(row[a.Index("spring.q")]));
    return s;
  }());
}

TEST(CompareRecordings, ChangedStiffnessGivesTheAnalyticDifference) {
  // k = 100 N/m against k = 150 N/m; m = 1 kg, c = 2 N s/m, F = 1 N. The report's difference
  // must be that of the two analytic solutions on the same grid.
  const double t_end = 2.0, dt = 1e-3;
  const std::string text_b = Replace(MassSpringDamper(), "stiffness: 100.0", "stiffness: 150.0");
  const RecordingObserver a = RunText(MassSpringDamper(), t_end, dt), b = RunText(text_b, t_end, dt);
  ComparisonReport r = CompareRecordings(a, b);
  const Oscillator oa{1.0, 2.0, 100.0, 1.0}, ob{1.0, 2.0, 150.0, 1.0};
  double dx = 0, tx = 0, sx = 0, dv = 0, tv = 0;
  for (const auto& row : a.rows()) {
    const double t = row[0];
    if (std::abs(oa.x(t) - ob.x(t)) > dx) dx = std::abs(oa.x(t) - ob.x(t)), tx = t;
    if (std::abs(oa.v(t) - ob.v(t)) > dv) dv = std::abs(oa.v(t) - ob.v(t)), tv = t;
    sx = std::max(sx, std::abs(oa.x(t)));
  }
  ASSERT_GT(dx, 1e-3);  // a real difference: about half the static deflection
  const ColumnComparison& q = Find(r, "spring.q");
  EXPECT_NEAR(q.max_abs_diff, dx, 1e-8);
  EXPECT_NEAR(q.time, tx, 1.5 * dt);  // the maximum is flat: a neighbouring sample may win
  EXPECT_NEAR(q.scale, sx, 1e-8);
  EXPECT_NEAR(q.relative, dx / sx, 1e-6);
  EXPECT_EQ(q.unit, "m");
  const ColumnComparison& v = Find(r, "velocity");
  EXPECT_NEAR(v.max_abs_diff, dv, 1e-8);
  EXPECT_NEAR(v.time, tv, 1.5 * dt);
  // mass.p = m v: the same difference as the velocity (m = 1 kg).
  EXPECT_NEAR(Find(r, "mass.p").max_abs_diff, dv, 1e-8);
  // Sorted by relative difference, the momentum and velocity (about 0.74) come first.
  SortComparison(r, ComparisonOrder::kRelative);
  for (size_t k = 1; k < r.columns.size(); ++k) EXPECT_GE(r.columns[k - 1].relative, r.columns[k].relative);
  EXPECT_EQ(r.Worst()->name, r.columns.front().name);
}

TEST(CompareRecordings, ColumnsOfOneRunOnlyAreListedByName) {
  std::string text_b = Replace(MassSpringDamper(), "name: spring_force", "name: force_in_spring");
  text_b = Replace(text_b, "  - {name: velocity, variable: j.f}\n", "  - {name: velocity, variable: j.f}\n  - {name: damper_force, variable: damper.e}\n");
  const ComparisonReport r = CompareRecordings(RunText(MassSpringDamper(), 0.1, 0.01), RunText(text_b, 0.1, 0.01));
  EXPECT_THAT(r.only_in_a, ElementsAre("spring_force"));
  EXPECT_THAT(r.only_in_b, ElementsAre("damper_force", "force_in_spring"));
  for (const auto& c : r.columns) EXPECT_EQ(c.max_abs_diff, 0.0) << c.name;
}

TEST(CompareRecordings, DifferentGridsAreAnError) {
  const RecordingObserver a = RunText(MassSpringDamper(), 0.1, 0.01);
  EXPECT_THROW(CompareRecordings(a, RunText(MassSpringDamper(), 0.2, 0.01)), std::invalid_argument);  // more samples
  EXPECT_THROW(CompareRecordings(a, RunText(MassSpringDamper(), 0.05, 0.005)), std::invalid_argument);  // same count, other times
  try {
    CompareRecordings(a, RunText(MassSpringDamper(), 0.2, 0.01));
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), ::testing::HasSubstr("different output grids"));
    EXPECT_THAT(e.what(), ::testing::HasSubstr("--dt"));
  }
}

TEST(CompareRecordings, ZeroScaleAndNaNAreGuarded) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const std::vector<Column> cols = {{"time", "s"}, {"zero", "m"}, {"both_zero", "m"}, {"broken", "-"}, {"same_nan", "-"}, {"x", "m"}};
  const std::vector<std::vector<double>> a = {{0.0, 0.0, 0.0, 1.0, nan, 1.0}, {0.5, 0.0, 0.0, 2.0, nan, -4.0}};
  const std::vector<std::vector<double>> b = {{0.0, 0.5, 0.0, 1.0, nan, 1.0}, {0.5, -2.0, 0.0, nan, nan, -3.0}};
  ComparisonReport r = CompareRecordings(cols, a, cols, b);
  EXPECT_EQ(Find(r, "zero").max_abs_diff, 2.0);
  EXPECT_EQ(Find(r, "zero").time, 0.5);
  EXPECT_EQ(Find(r, "zero").scale, 0.0);
  EXPECT_TRUE(std::isinf(Find(r, "zero").relative));
  EXPECT_EQ(Find(r, "both_zero").relative, 0.0);
  EXPECT_TRUE(std::isnan(Find(r, "broken").max_abs_diff));  // NaN in B only
  EXPECT_EQ(Find(r, "broken").time, 0.5);
  EXPECT_EQ(Find(r, "same_nan").max_abs_diff, 0.0);  // NaN in both: no difference
  EXPECT_EQ(Find(r, "x").max_abs_diff, 1.0);
  EXPECT_EQ(Find(r, "x").scale, 4.0);
  EXPECT_EQ(Find(r, "x").relative, 0.25);
  SortComparison(r, ComparisonOrder::kRelative);
  std::vector<std::string> order;
  for (const auto& c : r.columns) order.push_back(c.name);
  EXPECT_THAT(order, ElementsAre("broken", "zero", "x", "both_zero", "same_nan"));
  SortComparison(r, ComparisonOrder::kName);
  order.clear();
  for (const auto& c : r.columns) order.push_back(c.name);
  EXPECT_THAT(order, ElementsAre("both_zero", "broken", "same_nan", "x", "zero"));
  EXPECT_EQ(r.Worst()->name, "broken");
}

TEST(CompareRecordings, RunsWithoutTimeColumnAreRejected) {
  const std::vector<Column> cols = {{"x", "m"}};
  EXPECT_THROW(CompareRecordings(cols, {{1.0}}, cols, {{1.0}}), std::invalid_argument);
}

}  // namespace
}  // namespace multibond
