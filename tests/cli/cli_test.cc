// The command line as users and scripts see it: exit codes, files written (or not), messages.

#include <stdlib.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <utility>
#include <vector>

#include <algorithm>
#include <chrono>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "support/alive.h"
#include "support/nonlinear_pair.h"
#include "support/temp_dir.h"
#include "support/text_edit.h"

namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using ::testing::Not;
using multibond::testing::ListNames;
using multibond::testing::ReadFile;

struct Result {
  int code;
  std::string out;  // stdout and stderr together
};

/// Runs a shell command line; stdout and stderr together.
Result Shell(const std::string& command) {
  FILE* p = popen(("{ " + command + "\n} 2>&1").c_str(), "r");
  std::string out;
  char buf[4096];
  while (size_t n = fread(buf, 1, sizeof buf, p)) out.append(buf, n);
  const int status = pclose(p);
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, out};
}

Result Cli(const std::string& args) { return Shell(std::string(MULTIBOND_CLI) + " " + args); }


/// A shell test that holds once process $pid has a file open that has no name yet (the results
/// being written, O_TMPFILE) with more than `rows` lines in it (-1: as soon as it is open).
std::string WritingMoreRowsThan(int rows) {
  return "( for f in /proc/$pid/fd/*; do case $(readlink $f) in *'(deleted)'*) [ $(wc -l < $f) -gt " + std::to_string(rows) +
         " ] && exit 0;; esac; done; exit 1 )";
}

std::string Example(const std::string& name) { return std::string(MULTIBOND_SOURCE_DIR) + "/examples/" + name; }

class CliTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("multibond_cli_" + std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
    fs::remove_all(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  /// Runs `multibond run ARGS -o dir_ -q --jit off` in the background and sends it SIGINT `delay`
  /// seconds after the shell test `ready` holds (polled every 0.1 s, at most `polls` times).
  /// Returns its exit code.
  int RunAndInterrupt(const std::string& args, const std::string& ready, int polls, double delay) const {
    const std::string cmd = std::string(MULTIBOND_CLI) + " run " + args + " -o " + dir_.string() +
                            " -q --jit off > /dev/null 2>&1 & pid=$!; for i in $(seq " + std::to_string(polls) + "); do " + ready +
                            " && break; sleep 0.1; done; sleep " + std::to_string(delay) + "; kill -INT $pid; wait $pid; echo $?";
    FILE* p = popen(cmd.c_str(), "r");
    char buf[64] = {0};
    const size_t n = fread(buf, 1, sizeof buf - 1, p);
    pclose(p);
    return std::atoi(std::string(buf, n).c_str());
  }
  fs::path dir_;
};

TEST_F(CliTest, CheckIntegrallyCausalModelExitsZeroAndListsStates) {
  const Result r = Cli("check " + Example("mass_spring_damper.yaml"));
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_THAT(r.out, HasSubstr("integrally causal"));
  EXPECT_THAT(r.out, HasSubstr("spring.q [m]"));
  EXPECT_THAT(r.out, HasSubstr("effort from C 'spring', flow from 1 'j'"));
}

TEST_F(CliTest, CheckRigidGearPairExitsOneNamingTheDependentInertia) {
  const Result r = Cli("check " + Example("rigid_gear_pair.yaml"));
  EXPECT_EQ(r.code, 1);
  EXPECT_THAT(r.out, HasSubstr("rigid_gear_pair.yaml:16:3: error: J2: derivative causality at I 'J2'"));
  EXPECT_THAT(r.out, HasSubstr("TF 'gear'"));
  EXPECT_THAT(r.out, HasSubstr("hint: add a compliant coupling"));
}

TEST_F(CliTest, CheckAlgebraicLoopExitsOne) {
  const Result r = Cli("check " + Example("algebraic_loop.yaml"));
  EXPECT_EQ(r.code, 1);
  EXPECT_THAT(r.out, HasSubstr("algebraic loop"));
}

TEST_F(CliTest, AlgebraicLoopsOptionSolvesTheLoop) {
  const Result c = Cli("check " + Example("algebraic_loop.yaml") + " --algebraic-loops solve");
  EXPECT_EQ(c.code, 0) << c.out;
  EXPECT_THAT(c.out, HasSubstr("solved for j1.f at every evaluation"));
  const Result r = Cli("run " + Example("algebraic_loop.yaml") + " -o " + dir_.string() + " --algebraic-loops solve --t-end 0.05");
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_THAT(r.out, HasSubstr("ok to t = 0.05 s"));
  const Result eq = Cli("equations " + Example("algebraic_loop.yaml") + " --algebraic-loops solve");
  EXPECT_EQ(eq.code, 0) << eq.out;
  EXPECT_THAT(eq.out, HasSubstr("j1.f = 1/R2.R * (V(t) - R1.R * j1.f) + L.p/L.I"));
  EXPECT_EQ(Cli("check " + Example("algebraic_loop.yaml") + " --algebraic-loops error").code, 1);
  EXPECT_EQ(Cli("check " + Example("algebraic_loop.yaml") + " --algebraic-loops maybe").code, 64);
}

TEST_F(CliTest, RunWritesResultsWithUnitsAndRunRecord) {
  const Result r = Cli("run " + Example("mass_spring_damper.yaml") + " -o " + dir_.string() + " --t-end 1 --dt 0.01");
  ASSERT_EQ(r.code, 0) << r.out;
  const std::string csv = ReadFile(dir_ / "results.csv");
  const std::string header = csv.substr(0, csv.find('\n'));
  EXPECT_THAT(header, HasSubstr("time [s],mass.p [N s],spring.q [m]"));
  EXPECT_THAT(header, HasSubstr("energy.residual [-]"));
  EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 102);  // header + 101 samples
  EXPECT_EQ(ListNames(dir_), (std::vector<std::string>{".multibond.lock", "results.csv", "run.json"}));
  const auto run = nlohmann::json::parse(ReadFile(dir_ / "run.json"));
  EXPECT_EQ(run["status"], "ok");
  EXPECT_EQ(run["options"]["t_end"], 1.0);
  EXPECT_EQ(run["options"]["solver"], "bdf");  // the file's choice
  EXPECT_EQ(run["model"]["sha256"].get<std::string>().size(), 64u);
  EXPECT_FALSE(run["multibond_version"].get<std::string>().empty());
  EXPECT_GT(run["solver_stats"]["steps"].get<long>(), 0);
  EXPECT_LT(std::abs(run["energy"]["residual"].get<double>()), 1e-8);
}

TEST_F(CliTest, RunRecordsTheWallTimeOfEachPhase) {
  // run.json's phase_seconds: every phase from loading the model to writing the results, each a
  // time (nonnegative), together no more than the command's wall time, as it records it and as
  // measured from outside.
  const auto start = std::chrono::steady_clock::now();
  const Result r = Cli("run " + Example("mass_spring_damper.yaml") + " -o " + dir_.string() + " --t-end 1 --dt 0.01");
  const double outside = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  ASSERT_EQ(r.code, 0) << r.out;
  const auto run = nlohmann::json::parse(ReadFile(dir_ / "run.json"));
  ASSERT_TRUE(run.contains("phase_seconds"));
  const nlohmann::json& phases = run["phase_seconds"];
  double sum = 0.0;
  for (const char* phase : {"load", "causality", "compile_plan", "constraints", "generate_code", "setup", "integrate", "write_results"}) {
    ASSERT_TRUE(phases.contains(phase)) << phase;
    ASSERT_TRUE(phases[phase].is_number()) << phase;
    EXPECT_GE(phases[phase].get<double>(), 0.0) << phase;
    sum += phases[phase].get<double>();
  }
  EXPECT_EQ(phases.size(), 8u);
  EXPECT_GT(phases["integrate"].get<double>(), 0.0);
  EXPECT_LE(sum, run["command_wall_seconds"].get<double>());
  EXPECT_LE(run["command_wall_seconds"].get<double>(), outside);
}

TEST_F(CliTest, RunIsDeterministic) {
  const fs::path a = dir_ / "a", b = dir_ / "b";
  ASSERT_EQ(Cli("run " + Example("dc_motor.yaml") + " -o " + a.string() + " --t-end 0.5").code, 0);
  ASSERT_EQ(Cli("run " + Example("dc_motor.yaml") + " -o " + b.string() + " --t-end 0.5").code, 0);
  EXPECT_EQ(ReadFile(a / "results.csv"), ReadFile(b / "results.csv"));
}

// A model file's warnings are said on the terminal and kept in run.json (model_warnings): here a
// joint whose attachment points are apart at the start.
TEST_F(CliTest, TheModelFilesWarningsAreInRunJson) {
  const fs::path model = dir_.string() + "_gap.yaml";
  std::ofstream(model) << "model: gap\nbodies:\n  b: {mass: 1, inertia: [1, 1, 1], position: [0, 0, 0]}\n"
                          "joints:\n  j: {parent: ground, child: b, at: [0.1, 0, 0], child_at: [0, 0, 0], translation: {K: 100, R: 1}}\n";
  const Result r = Cli("run " + model.string() + " -o " + dir_.string() + " --t-end 0.01 --dt 0.01");
  fs::remove(model);
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_THAT(r.out, HasSubstr("warning: j: the attachment points are"));
  const auto run = nlohmann::json::parse(ReadFile(dir_ / "run.json"));
  ASSERT_EQ(run["model_warnings"].size(), 1u) << run["model_warnings"];
  EXPECT_EQ(run["model_warnings"][0]["code"], "mech.initial_gap");
  EXPECT_EQ(run["model_warnings"][0]["element"], "j");
  EXPECT_THAT(run["model_warnings"][0]["where"].get<std::string>(), HasSubstr("_gap.yaml:5:"));
  // A model without warnings records an empty list.
  ASSERT_EQ(Cli("run " + Example("mass_spring_damper.yaml") + " -o " + dir_.string() + "_none --t-end 0.01 --dt 0.01").code, 0);
  const auto none = nlohmann::json::parse(ReadFile(fs::path(dir_.string() + "_none") / "run.json"));
  fs::remove_all(dir_.string() + "_none");
  EXPECT_TRUE(none["model_warnings"].is_array() && none["model_warnings"].empty());
}

