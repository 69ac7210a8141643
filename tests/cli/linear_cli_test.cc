// The linear analysis commands as users and scripts see them: `multibond linearize`, `modes` and
// `bode` on models with closed forms (exit codes, the files written or not, the numbers in them).

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "support/cli_runner.h"
#include "support/temp_dir.h"

namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using ::testing::Not;
using multibond::testing::ReadFile;
using multibond::testing::TempDir;

struct Result {
  int code;
  std::string out;  // stdout
  std::string err;  // stderr
};

/// Runs the CLI with `args` (split at spaces, no shell); stdout and stderr apart.
Result Cli(const std::string& args, const fs::path& err_file) {
  std::vector<std::string> argv = multibond::testing::SplitArgs(args);
  argv.insert(argv.begin(), MULTIBOND_CLI);
  const multibond::testing::CliResult r = multibond::testing::RunProgram(argv, 600, "", err_file.string());
  return {r.code, r.out, r.err};
}

std::string Example(const std::string& name) { return std::string(MULTIBOND_SOURCE_DIR) + "/examples/" + name; }

class LinearCliTest : public ::testing::Test {
 protected:
  Result Run(const std::string& args) { return Cli(args, tmp_.path() / "stderr.txt"); }
  fs::path Out(const std::string& name) const { return tmp_.path() / name; }
  nlohmann::json Json(const fs::path& p) const { return nlohmann::json::parse(ReadFile(p)); }
  TempDir tmp_{"multibond-linear-cli"};
};

TEST_F(LinearCliTest, LinearizeMassSpringDamperWritesTheContractKeysAndItsEigenvalues) {
  const fs::path dir = Out("msd");
  const Result r = Run("linearize " + Example("mass_spring_damper.yaml") + " -o " + dir.string());
  ASSERT_EQ(r.code, 0) << r.out << r.err;
  const nlohmann::json j = Json(dir / "linear.json");
  for (const char* key : {"states", "inputs", "outputs", "A", "B", "C", "D", "at", "eigenvalues"})
    EXPECT_TRUE(j.contains(key)) << key;
  EXPECT_EQ(j["inputs"], nlohmann::json({"force"}));
  EXPECT_EQ(j["outputs"], nlohmann::json({"velocity", "spring_force"}));
  // m x'' + c x' + k x = F, m = 1, c = 2, k = 100: lambda = -1 +- i sqrt(99); sorted by modulus,
  // then real part, then imaginary part.
  ASSERT_EQ(j["eigenvalues"].size(), 2u);
  EXPECT_NEAR(j["eigenvalues"][0][0].get<double>(), -1.0, 1e-12);
  EXPECT_NEAR(j["eigenvalues"][0][1].get<double>(), -std::sqrt(99.0), 1e-12);
  EXPECT_NEAR(j["eigenvalues"][1][0].get<double>(), -1.0, 1e-12);
  EXPECT_NEAR(j["eigenvalues"][1][1].get<double>(), std::sqrt(99.0), 1e-12);
  ASSERT_TRUE(fs::is_regular_file(dir / "linear.m"));
  EXPECT_THAT(ReadFile(dir / "linear.m"), HasSubstr("A = "));
}

TEST_F(LinearCliTest, ModesOfTwoMassesAreTheRootsOfTheCharacteristicPolynomial) {
  const fs::path dir = Out("two_mass");
  const Result r = Run("modes " + Example("linear/two_mass.yaml") + " -o " + dir.string());
  ASSERT_EQ(r.code, 0) << r.out << r.err;
  const nlohmann::json j = Json(dir / "modes.json");
  ASSERT_EQ(j["modes"].size(), 2u) << j.dump(1);
  // det(K - w^2 M) = 0: w^4 - 175 w^2 + 2500 = 0, w^2 = (175 -+ sqrt(20625)) / 2, f = w / 2 pi.
  const double pi = std::acos(-1.0);
  const double f[2] = {std::sqrt((175.0 - std::sqrt(20625.0)) / 2.0) / (2.0 * pi), std::sqrt((175.0 + std::sqrt(20625.0)) / 2.0) / (2.0 * pi)};
  EXPECT_NEAR(f[0], 0.6304819551382173, 1e-12 * 0.6304819551382173);
  EXPECT_NEAR(f[1], 2.0088041936926975, 1e-12 * 2.0088041936926975);
  std::set<std::string> elements;
  for (int i = 0; i < 2; ++i) {
    const nlohmann::json& m = j["modes"][i];
    EXPECT_NEAR(m["frequency_hz"].get<double>(), f[i], 1e-12 * f[i]) << i;
    EXPECT_EQ(m["damping_ratio"].get<double>(), 0.0) << i;
    ASSERT_TRUE(m["participation"].is_object()) << i;
    ASSERT_FALSE(m["participation"].empty()) << i;
    double sum = 0.0;
    for (const auto& [element, share] : m["participation"].items()) {
      sum += share.get<double>();
      elements.insert(element);
    }
    EXPECT_NEAR(sum, 1.0, 1e-12) << i;
  }
  EXPECT_EQ(elements, (std::set<std::string>{"mass1", "mass2", "spring1", "spring2"}));
  EXPECT_THAT(r.out, HasSubstr("0.630482"));
}

