#include "multibond/analysis/linear_files.h"

#include <unistd.h>

#include <cctype>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <limits>
#include <set>
#include <sstream>
#include <stdexcept>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "analysis/test_models.h"
#include "multibond/core/process.h"
#include "support/temp_dir.h"

namespace multibond::linear {
namespace {

using multibond::testing::MassSpringDamper;
using multibond::testing::ReadFile;
using multibond::testing::TempDir;
using multibond::testing::TwoMasses;

const std::string kHostile = "a'; system('rm -rf /'); '";

/// The program `name` on PATH, or "" (as `which` finds it).
std::string OnPath(const std::string& name) {
  const char* path = std::getenv("PATH");
  std::stringstream dirs(path ? path : "");
  std::string dir;
  while (std::getline(dirs, dir, ':')) {
    const std::filesystem::path p = std::filesystem::path(dir.empty() ? "." : dir) / name;
    if (::access(p.c_str(), X_OK) == 0 && std::filesystem::is_regular_file(p)) return p.string();
  }
  return "";
}

TEST(LinearJson, HasExactlyTheContractKeysAndTheRecord) {
  const LinearModel lm = TwoMasses();
  const nlohmann::json record = {{"version", "0.1.0"}, {"options", {{"at", 0}}}};
  const nlohmann::json j = LinearJson(lm, record);
  std::set<std::string> keys;
  for (const auto& [k, v] : j.items()) keys.insert(k);
  const std::set<std::string> expected = {"states", "inputs", "outputs", "A", "B", "C", "D", "at", "eigenvalues", "state_units",
                                          "input_units", "output_units", "steady", "notes", "basis", "full_states", "x0", "model",
                                          "version", "options"};
  EXPECT_EQ(keys, expected);
  EXPECT_EQ(j["states"], nlohmann::json({"m1.p", "m2.p", "k1.q", "k2.q"}));
  EXPECT_EQ(j["inputs"], nlohmann::json({"F.e"}));
  EXPECT_EQ(j["outputs"], nlohmann::json({"k1.q"}));
  EXPECT_EQ(j["model"], "two-masses");
  EXPECT_EQ(j["options"]["at"], 0);
  ASSERT_EQ(j["A"].size(), 4u);
  for (int r = 0; r < 4; ++r) {
    ASSERT_EQ(j["A"][r].size(), 4u);
    for (int c = 0; c < 4; ++c) EXPECT_EQ(j["A"][r][c].get<double>(), lm.A(r, c));
  }
  EXPECT_EQ(j["B"], nlohmann::json::parse("[[0.0],[1.0],[0.0],[0.0]]"));
  EXPECT_EQ(j["D"], nlohmann::json::parse("[[0.0]]"));
  // Eigenvalues: +-i w1, +-i w2 as [re, im], by modulus.
  ASSERT_EQ(j["eigenvalues"].size(), 4u);
  for (const auto& e : j["eigenvalues"]) {
    ASSERT_EQ(e.size(), 2u);
    EXPECT_NEAR(e[0].get<double>(), 0.0, 1e-12);
  }
  EXPECT_LT(std::abs(j["eigenvalues"][1][1].get<double>()), std::abs(j["eigenvalues"][2][1].get<double>()));
}

TEST(LinearJson, DoublesRoundTripExactly) {
  LinearModel lm = MassSpringDamper();
  lm.A(0, 0) = 0.1;
  lm.A(0, 1) = 1.0 / 3.0;
  lm.at = 2.0 / 3.0;
  const nlohmann::json back = nlohmann::json::parse(LinearJson(lm).dump());
  EXPECT_EQ(back["A"][0][0].get<double>(), 0.1);
  EXPECT_EQ(back["A"][0][1].get<double>(), 1.0 / 3.0);
  EXPECT_EQ(back["at"].get<double>(), 2.0 / 3.0);
}

TEST(LinearJson, EmptyMatricesAreEmptyLists) {
  // No inputs and no outputs: B is 2x0, C is 0x2 (rows none, columns two), D 0x0.
  LinearModel lm = MassSpringDamper();
  lm.inputs.clear();
  lm.input_units.clear();
  lm.outputs.clear();
  lm.output_units.clear();
  lm.B.resize(2, 0);
  lm.C.resize(0, 2);
  lm.D.resize(0, 0);
  const nlohmann::json j = LinearJson(lm);
  for (const char* key : {"B", "C", "D", "inputs", "outputs"}) {
    EXPECT_TRUE(j[key].is_array()) << key;
    EXPECT_TRUE(j[key].empty()) << key;
  }
  EXPECT_EQ(j["A"].size(), 2u);
  // A model without states.
  const nlohmann::json none = LinearJson(LinearModel{});
  EXPECT_TRUE(none["A"].is_array() && none["A"].empty());
  EXPECT_TRUE(none["eigenvalues"].is_array() && none["eigenvalues"].empty());
}

TEST(LinearJson, RecordMayNotReplaceTheFilesOwnKeys) {
  EXPECT_THROW(LinearJson(MassSpringDamper(), {{"A", 1}}), std::invalid_argument);
  EXPECT_THROW(LinearJson(MassSpringDamper(), nlohmann::json::array({1})), std::invalid_argument);
  // The record's model replaces the model's name.
  const nlohmann::json j = LinearJson(MassSpringDamper(), {{"model", {{"file", "msd.yaml"}}}});
  EXPECT_EQ(j["model"]["file"], "msd.yaml");
  // Null: no record.
  EXPECT_EQ(LinearJson(MassSpringDamper(), nullptr)["model"], "msd");
}

TEST(LinearJson, NamesThatAreNotUtf8StillDump) {
  LinearModel lm = MassSpringDamper();
  lm.states[0] = "p\xff";
  const nlohmann::json j = LinearJson(lm);
  EXPECT_NO_THROW((void)j.dump());
  EXPECT_EQ(j["states"][0], "p\xEF\xBF\xBD");
}

TEST(MatlabString, DoublesQuotesAndReplacesControlCharacters) {
  EXPECT_EQ(MatlabString("k1"), "'k1'");
  EXPECT_EQ(MatlabString(kHostile), "'a''; system(''rm -rf /''); '''");
  EXPECT_EQ(MatlabString("a\nb\rc\td"), "'a\xEF\xBF\xBD" "b\xEF\xBF\xBD" "c\xEF\xBF\xBD" "d'");
  EXPECT_EQ(MatlabString(""), "''");
}

/// A MATLAB statement list, lexed the way MATLAB does for what the script uses: a ' after an
/// identifier, a number, ] ) } or ' is a transpose, elsewhere it opens a char literal that '' does
/// not end; % outside a literal starts a comment. Returns the literals and fills `code` with the
/// text outside literals and comments; fails the test when a literal is not closed on its line.
std::vector<std::string> Lex(const std::string& script, std::string& code) {
  std::vector<std::string> literals;
  size_t i = 0;
  char prev = '\n';
  while (i < script.size()) {
    const char c = script[i];
    if (c == '%') {
      while (i < script.size() && script[i] != '\n') ++i;
      continue;
    }
    const bool transpose = std::isalnum(static_cast<unsigned char>(prev)) || prev == '_' || prev == ']' || prev == ')' || prev == '}' ||
                           prev == '.' || prev == '\'';
    if (c == '\'' && !transpose) {
      std::string lit;
      ++i;
      for (;;) {
        if (i >= script.size() || script[i] == '\n') {
          ADD_FAILURE() << "a literal runs to the end of its line";
          return literals;
        }
        if (script[i] == '\'') {
          if (i + 1 < script.size() && script[i + 1] == '\'') {
            lit += '\'';
            i += 2;
            continue;
          }
          ++i;
          break;
        }
        lit += script[i++];
      }
      literals.push_back(lit);
      code += "STR";
      prev = 'R';
      continue;
    }
    code += c;
    if (c != ' ') prev = c;
    ++i;
  }
  return literals;
}

TEST(LinearOctaveScript, HostileNamesStayInsideTheirLiterals) {
  LinearModel lm = MassSpringDamper();
  lm.model = kHostile;
  lm.states = {kHostile, "x\nsystem('y')"};
  lm.inputs = {"F'"};
  lm.outputs = {"%{"};
  lm.output_units = {"..."};
  const std::string script = LinearOctaveScript(lm);
  std::string code;
  const std::vector<std::string> literals = Lex(script, code);
  // Outside the literals: only the script's own statements.
  EXPECT_EQ(code.find("system"), std::string::npos) << code;
  EXPECT_EQ(code.find("rm"), std::string::npos) << code;
  std::set<std::string> words;
  for (size_t i = 0; i < code.size();) {
    if (std::isalpha(static_cast<unsigned char>(code[i])) || code[i] == '_') {
      size_t j = i;
      while (j < code.size() && (std::isalnum(static_cast<unsigned char>(code[j])) || code[j] == '_')) ++j;
      if (i == 0 || !std::isdigit(static_cast<unsigned char>(code[i - 1]))) words.insert(code.substr(i, j - i));  // not 1e+02's e
      i = j;
    } else {
      ++i;
    }
  }
  const std::set<std::string> allowed = {"model", "at", "states", "state_units", "inputs", "input_units", "outputs",
                                         "output_units", "A", "B", "C", "D", "STR", "zeros", "cell", "e"};
  for (const std::string& w : words) EXPECT_TRUE(allowed.count(w)) << w << " outside a literal in\n" << script;
  // The names come back whole (a line break as U+FFFD).
  ASSERT_GE(literals.size(), 5u);
  EXPECT_EQ(literals[0], kHostile);
  EXPECT_EQ(literals[1], kHostile);
  EXPECT_EQ(literals[2], "x\xEF\xBF\xBDsystem('y')");
  EXPECT_NE(std::find(literals.begin(), literals.end(), "F'"), literals.end());
  EXPECT_NE(std::find(literals.begin(), literals.end(), "%{"), literals.end());
  // Lines: 2 comments, model, at, 6 cell arrays, A (2 rows), B (2), C, D.
  EXPECT_EQ(std::count(script.begin(), script.end(), '\n'), 2 + 2 + 6 + 2 + 2 + 1 + 1) << script;
}

TEST(LinearOctaveScript, MatricesWithAllDigitsAndEmptyOnesAsZeros) {
  LinearModel lm = MassSpringDamper();
  lm.A(0, 0) = 0.1;
  lm.inputs.clear();
  lm.input_units.clear();
  lm.B.resize(2, 0);
  lm.D.resize(1, 0);
  const std::string script = LinearOctaveScript(lm);
  EXPECT_NE(script.find("A = [0.10000000000000001 -100;\n  1 0];\n"), std::string::npos) << script;
  EXPECT_NE(script.find("B = zeros(2, 0);\n"), std::string::npos) << script;
  EXPECT_NE(script.find("C = [0 100];\n"), std::string::npos) << script;
  EXPECT_NE(script.find("D = zeros(1, 0);\n"), std::string::npos) << script;
  EXPECT_NE(script.find("inputs = cell(1, 0);\n"), std::string::npos) << script;
  EXPECT_NE(script.find("states = {'m.p', 'k.q'};\n"), std::string::npos) << script;
  lm.A(0, 1) = std::numeric_limits<double>::infinity();
  lm.A(1, 0) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NE(LinearOctaveScript(lm).find("A = [0.10000000000000001 Inf;\n  NaN 0];\n"), std::string::npos);
}

TEST(LinearOctaveScript, RunsInOctave) {
  const std::string octave = OnPath("octave");
  if (octave.empty()) GTEST_SKIP() << "octave is not installed (not on PATH): the script is not run";
  LinearModel lm = TwoMasses();
  lm.states[0] = kHostile;
  const TempDir dir("multibond-octave");
  {
    std::ofstream(dir.path() / "linear.m") << LinearOctaveScript(lm);
    // The hostile name as character codes, so that the check does not depend on the escaping.
    std::string codes;
    for (unsigned char c : kHostile) codes += fmt::format("{} ", static_cast<int>(c));
    std::ofstream(dir.path() / "check.m") << "linear;\n"
                                          << "assert(isequal(size(A), [4 4]) && isequal(size(B), [4 1]) && isequal(size(C), [1 4]));\n"
                                          << "assert(A(1, 3) == -100 && A(4, 1) == -1 && A(4, 2) == 0.5 && B(2) == 1 && C(3) == 1);\n"
                                          << "assert(strcmp(states{1}, char([" << codes << "])));\n"
                                          << "assert(strcmp(inputs{1}, 'F.e') && numel(states) == 4);\n"
                                          << "assert(abs(sort(abs(imag(eig(A))))(end) - 12.6217) < 1e-3);\n";
  }
  const std::string error =
      RunProcess({octave, "--no-gui", "--norc", "--quiet", "check.m"}, dir.path().string(), (dir.path() / "octave.log").string(), true);
  EXPECT_EQ(error, "");
}

TEST(ModesJson, HasTheContractKeys) {
  const LinearModel lm = MassSpringDamper();
  const std::vector<Mode> modes = ComputeModes(lm);
  const nlohmann::json j = ModesJson(modes, lm, {{"version", "x"}});
  EXPECT_EQ(j["version"], "x");
  ASSERT_EQ(j["modes"].size(), 1u);
  const nlohmann::json& m = j["modes"][0];
  std::set<std::string> keys;
  for (const auto& [k, v] : m.items()) keys.insert(k);
  EXPECT_EQ(keys, (std::set<std::string>{"eigenvalue", "frequency_hz", "damping_ratio", "time_constant_s", "damped_frequency_hz",
                                         "participation", "shape", "motion", "conjugate_pair", "stores_energy"}));
  EXPECT_EQ(m["eigenvalue"][0].get<double>(), modes[0].eigenvalue.real());
  EXPECT_EQ(m["eigenvalue"][1].get<double>(), modes[0].eigenvalue.imag());
  EXPECT_EQ(m["damping_ratio"].get<double>(), modes[0].damping_ratio);
  EXPECT_EQ(m["time_constant_s"].get<double>(), modes[0].time_constant_s);
  EXPECT_NEAR(m["participation"]["m"].get<double>(), 0.5, 1e-12);
  EXPECT_EQ(m["shape"]["m.p"], nlohmann::json::parse("[1.0, 0.0]"));
  EXPECT_EQ(m["shape"]["k.q"][0].get<double>(), modes[0].shape(1).real());
  EXPECT_EQ(m["motion"]["m.v"][1].get<double>(), modes[0].motion[0].imag());
  EXPECT_THROW(ModesJson(modes, lm, {{"modes", 1}}), std::invalid_argument);
}

TEST(ModesJson, InfiniteTimeConstantIsNull) {
  const LinearModel lm = TwoMasses();
  const nlohmann::json j = ModesJson(ComputeModes(lm), lm);
  ASSERT_EQ(j["modes"].size(), 2u);
  for (const auto& m : j["modes"]) {
    EXPECT_TRUE(m["time_constant_s"].is_null());
    EXPECT_EQ(m["damping_ratio"].get<double>(), 0.0);
    EXPECT_EQ(m["participation"].size(), 4u);
  }
}

TEST(BodeCsv, HeaderAndFullPrecisionRows) {
  const std::string csv = BodeCsv({{0.1, -3.0, 45.5, {}}, {1.0 / 3.0, 13.979400086720377, -90.0, {}}});
  EXPECT_EQ(csv, "frequency [Hz],magnitude [dB],phase [deg]\n0.10000000000000001,-3,45.5\n0.33333333333333331,13.979400086720377,-90\n");
  EXPECT_EQ(BodeCsv({}), "frequency [Hz],magnitude [dB],phase [deg]\n");
  // The rows read back to the same doubles.
  EXPECT_EQ(std::stod("0.33333333333333331"), 1.0 / 3.0);
}

TEST(BodePlot, ScriptEscapesTheTitleAndRefusesOtherThanPlainFileNames) {
  const std::string title = "F.e \u2192 k.e'\n`rm -rf /` @x ^{big}";
  const std::string script = BodeGnuplotScript("bode.csv", "bode", title);
  // Every line of the script is the writer's own: the title's line break does not start one.
  EXPECT_EQ(script.find("\n`"), std::string::npos);
  EXPECT_EQ(script.find('`'), std::string::npos) << script;
  // One gnuplot string: ' doubled, the line break a space, backquotes U+FFFD, enhanced-text
  // markup shown as it is.
  EXPECT_NE(script.find("\n  set multiplot layout 2,1 title 'F.e \u2192 k.e'' \uFFFDrm -rf /\uFFFD \\@x \\^\\{big\\}' font \",15\"\n"),
            std::string::npos)
      << script;
  EXPECT_EQ(script.rfind("# F.e \u2192 k.e' \uFFFDrm -rf /\uFFFD @x ^{big}\n", 0), 0u) << script;
  EXPECT_NE(script.find("set logscale x"), std::string::npos);
  EXPECT_NE(script.find("plot 'bode.csv' using 1:2"), std::string::npos) << script;
  EXPECT_NE(script.find("plot 'bode.csv' using 1:3"), std::string::npos) << script;
  EXPECT_NE(script.find("set output 'figures/bode'.\".\".format"), std::string::npos) << script;
  for (const char* bad : {"../x", "a b", "", ".hidden", "a'b", "x/y"})
    EXPECT_THROW(BodeGnuplotScript(bad, "bode", "t"), std::invalid_argument) << bad;
  EXPECT_THROW(BodeGnuplotScript("bode.csv", "../bode", "t"), std::invalid_argument);
}

TEST(BodePlot, GnuplotDrawsPngAndSvg) {
  if (OnPath("gnuplot").empty()) GTEST_SKIP() << "gnuplot is not installed (not on PATH)";
  const LinearModel lm = MassSpringDamper();
  const TempDir dir("multibond-bode");
  std::ofstream(dir.path() / "bode.csv") << BodeCsv(FrequencyResponse(lm, 0, 0, DefaultFrequencies(lm)));
  const std::vector<std::string> files = DrawBodePlot(dir.path().string(), "bode.csv", "bode", "F.e \u2192 k.e (msd) 'q' `x`");
  ASSERT_EQ(files.size(), 2u);
  for (const char* ext : {"png", "svg"}) {
    const auto p = dir.path() / "figures" / (std::string("bode.") + ext);
    ASSERT_TRUE(std::filesystem::is_regular_file(p)) << p;
    EXPECT_GT(std::filesystem::file_size(p), 1000u) << p;
  }
  EXPECT_NE(ReadFile(dir.path() / "figures" / "bode.svg").find("frequency [Hz]"), std::string::npos);
  EXPECT_TRUE(std::filesystem::is_regular_file(dir.path() / "plots" / "bode.gp"));
  // Only the pictures, the script and the input: the work folder is gone.
  size_t entries = 0;
  for (const auto& e : std::filesystem::directory_iterator(dir.path())) {
    (void)e;
    ++entries;
  }
  EXPECT_EQ(entries, 3u);
  // A missing input.
  EXPECT_THROW(DrawBodePlot(dir.path().string(), "none.csv", "bode", "t"), std::runtime_error);
}

}  // namespace
}  // namespace multibond::linear
