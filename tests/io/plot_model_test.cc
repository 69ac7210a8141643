// PlotModel and LinkGrouping: the model file of `plot --model`, read once, and its bond graph
// grouped by link.
#include "multibond/io/plot_model.h"

#include <gtest/gtest.h>

#include <fstream>
#include <string>

#include "support/temp_dir.h"

namespace multibond {
namespace {

const std::string kExamples = std::string(MULTIBOND_SOURCE_DIR) + "/examples/";

TEST(PlotModelTest, NoneGivenIsNotLoaded) {
  const PlotModel m = PlotModel::Read("", {});
  EXPECT_FALSE(m.given());
  EXPECT_FALSE(m.loaded);
  EXPECT_TRUE(m.dot.empty());
}

TEST(PlotModelTest, AModelThatDoesNotLoadIsGivenButNotLoaded) {
  const multibond::testing::TempDir dir("multibond-plot-model-test");
  const std::string path = (dir.path() / "bad.yaml").string();
  std::ofstream(path) << "model: m\nelements:\n  mass: {type: I, inertia: 1}\nbonds:\n  - mass -> nowhere\n";
  const PlotModel m = PlotModel::Read(path, {});  // does not throw: plot says why it draws no graph
  EXPECT_TRUE(m.given());
  EXPECT_EQ(m.path, path);
  EXPECT_FALSE(m.loaded);
  EXPECT_TRUE(m.dot.empty());
  // A missing file alike.
  EXPECT_FALSE(PlotModel::Read((dir.path() / "missing.yaml").string(), {}).loaded);
}

TEST(PlotModelTest, TheBondGraphIsDrawnOnceWithItsCausalityAndLinks) {
  const PlotModel m = PlotModel::Read(kExamples + "differential.yaml", {});
  ASSERT_TRUE(m.loaded);
  // The same DOT that 'multibond graph' draws with the link grouping, causal strokes included.
  EXPECT_EQ(m.dot.rfind("digraph", 0), 0u) << m.dot.substr(0, 80);
  EXPECT_NE(m.dot.find("subgraph cluster_G_bearing {"), std::string::npos);
  EXPECT_NE(m.dot.find("tee"), std::string::npos);  // a causal stroke
  const PlotModel msd = PlotModel::Read(kExamples + "mass_spring_damper.yaml", {});
  ASSERT_TRUE(msd.loaded);
  for (const char* name : {"force", "mass", "spring", "damper"}) EXPECT_NE(msd.dot.find(name), std::string::npos) << name;
}

TEST(PlotModelTest, BondGraphGroupedByLink) {
  const LoadedModel lm = LoadModelFile(kExamples + "differential.yaml");
  const DotOptions o = LinkGrouping(lm);
  EXPECT_EQ(o.nest.at("G_bearing"), "G");
  EXPECT_EQ(o.nest.at("S1_held"), "S1");
  EXPECT_EQ(o.nest.at("drive"), "G");
  EXPECT_EQ(o.nest.at("mesh_P2S1"), "P2");
  EXPECT_EQ(o.nest.at("G~H"), "G");
  EXPECT_FALSE(o.bond_names);
  const std::string dot = MakeDot(lm.graph, nullptr, nullptr, o);
  // The bearing's cluster opens inside G's, before G's closes.
  const size_t g = dot.find("subgraph cluster_G {"), bearing = dot.find("subgraph cluster_G_bearing {");
  const size_t h = dot.find("subgraph cluster_H {");
  ASSERT_NE(g, std::string::npos);
  ASSERT_NE(bearing, std::string::npos);
  EXPECT_LT(g, bearing);
  EXPECT_TRUE(h < g || h > bearing);
  // A model without mechanism sections: the plain grouping.
  const DotOptions plain = LinkGrouping(LoadModelFile(kExamples + "mass_spring_damper.yaml"));
  EXPECT_TRUE(plain.nest.empty());
  EXPECT_TRUE(plain.bond_names);
}

}  // namespace
}  // namespace multibond
