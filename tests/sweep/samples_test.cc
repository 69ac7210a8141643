// The design: grids, lists, Monte Carlo and Latin hypercube samples from a seed.

#include "multibond/sweep/samples.h"

#include <cmath>
#include <set>

#include <gtest/gtest.h>

namespace multibond::sweep {
namespace {

Axis Grid(const std::string& name, double from, double to, int count, Axis::Scale scale) {
  Axis a;
  a.name = name;
  a.from = from;
  a.to = to;
  a.count = count;
  a.scale = scale;
  return a;
}

Axis Dist(Axis::Distribution d, double a, double b) {
  Axis x;
  x.name = "p";
  x.kind = Axis::Kind::kDistribution;
  x.distribution = d;
  x.a = a;
  x.b = b;
  return x;
}

TEST(Samples, ALogGridIsGeometricWithExactEnds) {
  Study s;
  s.axes = {Grid("k", 10, 1000, 20, Axis::Scale::kLog)};
  const auto d = Design(s);
  ASSERT_EQ(d.size(), 20u);
  EXPECT_EQ(d.front()[0], 10.0);
  EXPECT_EQ(d.back()[0], 1000.0);
  const double ratio = std::pow(100.0, 1.0 / 19);
  for (size_t i = 1; i < d.size(); ++i) EXPECT_NEAR(d[i][0] / d[i - 1][0], ratio, 1e-13);
}

TEST(Samples, AGridIsTheProductFirstAxisSlowest) {
  Study s;
  Axis list;
  list.name = "c";
  list.kind = Axis::Kind::kList;
  list.values = {1, 2, 3};
  s.axes = {Grid("k", 0, 1, 2, Axis::Scale::kLinear), list};
  const auto d = Design(s);
  ASSERT_EQ(d.size(), 6u);
  EXPECT_EQ(d[0], (std::vector<double>{0, 1}));
  EXPECT_EQ(d[2], (std::vector<double>{0, 3}));
  EXPECT_EQ(d[3], (std::vector<double>{1, 1}));
  EXPECT_EQ(CountRuns(s), 6);
}

TEST(Samples, MonteCarloRunsDependOnTheSeedAndTheirIndexOnly) {
  Study s;
  s.method = Study::Method::kMonteCarlo;
  s.seed = 7;
  s.samples = 10;
  s.axes = {Dist(Axis::Distribution::kUniform, 2, 3)};
  const auto a = Design(s);
  s.samples = 20;
  const auto b = Design(s);
  for (size_t i = 0; i < a.size(); ++i) EXPECT_EQ(a[i], b[i]);  // the first 10 runs are the same
  for (const auto& r : b) {
    EXPECT_GT(r[0], 2.0);
    EXPECT_LT(r[0], 3.0);
  }
  s.seed = 8;
  EXPECT_NE(Design(s)[0], b[0]);
}

TEST(Samples, TheLatinHypercubePutsOneSampleInEachStratum) {
  Study s;
  s.method = Study::Method::kLatinHypercube;
  s.seed = 3;
  s.samples = 50;
  s.axes = {Dist(Axis::Distribution::kUniform, 0, 1), Dist(Axis::Distribution::kNormal, 0, 1)};
  const auto d = Design(s);
  std::set<int> bins0, bins1;
  for (const auto& r : d) {
    bins0.insert(static_cast<int>(r[0] * 50));
    // The normal axis: its probability (the standard normal CDF) stratified the same way.
    bins1.insert(static_cast<int>(0.5 * std::erfc(-r[1] / std::sqrt(2.0)) * 50));
  }
  EXPECT_EQ(bins0.size(), 50u);
  EXPECT_EQ(bins1.size(), 50u);
}

TEST(Samples, QuantilesOfTheDistributions) {
  EXPECT_NEAR(Quantile(Dist(Axis::Distribution::kNormal, 1, 2), 0.975), 1 + 2 * 1.959963984540054, 1e-12);
  EXPECT_NEAR(Quantile(Dist(Axis::Distribution::kLogUniform, 1, 100), 0.5), 10.0, 1e-12);
  EXPECT_NEAR(Quantile(Dist(Axis::Distribution::kLogNormal, 0, 1), 0.5), 1.0, 1e-15);
  EXPECT_EQ(OpenUnit(0), 0x1p-53);
  EXPECT_EQ(OpenUnit(~0ULL), 1.0 - 0x1p-53);
  EXPECT_LT(OpenUnit(~0ULL), 1.0);
}

}  // namespace
}  // namespace multibond::sweep
