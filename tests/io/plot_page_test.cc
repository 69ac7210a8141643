// The results page's text: markup to HTML, placeholders filled from the run, everything escaped.
#include "multibond/io/plot_page.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>

#include <fmt/format.h>

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

TEST(PlotPageTest, EventsTableIsEscapedAndCapped) {
  const multibond::testing::TempDir dir("multibond-plot-page-test");
  const PlotTable t = Table(dir);
  std::vector<PlotEvent> events = {{0.5, "impact", "<script>alert(1)</script>", "a \"quoted\"\nline & 'more' `x` @m"},
                                   {1.25, "time", "src", "restart"}};
  std::string html = ResultsPageHtml(t, nlohmann::json::object(), {}, {}, -1, events);
  EXPECT_EQ(html.find("<script>"), std::string::npos);
  EXPECT_THAT(html, HasSubstr("<a href=\"#run-events\">events</a>"));
  EXPECT_THAT(html, HasSubstr("<caption>Events (events.csv): 2 &mdash; <span style=\"color: #b2182b\">&#9646;</span> impact 1, "
                              "<span style=\"color: #a0a0a0\">&#9646;</span> time 1;"));
  EXPECT_THAT(html, HasSubstr("<tr><th>time [s]</th><th>kind</th><th>element</th><th>description</th></tr>"));
  EXPECT_THAT(html, HasSubstr("<tr><td>0.5</td><td><span style=\"color: #b2182b\">&#9646;</span> impact</td>"
                              "<td>&lt;script&gt;alert(1)&lt;/script&gt;</td><td>a &quot;quoted&quot;\nline &amp; &#39;more&#39; `x` @m</td></tr>"));
  EXPECT_THAT(html, HasSubstr("<tr><td>1.25</td>"));
  EXPECT_EQ(html.find("more (events.csv lists them all)"), std::string::npos);
  // Past kMaxPageEvents rows: "and N more".
  events.clear();
  for (size_t k = 0; k < kMaxPageEvents + 7; ++k) events.push_back({static_cast<double>(k), "slip", "f", "d"});
  html = ResultsPageHtml(t, nlohmann::json::object(), {}, {}, -1, events);
  size_t rows = 0;
  for (size_t at = html.find("<tr><td>"); at != std::string::npos; at = html.find("<tr><td>", at + 1)) ++rows;
  EXPECT_EQ(rows, kMaxPageEvents);
  EXPECT_THAT(html, HasSubstr("<tr><td colspan=\"4\">and 7 more (events.csv lists them all)</td></tr>"));
  EXPECT_THAT(html, HasSubstr(fmt::format("<tr><td>{}</td>", kMaxPageEvents - 1)));
  EXPECT_EQ(html.find(fmt::format("<tr><td>{}</td>", kMaxPageEvents)), std::string::npos);
  // Without events, no table and no link to it.
  html = ResultsPageHtml(t, nlohmann::json::object(), {}, {}, -1);
  EXPECT_EQ(html.find("events"), std::string::npos);
}

}  // namespace
}  // namespace multibond
