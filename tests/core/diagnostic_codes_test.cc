// The catalogue of diagnostic codes (core/diagnostic_codes.h) is the one list of codes: the table of
// docs/model-format.md shows it row for row, no source spells a code but through its constant, and
// every code the bad-model corpus and the documentation's bad examples expect is in it.

#include <filesystem>
#include <fstream>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "multibond/core/diagnostic_codes.h"
#include "multibond/io/limits.h"
#include "support/temp_dir.h"

namespace multibond {
namespace {

namespace fs = std::filesystem;

std::vector<std::string> Lines(const std::string& text) {
  std::vector<std::string> lines;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

std::set<std::string> CatalogueCodes() {
  std::set<std::string> out;
  for (const codes::CodeInfo& c : codes::kCatalogue) out.emplace(c.code);
  return out;
}

const char* ExitColumn(codes::Outcome o) {
  switch (o) {
    case codes::Outcome::kWarning: return "0 (warning)";
    case codes::Outcome::kModelError: return "1";
    case codes::Outcome::kFileError: return "74";
    case codes::Outcome::kUsage: return "64";
  }
  return "?";
}

/// The rows of the documentation's table of codes, as written.
std::vector<std::string> DocumentedRows() {
  std::vector<std::string> rows;
  bool inside = false;
  for (const std::string& line : Lines(testing::ReadFile(MULTIBOND_SOURCE_DIR "/docs/model-format.md"))) {
    if (line == "| code | exit | problem |") inside = true;
    else if (inside && line.rfind("| `", 0) == 0) rows.push_back(line);
    else if (inside && line.rfind("|---", 0) != 0) break;
  }
  return rows;
}

TEST(DiagnosticCodes, EachCodeOnceAsLayerDotName) {
  std::set<std::string> seen;
  const std::regex shape("[a-z]+\\.[a-z_-]+");
  for (const codes::CodeInfo& c : codes::kCatalogue) {
    EXPECT_TRUE(seen.emplace(c.code).second) << "twice in the catalogue: " << c.code;
    EXPECT_TRUE(std::regex_match(std::string(c.code), shape)) << c.code;
    EXPECT_FALSE(c.meaning.empty()) << c.code;
  }
}

TEST(DiagnosticCodes, TheDocumentationShowsTheCatalogueRowForRow) {
  std::vector<std::string> expected;
  for (const codes::CodeInfo& c : codes::kCatalogue)
    expected.push_back(fmt::format("| `{}` | {} | {} |", c.code, ExitColumn(c.outcome), c.meaning));
  const std::vector<std::string> documented = DocumentedRows();
  ASSERT_FALSE(documented.empty()) << "no '| code | exit | problem |' table in docs/model-format.md";
  std::string all;
  for (const auto& row : expected) all += row + "\n";
  EXPECT_EQ(documented, expected) << "docs/model-format.md's table of codes should read:\n" << all;
}

TEST(DiagnosticCodes, NoSourceSpellsACodeButTheCatalogue) {
  // Every layer names a code by its constant (codes::kExprUnsupported): a code written out as a
  // string literal elsewhere ("expr.unsupported", outside a comment) could drift from the
  // catalogue unseen. The sources of the library, the command line and the Python module.
  const std::set<std::string> known = CatalogueCodes();
  int files = 0;
  for (const char* root : {MULTIBOND_SOURCE_DIR "/src/multibond", MULTIBOND_SOURCE_DIR "/apps", MULTIBOND_SOURCE_DIR "/python/src"}) {
    for (const auto& entry : fs::recursive_directory_iterator(root)) {
      if (entry.path().extension() != ".cc" && entry.path().extension() != ".h") continue;
      if (entry.path().filename() == "diagnostic_codes.h") continue;
      ++files;
      int line_number = 0;
      for (const std::string& line : Lines(testing::ReadFile(entry.path()))) {
        ++line_number;
        const std::string code_part = line.substr(0, line.find("//"));
        for (const std::string& code : known)
          EXPECT_EQ(code_part.find('"' + code + '"'), std::string::npos)
              << entry.path().string() << ":" << line_number << " spells the code '" << code << "': use its constant of "
              << "core/diagnostic_codes.h";
      }
    }
  }
  EXPECT_GT(files, 100);
}

TEST(DiagnosticCodes, EveryCodeTheBadModelsAndTheDocumentationExpectIsCatalogued) {
  const std::set<std::string> known = CatalogueCodes();
  int found = 0;
  for (const auto& entry : fs::directory_iterator(MULTIBOND_SOURCE_DIR "/tests/models/bad"))
    for (const std::string& line : Lines(testing::ReadFile(entry.path())))
      if (line.rfind("# code:", 0) == 0) {
        std::string code = line.substr(7);
        code.erase(0, code.find_first_not_of(' '));
        ++found;
        EXPECT_TRUE(known.count(code)) << entry.path().filename() << " expects '" << code << "'";
      }
  for (const auto& entry : fs::directory_iterator(MULTIBOND_SOURCE_DIR "/docs")) {
    if (entry.path().extension() != ".md") continue;
    for (const std::string& line : Lines(testing::ReadFile(entry.path())))
      if (line.rfind("# doc: expect-error ", 0) == 0) {
        const std::string code = line.substr(20, line.find_first_of(" \r", 20) - 20);
        ++found;
        EXPECT_TRUE(known.count(code)) << entry.path().filename() << " expects '" << code << "'";
      }
  }
  EXPECT_GT(found, 20);
}

TEST(DiagnosticCodes, LimitsAModelFileCanExceedHaveACode) {
  for (const char* limit : {"file-size", "yaml-nodes", "depth", "instances", "elements", "bonds"}) {
    const std::string_view code = codes::LimitCode(limit);
    EXPECT_EQ(code, fmt::format("limit.{}", limit));
    ASSERT_NE(codes::Find(code), nullptr) << limit;
  }
  // 'steps' and 'results-size' are said by run and plot, not as model diagnostics.
  EXPECT_TRUE(codes::LimitCode("steps").empty());
  EXPECT_TRUE(codes::LimitCode("results-size").empty());
  EXPECT_TRUE(codes::LimitCode("").empty());
  for (const std::string& name : LimitNames()) {
    if (name == "steps" || name == "results-size") continue;
    EXPECT_FALSE(codes::LimitCode(name).empty()) << name;
  }
}

TEST(DiagnosticCodes, OutcomeIsTheExitCode) {
  EXPECT_EQ(codes::OutcomeOf(codes::kIoUnreadable), codes::Outcome::kFileError);
  EXPECT_EQ(codes::OutcomeOf(codes::kIoNotRegular), codes::Outcome::kFileError);
  EXPECT_EQ(static_cast<int>(codes::Outcome::kFileError), 74);
  EXPECT_EQ(codes::OutcomeOf(codes::kParamRange), codes::Outcome::kModelError);
  EXPECT_EQ(codes::OutcomeOf(codes::kMechInitialGap), codes::Outcome::kWarning);
  EXPECT_EQ(codes::OutcomeOf(""), codes::Outcome::kModelError);        // a loader message without a code
  EXPECT_EQ(codes::OutcomeOf("no.such"), codes::Outcome::kModelError);  // not catalogued: still the model's fault
  // Every io.* code, and only those, ends with 74 (the CLI's test of the prefix says the same).
  for (const codes::CodeInfo& c : codes::kCatalogue)
    EXPECT_EQ(c.outcome == codes::Outcome::kFileError, c.code.starts_with("io.")) << c.code;
}

}  // namespace
}  // namespace multibond