TEST_F(CliTest, ModelErrorExitsOneAndCreatesNothing) {
  const fs::path bad = dir_.string() + "_bad.yaml";
  std::ofstream(bad) << "elements:\n  m: {type: I, inertia: -1}\n  s: {type: Se, effort: 1}\nbonds: [s -> m]\n";
  const Result r = Cli("run " + bad.string() + " -o " + dir_.string());
  fs::remove(bad);
  EXPECT_EQ(r.code, 1);
  EXPECT_THAT(r.out, HasSubstr(":2:3: error: m: inertia must be > 0 (got -1)"));
  EXPECT_THAT(r.out, HasSubstr("nothing was written"));
  EXPECT_FALSE(fs::exists(dir_));
}

TEST_F(CliTest, AnEnergyBalanceThatDoesNotCloseIsAWarning) {
  // RK4 at a tenth of the oscillator's period loses 1.2 % of the energy that flowed: said on the
  // terminal and in run.json; at a hundredth (residual 4e-7) nothing is said.
  Result r = Cli("run " + Example("mass_spring_damper.yaml") + " -o " + dir_.string() + " --solver rk4 --step 0.1 --dt 0.1");
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_THAT(r.out, HasSubstr("warning: the energy balance does not close: at t = 5 s"));
  EXPECT_THAT(r.out, HasSubstr("take a smaller fixed step"));
  auto run = nlohmann::json::parse(ReadFile(dir_ / "run.json"));
  ASSERT_EQ(run["warnings"].size(), 1u);
  EXPECT_GT(std::abs(run["energy"]["residual"].get<double>()), 1e-3);
  r = Cli("run " + Example("mass_spring_damper.yaml") + " -o " + dir_.string() + " --solver rk4 --step 0.01 --dt 0.1");
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_THAT(r.out, Not(HasSubstr("warning")));
  run = nlohmann::json::parse(ReadFile(dir_ / "run.json"));
  EXPECT_TRUE(run["warnings"].empty());
}

TEST_F(CliTest, UnreadableModelFileExits74AndCreatesNothing) {
  // A model file that cannot be read is an input/output failure (README: 74), not a model error.
  for (const std::string cmd : {"check", "run", "graph", "equations"}) {
    const std::string out = cmd == "run" ? " -o " + dir_.string() : cmd == "graph" ? " -o " + (dir_ / "g.svg").string() : "";
    const Result r = Cli(cmd + " " + (dir_.string() + "_no_such_model.yaml") + out);
    EXPECT_EQ(r.code, 74) << cmd << ": " << r.out;
    EXPECT_THAT(r.out, HasSubstr("cannot open the model file")) << cmd;
    EXPECT_THAT(r.out, Not(HasSubstr("error in the model"))) << cmd;
  }
  EXPECT_FALSE(fs::exists(dir_));
  // A folder given as the model file.
  const Result folder = Cli("check " + std::string(MULTIBOND_SOURCE_DIR) + "/examples");
  EXPECT_EQ(folder.code, 74) << folder.out;
  EXPECT_THAT(folder.out, HasSubstr("cannot read the model file: it is a directory"));
}

TEST_F(CliTest, UsageErrorsExit64) {
  EXPECT_EQ(Cli("").code, 64);
  EXPECT_EQ(Cli("frobnicate").code, 64);
  EXPECT_EQ(Cli("run " + Example("mass_spring_damper.yaml")).code, 64);  // no -o
  EXPECT_EQ(Cli("run " + Example("mass_spring_damper.yaml") + " -o " + dir_.string() + " --rtol -1").code, 64);
  const Result r = Cli("run " + Example("mass_spring_damper.yaml") + " -o " + dir_.string() + " --solver euler");
  EXPECT_EQ(r.code, 64);
  EXPECT_THAT(r.out, HasSubstr("bdf"));
  // An empty output name names nothing: a usage error, said before anything runs.
  for (const std::string& cmd : {"run " + Example("mass_spring_damper.yaml") + " -o ''",
                                 "graph " + Example("mass_spring_damper.yaml") + " -o ''"}) {
    const Result empty = Cli(cmd);
    EXPECT_EQ(empty.code, 64) << cmd << "\n" << empty.out;
    EXPECT_THAT(empty.out, HasSubstr("empty string")) << cmd;
  }
}

TEST_F(CliTest, GraphIntoAFolderThatIsAFileSaysSoAndExits74) {
  fs::create_directories(dir_);
  const fs::path file = dir_ / "afile";
  std::ofstream(file) << "not a folder\n";
  const Result r = Cli("graph " + Example("mass_spring_damper.yaml") + " -o " + (file / "g.dot").string());
  EXPECT_EQ(r.code, 74) << r.out;
  EXPECT_THAT(r.out, HasSubstr("cannot create the folder '" + file.string() + "'")) << r.out;
  EXPECT_FALSE(fs::exists(file / "g.dot"));
}

// Options a run would refuse are refused before anything is written (the output folder is not
// created), with a message that says what is expected; rk4's step cannot pass the output times.
TEST_F(CliTest, RefusedOptionsCreateNothingAndSayWhatIsExpected) {
  const std::string base = "run " + Example("mass_spring_damper.yaml") + " -o " + dir_.string();
  for (const auto& [args, expected] : std::vector<std::pair<std::string, std::string>>{
           {" --solver rk4", "rk4 needs a fixed step"},
           {" --solver rk4 --step 0.01 --dt 0.001", "longer than the output interval"},
           {" --solver bdf --step 0.01", "chooses its own steps"},
           {" --t-end 1e14", "output rows"},
           {" --t-end 1e16 --dt 1e10", "a run to 1e+16 s goes beyond 1e+15 s"},
           {" --t-end 0", "must be > 0 (got 0)"},
           {" --t-end 1s", "'1s' is not a number"},
           {" --rtol 1", "rtol is a relative tolerance and must be below 1"}}) {
    const Result r = Cli(base + args);
    EXPECT_EQ(r.code, 64) << args << ": " << r.out;
    EXPECT_THAT(r.out, HasSubstr(expected)) << args;
    EXPECT_FALSE(fs::exists(dir_)) << args << " created the output folder";
  }
}

// A model file's fixed step belongs to its solver: --solver bdf on the command line leaves it.
TEST_F(CliTest, TheFilesFixedStepDoesNotFollowAnotherSolver) {
  fs::create_directories(dir_);
  std::string text = ReadFile(Example("mass_spring_damper.yaml"));
  const std::string settings = "simulation: {t_end: 5, dt: 0.001, solver: bdf, rtol: 1.0e-10, atol: 1.0e-12}";
  ASSERT_NE(text.find(settings), std::string::npos);
  text.replace(text.find(settings), settings.size(), "simulation: {solver: rk4, step: 1.0e-3, t_end: 0.05}");
  const fs::path model = dir_ / "rk4.yaml";
  std::ofstream(model) << text;
  EXPECT_EQ(Cli("run " + model.string() + " -q -o " + (dir_ / "a").string()).code, 0);
  const Result bdf = Cli("run " + model.string() + " -q --solver bdf -o " + (dir_ / "b").string());
  EXPECT_EQ(bdf.code, 0) << bdf.out;
  EXPECT_EQ(Cli("run " + model.string() + " -q --solver bdf --step 1e-3 -o " + (dir_ / "c").string()).code, 64);
}

// The output grid is 0, dt, 2 dt, ... and t_end, also when t_end is not a multiple of dt.
TEST_F(CliTest, OutputGridEndsExactlyAtTheEndTime) {
  const Result r = Cli("run " + Example("mass_spring_damper.yaml") + " -o " + dir_.string() + " --t-end 1 --dt 0.3");
  ASSERT_EQ(r.code, 0) << r.out;
  std::istringstream csv(ReadFile(dir_ / "results.csv"));
  std::string line;
  std::vector<double> times;
  std::getline(csv, line);  // header
  while (std::getline(csv, line))
    if (!line.empty() && line[0] != '#') times.push_back(std::stod(line.substr(0, line.find(','))));
  ASSERT_EQ(times.size(), 5u);
  const double expected[] = {0.0, 0.3, 0.6, 0.9, 1.0};
  for (size_t k = 0; k < times.size(); ++k) EXPECT_NEAR(times[k], expected[k], 1e-12) << k;
}

// --coordinates: the integrator's variables. The same model and columns; recorded in run.json;
// refused for a model without bodies and for an unknown choice (exit 64, nothing written).
TEST_F(CliTest, CoordinatesOptionChangesTheVariablesNotTheResults) {
  const std::string model = Example("differential_ideal.yaml");
  const std::string common = " --t-end 0.2 --dt 0.01 --solver bdf --rtol 1e-10 --atol 1e-12";
  const Result joint = Cli("run " + model + " -o " + dir_.string() + "_joint" + common);  // the file's: joint
  const Result inertial = Cli("run " + model + " -o " + dir_.string() + "_inertial --coordinates inertial" + common);
  ASSERT_EQ(joint.code, 0) << joint.out;
  ASSERT_EQ(inertial.code, 0) << inertial.out;
  EXPECT_EQ(nlohmann::json::parse(ReadFile(fs::path(dir_.string() + "_joint") / "run.json"))["options"]["coordinates"], "joint");
  EXPECT_EQ(nlohmann::json::parse(ReadFile(fs::path(dir_.string() + "_inertial") / "run.json"))["options"]["coordinates"], "inertial");
  const std::string a = ReadFile(fs::path(dir_.string() + "_joint") / "results.csv");
  const std::string b = ReadFile(fs::path(dir_.string() + "_inertial") / "results.csv");
  auto header = [](const std::string& csv) {
    const size_t at = csv.find("time [s]");
    return at == std::string::npos ? std::string() : csv.substr(at, csv.find('\n', at) - at);
  };
  EXPECT_FALSE(header(a).empty());
  EXPECT_EQ(header(a), header(b));  // the same columns
  const Result c = Cli("compare " + model + " " + model + " --coordinates inertial" + common);
  ASSERT_EQ(c.code, 0) << c.out;
  fs::remove_all(dir_.string() + "_joint");
  fs::remove_all(dir_.string() + "_inertial");
  const Result none = Cli("run " + Example("mass_spring_damper.yaml") + " -o " + dir_.string() + " --coordinates joint");
  EXPECT_EQ(none.code, 64) << none.out;
  EXPECT_THAT(none.out, HasSubstr("no bodies"));
  EXPECT_FALSE(fs::exists(dir_ / "results.csv"));
  EXPECT_EQ(Cli("run " + model + " -o " + dir_.string() + " --coordinates polar").code, 64);
}

