// `multibond sweep` from the command line: the mass-spring-damper study on threads and under
// mpirun with 1, 2 and 4 ranks gives one table, to the last bit, that matches the closed forms;
// bad input is refused with exit 64 and a located message before any run.

#include <sys/stat.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>

#include "support/cli_runner.h"
#include "support/temp_dir.h"

namespace multibond {
namespace {

using testing::ReadFile;
using testing::RunProgram;
using testing::TempDir;

const std::string kStudy = std::string(MULTIBOND_SOURCE_DIR) + "/examples/sweeps/mass_spring_damper.yaml";
const std::string kModel = std::string(MULTIBOND_SOURCE_DIR) + "/examples/sweeps/mass_spring_damper_model.yaml";

std::vector<std::vector<std::string>> Rows(const std::string& csv) {
  std::vector<std::vector<std::string>> rows;
  std::istringstream in(csv);
  for (std::string line; std::getline(in, line);) {
    std::vector<std::string> f;
    std::istringstream l(line);
    for (std::string x; std::getline(l, x, ',');) f.push_back(x);
    rows.push_back(f);
  }
  return rows;
}

int Column(const std::vector<std::string>& header, const std::string& name) {
  for (size_t i = 0; i < header.size(); ++i)
    if (header[i] == name) return static_cast<int>(i);
  ADD_FAILURE() << "no column " << name;
  return 0;
}

/// mpirun's arguments before the command. Under AddressSanitizer the ranks keep its checks but not
/// the leak report: Open MPI keeps what MPI_Init allocates, partly in components it has unloaded,
/// which no suppression can name (the rest of the suite's leak checks are untouched).
std::vector<std::string> MpiRun(const std::string& mpirun, const char* ranks) {
  std::vector<std::string> a = {mpirun, "--oversubscribe", "-n", ranks};
#if defined(__SANITIZE_ADDRESS__)
  a.insert(a.end(), {"-x", "ASAN_OPTIONS=detect_leaks=0"});
#endif
  return a;
}

TEST(SweepCli, MassSpringDamperOnThreadsAndRanksGivesOneTable) {
  TempDir dir;
  const auto threads = (dir.path() / "threads").string();
  const auto r = RunProgram({MULTIBOND_CLI, "sweep", kStudy, "-o", threads, "--jit", "off", "--threads", "2"}, 120);
  ASSERT_EQ(r.code, 0) << r.out;
  const std::string table = ReadFile(dir.path() / "threads" / "sweep.csv");
  const auto rows = Rows(table);
  ASSERT_EQ(rows.size(), 21u);
  const int k = Column(rows[0], "k"), xf = Column(rows[0], "x_final"), xm = Column(rows[0], "x_max"), st = Column(rows[0], "status");
  for (size_t i = 1; i < rows.size(); ++i) {
    const double kv = std::stod(rows[i][k]), zeta = 2.0 / (2 * std::sqrt(kv));
    EXPECT_EQ(rows[i][st], "ok");
    EXPECT_NEAR(std::stod(rows[i][xf]), 1 / kv, 1e-8);
    const double peak = (1 / kv) * (1 + std::exp(-M_PI * zeta / std::sqrt(1 - zeta * zeta)));
    EXPECT_NEAR(std::stod(rows[i][xm]), peak, 1e-3 * peak);
  }
  EXPECT_EQ(std::stod(rows[1][k]), 10.0);
  EXPECT_EQ(std::stod(rows[20][k]), 1000.0);
  for (const char* plot : {"x_final_vs_k.svg", "x_max_vs_k.svg"}) EXPECT_TRUE(std::filesystem::exists(dir.path() / "threads" / "plots" / plot)) << plot;

  const std::string mpirun = MULTIBOND_MPIEXEC;
  if (mpirun.empty()) GTEST_SKIP() << "no mpirun: the MPI half is not tested";
  // CI runs as root; Open MPI refuses that unless told.
  setenv("OMPI_ALLOW_RUN_AS_ROOT", "1", 1);
  setenv("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1", 1);
  for (const char* ranks : {"1", "2", "4"}) {
    const auto out = (dir.path() / (std::string("ranks") + ranks)).string();
    std::vector<std::string> argv = MpiRun(mpirun, ranks);
    argv.insert(argv.end(), {MULTIBOND_CLI, "sweep", kStudy, "-o", out, "--jit", "off"});
    const auto m = RunProgram(argv, 180);
    ASSERT_EQ(m.code, 0) << ranks << " ranks: " << m.out;
    EXPECT_NE(m.out.find(std::string("on ") + ranks + " rank"), std::string::npos) << m.out;
    EXPECT_EQ(ReadFile(std::filesystem::path(out) / "sweep.csv"), table) << ranks << " ranks";
  }
}

TEST(SweepCli, BadInputIsRefusedBeforeAnyRun) {
  TempDir dir;
  const auto out = (dir.path() / "out").string();
  struct Case {
    std::vector<std::string> args;
    std::string expect;
  };
  const std::vector<Case> cases = {
      {{"--grid", "kk=10:100:log:5", "--keep", "x=final:spring.q"}, "<command line>:1:8: error: kk: the model"},
      {{"--grid", "k=100:10:log:5", "--keep", "x=final:spring.q"}, "reversed"},
      {{"--grid", "k=10:10:5", "--keep", "x=final:spring.q"}, "empty"},
      {{"--sample", "k=gauss:1:2", "--samples", "5", "--seed", "1", "--keep", "x=final:spring.q"}, "unknown distribution 'gauss'"},
      {{"--sample", "k=uniform:1:2", "--samples", "5", "--keep", "x=final:spring.q"}, "without a seed"},
      {{"--grid", "k=10:100:5", "--keep", "x=max:sprng.q"}, "did you mean 'spring.q'?"},
  };
  for (const Case& c : cases) {
    std::vector<std::string> argv = {MULTIBOND_CLI, "sweep", kModel, "-o", out};
    argv.insert(argv.end(), c.args.begin(), c.args.end());
    const auto r = RunProgram(argv);
    EXPECT_EQ(r.code, 64) << r.out;
    EXPECT_NE(r.out.find(c.expect), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("nothing was run"), std::string::npos) << r.out;
    EXPECT_FALSE(std::filesystem::exists(out));
  }
  // A study file's problem: at its line and column.
  const auto study = dir.path() / "study.yaml";
  {
    std::ofstream s(study);
    s << "model: " << kModel << "\nsweep:\n  k: {from: 10, to: 1000, count: 5}\nkeep:\n  x: {max: spring.qq}\n";
  }
  const auto r = RunProgram({MULTIBOND_CLI, "sweep", study.string(), "-o", out});
  EXPECT_EQ(r.code, 64);
  EXPECT_NE(r.out.find(study.string() + ":5:12: error: x: 'spring.qq' names no result column"), std::string::npos) << r.out;
}

TEST(SweepCli, AJournalThatIsAFifoIsRefusedNotWaitedOn) {
  // A FIFO at sweep.journal hung the sweep (opening it waited for a reader), with and without
  // --resume: it is refused as not a regular file, at once.
  TempDir dir;
  const auto out = dir.path() / "out";
  std::filesystem::create_directories(out);
  ASSERT_EQ(::mkfifo((out / "sweep.journal").c_str(), 0600), 0);
  for (const bool resume : {false, true}) {
    std::vector<std::string> argv = {MULTIBOND_CLI, "sweep", kModel, "-o", out.string(), "--jit", "off", "--grid", "k=10:100:3", "--keep",
                                     "x=final:spring.q"};
    if (resume) argv.push_back("--resume");
    const auto r = RunProgram(argv, 20);
    EXPECT_FALSE(r.timed_out) << (resume ? "--resume: " : "") << r.out;
    EXPECT_NE(r.code, 0) << r.out;
    EXPECT_NE(r.out.find("is a FIFO (named pipe), not a regular file"), std::string::npos) << r.out;
  }
}

TEST(SweepCli, ResumeGoesOnFromTheJournal) {
  TempDir dir;
  const auto out = (dir.path() / "out").string();
  const std::vector<std::string> argv = {MULTIBOND_CLI, "sweep", kModel, "-o", out, "--jit", "off", "--list", "k=100,200,300,400", "--keep",
                                         "x=final:spring.q", "--t-end", "0.5"};
  ASSERT_EQ(RunProgram(argv).code, 0);
  const std::string full = ReadFile(std::filesystem::path(out) / "sweep.csv");
  const auto journal = std::filesystem::path(out) / "sweep.journal";
  const std::string j = ReadFile(journal);
  size_t cut = 0;
  for (int lines = 0; lines < 3; ++lines) cut = j.find('\n', cut) + 1;
  {
    std::ofstream f(journal, std::ios::trunc | std::ios::binary);
    f << j.substr(0, cut);
  }
  auto resume = argv;
  resume.push_back("--resume");
  const auto r = RunProgram(resume);
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("2 from the journal"), std::string::npos) << r.out;
  EXPECT_EQ(ReadFile(std::filesystem::path(out) / "sweep.csv"), full);
  // Another study into the same folder, resumed: refused.
  auto other = resume;
  other[8] = "k=100,200,300,401";
  const auto o = RunProgram(other);
  EXPECT_EQ(o.code, 64) << o.out;
  EXPECT_NE(o.out.find("another study"), std::string::npos) << o.out;
  // The same under mpirun: rank 0 refuses, and ends the ranks waiting for it (no hang).
  const std::string mpirun = MULTIBOND_MPIEXEC;
  if (mpirun.empty()) GTEST_SKIP() << "no mpirun";
  setenv("OMPI_ALLOW_RUN_AS_ROOT", "1", 1);
  setenv("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1", 1);
  std::vector<std::string> ranks = MpiRun(mpirun, "2");
  ranks.insert(ranks.end(), other.begin(), other.end());
  const auto m = RunProgram(ranks, 120);
  EXPECT_FALSE(m.timed_out);
  EXPECT_EQ(m.code, 64) << m.out;
  EXPECT_NE(m.out.find("another study"), std::string::npos) << m.out;
}

}  // namespace
}  // namespace multibond
