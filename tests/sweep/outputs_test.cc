// sweep.csv's rows and the sensitivity ranking.

#include "multibond/sweep/outputs.h"

#include <cmath>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

namespace multibond::sweep {
namespace {

TEST(Outputs, SpearmanOfMonotoneAndTiedData) {
  EXPECT_DOUBLE_EQ(Spearman({1, 2, 3, 4}, {1, 8, 27, 64}), 1.0);
  EXPECT_DOUBLE_EQ(Spearman({1, 2, 3, 4}, {4, 3, 2, 1}), -1.0);
  // Ties take their mean rank: x ranks 1.5 1.5 3 4, y 1 2 3 4: rho = 4.5 / sqrt(4.5 * 5).
  EXPECT_NEAR(Spearman({1, 1, 2, 3}, {1, 2, 3, 4}), 4.5 / std::sqrt(4.5 * 5.0), 1e-15);
  EXPECT_TRUE(std::isnan(Spearman({1, 2}, {1, 2})));
  EXPECT_TRUE(std::isnan(Spearman({1, 2, 3}, {5, 5, 5})));
}

Study TwoParameters() {
  Study s;
  DiagnosticSink sink;
  AddAxisSpec(s, "--sample", "a=uniform:0:1", sink);
  AddAxisSpec(s, "--sample", "b=uniform:0:1", sink);
  AddKeepSpec(s, "y=final:x", sink);
  EXPECT_FALSE(sink.has_errors());
  EXPECT_EQ(s.method, Study::Method::kMonteCarlo);
  return s;
}

TEST(Outputs, TheParameterThatMovesAQuantityMostRanksFirst) {
  const Study s = TwoParameters();
  // y = b^3 + a/100 over a scattered design: y follows b's order, hardly a's.
  const std::vector<std::vector<double>> design = {{5, 1}, {1, 2}, {4, 3}, {2, 4}, {3, 5}, {6, 6}};
  std::vector<RunResult> results;
  for (long i = 0; i < 6; ++i) results.push_back({i, true, "", {std::pow(design[i][1], 3) + design[i][0] / 100}});
  results.push_back({6, false, "failed", {std::nan("")}});  // a failed run is left out
  auto design7 = design;
  design7.push_back({100, 100});
  const auto ranking = SensitivityRanking(s, design7, results);
  ASSERT_EQ(ranking.size(), 2u);
  EXPECT_EQ(ranking[0].parameter, "b");
  EXPECT_DOUBLE_EQ(ranking[0].spearman, 1.0);
  EXPECT_EQ(ranking[0].rank, 1);
  EXPECT_EQ(ranking[1].parameter, "a");
  EXPECT_LT(std::abs(ranking[1].spearman), 0.5);
}

TEST(Outputs, SweepJsonRecordsAKeptQuantitysWindow) {
  Study s = TwoParameters();
  DiagnosticSink sink;
  AddKeepSpec(s, "late=max[0.5,]:x", sink);
  ASSERT_FALSE(sink.has_errors());
  const nlohmann::json j = nlohmann::json::parse(SweepJson(s, SweepFacts{}, {}));
  ASSERT_EQ(j["keep"].size(), 2u);
  EXPECT_FALSE(j["keep"][0].contains("from"));  // the whole run: no window
  EXPECT_EQ(j["keep"][1]["from"], 0.5);
  EXPECT_FALSE(j["keep"][1].contains("to"));
}

TEST(Outputs, SweepCsvRowsInRunOrderWithExactNumbers) {
  Study s = TwoParameters();
  s.method = Study::Method::kGrid;
  const std::string csv =
      SweepCsv(s, {{0.1, 2}, {1e-300, 3}}, {{0, true, "", {1.0 / 3.0}}, {1, false, "param.range: k, negative", {std::nan("")}}});
  EXPECT_EQ(csv,
            "run,a,b,status,y,reason\n"
            "0,0.1,2,ok,0.3333333333333333,\n"
            "1,1e-300,3,failed,nan,\"param.range: k, negative\"\n");
}

}  // namespace
}  // namespace multibond::sweep