TEST_F(CliTest, JacobianOptionIsRecordedAndCheckedAgainstTheModel) {
  const Result r = Cli("run " + Example("mass_spring_damper.yaml") + " -o " + dir_.string() + " --t-end 0.1 --jacobian sparse");
  ASSERT_EQ(r.code, 0) << r.out;
  const auto run = nlohmann::json::parse(ReadFile(dir_ / "run.json"));
  EXPECT_EQ(run["options"]["jacobian"], "sparse");
  EXPECT_EQ(run["solver_stats"]["jacobian"], "sparse");
  EXPECT_GE(run["solver_stats"]["evals_per_jacobian"].get<long>(), 1);
  EXPECT_EQ(Cli("run " + Example("mass_spring_damper.yaml") + " -o " + dir_.string() + " --jacobian banded").code, 64);
  // A model with ideal constraints: every column full but the energy integrals' (no structure
  // through the constraint solve), which a sparse factorisation takes as it is.
  const Result ideal = Cli("run " + Example("rigid_gear_pair.yaml") + " -o " + dir_.string() +
                           "_ideal --constraints ideal --solver bdf --jacobian sparse --t-end 0.1");
  EXPECT_EQ(ideal.code, 0) << ideal.out;
  EXPECT_EQ(nlohmann::json::parse(ReadFile(fs::path(dir_.string() + "_ideal") / "run.json"))["solver_stats"]["jacobian"], "sparse");
  fs::remove_all(dir_.string() + "_ideal");
  // With an explicit solver it changes nothing, and the run says so.
  const Result rk = Cli("run " + Example("mass_spring_damper.yaml") + " -o " + dir_.string() +
                        " --t-end 0.1 --solver dopri5 --jacobian dense");
  EXPECT_EQ(rk.code, 0) << rk.out;
  EXPECT_THAT(rk.out, HasSubstr("warning: --jacobian dense has no effect with the explicit solver 'dopri5'"));
  EXPECT_THAT(Cli("run " + Example("mass_spring_damper.yaml") + " -o " + dir_.string() + " --t-end 0.1").out,
              Not(HasSubstr("--jacobian")));
}

TEST_F(CliTest, DivergingRunExitsTwoKeepsResultsAndMarksThemFailed) {
  // RK4 with a step far beyond its stability limit (w h = 5): the state overflows.
  const Result r = Cli("run " + Example("mass_spring_damper.yaml") + " -o " + dir_.string() +
                       " --solver rk4 --step 0.5 --dt 0.5 --t-end 500");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_THAT(r.out, HasSubstr("at t = "));
  EXPECT_THAT(r.out, HasSubstr("the states that failed first: "));
  EXPECT_THAT(r.out, HasSubstr("hint: try a smaller fixed step (--step, now 0.5 s)"));  // not --rtol, which rk4 ignores
  const auto run = nlohmann::json::parse(ReadFile(dir_ / "run.json"));
  EXPECT_EQ(run["status"], "failed");
  EXPECT_LT(run["t_reached"].get<double>(), 500.0);
  EXPECT_GT(run["t_reached"].get<double>(), 0.0);
  const std::string csv = ReadFile(dir_ / "results.csv");
  EXPECT_GT(std::count(csv.begin(), csv.end(), '\n'), 2);  // the samples up to the failure are kept
}

TEST_F(CliTest, DerivativesThatOverflowAtTheStartAreSaidByStateName) {
  // m's flow p / I = 1e308 / 1e-10 overflows: the spring's rate and the source's power are infinite
  // at t = 0. Said as such, before any step (the solvers failed at h = 0, or at t = NaN).
  fs::create_directories(dir_);
  std::ofstream(dir_ / "huge.yaml") << R"(model: huge
elements:
  f: {type: Se, effort: 1.0}
  v: {type: "1"}
  m: {type: I, inertia: 1.0e-10, p0: 1.0e308}
  c: {type: C, stiffness: 1.0}
bonds: [f -> v, v -> m, v -> c]
)";
  for (const char* solver : {"bdf", "dopri5"}) {
    const Result r = Cli("run " + (dir_ / "huge.yaml").string() + " -o " + (dir_ / solver).string() + " --jit off --solver " + solver);
    EXPECT_EQ(r.code, 2) << r.out;
    EXPECT_THAT(r.out, HasSubstr("at t = 0 s: the derivatives of the initial state are not finite (infinite or NaN): c.q, f.work"));
    EXPECT_THAT(r.out, HasSubstr("hint: check the parameters and initial values"));
    EXPECT_EQ(nlohmann::json::parse(ReadFile(dir_ / solver / "run.json"))["status"], "failed");
  }
}

// Ctrl-C stops a run within a step, not at the end of an output interval (here 50 s of model time
// at fixed steps of 1e-6 s: 5e7 steps, about 12 s here before the first output after t = 0); the
// rows written until then are kept. (An adaptive solver at --max-step 1e-5 reached its step limit,
// exit 2, within 0.45 s: a race with the interrupt on a loaded machine.)
TEST_F(CliTest, AnInterruptIsHonouredWithinAnOutputInterval) {
  EXPECT_EQ(RunAndInterrupt(Example("mass_spring_damper.yaml") + " --t-end 100 --dt 50 --solver rk4 --step 1e-6", WritingMoreRowsThan(-1), 600, 0.3),
            130);
  const auto run = nlohmann::json::parse(ReadFile(dir_ / "run.json"));
  EXPECT_EQ(run["status"], "interrupted");
  EXPECT_EQ(run["t_reached"].get<double>(), 0.0);
}

// A step-choosing solver that needs more than max_steps_per_output steps in one output interval is
// told to shorten the interval (and, with --max-step, to raise it), not to tighten the tolerance or
// to use the solver it already uses; no state "failed first". A fixed step takes its dt / step steps
// per interval, however many (2e6 here).
TEST_F(CliTest, TooManyStepsPerOutputIntervalGetsItsOwnAdvice) {
  const Result r = Cli("run " + Example("mass_spring_damper.yaml") + " -o " + (dir_ / "bdf").string() +
                       " --t-end 40 --dt 20 --max-step 1e-5 --jit off -q");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_THAT(r.out, HasSubstr("hint: a shorter output interval (--dt, now 20 s) lets the solver take more steps; or a larger --max-step (now 1e-05 s)"));
  EXPECT_THAT(r.out, Not(HasSubstr("--solver bdf")));
  EXPECT_THAT(r.out, Not(HasSubstr("failed first")));
  const Result fixed = Cli("run " + Example("mass_spring_damper.yaml") + " -o " + (dir_ / "rk4").string() +
                           " --t-end 2 --dt 2 --solver rk4 --step 1e-6 --jit off -q");
  EXPECT_EQ(fixed.code, 0) << fixed.out;
}

// Output names that cannot be taken are said before any run (run.json is written after it), and
// compare passes on what its runs warn about.
TEST_F(CliTest, OutputClashesAreSaidBeforeRunningAndCompareRepeatsWarnings) {
  fs::create_directories(dir_ / "out" / "run.json");
  const Result r = Cli("run " + Example("mass_spring_damper.yaml") + " -o " + (dir_ / "out").string() + " --jit off");
  EXPECT_EQ(r.code, 74) << r.out;
  EXPECT_THAT(r.out, HasSubstr("run.json': it is a directory"));
  EXPECT_FALSE(fs::exists(dir_ / "out" / "results.csv"));
  const Result c = Cli("compare " + Example("mass_spring_damper.yaml") + " " + Example("mass_spring_damper.yaml") + " -o " +
                       (dir_ / "out").string() + " --jit off");
  EXPECT_EQ(c.code, 74) << c.out;
  EXPECT_THAT(c.out, HasSubstr("it is a directory"));
  const Result w = Cli("compare " + Example("mass_spring_damper.yaml") + " " + Example("mass_spring_damper.yaml") +
                       " --rtol 0.9 --atol 1e-2 --jit off");
  EXPECT_EQ(w.code, 0) << w.out;
  EXPECT_THAT(w.out, HasSubstr("warning: A ("));
  EXPECT_THAT(w.out, HasSubstr("the energy balance does not close"));
}

TEST_F(CliTest, EquationsTextAndLatex) {
  Result r = Cli("equations " + Example("mass_spring_damper.yaml"));
  EXPECT_EQ(r.code, 0);
  EXPECT_THAT(r.out, HasSubstr("d(mass.p)/dt = force(t) - spring.K spring.q - damper.R * mass.p/mass.I"));
  r = Cli("equations " + Example("mass_spring_damper.yaml") + " --format latex");
  EXPECT_EQ(r.code, 0);
  EXPECT_THAT(r.out, HasSubstr("\\dot{p}_{\\mathrm{mass}}"));
  EXPECT_THAT(r.out, HasSubstr("\\mathrm{force}(t)"));  // a step: a function of time
  EXPECT_EQ(Cli("equations " + Example("rigid_gear_pair.yaml")).code, 1);
  // A nonlinear law typeset as mathematics (#43: it was verbatim in \mathtt{}), at the variable it
  // is evaluated at; a constant force as a constant.
  r = Cli("equations " + Example("linear/bilinear_damper.yaml") + " --format latex");
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_THAT(r.out, HasSubstr("\\mathrm{c\\_bump} \\, \\max\\left(f, 0\\right) + \\mathrm{c\\_reb} \\, \\min\\left(f, 0\\right)\\right|_{f = \\mathrm{j.f}}"));
  EXPECT_THAT(r.out, HasSubstr("&= \\mathrm{force} - K_{\\mathrm{spring}}"));
  EXPECT_THAT(r.out, Not(HasSubstr("\\mathtt")));
  r = Cli("equations " + Example("linear/bilinear_damper.yaml"));
  EXPECT_THAT(r.out, HasSubstr("force(t)"));  // the text keeps its form
}

