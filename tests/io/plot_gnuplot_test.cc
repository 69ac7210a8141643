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
#include <thread>

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
  EXPECT_THAT(gp, HasSubstr("plot \"results.csv\" using (strcol(1)):(strcol(3)):(strcol(2)) with table"));
  EXPECT_THAT(gp, HasSubstr("set multiplot layout 1,1 title 'Fig. 1. it''s \xef\xbf\xbd" "b\xef\xbf\xbd'"));
  EXPECT_THAT(gp, HasSubstr("set title 'panel !touch x'"));
  EXPECT_THAT(gp, HasSubstr("$d using 1:(($2 - (2))*1000) lw 1.5 lc rgb \"#000000\" title 'b_{1}'"));
  EXPECT_THAT(gp, HasSubstr("set print \"plots/fig.ranges\""));
  EXPECT_EQ(gp.find('`'), std::string::npos);
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
