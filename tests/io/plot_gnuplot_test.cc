// GnuplotScript and RunGnuplot: a figure's script, and gnuplot runs a few at a time, all of them
// ended when a stop is asked for.
#include "multibond/io/plot_gnuplot.h"

#include <signal.h>
#include <sys/stat.h>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cerrno>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <fmt/format.h>

#include "multibond/core/interrupt.h"
#include "support/temp_dir.h"

namespace multibond {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

struct TempDir : multibond::testing::TempDir {
  TempDir() : multibond::testing::TempDir("multibond-plot-gnuplot-test") {}
};

TEST(PlotGnuplotTest, ScriptReadsTheColumnsByNumberAndEscapesText) {
  TempDir dir;
  std::ofstream(dir.path() / "results.csv") << "time [s],a [m],b [m`x`]\n0,1,2\n1,3,5\n";
  struct stat st {};
  const PlotTable t = PlotTable::Load(ResultsFolder(dir.path().string()), 1 << 20, &st);
  Figure f;
  f.name = "fig";
  f.label = "Fig. 1";
  f.caption = "it's `b`";
  Panel p;
  p.id = "a";
  p.title = "panel\n!touch x";
  p.curves = {{{"b"}, "b_{1}", "#000000", true, 1000.0}, {{"a"}, "a", "#ffffff"}};
  f.panels = {p};
  const std::string gp = GnuplotScript(t, f);
  // The columns it draws are in it (time, b, a), as results.csv has them: gnuplot does not read
  // the file again.
  EXPECT_THAT(gp, HasSubstr("$d << EOD\n0,2,1\n1,5,3\nEOD\n"));
  EXPECT_THAT(gp, HasSubstr("#   $d column 2 = results.csv column 3: b [m\xef\xbf\xbdx\xef\xbf\xbd]"));
  EXPECT_EQ(gp.find("\"results.csv\""), std::string::npos);
  EXPECT_THAT(gp, HasSubstr("set multiplot layout 1,1 title 'Fig. 1. it''s \xef\xbf\xbd" "b\xef\xbf\xbd'"));
  EXPECT_THAT(gp, HasSubstr("set title 'panel !touch x'"));
  EXPECT_THAT(gp, HasSubstr("$d using 1:(($2 - (2))*1000) lw 1.5 lc rgb \"#000000\" title 'b_{1}'"));
  EXPECT_THAT(gp, HasSubstr("set print \"plots/fig.ranges\""));
  EXPECT_EQ(gp.find('`'), std::string::npos);
}

TEST(PlotGnuplotTest, TheDatablockHoldsEveryValueAsResultsCsvWritesIt) {
  TempDir dir;
  // Values that a short format would change, and values that are not numbers.
  const std::vector<std::string> a = {"0.1", "0.30000000000000004", "1e-300", "-2.2250738585072014e-308", "nan", "inf", "-inf",
                                      "1.2345678901234568e+17"};
  std::string csv = "time [s],a [m]\n";
  for (size_t r = 0; r < a.size(); ++r) csv += fmt::format("{},{}\n", r, a[r]);
  std::ofstream(dir.path() / "results.csv") << csv;
  struct stat st {};
  const PlotTable t = PlotTable::Load(ResultsFolder(dir.path().string()), 1 << 20, &st);
  Figure f;
  f.name = "fig";
  Panel p;
  p.id = "a";
  p.curves = {{{"a"}, "a", "#000000"}};
  f.panels = {p};
  const std::string gp = GnuplotScript(t, f);
  // results.csv without its header is the block, character for character.
  EXPECT_THAT(gp, HasSubstr("$d << EOD\n" + csv.substr(csv.find('\n') + 1) + "EOD\n"));
}

TEST(PlotGnuplotTest, EventsAreMarkedOnEveryTimePanelInItsWindow) {
  TempDir dir;
  std::ofstream(dir.path() / "results.csv") << "time [s],a [m],b [m],c.x [m],c.y [m],c.z [m]\n0,1,2,0,0,0\n1,3,5,1,1,1\n2,4,4,2,2,2\n4,5,5,3,3,3\n";
  struct stat st {};
  const PlotTable t = PlotTable::Load(ResultsFolder(dir.path().string()), 1 << 20, &st);
  Figure f;
  f.name = "fig";
  Panel a;
  a.id = "a";
  a.zoom = true;  // its companion shows [0, 0.5 s]
  a.curves = {{{"a"}, "a", "#000000"}};
  Panel path;
  path.id = "b";
  path.kind = PanelKind::kPath;
  path.curves = {{{"c.x", "c.y", "c.z"}, "c", "#000000"}};
  f.panels = {a, path};
  const std::vector<PlotEvent> events = {{0.25, "impact", "wall", "bounce"}, {3, "time", "src", "jump"}};
  const std::string gp = GnuplotScript(t, f, {}, events);
  // The time panel: both events; its start transient: the impact only; the 3D path: none.
  const std::string impact = "set arrow from first 0.25, graph 0 to first 0.25, graph 1 nohead back lw 1 lc rgb \"#b2182b\" dt 1\n";
  const std::string time = "set arrow from first 3, graph 0 to first 3, graph 1 nohead back lw 1 lc rgb \"#a0a0a0\" dt 3\n";
  const size_t panel = gp.find("# panel a\n"), zoom = gp.find("# panel a-zoom\n"), path_panel = gp.find("# panel b\n");
  ASSERT_TRUE(panel < zoom && zoom < path_panel && path_panel != std::string::npos);
  const std::string in_panel = gp.substr(panel, zoom - panel), in_zoom = gp.substr(zoom, path_panel - zoom), in_path = gp.substr(path_panel);
  EXPECT_THAT(in_panel, HasSubstr(impact));
  EXPECT_THAT(in_panel, HasSubstr(time));
  EXPECT_THAT(in_panel, HasSubstr("$d using 1:2 lw 1.5 lc rgb \"#000000\" title 'a', \\\n       NaN with lines lw 1 lc rgb \"#b2182b\" dt 1 "
                                  "title 'impact (1)', \\\n       NaN with lines lw 1 lc rgb \"#a0a0a0\" dt 3 title 'time (1)'\n"));
  EXPECT_THAT(in_zoom, HasSubstr(impact));
  EXPECT_EQ(in_zoom.find("set arrow from first 3,"), std::string::npos);
  EXPECT_THAT(in_zoom, HasSubstr("title 'impact (1)'\n"));
  EXPECT_EQ(in_path.find("graph 1 nohead"), std::string::npos);
  // Each panel starts without the marks of the one before.
  EXPECT_THAT(in_zoom, HasSubstr("unset arrow\n"));
  // Without events (or none in any window) the script is the one without marks, byte for byte.
  const std::string plain = GnuplotScript(t, f);
  EXPECT_EQ(GnuplotScript(t, f, {}, {{7, "impact", "late", ""}}), plain);
  EXPECT_EQ(plain.find("nohead"), std::string::npos);
  EXPECT_EQ(plain.find("NaN with lines"), std::string::npos);
}

bool Alive(pid_t pid) { return ::kill(pid, 0) == 0 || errno != ESRCH; }

TEST(PlotGnuplotTest, AStopEndsEveryRunningGnuplot) {
  TempDir dir;
  const fs::path pids = dir.path() / "pids", program = dir.path() / "slow-gnuplot";
  std::ofstream(program) << "#!/bin/sh\necho $$ >> '" << pids.string() << "'\nexec sleep 30\n";
  fs::permissions(program, fs::perms::owner_all);
  const ResultsFolder folder(dir.path().string());
  const WorkFolder work(folder);
  const Fd plots = folder.OutputDir("plots");
  std::thread stopper([] {
    std::this_thread::sleep_for(std::chrono::milliseconds(800));
    StopFlag().store(true);
  });
  const auto start = std::chrono::steady_clock::now();
  EXPECT_THROW(RunGnuplot(work, plots.get(), {"a", "b", "c", "d"}, program.string(), 3), Interrupted);
  stopper.join();
  ResetStop();
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), 20.0);
  std::ifstream in(pids);
  int started = 0;
  for (pid_t pid; in >> pid; ++started) EXPECT_FALSE(Alive(pid)) << "gnuplot " << pid << " still runs after the stop";
  EXPECT_EQ(started, 3);
}

TEST(PlotGnuplotTest, FailuresAreReportedWithTheLog) {
  TempDir dir;
  const fs::path program = dir.path() / "failing-gnuplot";
  std::ofstream(program) << "#!/bin/sh\necho \"line 3: bad thing\" >&2\nexit 1\n";
  fs::permissions(program, fs::perms::owner_all);
  const ResultsFolder folder(dir.path().string());
  const WorkFolder work(folder);
  const Fd plots = folder.OutputDir("plots");
  const auto failures = RunGnuplot(work, plots.get(), {"a", "b"}, program.string(), 1);
  ASSERT_EQ(failures.size(), 2u);
  EXPECT_THAT(failures.at("a"), HasSubstr("line 3: bad thing"));
  EXPECT_TRUE(fs::exists(dir.path() / "plots" / "a.log"));
  EXPECT_THROW(RunGnuplot(work, plots.get(), {"a"}, (dir.path() / "none").string(), 1), std::runtime_error);
}

}  // namespace
}  // namespace multibond