TEST_F(LinearCliTest, ModesOfTheBilinearDamperAtRestHaveTheMeanOfItsTwoRates) {
  // examples/linear/bilinear_damper.yaml at rest, on the damper's kink: c_mean = (800 + 2400)/2,
  // w_n = sqrt(16000/250) = 8 rad/s, zeta = c_mean / (2 sqrt(k m)) = 1600 / 4000 = 0.4; and with
  // --set c_reb=1200, c_mean = 1000 and zeta = 0.25.
  const double pi = std::acos(-1.0);
  for (const auto& [set, zeta] : {std::pair{std::string(), 0.4}, std::pair{std::string(" --set c_reb=1200"), 0.25}}) {
    const fs::path dir = Out("bilinear" + std::to_string(static_cast<int>(zeta * 100)));
    const Result r = Run("modes " + Example("linear/bilinear_damper.yaml") + set + " -o " + dir.string());
    ASSERT_EQ(r.code, 0) << r.out << r.err;
    // On the damper's kink: said on the terminal and in the record.
    EXPECT_NE(r.err.find("warning: the operating point sits on a kink"), std::string::npos) << r.err;
    const nlohmann::json j = Json(dir / "modes.json");
    ASSERT_EQ(j["modes"].size(), 1u) << j.dump(1);
    const nlohmann::json& m = j["modes"][0];
    EXPECT_NEAR(m["frequency_hz"].get<double>(), 8.0 / (2.0 * pi), 1e-9) << set;
    EXPECT_NEAR(m["damping_ratio"].get<double>(), zeta, 1e-9) << set;
    EXPECT_NEAR(m["damped_frequency_hz"].get<double>(), 8.0 * std::sqrt(1.0 - zeta * zeta) / (2.0 * pi), 1e-9) << set;
  }
}

TEST_F(LinearCliTest, BodeOfTheBilinearDamperAtResonanceIsTheMobilityOneOverTheMeanRate) {
  // Force -> velocity, j w / (k - m w^2 + j c w): 1/c_mean = 1/1600 at w_n = 8 rad/s, phase 0.
  const fs::path dir = Out("bilinear_bode");
  char fn[32];
  std::snprintf(fn, sizeof fn, "%.17g", 8.0 / (2.0 * std::acos(-1.0)));
  const Result r = Run("bode " + Example("linear/bilinear_damper.yaml") + " --input force --output velocity --freq " + fn + " -o " +
                       dir.string());
  ASSERT_EQ(r.code, 0) << r.out << r.err;
  std::istringstream in(ReadFile(dir / "bode.csv"));
  std::string header, row;
  std::getline(in, header);
  std::getline(in, row);
  double f = 0.0, db = 0.0, deg = 0.0;
  ASSERT_EQ(std::sscanf(row.c_str(), "%lf,%lf,%lf", &f, &db, &deg), 3) << row;
  EXPECT_NEAR(db, 20.0 * std::log10(1.0 / 1600.0), 1e-9);
  EXPECT_NEAR(deg, 0.0, 1e-9);
}

