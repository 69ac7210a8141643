// The examples of examples/equations/ from the command line: a parameter given with --set is
// recorded in run.json and reaches the model; generated code (--jit on) writes the same results
// as the interpreter (--jit off), byte for byte; a run started from a steady state (--steady,
// --initial, the file's simulation: initial) stays there, and what has none says so.

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "support/cli_runner.h"
#include "support/temp_dir.h"

namespace multibond {
namespace {

namespace fs = std::filesystem;
using testing::CliResult;
using testing::ReadFile;
using testing::RunCli;
using testing::TempDir;

std::string Example(const std::string& name) { return std::string(MULTIBOND_SOURCE_DIR) + "/examples/equations/" + name; }

std::vector<std::string> Cells(const std::string& line) {
  std::vector<std::string> cells;
  std::stringstream ss(line);
  for (std::string c; std::getline(ss, c, ',');) cells.push_back(c);
  return cells;
}

TEST(EquationExamplesCli, SetIsRecordedInRunJsonAndReachesTheModel) {
  TempDir tmp("multibond-equations");
  const fs::path out = tmp.path() / "out";
  const CliResult r = RunCli({"run", Example("pendulum.yaml"), "--set", "theta0=1.0", "-o", out.string(), "-q"});
  ASSERT_EQ(r.code, 0) << r.out;
  const auto run = nlohmann::json::parse(ReadFile(out / "run.json"));
  EXPECT_EQ(run["status"], "ok");
  const auto& p = run["parameters"];
  ASSERT_EQ(p.size(), 4u) << p.dump();
  EXPECT_EQ(p["theta0"]["value"], 1.0);
  EXPECT_EQ(p["theta0"]["unit"], "rad");
  EXPECT_EQ(p["theta0"]["set"], true);
  for (const char* other : {"L", "m", "g"}) EXPECT_EQ(p[other]["set"], false) << other;
  EXPECT_EQ(p["g"]["value"], 9.81);
  // The results have the output `theta` with its unit, and it starts at the angle set.
  std::istringstream csv(ReadFile(out / "results.csv"));
  std::string header, first;
  std::getline(csv, header);
  std::getline(csv, first);
  const std::vector<std::string> names = Cells(header), values = Cells(first);
  const auto theta = std::find(names.begin(), names.end(), "theta [rad]");
  ASSERT_NE(theta, names.end()) << header;
  ASSERT_EQ(values.size(), names.size());
  EXPECT_EQ(std::stod(values[static_cast<size_t>(theta - names.begin())]), 1.0);
  EXPECT_EQ(std::stod(values[0]), 0.0);
}

TEST(EquationExamplesCli, SetReachesTheInitialValuesOfAPidAndALag) {
  // pi_steady.yaml: the pid's initial value b*w_ref/ki and the lag's w_meas0 are formulas of
  // parameters; with --set w_ref=20 --set ki=4 the loop starts (and stays) at w = 20 rad/s,
  // u = b w_ref = 1 N m, i = b w_ref/ki = 0.25, and the sensor at w_meas0 = 5.
  TempDir tmp("multibond-equations");
  const fs::path out = tmp.path() / "out";
  const CliResult r = RunCli({"run", Example("pi_steady.yaml"), "--set", "w_ref=20", "--set", "ki=4", "--set", "w_meas0=5", "-o",
                              out.string(), "-q"});
  ASSERT_EQ(r.code, 0) << r.out;
  std::istringstream csv(ReadFile(out / "results.csv"));
  std::string header, line;
  std::getline(csv, header);
  const std::vector<std::string> names = Cells(header);
  auto column = [&](const std::string& name) {
    const auto it = std::find(names.begin(), names.end(), name);
    EXPECT_NE(it, names.end()) << name << " in " << header;
    return static_cast<size_t>(it - names.begin());
  };
  const size_t speed = column("speed [rad/s]"), torque = column("torque [N m]"), i = column("speed_control.i [rad]");
  const size_t measured = column("measured [rad/s]");
  int rows = 0;
  while (std::getline(csv, line) && !line.empty()) {
    const std::vector<std::string> v = Cells(line);
    ASSERT_EQ(v.size(), names.size());
    if (rows == 0) {
      EXPECT_EQ(std::stod(v[i]), 0.25);
      EXPECT_EQ(std::stod(v[measured]), 5.0);
    }
    EXPECT_NEAR(std::stod(v[speed]), 20.0, 1e-9 * 20.0) << line;
    EXPECT_NEAR(std::stod(v[torque]), 1.0, 1e-9) << line;
    ++rows;
  }
  EXPECT_GT(rows, 100);
}

TEST(EquationExamplesCli, GeneratedCodeWritesTheInterpretersResults) {
  TempDir tmp("multibond-equations");
  for (const char* file : {"pendulum.yaml", "duffing.yaml", "tank.yaml", "motor_pi.yaml", "speed_dependent_load.yaml", "pi_steady.yaml",
                           "switched_spring.yaml", "modulated_capacitor.yaml", "electrostatic_transducer.yaml",
                           "mtf_pendulum.yaml"}) {
    SCOPED_TRACE(file);
    std::vector<std::string> sha;
    for (const char* jit : {"off", "on"}) {
      const fs::path out = tmp.path() / (std::string(file) + "." + jit);
      const CliResult r = RunCli({"run", Example(file), "--jit", jit, "-o", out.string(), "-q"});
      ASSERT_EQ(r.code, 0) << r.out;
      const auto run = nlohmann::json::parse(ReadFile(out / "run.json"));
      EXPECT_EQ(run["rhs_engine"].get<std::string>().rfind(std::string(jit) == "on" ? "generated code" : "interpreter", 0), 0u)
          << run["rhs_engine"];
      sha.push_back(run["results"]["sha256"]);
    }
    EXPECT_EQ(sha[0], sha[1]);
  }
}

/// A PI speed loop from rest (no initial values): its steady state is w = w_ref, the integral
/// carrying the friction, i = b w_ref / ki, the sensor at w_ref.
std::string PiFromRest(const std::string& simulation = "") {
  return R"(model: pi_from_rest
parameters:
  J: {value: 0.02, unit: kg m^2}
  b: {value: 0.05, unit: N m s/rad}
  w_ref: {value: 10.0, unit: rad/s}
  kp: {value: 0.4, unit: N m s/rad}
  ki: {value: 2.0, unit: N m/rad}
  T: {value: 0.2, unit: s}
states:
  speed_control: {kind: pid, input: "w_ref - shaft.f", kp: kp, ki: ki}
  sensor: {kind: lag, input: shaft.f, time_constant: T, unit: rad/s}
elements:
  motor:    {type: Se, effort: "speed_control.u", domain: rotation}
  shaft:    {type: "1", domain: rotation}
  rotor:    {type: I, inertia: J}
  friction: {type: R, resistance: b}
bonds: [motor -> shaft, shaft -> rotor, shaft -> friction]
outputs:
  - {name: speed, variable: shaft.f}
  - {name: torque, variable: speed_control.u}
  - {name: measured, variable: sensor}
)" + simulation;
}

/// results.csv's column `name` (header "name [unit]"), every row.
std::vector<double> Column(const fs::path& csv_path, const std::string& header) {
  std::istringstream csv(ReadFile(csv_path));
  std::string line;
  std::getline(csv, line);
  const std::vector<std::string> names = Cells(line);
  const auto it = std::find(names.begin(), names.end(), header);
  EXPECT_NE(it, names.end()) << header << " in " << line;
  std::vector<double> out;
  while (std::getline(csv, line) && !line.empty()) out.push_back(std::stod(Cells(line)[static_cast<size_t>(it - names.begin())]));
  return out;
}

TEST(EquationExamplesCli, SteadyStartsFromTheSteadyStateAndStaysThere) {
  TempDir tmp("multibond-steady");
  const fs::path model = tmp.path() / "pi.yaml", in_file = tmp.path() / "pi_file.yaml";
  std::ofstream(model) << PiFromRest();
  std::ofstream(in_file) << PiFromRest("simulation: {t_end: 1.0, initial: steady}\n");
  const fs::path flag = tmp.path() / "flag", file = tmp.path() / "file", overridden = tmp.path() / "overridden";
  CliResult r = RunCli({"run", model.string(), "--steady", "--t-end", "1", "-o", flag.string(), "-q"});
  ASSERT_EQ(r.code, 0) << r.out;
  for (const double w : Column(flag / "results.csv", "speed [rad/s]")) EXPECT_NEAR(w, 10.0, 1e-9);
  for (const double u : Column(flag / "results.csv", "torque [N m]")) EXPECT_NEAR(u, 0.5, 1e-9);  // b w_ref: the friction (the pid output takes the motor's unit)
  for (const double x : Column(flag / "results.csv", "measured [rad/s]")) EXPECT_NEAR(x, 10.0, 1e-9);
  for (const double i : Column(flag / "results.csv", "speed_control.i [rad]")) EXPECT_NEAR(i, 0.25, 1e-9);  // b w_ref / ki
  const auto run = nlohmann::json::parse(ReadFile(flag / "run.json"));
  EXPECT_EQ(run["options"]["initial"], "steady");
  EXPECT_NEAR(run["initial_state"]["rotor.p"].get<double>(), 0.2, 1e-12);  // J w_ref
  EXPECT_NEAR(run["initial_state"]["speed_control.i"].get<double>(), 0.25, 1e-12);
  EXPECT_NEAR(run["initial_state"]["sensor"].get<double>(), 10.0, 1e-12);
  // The file's `initial: steady` is the same start, and --initial model overrides it.
  r = RunCli({"run", in_file.string(), "-o", file.string(), "-q"});
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_EQ(ReadFile(file / "results.csv"), ReadFile(flag / "results.csv"));
  r = RunCli({"run", in_file.string(), "--initial", "model", "-o", overridden.string(), "-q"});
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_EQ(Column(overridden / "results.csv", "speed [rad/s]").front(), 0.0);
  EXPECT_EQ(nlohmann::json::parse(ReadFile(overridden / "run.json"))["options"]["initial"], "model");
  // Two different starts asked for at once.
  r = RunCli({"run", model.string(), "--steady", "--initial", "model", "-o", (tmp.path() / "both").string(), "-q"});
  EXPECT_EQ(r.code, 64) << r.out;
  EXPECT_THAT(r.out, ::testing::HasSubstr("two different starts"));
}

TEST(EquationExamplesCli, AModelWithoutASteadyStateSaysSoAndWritesNothing) {
  // A rotor driven by a constant torque against nothing: dp/dt = 1 never vanishes.
  TempDir tmp("multibond-steady");
  const fs::path model = tmp.path() / "free.yaml", out = tmp.path() / "out";
  std::ofstream(model) << "model: free\nelements:\n  torque: {type: Se, effort: 1.0}\n  rotor: {type: I, inertia: 2.0}\n"
                          "bonds: [torque -> rotor]\n";
  const CliResult r = RunCli({"run", model.string(), "--steady", "-o", out.string(), "-q"});
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_THAT(r.out, ::testing::HasSubstr("no steady state found"));
  EXPECT_THAT(r.out, ::testing::HasSubstr("--initial model"));
  EXPECT_FALSE(fs::exists(out / "results.csv"));
  // A sweep does not find one per run yet: refused, not started from the nominal one.
  const fs::path pi = tmp.path() / "pi.yaml";
  std::ofstream(pi) << PiFromRest("simulation: {initial: steady}\n");
  const CliResult s = RunCli({"sweep", pi.string(), "-o", (tmp.path() / "sweep").string(), "--grid", "b=0.05:0.1:2", "--keep",
                              "w=final:shaft.f", "--jit", "off"});
  EXPECT_EQ(s.code, 64) << s.out;
  EXPECT_THAT(s.out, ::testing::HasSubstr("a sweep does not yet find for each of its runs"));
}

}  // namespace
}  // namespace multibond
