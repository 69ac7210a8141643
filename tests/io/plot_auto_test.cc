// AutoFigures: the general figures of any results.csv, grouped by element and unit, bounded.
#include "multibond/io/plot_auto.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <set>
#include <string>
#include <vector>

#include <fmt/format.h>

namespace multibond {
namespace {

using ::testing::HasSubstr;

/// Columns of a figure, in order.
std::vector<std::string> ColumnsOf(const FigureList& list, const std::string& name) {
  for (const Figure& f : list.figures)
    if (f.name == name) return f.Columns();
  ADD_FAILURE() << "no figure " << name;
  return {};
}

TEST(PlotAutoTest, GroupsByElementAndUnit) {
  // The mass-spring-damper's header, with a body's vectors and orientation added.
  const std::vector<std::string> names = {"time",       "mass.p",        "spring.q",       "force.work",     "damper.dissipated",
                                          "velocity",   "spring_force",  "mass.energy",    "spring.energy",  "energy.work",
                                          "energy.kinetic", "energy.potential", "energy.dissipated", "energy.residual",
                                          "B.r.x",      "B.r.y",         "B.r.z",          "B.R.11",         "B.R.12",
                                          "B.R.13",     "B.R.21",        "B.R.22",         "B.R.23",         "B.R.31",
                                          "B.R.32",     "B.R.33"};
  const std::vector<std::string> units = {"s", "N s", "m", "J", "J", "m/s", "N", "J", "J", "J", "J", "J", "J", "-",
                                          "m", "m", "m", "-", "-", "-", "-", "-", "-", "-", "-", "-"};
  std::vector<std::string> warnings;
  const FigureList list = AutoFigures(names, units, 100, warnings);
  EXPECT_TRUE(warnings.empty());
  EXPECT_EQ(FigureNames(list), (std::vector<std::string>{"energy-account", "mass-N_s", "spring-m", "force-J", "damper-J", "outputs-m_s",
                                                          "outputs-N", "mass-J", "spring-J", "B-m", "B-1"}));
  EXPECT_EQ(ColumnsOf(list, "spring-m"), (std::vector<std::string>{"spring.q"}));
  EXPECT_EQ(ColumnsOf(list, "B-m"), (std::vector<std::string>{"B.r.x", "B.r.y", "B.r.z"}));
  EXPECT_EQ(ColumnsOf(list, "B-1").size(), 9u);  // R.ij as one figure
  // The energy account: J in panel a, the residual in panel b.
  const Figure& energy = list.figures[0];
  ASSERT_EQ(energy.panels.size(), 2u);
  EXPECT_EQ(energy.panels[0].curves.size(), 4u);
  EXPECT_EQ(energy.panels[1].curves[0].columns[0], "energy.residual");
  EXPECT_EQ(energy.panels[1].curves[0].title, "residual");
  // Sections: one per element, in order.
  EXPECT_EQ(list.sections.front(), "Energy account");
  EXPECT_EQ(list.sections[static_cast<size_t>(list.figures[1].section)], "mass");
  EXPECT_EQ(list.figures[1].section, list.figures[7].section);  // mass-N_s and mass-J
}

TEST(PlotAutoTest, FileTextIsEscapedAndNamesAreSafe) {
  std::vector<std::string> warnings;
  const FigureList list = AutoFigures({"time", "a_{b}.x", "../../x.q", "..y", "é.q"}, {"s", "m^2", "m`touch`", "N", "µm"}, 100, warnings);
  for (const Figure& f : list.figures) EXPECT_TRUE(IsFigureName(f.name)) << f.name;
  EXPECT_EQ(list.figures[0].caption, "a\\_\\{b\\} [m\\^2]");
  EXPECT_EQ(list.figures[0].panels[0].curves[0].title, "x");
  // Names that differ only in the bytes a file name cannot hold stay apart.
  const std::vector<std::string> names = FigureNames(list);
  EXPECT_EQ(std::set<std::string>(names.begin(), names.end()).size(), names.size());
}

TEST(PlotAutoTest, BoundedFiguresAndCurves) {
  std::vector<std::string> names = {"time"}, units = {"s"}, warnings;
  for (int c = 0; c < 30; ++c) names.push_back(fmt::format("big.c{}", c)), units.push_back("m");
  for (int c = 0; c < 50; ++c) names.push_back(fmt::format("e{}.q", c)), units.push_back("m");
  FigureList list = AutoFigures(names, units, 1000, warnings);
  EXPECT_TRUE(warnings.empty());
  ASSERT_EQ(list.figures.size(), 3u + 50u);  // 30 columns: 12 + 12 + 6
  EXPECT_EQ(list.figures[0].name, "big-m-1");
  EXPECT_EQ(list.figures[2].Columns().size(), 6u);
  for (const Figure& f : list.figures) EXPECT_LE(f.Columns().size(), kMaxCurvesPerFigure);
  list = AutoFigures(names, units, 10, warnings);
  EXPECT_EQ(list.figures.size(), 10u);
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_THAT(warnings[0], HasSubstr("43 of 53 figures left out"));
}

}  // namespace
}  // namespace multibond