TEST_F(LinearCliTest, BodeAtTheUndampedNaturalFrequencyIsFiveAtMinus90Degrees) {
  // F -> spring force: k / (m s^2 + c s + k); at w = 10 rad/s (f = 10 / 2 pi Hz): 100 / (20 i) = -5 i.
  const fs::path dir = Out("bode");
  const Result r = Run("bode " + Example("mass_spring_damper.yaml") + " --input force --output spring_force --freq 1.5915494309189535 -o " +
                       dir.string());
  ASSERT_EQ(r.code, 0) << r.out << r.err;
  const std::string csv = ReadFile(dir / "bode.csv");
  std::istringstream in(csv);
  std::string header, row, extra;
  std::getline(in, header);
  std::getline(in, row);
  EXPECT_EQ(header, "frequency [Hz],magnitude [dB],phase [deg]");
  EXPECT_FALSE(std::getline(in, extra) && !extra.empty()) << csv;
  double f = 0.0, db = 0.0, deg = 0.0;
  ASSERT_EQ(std::sscanf(row.c_str(), "%lf,%lf,%lf", &f, &db, &deg), 3) << row;
  EXPECT_NEAR(f, 10.0 / (2.0 * std::acos(-1.0)), 1e-15);
  EXPECT_NEAR(db, 20.0 * std::log10(5.0), 1e-9);
  EXPECT_NEAR(20.0 * std::log10(5.0), 13.979400086720377, 1e-12);
  EXPECT_NEAR(deg, -90.0, 1e-9);
}

TEST_F(LinearCliTest, BodeWithAnUnknownInputOrOutputIsUsageAndWritesNothing) {
  const fs::path a = Out("forse"), b = Out("nonsense");
  const Result r = Run("bode " + Example("mass_spring_damper.yaml") + " --input forse --output spring_force -o " + a.string());
  EXPECT_EQ(r.code, 64) << r.out << r.err;
  EXPECT_THAT(r.err, HasSubstr("did you mean 'force'"));
  EXPECT_FALSE(fs::exists(a / "bode.csv"));
  EXPECT_FALSE(fs::exists(a));
  const Result s = Run("bode " + Example("mass_spring_damper.yaml") + " --input force --output nonsense -o " + b.string());
  EXPECT_EQ(s.code, 64) << s.out << s.err;
  EXPECT_THAT(s.err, HasSubstr("'nonsense' is no output"));
  EXPECT_FALSE(fs::exists(b / "bode.csv"));
  EXPECT_FALSE(fs::exists(b));
}

TEST_F(LinearCliTest, LinearizeAtATimeOutsideTheRunIsUsage) {
  const fs::path dir = Out("at100");
  const Result r = Run("linearize " + Example("mass_spring_damper.yaml") + " --at 100 -o " + dir.string());
  EXPECT_EQ(r.code, 64) << r.out << r.err;
  EXPECT_THAT(r.err, HasSubstr("outside the run"));
  EXPECT_FALSE(fs::exists(dir / "linear.json"));
}

TEST_F(LinearCliTest, LinearizeAtALaterTimeOfALinearModelGivesTheSameA) {
  const fs::path d0 = Out("at0"), d4 = Out("at4");
  const Result r0 = Run("linearize " + Example("mass_spring_damper.yaml") + " -o " + d0.string());
  ASSERT_EQ(r0.code, 0) << r0.out << r0.err;
  const Result r4 = Run("linearize " + Example("mass_spring_damper.yaml") + " --at 4 -o " + d4.string());
  ASSERT_EQ(r4.code, 0) << r4.out << r4.err;
  const nlohmann::json j0 = Json(d0 / "linear.json"), j4 = Json(d4 / "linear.json");
  EXPECT_EQ(j0["at"].get<double>(), 0.0);
  EXPECT_EQ(j4["at"].get<double>(), 4.0);
  // A = [[-c/m, -k], [1/m, 0]] wherever the state is: the laws are linear.
  EXPECT_EQ(j4["A"], j0["A"]);
  EXPECT_EQ(j4["A"], nlohmann::json({{-2.0, -100.0}, {1.0, 0.0}}));
  // The state has moved: the run to t = 4 s did happen.
  EXPECT_NE(j4["x0"], j0["x0"]);
}

TEST_F(LinearCliTest, LinearizeSteadyFindsTheStaticDeflection) {
  const fs::path dir = Out("steady");
  const Result r = Run("linearize " + Example("mass_spring_damper.yaml") + " --steady -o " + dir.string());
  ASSERT_EQ(r.code, 0) << r.out << r.err;
  const nlohmann::json j = Json(dir / "linear.json");
  EXPECT_EQ(j["steady"], true);
  const std::vector<std::string> names = j["full_states"].get<std::vector<std::string>>();
  const auto q = std::find(names.begin(), names.end(), "spring.q"), p = std::find(names.begin(), names.end(), "mass.p");
  ASSERT_NE(q, names.end());
  ASSERT_NE(p, names.end());
  ASSERT_EQ(j["x0"].size(), names.size());
  EXPECT_NEAR(j["x0"][q - names.begin()].get<double>(), 1.0 / 100.0, 1e-12);  // F / k
  EXPECT_NEAR(j["x0"][p - names.begin()].get<double>(), 0.0, 1e-12);          // at rest
}