TEST_F(CliTest, GraphWritesDotAndSvg) {
  const Result r = Cli("graph " + Example("compliant_gear_pair.yaml") + " -o " + (dir_ / "g.svg").string());
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_THAT(ReadFile(dir_ / "g.dot"), HasSubstr("digraph"));
  EXPECT_THAT(ReadFile(dir_ / "g.svg"), HasSubstr("<svg"));
  // The extension in any case; anything else is a usage error that writes nothing.
  EXPECT_EQ(Cli("graph " + Example("compliant_gear_pair.yaml") + " -o " + (dir_ / "h.SVG").string()).code, 0);
  EXPECT_THAT(ReadFile(dir_ / "h.SVG"), HasSubstr("<svg"));  // the name asked for, not h.svg
  EXPECT_FALSE(fs::exists(dir_ / "h.svg"));
  for (const std::string bad : {"p.pdf", "notes.txt", ".dot"}) {
    const Result b = Cli("graph " + Example("compliant_gear_pair.yaml") + " -o " + (dir_ / bad).string());
    EXPECT_EQ(b.code, 64) << bad << ": " << b.out;
    EXPECT_THAT(b.out, HasSubstr("must end in .dot, .gv, .svg or .png")) << bad;
  }
  EXPECT_FALSE(fs::exists(dir_ / "p.dot"));
  EXPECT_FALSE(fs::exists(dir_ / "notes.dot"));
}

TEST_F(CliTest, Version) {
  const Result r = Cli("version");
  EXPECT_EQ(r.code, 0);
  EXPECT_THAT(r.out, HasSubstr("multibond 0."));
}

}  // namespace

namespace {

TEST_F(CliTest, InterruptStopsCleanlyAndKeepsWhatWasComputed) {
  // A long run of the differential, interrupted with SIGINT once it has written some rows (polled,
  // not a fixed delay: under the sanitizers on a loaded machine 1.5 s gave only 6 rows).
  EXPECT_EQ(RunAndInterrupt(Example("differential.yaml") + " --t-end 1000", WritingMoreRowsThan(20), 1200, 0.0), 130);
  const auto run = nlohmann::json::parse(ReadFile(dir_ / "run.json"));
  EXPECT_EQ(run["status"], "interrupted");
  EXPECT_GT(run["t_reached"].get<double>(), 0.0);
  EXPECT_LT(run["t_reached"].get<double>(), 1000.0);
  EXPECT_EQ(ListNames(dir_), (std::vector<std::string>{".multibond.lock", "results.csv", "run.json"}));
  const std::string csv = ReadFile(dir_ / "results.csv");
  EXPECT_GT(std::count(csv.begin(), csv.end(), '\n'), 10);
}

}  // namespace

namespace {

TEST_F(CliTest, CheckExplainsDerivativeCausalityInMechanismTerms) {
  // A flow source bolted straight onto a body's angular velocity: no compliance in between.
  const fs::path model = dir_.string() + "_rigid_drive.yaml";
  std::ofstream(model) << "bodies:\n"
                          "  G: {shape: {disc: {diameter: 0.1, thickness: 0.01, axis: x}}, density: 2700}\n"
                          "joints:\n"
                          "  G_bearing: {child: G, translation: {K: 1.0e6, R: 20}, rotation: {axes: [y, z], K: 1.0e4, R: 10}}\n"
                          "elements:\n"
                          "  motor: {type: Sf, flow: [50, 0, 0]}\n"
                          "bonds:\n"
                          "  - motor -> G.omega\n";
  const Result r = Cli("check " + model.string());
  fs::remove(model);
  EXPECT_EQ(r.code, 1);
  EXPECT_THAT(r.out, HasSubstr("derivative causality at I 'G.inertia'"));
  EXPECT_THAT(r.out, HasSubstr("in mechanism terms: 'motor' (not a mechanism part) -> body 'G'"));
  EXPECT_THAT(r.out, HasSubstr("connect them through a joint, gear mesh or velocity drive"));
}

}  // namespace

