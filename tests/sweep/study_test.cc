// The study reader: a study file's keys into a Study; every problem located with its code.

#include "multibond/sweep/study.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "multibond/core/diagnostic_codes.h"

namespace multibond::sweep {
namespace {

std::vector<Diagnostic> Problems(const std::string& text) {
  try {
    ReadStudyString(text, "s.yaml");
  } catch (const ModelError& e) {
    return e.diagnostics();
  }
  return {};
}

const Diagnostic* Find(const std::vector<Diagnostic>& ds, const std::string& code) {
  for (const Diagnostic& d : ds)
    if (d.code == code) return &d;
  return nullptr;
}

TEST(Study, ReadsAGridStudy) {
  const Study s = ReadStudyString(
      "study: msd\nmodel: m.yaml\nsweep:\n  k: {from: 10, to: 1000, scale: log, count: 20}\n  c: [1, 2]\n"
      "keep:\n  x_final: {final: spring.q}\n  x_max: {max: spring.q}\n  t_s: {settling_time: spring.q, band: 0.05}\n  e: spring.q*2\n"
      "simulation: {t_end: 30, dt: 0.01}\n",
      "dir/s.yaml");
  EXPECT_EQ(s.name, "msd");
  EXPECT_EQ(s.model, "dir/m.yaml");  // relative to the study's folder
  ASSERT_EQ(s.axes.size(), 2u);
  EXPECT_EQ(s.axes[0].kind, Axis::Kind::kGrid);
  EXPECT_EQ(s.axes[0].scale, Axis::Scale::kLog);
  EXPECT_EQ(s.axes[0].count, 20);
  EXPECT_EQ(s.axes[1].kind, Axis::Kind::kList);
  EXPECT_EQ(s.axes[1].values, (std::vector<double>{1, 2}));
  ASSERT_EQ(s.keep.size(), 4u);
  EXPECT_EQ(s.keep[1].take, Keep::Take::kMax);
  EXPECT_EQ(s.keep[2].band, 0.05);
  EXPECT_EQ(s.keep[3].take, Keep::Take::kFinal);
  EXPECT_EQ(s.keep[3].of, "spring.q*2");
  EXPECT_EQ(s.keep[3].expression.line, 10);
  EXPECT_EQ(s.keep[3].expression.column, 6);
  EXPECT_EQ(s.t_end, 30.0);
  EXPECT_EQ(s.method, Study::Method::kGrid);
}

TEST(Study, ADistributionMakesAMonteCarloStudy) {
  const Study s = ReadStudyString(
      "model: m.yaml\nsamples: 50\nseed: 18446744073709551615\nsweep:\n  k: {distribution: lognormal, mean: 4, sd: 0.5}\nkeep: {x: spring.q}\n",
      "s.yaml");
  EXPECT_EQ(s.method, Study::Method::kMonteCarlo);
  EXPECT_EQ(s.samples, 50);
  EXPECT_EQ(s.seed, 18446744073709551615ULL);
  EXPECT_EQ(s.axes[0].distribution, Axis::Distribution::kLogNormal);
}

TEST(Study, EachProblemIsLocatedWithItsCode) {
  const auto ds = Problems(
      "model: m.yaml\nsweep:\n  k: {from: 1000, to: 10, count: 20}\n  c: {from: 1, to: 1, count: 5}\n  m: {from: 0, to: 1, count: 3, scale: log}\n"
      "keep:\n  x: {maxx: spring.q}\n");
  const Diagnostic* reversed = Find(ds, codes::kSweepRange);
  ASSERT_NE(reversed, nullptr);
  EXPECT_EQ(reversed->where.line, 3);
  EXPECT_EQ(reversed->where.column, 3);
  EXPECT_NE(reversed->message.find("reversed"), std::string::npos);
  int ranges = 0;
  for (const Diagnostic& d : ds) ranges += d.code == codes::kSweepRange;
  EXPECT_EQ(ranges, 3);  // reversed, empty, log through zero
  const Diagnostic* key = Find(ds, codes::kSweepStudy);
  ASSERT_NE(key, nullptr);
  EXPECT_EQ(key->where.line, 7);
  EXPECT_EQ(key->hint, "did you mean 'max'?");
}

TEST(Study, AKeptQuantityOverAWindow) {
  const Study s = ReadStudyString("model: m.yaml\nsweep:\n  k: [1, 2]\nkeep:\n  late: {max: spring.q, from: 0.5, to: 2}\n  after: {min: spring.q, from: 1}\n",
                                  "s.yaml");
  ASSERT_EQ(s.keep.size(), 2u);
  EXPECT_EQ(s.keep[0].from, 0.5);
  EXPECT_EQ(s.keep[0].to, 2.0);
  EXPECT_EQ(s.keep[1].from, 1.0);
  EXPECT_EQ(s.keep[1].to, HUGE_VAL);
  const auto ds = Problems("model: m.yaml\nsweep:\n  k: [1, 2]\nkeep:\n  late: {max: spring.q, from: 2, to: 0.5}\n");
  const Diagnostic* empty = Find(ds, codes::kSweepKeep);
  ASSERT_NE(empty, nullptr);
  EXPECT_EQ(empty->where.line, 5);
  EXPECT_NE(empty->message.find("is empty"), std::string::npos) << empty->message;
}

TEST(Study, BadDistributionsAndSeeds) {
  const auto ds = Problems(
      "model: m.yaml\nsamples: 0\nseed: -1\nsweep:\n  k: {distribution: gaussian, mean: 1, sd: 1}\n"
      "  c: {distribution: uniform, low: 2, high: 1}\n  m: {distribution: normal, mean: 1, sd: -1}\nkeep: {x: spring.q}\n");
  int seeds = 0, distributions = 0;
  for (const Diagnostic& d : ds) {
    seeds += d.code == codes::kSweepSeed;
    distributions += d.code == codes::kSweepDistribution;
  }
  EXPECT_EQ(seeds, 2);          // samples 0, seed -1
  EXPECT_EQ(distributions, 3);  // unknown, reversed, negative deviation
  const Diagnostic* d = Find(ds, codes::kSweepDistribution);
  EXPECT_EQ(d->where.line, 5);
  EXPECT_EQ(d->hint, "one of uniform, loguniform, normal, lognormal");
}

TEST(Study, ASampledStudyNeedsASeed) {
  const auto ds = Problems("model: m.yaml\nsamples: 10\nsweep:\n  k: {distribution: uniform, low: 1, high: 2}\nkeep: {x: spring.q}\n");
  ASSERT_EQ(ds.size(), 1u);
  EXPECT_EQ(ds[0].code, codes::kSweepSeed);
}

TEST(Study, CommandLineSpecs) {
  Study s;
  DiagnosticSink sink;
  AddAxisSpec(s, "--grid", "k=1e3:1e5:log:20", sink);
  AddAxisSpec(s, "--list", "c=1,2,5", sink);
  AddKeepSpec(s, "x=max:spring.q", sink);
  AddKeepSpec(s, "tc=crossing_time@0.5:spring.q", sink);
  ASSERT_FALSE(sink.has_errors());
  EXPECT_EQ(s.axes[0].from, 1e3);
  EXPECT_EQ(s.axes[0].to, 1e5);
  EXPECT_EQ(s.axes[0].count, 20);
  EXPECT_EQ(s.axes[0].scale, Axis::Scale::kLog);
  EXPECT_EQ(s.axes[1].values, (std::vector<double>{1, 2, 5}));
  EXPECT_EQ(s.keep[0].take, Keep::Take::kMax);
  EXPECT_EQ(s.keep[1].take, Keep::Take::kCrossingTime);
  EXPECT_EQ(s.keep[1].level, 0.5);
  EXPECT_EQ(s.keep[1].of, "spring.q");

  // A window after the take (and its @ARG): [FROM,TO], either bound left out.
  AddKeepSpec(s, "late=max[0.5,2]:spring.q", sink);
  AddKeepSpec(s, "ts=settling_time@0.05[1,]:spring.q", sink);
  AddKeepSpec(s, "early=min[,0.25]:spring.q", sink);
  ASSERT_FALSE(sink.has_errors());
  EXPECT_EQ(s.keep[2].take, Keep::Take::kMax);
  EXPECT_EQ(s.keep[2].from, 0.5);
  EXPECT_EQ(s.keep[2].to, 2.0);
  EXPECT_EQ(s.keep[2].of, "spring.q");
  EXPECT_EQ(s.keep[3].take, Keep::Take::kSettlingTime);
  EXPECT_EQ(s.keep[3].band, 0.05);
  EXPECT_EQ(s.keep[3].from, 1.0);
  EXPECT_EQ(s.keep[3].to, HUGE_VAL);
  EXPECT_EQ(s.keep[4].from, -HUGE_VAL);
  EXPECT_EQ(s.keep[4].to, 0.25);
  EXPECT_FALSE(s.keep[0].windowed());
  // A window changes what a run keeps, so the study's text (its journal's hash); none leaves it as it was.
  EXPECT_NE(CanonicalText(s).find("keep late max spring.q 0.02 0  window 0.5 2\n"), std::string::npos) << CanonicalText(s);
  EXPECT_NE(CanonicalText(s).find("keep x max spring.q 0.02 0 \n"), std::string::npos) << CanonicalText(s);
  // Located at the '[' ("--keep w=max" then it: column 13), or at a bound that is no number.
  for (const auto& [spec, column] : {std::pair{"w=max[2,1]:spring.q", 13}, std::pair{"w=max[a,1]:spring.q", 14},
                                     std::pair{"w=max[1:spring.q", 13}, std::pair{"w=max[1]:spring.q", 13}}) {
    DiagnosticSink one;
    Study u;
    AddKeepSpec(u, spec, one);
    ASSERT_EQ(one.diagnostics().size(), 1u) << spec;
    EXPECT_EQ(one.diagnostics()[0].code, codes::kSweepKeep) << spec;
    EXPECT_EQ(one.diagnostics()[0].where.column, column) << spec;
  }

  DiagnosticSink bad;
  Study t;
  AddAxisSpec(t, "--grid", "k=1e3:x:20", bad);
  AddKeepSpec(t, "x=maximum:spring.q", bad);
  ASSERT_EQ(bad.diagnostics().size(), 2u);
  EXPECT_EQ(bad.diagnostics()[0].code, codes::kSweepRange);
  EXPECT_EQ(bad.diagnostics()[0].where.column, 14);  // "--grid k=1e3:" then the 'x'
  EXPECT_EQ(bad.diagnostics()[1].code, codes::kSweepKeep);
}

TEST(Study, AGridsNumbersAreRefusedOnceEach) {
  // A count of 1e8 said "a grid of 0 point(s)"; NaN, inf or a subnormal in a range was said, then
  // taken as 0 for a second, spurious error ("the range 1 to 0 is reversed"). One error each now,
  // with what was asked for and the limit.
  struct Case {
    std::string spec, says;
    int column;
  };
  for (const Case& c : std::vector<Case>{{"k=1:2:100000000", "a grid of 100000000 points asked for: more than the 10000000 runs", 14},
                                         {"k=1:2:2.5", "the count '2.5' is not a whole number of points", 14},
                                         {"k=1:nan:5", "'nan' is not a number", 12},
                                         {"k=inf:2:5", "'inf' is not a number", 10},
                                         {"k=1e-310:1:5", "'1e-310' is below the smallest normal double", 10}}) {
    SCOPED_TRACE(c.spec);
    Study st;
    DiagnosticSink sink;
    AddAxisSpec(st, "--grid", c.spec, sink);
    AddKeepSpec(st, "x=max:spring.q", sink);
    CheckStudy(st, sink);
    ASSERT_EQ(sink.diagnostics().size(), 1u) << sink.diagnostics().back().message;
    EXPECT_THAT(sink.diagnostics()[0].message, ::testing::HasSubstr(c.says));
    EXPECT_EQ(sink.diagnostics()[0].where.column, c.column);  // "--grid " then the spec, 1-based
  }
}

TEST(Study, RunSettingsMustBePositive) {
  const auto ds = Problems("model: m.yaml\nsweep: {k: [1, 2]}\nkeep: {x: spring.q}\nsimulation: {t_end: -1, dt: 0}\n");
  ASSERT_EQ(ds.size(), 2u);
  EXPECT_EQ(ds[0].code, codes::kSweepStudy);
  EXPECT_NE(ds[0].message.find("t_end is -1"), std::string::npos);
}

TEST(Study, KeptNamesMustBeColumnNames) {
  const auto ds = Problems("model: m.yaml\nsweep: {k: [1, 2]}\nkeep: {status: spring.q, k: spring.q}\n");
  int keeps = 0;
  for (const Diagnostic& d : ds) keeps += d.code == codes::kSweepKeep;
  EXPECT_EQ(keeps, 2);
}

}  // namespace
}  // namespace multibond::sweep