TEST_F(LinearCliTest, LinearizeThroughASolvedAlgebraicLoop) {
  // It was refused ("cannot linearise"): the torn variable's derivative now comes from the
  // implicit function theorem. The inductor sees R1 || R2: dp/dt = -(R1 R2 / (R1 + R2)) / L p + ...
  const fs::path dir = Out("loops");
  const Result r = Run("linearize " + Example("algebraic_loop.yaml") + " --algebraic-loops solve -o " + dir.string());
  ASSERT_EQ(r.code, 0) << r.out << r.err;
  const nlohmann::json j = Json(dir / "linear.json");
  ASSERT_EQ(j["states"], nlohmann::json::array({"L.p"}));
  const double expected = -(10.0 * 20.0 / 30.0) / 0.1;  // -1/tau, tau = L / (R1 || R2)
  EXPECT_NEAR(j["A"][0][0].get<double>(), expected, 1e-12 * std::abs(expected));
}

TEST_F(LinearCliTest, LinearizeWithIdealConstraintsIsOnTheConstraintManifold) {
  // The rigid differential: of its storage coordinates only the carrier's spin and the drive's
  // coupling are independent; the rest are the bodies' positions and angles (modes that store no
  // energy), and no mode is spurious or infinite.
  const fs::path dir = Out("ideal");
  const Result r = Run("modes " + Example("differential_ideal.yaml") + " -o " + dir.string());
  ASSERT_EQ(r.code, 0) << r.out << r.err;
  const nlohmann::json j = Json(dir / "linear.json");
  EXPECT_EQ(j["states"].size(), 44u);
  bool noted = false;
  for (const auto& note : j["notes"]) noted = noted || note.get<std::string>().find("constraint manifold") != std::string::npos;
  EXPECT_TRUE(noted);
  for (const auto& ev : j["eigenvalues"]) {
    EXPECT_TRUE(std::isfinite(ev[0].get<double>()) && std::isfinite(ev[1].get<double>()));
    EXPECT_LE(ev[0].get<double>(), 1e-9);  // nothing grows
  }
}

TEST_F(LinearCliTest, NoSteadyStateIsASolverFailureThatSaysWhy) {
  // A constant torque on a free gear pair accelerates it for ever: dz/dt = 0 has no solution.
  const fs::path dir = Out("nosteady");
  const Result r = Run("linearize " + Example("rigid_gear_pair.yaml") + " --constraints ideal --steady -o " + dir.string());
  EXPECT_EQ(r.code, 2) << r.out << r.err;
  EXPECT_THAT(r.err, HasSubstr("no steady state found"));
  EXPECT_THAT(r.err, HasSubstr("singular"));
  EXPECT_THAT(r.err, Not(HasSubstr("KINSOL ERROR")));
  EXPECT_FALSE(fs::exists(dir / "linear.json"));
}

TEST_F(LinearCliTest, LinearizePendulumAtTheBottomOscillatesAtSqrtGOverL) {
  const fs::path dir = Out("pendulum");
  const Result r = Run("linearize " + Example("equations/pendulum.yaml") + " --set theta0=0 -o " + dir.string());
  ASSERT_EQ(r.code, 0) << r.out << r.err;
  const nlohmann::json j = Json(dir / "linear.json");
  // theta'' = -(g / L) sin(theta) ~ -(g / L) theta: lambda = +- i sqrt(g / L), g = 9.81, L = 1.
  ASSERT_EQ(j["eigenvalues"].size(), 2u);
  const double w = std::sqrt(9.81 / 1.0);
  EXPECT_NEAR(j["eigenvalues"][0][0].get<double>(), 0.0, 1e-12);
  EXPECT_NEAR(j["eigenvalues"][0][1].get<double>(), -w, 1e-12);
  EXPECT_NEAR(j["eigenvalues"][1][0].get<double>(), 0.0, 1e-12);
  EXPECT_NEAR(j["eigenvalues"][1][1].get<double>(), w, 1e-12);
}

}  // namespace