namespace {

// --- check --suggest ---------------------------------------------------------

TEST_F(CliTest, CheckSuggestListsOneCouplingForTheRigidGearPairWithItsDefaults) {
  const Result r = Cli("check " + Example("rigid_gear_pair.yaml") + " --suggest");
  EXPECT_EQ(r.code, 1) << r.out;  // the model as given is still not integrally causal
  EXPECT_THAT(r.out, HasSubstr("f = 100 Hz (default) and zeta = 0.7 (default)"));
  EXPECT_THAT(r.out, HasSubstr("1 coupling:"));
  EXPECT_THAT(r.out, HasSubstr("I 'J2' (dependent: I 'J1' -> 1 'j1' -> TF 'gear' -> 1 'j2' -> I 'J2'), on bond 'j2->J2'"));
  // m_eff = 0.04 * (0.01 / 0.5^2) / (0.04 + 0.04) = 0.02; K = m_eff (2 pi 100)^2; R = 2 0.7 sqrt(K m_eff)
  EXPECT_THAT(r.out, HasSubstr("C 'J2_K' K = 7895.68 N m/rad and R 'J2_R' R = 17.5929 N m s/rad"));
  EXPECT_THAT(r.out, HasSubstr("m_eff = 0.02 kg m^2"));
  EXPECT_THAT(r.out, HasSubstr("the repaired graph is integrally causal"));
  EXPECT_THAT(r.out, HasSubstr("removes at least one derivative causality"));
}

TEST_F(CliTest, CheckSuggestTakesFrequencyAndDampingRatio) {
  const Result r = Cli("check " + Example("rigid_gear_pair.yaml") + " --suggest --frequency 50 --damping-ratio 0.2");
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_THAT(r.out, HasSubstr("f = 50 Hz and zeta = 0.2\n"));
  EXPECT_THAT(r.out, HasSubstr("K = 1973.92 N m/rad"));  // 0.02 (2 pi 50)^2
  EXPECT_EQ(Cli("check " + Example("rigid_gear_pair.yaml") + " --suggest --frequency -1").code, 64);
  EXPECT_EQ(Cli("check " + Example("rigid_gear_pair.yaml") + " --suggest --damping-ratio x").code, 64);
  EXPECT_THAT(Cli("check --help").out, HasSubstr("(default 100)"));
  EXPECT_THAT(Cli("check --help").out, HasSubstr("(default 0.7)"));
}

TEST_F(CliTest, CheckSuggestWriteGivesAModelThatChecksAndRuns) {
  fs::create_directories(dir_);
  const fs::path fixed = dir_ / "fixed.yaml";
  Result r = Cli("check " + Example("rigid_gear_pair.yaml") + " --suggest --write " + fixed.string());
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_THAT(r.out, HasSubstr("wrote " + fixed.string()));
  EXPECT_EQ(ListNames(dir_), std::vector<std::string>{"fixed.yaml"});
  const std::string text = ReadFile(fixed);
  EXPECT_THAT(text, HasSubstr("# Two inertias joined by a rigid gear (TF)"));  // the user's comments are kept
  EXPECT_THAT(text, HasSubstr("  - j2 -> J2_coupling\n  - J2_coupling -> J2\n"));
  r = Cli("check " + fixed.string());
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_THAT(r.out, HasSubstr("integrally causal; 5 states"));
  EXPECT_THAT(r.out, HasSubstr("J2_K.q [rad]"));
  r = Cli("run " + fixed.string() + " -o " + (dir_ / "out").string() + " --t-end 0.2");
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_THAT(ReadFile(dir_ / "out" / "results.csv"), HasSubstr("J2_K.q [rad]"));
}

TEST_F(CliTest, CheckSuggestWriteGivesTwoCouplingsForTwoDependentInertias) {
  fs::create_directories(dir_);
  const fs::path fixed = dir_ / "train.yaml";
  Result r = Cli("check " + std::string(MULTIBOND_SOURCE_DIR) + "/tests/models/rigid_gear_train.yaml --write " + fixed.string());
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_THAT(r.out, HasSubstr("2 couplings:"));
  EXPECT_THAT(r.out, HasSubstr("on bond 'j2->J2'"));
  EXPECT_THAT(r.out, HasSubstr("on bond 'j3->J3'"));
  EXPECT_EQ(Cli("check " + fixed.string()).code, 0);
  EXPECT_EQ(Cli("run " + fixed.string() + " -q -o " + (dir_ / "out").string()).code, 0);
}

TEST_F(CliTest, CheckSuggestWriteFailuresWriteNothing) {
  // A folder that does not exist: 74.
  Result r = Cli("check " + Example("rigid_gear_pair.yaml") + " --write " + (dir_ / "no" / "such" / "f.yaml").string());
  EXPECT_EQ(r.code, 74) << r.out;
  EXPECT_FALSE(fs::exists(dir_ / "no"));
  // An integrally causal model: nothing to repair, nothing written, exit 0.
  fs::create_directories(dir_);
  r = Cli("check " + Example("mass_spring_damper.yaml") + " --suggest --write " + (dir_ / "x.yaml").string());
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_THAT(r.out, HasSubstr("nothing to repair"));
  EXPECT_FALSE(fs::exists(dir_ / "x.yaml"));
}

TEST_F(CliTest, CheckSuggestOnAMechanismFileAnswersInMechanismTerms) {
  fs::create_directories(dir_);
  const fs::path model = dir_ / "rigid_drive.yaml";
  std::ofstream(model) << "bodies:\n"
                          "  G: {shape: {disc: {diameter: 0.1, thickness: 0.01, axis: x}}, density: 2700}\n"
                          "joints:\n"
                          "  G_bearing: {child: G, translation: {K: 1.0e6, R: 20}, rotation: {axes: [y, z], K: 1.0e4, R: 10}}\n"
                          "elements:\n"
                          "  motor: {type: Sf, flow: [50, 0, 0]}\n"
                          "bonds:\n"
                          "  - motor -> G.omega\n";
  const Result r = Cli("check " + model.string() + " --suggest --write " + (dir_ / "fixed.yaml").string());
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_THAT(r.out, HasSubstr("this is a mechanism file"));
  EXPECT_THAT(r.out, HasSubstr("body 'G' (I 'G.inertia')"));
  EXPECT_THAT(r.out, HasSubstr("joint, gear mesh or velocity drive"));
  EXPECT_THAT(r.out, HasSubstr("nothing was written"));
  EXPECT_FALSE(fs::exists(dir_ / "fixed.yaml"));
}

TEST_F(CliTest, ConstraintsOptionIsCheckedAndAcceptedByCheckRunAndCompare) {
  EXPECT_EQ(Cli("check " + Example("mass_spring_damper.yaml") + " --constraints compliant").code, 0);
  EXPECT_EQ(Cli("check " + Example("mass_spring_damper.yaml") + " --constraints bogus").code, 64);
  EXPECT_EQ(Cli("run " + Example("mass_spring_damper.yaml") + " -q --t-end 0.1 --constraints compliant -o " + dir_.string()).code, 0);
  EXPECT_EQ(nlohmann::json::parse(ReadFile(dir_ / "run.json"))["options"]["ideal_constraints"], false);
  EXPECT_EQ(Cli("compare " + Example("mass_spring_damper.yaml") + " " + Example("mass_spring_damper.yaml") +
                " --t-end 0.1 --constraints compliant").code,
            0);
  // compliant: derivative causality stays an error.
  EXPECT_EQ(Cli("check " + Example("rigid_gear_pair.yaml") + " --constraints compliant").code, 1);
}

// Conflicts between options are usage errors (64), whatever command meets them; a plot that
// draws nothing says so and writes no page.
TEST_F(CliTest, OptionConflictsExit64AndAnEmptyPlotSaysSo) {
  fs::create_directories(dir_);
  const fs::path copy = dir_ / "gears.yaml";
  fs::copy_file(Example("rigid_gear_pair.yaml"), copy);
  const std::string before = ReadFile(copy);
  const Result onto_model = Cli("check " + copy.string() + " --constraints ideal --write " + copy.string());
  EXPECT_EQ(onto_model.code, 64) << onto_model.out;
  EXPECT_EQ(ReadFile(copy), before);
  const Result jit = Cli("run " + Example("algebraic_loop.yaml") + " -o " + (dir_ / "loop").string() +
                         " --algebraic-loops solve --jit on --t-end 0.01");
  EXPECT_EQ(jit.code, 64) << jit.out;
  EXPECT_THAT(jit.out, HasSubstr("--jit on"));
  // The paper's figures from a run of another model, without its run.json (which names the
  // model, for the graph of Fig. 2): none can be drawn.
  const fs::path other = dir_ / "msd";
  ASSERT_EQ(Cli("run " + Example("mass_spring_damper.yaml") + " -q --t-end 0.01 -o " + other.string()).code, 0);
  fs::remove(other / "run.json");
  const Result plot = Cli("plot " + other.string() + " --figures " + Example("differential/figures.yaml"));
  EXPECT_EQ(plot.code, 74) << plot.out;
  EXPECT_THAT(plot.out, HasSubstr("error: no figure drawn"));
  EXPECT_FALSE(fs::exists(other / "index.html"));
}

// Without a working compiler, --jit auto runs on the interpreter and says so on the terminal. The
// compile runs in the background and the end of the run cancels it silently (its code was not
// needed): the run here lasts long enough (100,000 steps) for the failing compiler to have failed.
TEST_F(CliTest, AFailedCodeGenerationIsSaid) {
  const char* before = std::getenv("MULTIBOND_CXX");
  const std::string saved = before ? before : "";
  setenv("MULTIBOND_CXX", "false", 1);
  const Result r = Cli("run " + Example("mass_spring_damper.yaml") + " -q --t-end 10 --max-step 1e-4 -o " + dir_.string());
  if (before) setenv("MULTIBOND_CXX", saved.c_str(), 1);
  else unsetenv("MULTIBOND_CXX");
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_THAT(r.out, HasSubstr("warning: running on the interpreter"));
}

// --- compare -----------------------------------------------------------------

class CompareTest : public CliTest {
 protected:
  /// The mass-spring-damper with k = 150 N/m and its spring force output renamed.
  std::string Stiffer() {
    fs::create_directories(dir_);
    std::string text = ReadFile(Example("mass_spring_damper.yaml"));
    text.replace(text.find("stiffness: 100.0"), 16, "stiffness: 150.0");
    text.replace(text.find("name: spring_force"), 18, "name: force_in_spring");
    const fs::path p = dir_ / "stiffer.yaml";
    std::ofstream(p) << text;
    return p.string();
  }
};

std::vector<std::string> Lines(const std::string& text) {
  std::vector<std::string> lines;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

TEST_F(CompareTest, ReportsEachColumnsLargestDifferenceAndWritesCsv) {
  const std::string b = Stiffer(), csv = (dir_ / "report.csv").string();
  const Result r = Cli("compare " + Example("mass_spring_damper.yaml") + " " + b + " --t-end 2 -o " + csv);
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_THAT(r.out, HasSubstr("2001 samples from t = 0 to 2 s (dt 0.001 s); 12 columns in both, by relative difference"));
  EXPECT_THAT(r.out, HasSubstr("only in A (1): spring_force"));
  EXPECT_THAT(r.out, HasSubstr("only in B (1): force_in_spring"));
  EXPECT_THAT(r.out, HasSubstr("largest relative difference: 0.743 in "));
  EXPECT_EQ(ListNames(dir_), (std::vector<std::string>{"report.csv", "stiffer.yaml"}));
  const std::vector<std::string> lines = Lines(ReadFile(csv));
  ASSERT_EQ(lines.size(), 4u + 12u);
  EXPECT_THAT(lines[0], HasSubstr("# multibond compare; A: " + Example("mass_spring_damper.yaml") + " (solver bdf, rtol 1e-10"));
  EXPECT_THAT(lines[0], HasSubstr("B: " + b));
  EXPECT_THAT(lines[0], HasSubstr("t_end 2 s, dt 0.001 s"));
  EXPECT_THAT(lines[0], HasSubstr("multibond 0."));
  EXPECT_EQ(lines[1], "# only in A (1): spring_force");
  EXPECT_EQ(lines[2], "# only in B (1): force_in_spring");
  EXPECT_EQ(lines[3], "column,unit,max_abs_diff,time,scale,relative_diff");
  // The largest relative difference first: the momentum and the velocity (0.743), then the others.
  EXPECT_THAT(lines[4], ::testing::StartsWith("mass.p,N s,0.0640"));
  double previous = 1e300;
  for (size_t k = 4; k < lines.size(); ++k) {
    const double rel = std::stod(lines[k].substr(lines[k].rfind(',') + 1));
    EXPECT_LE(rel, previous) << lines[k];
    previous = rel;
  }
  bool found = false;
  for (const auto& l : lines) found = found || l.rfind("spring.q,m,0.00897", 0) == 0;
  EXPECT_TRUE(found);
}

TEST_F(CompareTest, SortByNameAndTop) {
  const std::string csv = (dir_ / "top.csv").string();
  const Result r = Cli("compare " + Example("mass_spring_damper.yaml") + " " + Stiffer() + " --t-end 0.5 --sort name --top 3 -o " + csv);
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_THAT(r.out, HasSubstr("by name, top 3 shown"));
  const std::vector<std::string> lines = Lines(ReadFile(csv));
  ASSERT_EQ(lines.size(), 4u + 3u);
  EXPECT_THAT(lines[0], HasSubstr("sort name, top 3"));
  EXPECT_THAT(lines[4], ::testing::StartsWith("damper.dissipated,"));
  EXPECT_THAT(lines[5], ::testing::StartsWith("energy.dissipated,"));
  EXPECT_THAT(lines[6], ::testing::StartsWith("energy.kinetic,"));
}

TEST_F(CompareTest, TheSameModelTwiceHasNoDifference) {
  const Result r = Cli("compare " + Example("dc_motor.yaml") + " " + Example("dc_motor.yaml") + " --t-end 0.2 --jit off");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_THAT(r.out, HasSubstr("only in A (0)\nonly in B (0)\n"));
  EXPECT_THAT(r.out, HasSubstr("largest relative difference: 0 in "));
}

TEST_F(CompareTest, ExitCodes) {
  fs::create_directories(dir_);
  const std::string msd = Example("mass_spring_damper.yaml");
  // usage: a missing model, an unknown sort, a bad --top, models on different output grids
  EXPECT_EQ(Cli("compare " + msd).code, 64);
  EXPECT_EQ(Cli("compare " + msd + " " + msd + " --sort size").code, 64);
  EXPECT_EQ(Cli("compare " + msd + " " + msd + " --top 0").code, 64);
  EXPECT_EQ(Cli("compare " + msd + " " + msd + " --solver euler").code, 64);
  Result r = Cli("compare " + msd + " " + Example("rlc_circuit.yaml"));
  EXPECT_EQ(r.code, 64);
  EXPECT_THAT(r.out, HasSubstr("output grids differ"));
  EXPECT_EQ(Cli("compare " + msd + " " + Example("rlc_circuit.yaml") + " --t-end 0.1 --dt 0.001").code, 0);
  // a model error in either model, before anything runs
  r = Cli("compare " + msd + " " + Example("rigid_gear_pair.yaml") + " --t-end 1");
  EXPECT_EQ(r.code, 1);
  EXPECT_THAT(r.out, HasSubstr("derivative causality at I 'J2'"));
  // a solver failure
  r = Cli("compare " + msd + " " + msd + " --solver rk4 --step 0.5 --dt 0.5 --t-end 500 -o " + (dir_ / "r.csv").string());
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_FALSE(fs::exists(dir_ / "r.csv"));
  // the report cannot be written
  r = Cli("compare " + msd + " " + msd + " --t-end 0.1 -o " + (dir_ / "no" / "such" / "r.csv").string());
  EXPECT_EQ(r.code, 74);
  EXPECT_FALSE(fs::exists(dir_ / "no"));
}

}  // namespace

namespace {

TEST_F(CliTest, CheckAcceptsRigidJointsAndSuggestNamesThem) {
  // Rigid joints and meshes are ideal constraints the compiler solves: check must see the
  // causality the compiler sees (their Sf is an effort source of unknown reaction), not conflicts.
  Result r = Cli("check " + Example("differential_ideal.yaml"));
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_THAT(r.out, HasSubstr("causal with ideal constraints"));
  r = Cli("check " + Example("differential_ideal.yaml") + " --suggest");
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_THAT(r.out, HasSubstr("nothing to repair"));
  EXPECT_THAT(r.out, HasSubstr("rigid (ideal constraints, solved exactly by their reactions): 16 parts"));
  EXPECT_THAT(r.out, HasSubstr("  - gear mesh 'mesh_GA'\n"));
  EXPECT_THAT(r.out, HasSubstr("give these joints and gear meshes K and R instead of 'rigid'"));
}

TEST_F(CliTest, CheckWithIdealConstraintsAcceptsDerivativeCausality) {
  const Result r = Cli("check " + Example("rigid_gear_pair.yaml") + " --constraints ideal");
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_THAT(r.out, HasSubstr("ideal constraints: 1 storage element in derivative causality, solved exactly: I 'J2'"));
  EXPECT_THAT(r.out, HasSubstr("causal with ideal constraints (1 constraint effort)"));
}

// Derivative causality is said to be solved only once the model compiles: a C cut next to a
// nonlinear formula law is refused (the solver cannot differentiate it), and check must not claim
// first that it is solved exactly.
TEST_F(CliTest, CheckSaysDerivativeCausalityIsSolvedOnlyWhenItIs) {
  fs::create_directories(dir_);
  for (const bool formula : {false, true}) {
    const std::string text = formula ? std::string(multibond::testing::kNonlinearPair)
                                     : multibond::testing::Replaced(multibond::testing::kNonlinearPair, "effort: 10 * q + q^3", "stiffness: 10.0");
    const fs::path model = dir_ / (formula ? "nonlinear.yaml" : "linear.yaml");
    std::ofstream(model) << text;
    const Result r = Cli("check " + model.string());
    if (formula) {
      EXPECT_EQ(r.code, 1) << r.out;
      EXPECT_THAT(r.out, Not(HasSubstr("solved exactly")));
      EXPECT_THAT(r.out, HasSubstr("the formula of k1 for 'z.e' cannot reach an ideal constraint"));
      EXPECT_THAT(r.out, HasSubstr("; C 'k2' is in derivative causality"));
    } else {
      EXPECT_EQ(r.code, 0) << r.out;
      EXPECT_THAT(r.out, HasSubstr("ideal constraints: 1 storage element in derivative causality, solved exactly: C 'k2'"));
    }
  }
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// Output folders on a shared machine: one command at a time, nothing half-written, never onto an
// input (docs/security.md).

namespace {

TEST_F(CliTest, RunJsonRecordsTheSizeAndHashOfItsResults) {
  const Result r = Cli("run " + Example("mass_spring_damper.yaml") + " -o " + dir_.string() + " -q --t-end 0.1");
  ASSERT_EQ(r.code, 0) << r.out;
  const auto run = nlohmann::json::parse(ReadFile(dir_ / "run.json"));
  const std::string csv = ReadFile(dir_ / "results.csv");
  EXPECT_EQ(run["results"]["file"], "results.csv");
  EXPECT_EQ(run["results"]["bytes"].get<size_t>(), csv.size());
  const Result sum = Shell("sha256sum " + (dir_ / "results.csv").string());
  EXPECT_THAT(sum.out, HasSubstr(run["results"]["sha256"].get<std::string>()));
}

TEST_F(CliTest, ASecondRunIntoABusyFolderIsRefusedNamingTheFirst) {
  // The first run holds the folder while it integrates; the second is told who holds it (exit 74)
  // and the first's results come out whole, with no rows of the second model in them.
  const std::string first = std::string(MULTIBOND_CLI) + " run " + Example("differential.yaml") + " -o " + dir_.string() +
                            " -q --jit off --t-end 3 > /dev/null 2>&1 & pid=$!; for i in $(seq 600); do [ -s " +
                            (dir_ / ".multibond.lock").string() + " ] && break; sleep 0.05; done; ";
  const std::string second = std::string(MULTIBOND_CLI) + " run " + Example("mass_spring_damper.yaml") + " -o " + dir_.string() +
                             " -q; echo \"second exit $?\"; wait $pid; echo \"first exit $?\"";
  const std::string out = Shell(first + second).out;
  EXPECT_THAT(out, HasSubstr("another multibond command is writing into it (pid "));
  EXPECT_THAT(out, HasSubstr("differential.yaml -o " + dir_.string()));
  EXPECT_THAT(out, HasSubstr("second exit 74"));
  EXPECT_THAT(out, HasSubstr("first exit 0"));
  const std::string csv = ReadFile(dir_ / "results.csv");
  EXPECT_THAT(csv.substr(0, csv.find('\n')), HasSubstr("G.p.x"));
  EXPECT_THAT(csv, Not(HasSubstr("mass.p")));
  EXPECT_EQ(csv.find('\0'), std::string::npos);
  EXPECT_EQ(nlohmann::json::parse(ReadFile(dir_ / "run.json"))["results"]["bytes"].get<size_t>(), csv.size());
}

TEST_F(CliTest, AKilledRunLeavesNothingAndTheNextOneCleansUpAfterOlderVersions) {
  const std::string cmd = std::string(MULTIBOND_CLI) + " run " + Example("differential.yaml") + " -o " + dir_.string() +
                          " -q --jit off --t-end 1000 > /dev/null 2>&1 & pid=$!; for i in $(seq 1200); do " + WritingMoreRowsThan(5) +
                          " && break; sleep 0.05; done; kill -9 $pid; wait $pid";
  ASSERT_EQ(std::system(cmd.c_str()) == -1, false);
  EXPECT_EQ(ListNames(dir_), std::vector<std::string>{".multibond.lock"});
  // A temporary left by an earlier version (fixed name) or by a file system without unnamed files.
  std::ofstream(dir_ / "results.csv.partial") << "time [s]\n0\n";
  std::ofstream(dir_ / ".run.json.123.abcd.multibond-tmp") << "{";
  const Result r = Cli("run " + Example("mass_spring_damper.yaml") + " -o " + dir_.string() + " -q --t-end 0.1");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_THAT(r.out, HasSubstr("note: removed '" + (dir_ / "results.csv.partial").string() + "', a temporary file of an earlier command"));
  EXPECT_EQ(ListNames(dir_), (std::vector<std::string>{".multibond.lock", "results.csv", "run.json"}));
}

TEST_F(CliTest, AFullDiskLeavesNothingThatLooksComplete) {
  // A file size limit stands in for a full disk: writes past it fail (EFBIG) as they would (ENOSPC).
  const Result r = Shell("trap '' XFSZ; ulimit -f 64; " + std::string(MULTIBOND_CLI) + " run " + Example("mass_spring_damper.yaml") +
                         " -o " + dir_.string() + " -q");
  EXPECT_EQ(r.code, 74) << r.out;
  EXPECT_THAT(r.out, HasSubstr("cannot write '" + (dir_ / "results.csv").string() + "': File too large"));
  EXPECT_EQ(ListNames(dir_), std::vector<std::string>{".multibond.lock"});
}

// The disk fills between the two files: results.csv (29,308 bytes, 8 pages) fits on a 9-page file
// system beside the lock file's page, run.json does not. Neither is published: a results.csv
// without its run.json, or beside an older run's, would look complete.
TEST_F(CliTest, ADiskThatFillsBetweenTheTwoFilesPublishesNeither) {
  const fs::path mnt = fs::temp_directory_path() / "multibond_cli_full_disk";
  fs::create_directories(mnt);
  // A private mount namespace: the small file system exists for this one command line.
  const Result r = Shell("unshare -rm sh -c 'mount -t tmpfs -o size=36k tmpfs " + mnt.string() + " && " + MULTIBOND_CLI + " run " +
                         Example("mass_spring_damper.yaml") + " -o " + (mnt / "out").string() +
                         " -q --t-end 0.1; echo \"exit $?\"; ls -A " + (mnt / "out").string() + "'");
  if (r.out.find("exit ") == std::string::npos) GTEST_SKIP() << "no private tmpfs here: " << r.out;
  EXPECT_THAT(r.out, HasSubstr("cannot write '" + (mnt / "out" / "run.json").string() + "': No space left on device"));
  EXPECT_THAT(r.out, HasSubstr("exit 74"));
  EXPECT_THAT(r.out, Not(HasSubstr("results.csv\n")));
  EXPECT_THAT(r.out, HasSubstr(".multibond.lock\n"));
}

TEST_F(CliTest, APlantedLinkAtAnOutputNameIsReplacedNotFollowed) {
  fs::create_directories(dir_);
  const fs::path victim = dir_ / "victim.txt";
  std::ofstream(victim) << "precious";
  fs::create_symlink(victim, dir_ / "results.csv");
  fs::create_symlink(victim, dir_ / "results.csv.partial");  // the fixed temporary name of earlier versions
  const Result r = Cli("run " + Example("mass_spring_damper.yaml") + " -o " + dir_.string() + " -q --t-end 0.1");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_EQ(ReadFile(victim), "precious");
  EXPECT_FALSE(fs::is_symlink(dir_ / "results.csv"));
  EXPECT_THAT(ReadFile(dir_ / "results.csv"), HasSubstr("time [s]"));
}

TEST_F(CliTest, ACommandNeverWritesOntoItsOwnInput) {
  fs::create_directories(dir_);
  const fs::path b = dir_ / "b.yaml";
  fs::copy_file(Example("mass_spring_damper.yaml"), b);
  const std::string before = ReadFile(b);
  Result r = Cli("compare " + Example("mass_spring_damper.yaml") + " " + b.string() + " --t-end 0.1 -o " + b.string());
  EXPECT_EQ(r.code, 64) << r.out;
  EXPECT_THAT(r.out, HasSubstr("an input of this command"));
  EXPECT_EQ(ReadFile(b), before);
  // A model called results.csv run into its own folder.
  fs::copy_file(b, dir_ / "results.csv");
  r = Cli("run " + (dir_ / "results.csv").string() + " -o " + dir_.string() + " -q");
  EXPECT_EQ(r.code, 64) << r.out;
  EXPECT_EQ(ReadFile(dir_ / "results.csv"), before);
  // A drawing over the model.
  fs::copy_file(b, dir_ / "m.dot");
  r = Cli("graph " + (dir_ / "m.dot").string() + " -o " + (dir_ / "m.dot").string());
  EXPECT_EQ(r.code, 64) << r.out;
  EXPECT_EQ(ReadFile(dir_ / "m.dot"), before);
}

TEST_F(CliTest, ImpossibleRequestsAreRefusedUpFrontWithTheEstimate) {
  // Each request (the options of a run of the mass-spring-damper) with what its refusal says.
  const struct {
    const char* options;
    std::vector<const char*> says;
  } requests[] = {
      {" --solver rk4 --step 1e-12", {"is 5e+12 steps, more than the limit of 1e+08", "--limit steps=N"}},
      {" --max-step 1e-11", {"largest step (--max-step) of 1e-11 s is 5e+11 steps"}},
      // The limit is the user's: lowered, an ordinary request goes over it.
      {" --solver rk4 --step 1e-3 --limit steps=100", {"is 5e+03 steps, more than the limit of 100"}},
      {" --limit step=100", {"unknown limit 'step' (did you mean 'steps'?)"}},
      // Denormal and unresolvable times.
      {" --dt 1e-310", {"beyond the range of normal double-precision numbers"}},
      {" --t-end 1e9 --dt 10 --solver rk4 --step 1e-8", {"fixed step (--step) of 1e-08 s is below what time near 1e+09 s can resolve"}},
  };
  for (const auto& request : requests) {
    const Result r = Cli("run " + Example("mass_spring_damper.yaml") + " -o " + dir_.string() + request.options);
    EXPECT_EQ(r.code, 64) << r.out;
    for (const char* said : request.says) EXPECT_THAT(r.out, HasSubstr(said)) << request.options;
  }
  EXPECT_FALSE(fs::exists(dir_));
}

TEST_F(CliTest, SigtermDuringARunKeepsTheRowsAndExits143) {
  const std::string cmd = std::string(MULTIBOND_CLI) + " run " + Example("differential.yaml") + " -o " + dir_.string() +
                          " -q --jit off --t-end 1000 > /dev/null 2>&1 & pid=$!; for i in $(seq 1200); do " + WritingMoreRowsThan(5) +
                          " && break; sleep 0.05; done; kill -TERM $pid; wait $pid; echo $?";
  FILE* p = popen(cmd.c_str(), "r");
  char buf[64] = {0};
  const size_t n = fread(buf, 1, sizeof buf - 1, p);
  pclose(p);
  EXPECT_EQ(std::atoi(std::string(buf, n).c_str()), 143);
  const auto run = nlohmann::json::parse(ReadFile(dir_ / "run.json"));
  EXPECT_EQ(run["status"], "interrupted");
  EXPECT_EQ(ListNames(dir_), (std::vector<std::string>{".multibond.lock", "results.csv", "run.json"}));
}

}  // namespace

namespace {

// A stop while the generated code compiles: the compiler (here a stand-in that sleeps, with a
// child of its own) is ended with its whole process group, the command exits 128 + SIGTERM, and
// nothing is left in the output folder or the cache but what was complete.
TEST_F(CliTest, SigtermWhileTheGeneratedCodeCompilesEndsTheCompilerAndExits143) {
  fs::create_directories(dir_);
  const fs::path compiler = dir_ / "slow-cxx", pidfile = dir_ / "compiler.pid", cache = dir_ / "cache", out = dir_ / "out";
  std::ofstream(compiler) << "#!/bin/sh\nsleep 30 &\necho $! > " << pidfile.string() << "\nwait\n";
  fs::permissions(compiler, fs::perms::owner_all);
  const Result r = Shell("MULTIBOND_CXX=" + compiler.string() + " MULTIBOND_CACHE=" + cache.string() + " " + MULTIBOND_CLI + " run " +
                         Example("mass_spring_damper.yaml") + " -o " + out.string() + " -q --jit on & pid=$!; for i in $(seq 600); do [ -s " +
                         pidfile.string() + " ] && break; sleep 0.05; done; kill -TERM $pid; wait $pid; echo \"exit $?\"");
  EXPECT_THAT(r.out, HasSubstr("exit 143")) << r.out;
  EXPECT_THAT(r.out, HasSubstr("interrupted by SIGTERM while compiling the generated code"));
  const pid_t sleeper = std::atoi(ReadFile(pidfile).c_str());
  ASSERT_GT(sleeper, 0);
  for (int i = 0; i < 100 && multibond::testing::Alive(sleeper); ++i) usleep(20000);
  EXPECT_FALSE(multibond::testing::Alive(sleeper)) << "the compiler's child " << sleeper << " still runs";
  EXPECT_FALSE(fs::exists(out)) << "the output folder was touched before the model compiled";
  for (const auto& entry : fs::directory_iterator(cache)) EXPECT_EQ(entry.path().extension(), ".cc") << entry.path();
}

// A stop asked for while a large model file loads ends the command at once (#44: SIGTERM waited for
// the end of the load, 45 s and more): the parser checks the flag as it goes, and the check of
// duplicate keys walks a collection once however many aliases name it (a billion laughs took 78 s).
TEST_F(CliTest, AStopIsHonouredWhileALargeModelLoads) {
  fs::create_directories(dir_);
  const fs::path big = dir_ / "big.yaml";
  {
    std::ofstream f(big);
    f << "model: big\nelements:\n  m: {type: I, inertia: 1.0}\n  f: {type: Se, effort: 1.0}\nbonds: [f -> m]\nnotes:\n";
    for (int i = 0; i < 1500000; ++i) f << "  - [1, 2, 3, 4]\n";  // 7.5 million nodes, 24 MB
  }
  const std::string cmd = std::string(MULTIBOND_CLI) + " check " + big.string() +
                          " --limit file-size=64M --limit yaml-nodes=20M > /dev/null 2>&1 & pid=$!; sleep 0.5; kill -TERM $pid; "
                          "start=$(date +%s%N); wait $pid; code=$?; end=$(date +%s%N); echo $code $(( (end - start) / 1000000 ))";
  const Result r = Shell(cmd);
  int code = -1, ms = -1;
  ASSERT_EQ(std::sscanf(r.out.c_str(), "%d %d", &code, &ms), 2) << r.out;
  EXPECT_EQ(code, 143) << "the load was not stopped by SIGTERM (or ended before it)";
  EXPECT_LT(ms, 5000) << "the load went on " << ms << " ms after SIGTERM";
  // A billion laughs under a raised node limit: checked as fast as its text is read.
  const fs::path laughs = dir_ / "laughs.yaml";
  {
    std::ofstream f(laughs);
    f << "model: laughs\na0: &a0 [x, x, x, x, x, x, x, x, x, x]\n";
    for (int i = 1; i < 8; ++i) {
      f << "a" << i << ": &a" << i << " [";
      for (int k = 0; k < 10; ++k) f << (k ? ", " : "") << "*a" << i - 1;
      f << "]\n";
    }
    f << "elements:\n  m: {type: I, inertia: 1.0}\nbonds: []\n";
  }
  const std::string timed = "start=$(date +%s%N); " + std::string(MULTIBOND_CLI) + " check " + laughs.string() +
                            " --limit yaml-nodes=2G > /dev/null 2>&1; code=$?; end=$(date +%s%N); echo $code $(( (end - start) / 1000000 ))";
  const Result l = Shell(timed);
  ASSERT_EQ(std::sscanf(l.out.c_str(), "%d %d", &code, &ms), 2) << l.out;
  EXPECT_EQ(code, 1);  // its unknown keys
  EXPECT_LT(ms, 5000) << "the aliases were walked one by one";
}

// plot reads its folder before it writes into it: a folder that is not there, or a file, is said as
// a read (it said "cannot write into").
TEST_F(CliTest, PlotOfAMissingFolderSaysItCannotReadIt) {
  fs::create_directories(dir_);
  const Result missing = Cli("plot " + (dir_ / "nowhere").string());
  EXPECT_EQ(missing.code, 74) << missing.out;
  EXPECT_THAT(missing.out, HasSubstr("error: cannot read the results folder '" + (dir_ / "nowhere").string() + "': No such file or directory"));
  EXPECT_THAT(missing.out, HasSubstr("hint: 'multibond run MODEL -o"));
  EXPECT_THAT(missing.out, Not(HasSubstr("cannot write")));
  EXPECT_FALSE(fs::exists(dir_ / "nowhere"));
  std::ofstream(dir_ / "a_file") << "x\n";
  const Result file = Cli("plot " + (dir_ / "a_file").string());
  EXPECT_EQ(file.code, 74) << file.out;
  EXPECT_THAT(file.out, HasSubstr("cannot read the results folder '" + (dir_ / "a_file").string() + "': it is not a folder"));
}

// --jit auto: a run that ends before its background compile hands the compile over to
// `multibond jit-finish`, which fills the cache; the next run of the model compiles nothing.
// (The other tests run with MULTIBOND_JIT_KEEP=0, tests/CMakeLists.txt.) The stand-in compiler
// counts its calls and waits a second, so that the run surely ends first. A model with ideal
// constraints too: its first run starts on the interpreter instead of waiting for the compiler.
TEST_F(CliTest, JitAutoKeepsTheGeneratedCodeOfARunShorterThanTheCompileForTheNextRun) {
  for (const std::string example : {"mass_spring_damper.yaml", "equations/mtf_pendulum.yaml"}) {
    SCOPED_TRACE(example);
    const fs::path here = dir_ / fs::path(example).stem();
    fs::create_directories(here);
    const fs::path compiler = here / "counting-cxx", calls = here / "calls", cache = here / "cache";
    std::ofstream(compiler) << "#!/bin/sh\necho call >> " << calls.string() << "\nsleep 1\nexec c++ \"$@\"\n";
    fs::permissions(compiler, fs::perms::owner_all);
    const std::string env = "MULTIBOND_JIT_KEEP=1 MULTIBOND_CXX=" + compiler.string() + " MULTIBOND_CACHE=" + cache.string() + " ";
    const Result first = Shell(env + MULTIBOND_CLI + " run " + Example(example) + " -o " + (here / "a").string() +
                               " -q --t-end 0.01 2>&1");
    ASSERT_EQ(first.code, 0) << first.out;
    const auto a = nlohmann::json::parse(ReadFile(here / "a" / "run.json"));
    EXPECT_THAT(a["rhs_engine"].get<std::string>(), ::testing::StartsWith("interpreter")) << a["rhs_engine"];
    EXPECT_THAT(a["rhs_engine"].get<std::string>(), HasSubstr("compiling on for the next run")) << a["rhs_engine"];
    // The library appears once the finisher is done (a compile of a few seconds).
    const auto built = [&] {
      if (!fs::exists(cache)) return false;
      for (const auto& entry : fs::directory_iterator(cache))
        if (entry.path().extension() == ".so") return true;
      return false;
    };
    for (int i = 0; i < 1800 && !built(); ++i) usleep(100000);
    ASSERT_TRUE(built()) << "no library in " << cache << " three minutes after the run";
    const auto count = [&] {
      std::ifstream in(calls);
      int n = 0;
      for (std::string line; std::getline(in, line);) ++n;
      return n;
    };
    const int before = count();
    const Result second = Shell(env + MULTIBOND_CLI + " run " + Example(example) + " -o " + (here / "b").string() +
                                " -q --t-end 0.01 --jit on 2>&1");
    ASSERT_EQ(second.code, 0) << second.out;
    const auto b = nlohmann::json::parse(ReadFile(here / "b" / "run.json"));
    EXPECT_THAT(b["rhs_engine"].get<std::string>(), ::testing::StartsWith("generated code")) << b["rhs_engine"];
    EXPECT_EQ(count(), before) << "the second run compiled again";
    // The same numbers either way (interpreter then generated code: the same bits).
    EXPECT_EQ(ReadFile(here / "a" / "results.csv"), ReadFile(here / "b" / "results.csv"));
  }
}

}  // namespace

// --set NAME=VALUE: the model's named parameters from the command line.
class CliSetTest : public CliTest {
 protected:
  /// A mass pushed from rest by a constant force F: its velocity at t = 1 s is F/m.
  fs::path Push() const {
    fs::create_directories(dir_);
    const fs::path model = dir_ / "push.yaml";
    std::ofstream(model) << "model: push\n"
                            "domain: translation\n"
                            "parameters:\n"
                            "  m: {value: 2.0, unit: kg, description: the mass}\n"
                            "  F: 3.0\n"
                            "  F2: 2*F\n"
                            "elements:\n"
                            "  force: {type: Se, effort: F}\n"
                            "  j:     {type: \"1\"}\n"
                            "  mass:  {type: I, inertia: m}\n"
                            "bonds: [force -> j, j -> mass]\n"
                            "outputs: [{name: v, variable: j.f}]\n"
                            "simulation: {t_end: 1.0, dt: 0.5, rtol: 1.0e-10, atol: 1.0e-12}\n";
    return model;
  }
  /// The last value of the column `name` of `folder`/results.csv.
  static double LastValue(const fs::path& folder, const std::string& name) {
    std::istringstream csv(ReadFile(folder / "results.csv"));
    std::string header, line, last;
    std::getline(csv, header);
    while (std::getline(csv, line))
      if (!line.empty()) last = line;
    auto cells = [](const std::string& row) {
      std::vector<std::string> out;
      std::stringstream ss(row);
      for (std::string c; std::getline(ss, c, ',');) out.push_back(c);
      return out;
    };
    const std::vector<std::string> names = cells(header), values = cells(last);
    for (size_t k = 0; k < names.size() && k < values.size(); ++k)
      if (names[k].rfind(name + " [", 0) == 0) return std::stod(values[k]);
    ADD_FAILURE() << "no column " << name << " in " << header;
    return 0.0;
  }
};

TEST_F(CliSetTest, SetChangesTheResultAndRunJsonRecordsTheParameters) {
  const fs::path model = Push();
  const fs::path a = dir_ / "a", b = dir_ / "b";
  ASSERT_EQ(Cli("run " + model.string() + " -q -o " + a.string()).code, 0);
  EXPECT_NEAR(LastValue(a, "v"), 3.0 / 2.0, 1e-9);  // F/m
  const Result r = Cli("run " + model.string() + " -q -o " + b.string() + " --set m=4 --set F=m/2");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NEAR(LastValue(b, "v"), 2.0 / 4.0, 1e-9);  // F = m/2 = 2, m = 4
  const auto run = nlohmann::json::parse(ReadFile(b / "run.json"));
  const auto& p = run["parameters"];
  ASSERT_EQ(p.size(), 3u);
  EXPECT_EQ(p["m"]["value"], 4.0);
  EXPECT_EQ(p["m"]["unit"], "kg");
  EXPECT_EQ(p["m"]["set"], true);
  EXPECT_FALSE(p["m"].contains("formula"));
  EXPECT_EQ(p["F"]["value"], 2.0);
  EXPECT_EQ(p["F"]["formula"], "m/2");
  EXPECT_EQ(p["F"]["set"], true);
  EXPECT_EQ(p["F2"]["value"], 4.0);  // 2*F follows
  EXPECT_EQ(p["F2"]["formula"], "2*F");
  EXPECT_EQ(p["F2"]["set"], false);
  EXPECT_EQ(p["F2"]["unit"], "");
}

TEST_F(CliSetTest, AnUnknownOrBadSetIsAUsageErrorAndNothingIsWritten) {
  const fs::path model = Push();
  Result r = Cli("run " + model.string() + " -o " + (dir_ / "out").string() + " --set mm=4");
  EXPECT_EQ(r.code, 64);
  EXPECT_THAT(r.out, HasSubstr("error: --set: the model has no parameter 'mm': did you mean 'm'?"));
  EXPECT_FALSE(fs::exists(dir_ / "out"));
  r = Cli("check " + model.string() + " --set x=1");
  EXPECT_EQ(r.code, 64);
  EXPECT_THAT(r.out, HasSubstr("the model has no parameter 'x' (its parameters: m, F, F2)"));
  r = Cli("check " + model.string() + " --set m");
  EXPECT_EQ(r.code, 64);
  EXPECT_THAT(r.out, HasSubstr("error: --set 'm' is not NAME=VALUE"));
  r = Cli("equations " + model.string() + " --set m=2*");
  EXPECT_EQ(r.code, 64);
  EXPECT_THAT(r.out, HasSubstr("parameter 'm' set to '2*': the formula ends early"));
  r = Cli("check " + model.string() + " --set F=F2");
  EXPECT_EQ(r.code, 64);
  EXPECT_THAT(r.out, HasSubstr("the parameters set make a cycle: F (set) -> F2 -> F"));
  // A value the model refuses is the model's error (1), at the element.
  r = Cli("check " + model.string() + " --set m=-1");
  EXPECT_EQ(r.code, 1);
  EXPECT_THAT(r.out, HasSubstr("mass: inertia must be > 0 (got -1)"));
}

TEST_F(CliSetTest, CheckListsTheParametersAndEquationsTakesSet) {
  const fs::path model = Push();
  const Result r = Cli("check " + model.string() + " --set m=2.5");
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_THAT(r.out, HasSubstr("parameters (3):\n  m = 2.5 kg  (set on the command line)\n  F = 3\n  F2 = 6  (= 2*F)\n"));
  const Result eq = Cli("equations " + model.string() + " --set F=5");
  EXPECT_EQ(eq.code, 0) << eq.out;
}

TEST_F(CliSetTest, CompareSetsBothOrOneModel) {
  const fs::path model = Push();
  // The same file twice, B with another mass: v differs by F/2 - F/4 = 0.75 at the end, the
  // momentum F t not at all.
  Result r = Cli("compare " + model.string() + " " + model.string() + " --set-b m=4 --sort name");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_THAT(r.out, HasSubstr("atol 1e-12, m = 4)"));
  auto row = [&](const std::string& column) {
    const auto at = r.out.find("\n  " + column + " [");
    return at == std::string::npos ? std::string() : r.out.substr(at + 1, r.out.find('\n', at + 1) - at - 1);
  };
  EXPECT_THAT(row("v"), ::testing::MatchesRegex(" +v \\[m/s\\] +0\\.75 +1 +1\\.5 +0\\.5"));
  const std::string momentum = row("mass.p");
  ASSERT_NE(momentum.find(']'), std::string::npos) << r.out;
  EXPECT_LT(std::stod(momentum.substr(momentum.find(']') + 1)), 1e-12);  // rounding only
  // --set applies to both: no difference left.
  r = Cli("compare " + model.string() + " " + model.string() + " --set m=4");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_THAT(r.out, HasSubstr("largest relative difference: 0 "));
  r = Cli("compare " + model.string() + " " + Example("mass_spring_damper.yaml") + " --set m=4");
  EXPECT_EQ(r.code, 64);
  EXPECT_THAT(r.out, HasSubstr("the model has no parameter 'm' (it declares no parameters)"));
  r = Cli("compare " + model.string() + " " + model.string() + " --set-a q=4");
  EXPECT_EQ(r.code, 64);
  EXPECT_THAT(r.out, HasSubstr("error: --set-a: the model has no parameter 'q'"));
}
