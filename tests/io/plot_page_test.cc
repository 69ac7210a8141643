// The results page's text: markup to HTML, placeholders filled from the run, everything escaped.
#include "multibond/io/plot_page.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>

#include "support/temp_dir.h"

namespace multibond {
namespace {

using ::testing::HasSubstr;

TEST(PlotPageTest, MarkupToHtml) {
  EXPECT_EQ(MarkupToHtml("Q_{P1} and x^{2}"), "Q<sub>P1</sub> and x<sup>2</sup>");
  EXPECT_EQ(MarkupToHtml("a\\_\\{b\\} <b>&"), "a_{b} &lt;b&gt;&amp;");
  EXPECT_EQ(MarkupToHtml("_{<script>}"), "<sub>&lt;script&gt;</sub>");
  EXPECT_EQ(MarkupToHtml("x_{"), "x_{");
}

/// A two-column results.csv read as plot reads it.
PlotTable Table(const multibond::testing::TempDir& dir) {
  std::ofstream(dir.path() / "results.csv") << "time [s],v.x [m],v.y [m],v.z [m]\n0,3,0,0\n1,-5,0,0\n2,0,3,4\n";
  struct stat st {};
  return PlotTable::Load(ResultsFolder(dir.path().string()), 1 << 20, &st);
}

TEST(PlotPageTest, PlaceholdersTakeTheRunsValues) {
  const multibond::testing::TempDir dir("multibond-plot-page-test");
  const PlotTable t = Table(dir);
  EXPECT_EQ(TextToHtml("v_{x} ends at {{last v.x}} m, from {{first v.x}}", t), "v<sub>x</sub> ends at 0 m, from 3.000");
  EXPECT_EQ(TextToHtml("{{min v.x}} {{max v.x}} {{max_abs v.x}}", t), "\u22125.000 3.000 5.000");
  EXPECT_EQ(TextToHtml("{{last_norm v}} {{max_norm v}} {{end_time}}", t), "5.000 5.000 2.000");
  EXPECT_EQ(TextToHtml("{{last nothing}}", t), "n/a");
  EXPECT_EQ(TextToHtml("{{rm -rf <x>}} {{", t), "{{rm -rf &lt;x&gt;}} {{");
}

TEST(PlotPageTest, PageEscapesEveryText) {
  const multibond::testing::TempDir dir("multibond-plot-page-test");
  const PlotTable t = Table(dir);
  FigureList list;
  list.title = "<script>";
  list.checks.push_back({"<b>", "v.x", false, 0.0, 0.1, "m", "<i>"});
  const nlohmann::json run = {{"model", {{"name", "<img>"}}}, {"options", {{"<k>", "<v>"}}}, {"status", "ok"}};
  const std::string html = ResultsPageHtml(t, run, list, {"<warn>"}, -1);
  EXPECT_EQ(html.find("<script>"), std::string::npos);
  EXPECT_EQ(html.find("<img>"), std::string::npos);
  EXPECT_EQ(html.find("<k>"), std::string::npos);
  EXPECT_EQ(html.find("<warn>"), std::string::npos);
  EXPECT_THAT(html, HasSubstr("&lt;img&gt;"));
  EXPECT_THAT(html, HasSubstr("&lt;k&gt; <strong>&lt;v&gt;</strong>"));
  EXPECT_THAT(html, HasSubstr("<td>&lt;b&gt;</td><td>0</td><td>0</td><td>0</td><td>0.10</td><td>m</td><td>ok</td>"));
}

}  // namespace
}  // namespace multibond
