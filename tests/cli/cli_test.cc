// The command line as users and scripts see it: exit codes, files written (or not), messages.

#include <sys/wait.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

struct Result {
  int code;
  std::string out;  // stdout and stderr together
};

Result Cli(const std::string& args) {
  const std::string cmd = std::string(MULTIBOND_CLI) + " " + args + " 2>&1";
  FILE* p = popen(cmd.c_str(), "r");
  std::string out;
  char buf[4096];
  while (size_t n = fread(buf, 1, sizeof buf, p)) out.append(buf, n);
  const int status = pclose(p);
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, out};
}

std::string Example(const std::string& name) { return std::string(MULTIBOND_SOURCE_DIR) + "/examples/" + name; }

std::string Read(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

class CliTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("multibond_cli_" + std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
    fs::remove_all(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
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

TEST_F(CliTest, RunWritesResultsWithUnitsAndRunRecord) {
  const Result r = Cli("run " + Example("mass_spring_damper.yaml") + " -o " + dir_.string() + " --t-end 1 --dt 0.01");
  ASSERT_EQ(r.code, 0) << r.out;
  const std::string csv = Read(dir_ / "results.csv");
  const std::string header = csv.substr(0, csv.find('\n'));
  EXPECT_THAT(header, HasSubstr("time [s],mass.p [N s],spring.q [m]"));
  EXPECT_THAT(header, HasSubstr("energy.residual [-]"));
  EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 102);  // header + 101 samples
  EXPECT_FALSE(fs::exists(dir_ / "results.csv.partial"));
  const auto run = nlohmann::json::parse(Read(dir_ / "run.json"));
  EXPECT_EQ(run["status"], "ok");
  EXPECT_EQ(run["options"]["t_end"], 1.0);
  EXPECT_EQ(run["options"]["solver"], "bdf");  // the file's choice
  EXPECT_EQ(run["model"]["sha256"].get<std::string>().size(), 64u);
  EXPECT_FALSE(run["multibond_version"].get<std::string>().empty());
  EXPECT_GT(run["solver_stats"]["steps"].get<long>(), 0);
  EXPECT_LT(std::abs(run["energy"]["residual"].get<double>()), 1e-8);
}

TEST_F(CliTest, RunIsDeterministic) {
  const fs::path a = dir_ / "a", b = dir_ / "b";
  ASSERT_EQ(Cli("run " + Example("dc_motor.yaml") + " -o " + a.string() + " --t-end 0.5").code, 0);
  ASSERT_EQ(Cli("run " + Example("dc_motor.yaml") + " -o " + b.string() + " --t-end 0.5").code, 0);
  EXPECT_EQ(Read(a / "results.csv"), Read(b / "results.csv"));
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

TEST_F(CliTest, UsageErrorsExit64) {
  EXPECT_EQ(Cli("").code, 64);
  EXPECT_EQ(Cli("frobnicate").code, 64);
  EXPECT_EQ(Cli("run " + Example("mass_spring_damper.yaml")).code, 64);  // no -o
  EXPECT_EQ(Cli("run " + Example("mass_spring_damper.yaml") + " -o " + dir_.string() + " --rtol -1").code, 64);
  const Result r = Cli("run " + Example("mass_spring_damper.yaml") + " -o " + dir_.string() + " --solver euler");
  EXPECT_EQ(r.code, 64);
  EXPECT_THAT(r.out, HasSubstr("bdf"));
}

TEST_F(CliTest, DivergingRunExitsTwoKeepsResultsAndMarksThemFailed) {
  // RK4 with a step far beyond its stability limit (w h = 5): the state overflows.
  const Result r = Cli("run " + Example("mass_spring_damper.yaml") + " -o " + dir_.string() +
                       " --solver rk4 --step 0.5 --dt 0.5 --t-end 500");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_THAT(r.out, HasSubstr("at t = "));
  EXPECT_THAT(r.out, HasSubstr("the states that failed first: "));
  const auto run = nlohmann::json::parse(Read(dir_ / "run.json"));
  EXPECT_EQ(run["status"], "failed");
  EXPECT_LT(run["t_reached"].get<double>(), 500.0);
  EXPECT_GT(run["t_reached"].get<double>(), 0.0);
  const std::string csv = Read(dir_ / "results.csv");
  EXPECT_GT(std::count(csv.begin(), csv.end(), '\n'), 2);  // the samples up to the failure are kept
}

TEST_F(CliTest, EquationsTextAndLatex) {
  Result r = Cli("equations " + Example("mass_spring_damper.yaml"));
  EXPECT_EQ(r.code, 0);
  EXPECT_THAT(r.out, HasSubstr("d(mass.p)/dt = force(t) - spring.K spring.q - damper.R * mass.p/mass.I"));
  r = Cli("equations " + Example("mass_spring_damper.yaml") + " --format latex");
  EXPECT_EQ(r.code, 0);
  EXPECT_THAT(r.out, HasSubstr("\\dot{p}_{\\mathrm{mass}}"));
  EXPECT_EQ(Cli("equations " + Example("rigid_gear_pair.yaml")).code, 1);
}

TEST_F(CliTest, GraphWritesDotAndSvg) {
  const Result r = Cli("graph " + Example("compliant_gear_pair.yaml") + " -o " + (dir_ / "g.svg").string());
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_THAT(Read(dir_ / "g.dot"), HasSubstr("digraph"));
  EXPECT_THAT(Read(dir_ / "g.svg"), HasSubstr("<svg"));
}

TEST_F(CliTest, Version) {
  const Result r = Cli("version");
  EXPECT_EQ(r.code, 0);
  EXPECT_THAT(r.out, HasSubstr("multibond 0."));
}

}  // namespace

namespace {

TEST_F(CliTest, InterruptStopsCleanlyAndKeepsWhatWasComputed) {
  // A long run of the differential, interrupted after a moment with SIGINT.
  const std::string cmd = std::string(MULTIBOND_CLI) + " run " + Example("differential.yaml") + " -o " + dir_.string() +
                          " --t-end 1000 -q --jit off > /dev/null 2>&1 & pid=$!; sleep 1.5; kill -INT $pid; wait $pid; echo $?";
  FILE* p = popen(cmd.c_str(), "r");
  char buf[64] = {0};
  const size_t n = fread(buf, 1, sizeof buf - 1, p);
  pclose(p);
  EXPECT_EQ(std::atoi(std::string(buf, n).c_str()), 130);
  const auto run = nlohmann::json::parse(Read(dir_ / "run.json"));
  EXPECT_EQ(run["status"], "interrupted");
  EXPECT_GT(run["t_reached"].get<double>(), 0.0);
  EXPECT_LT(run["t_reached"].get<double>(), 1000.0);
  EXPECT_TRUE(fs::exists(dir_ / "results.csv"));
  EXPECT_FALSE(fs::exists(dir_ / "results.csv.partial"));
  const std::string csv = Read(dir_ / "results.csv");
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
