// The examples of examples/equations/ from the command line: a parameter given with --set is
// recorded in run.json and reaches the model; generated code (--jit on) writes the same results
// as the interpreter (--jit off), byte for byte.

#include <algorithm>
#include <filesystem>
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
  const size_t speed = column("speed [rad/s]"), torque = column("torque [N m]"), i = column("speed_control.i [-]");
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
                           "switched_spring.yaml", "modulated_capacitor.yaml"}) {
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

}  // namespace
}  // namespace multibond
