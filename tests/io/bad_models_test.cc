// The bad-model corpus: every file in tests/models/bad/ is a realistic mistake in a model file.
// Each opens with a header saying what multibond must report:
//   # expect: <substring of the diagnostic, as Diagnostic::ToString() prints it>
//   # line: <line the diagnostic points at, 0 = any/none>
//   # code: <diagnostic code>          (optional; every diagnostic has one, the header checks which)
//   # errors: <how many errors in all> (optional; for mistakes that used to bring follow-on errors)
// Loading, compiling and laying out the outputs (as `multibond run` does) must throw a
// ModelError, one of whose diagnostics contains the text, at that line, with that code.

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "support/corpus_header.h"
#include "multibond/io/model_loader.h"
#include "multibond/sim/simulator.h"

namespace multibond {
namespace {

namespace fs = std::filesystem;

constexpr const char* kCorpus = MULTIBOND_SOURCE_DIR "/tests/models/bad";

std::vector<fs::path> CorpusFiles() {
  std::vector<fs::path> files;
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(kCorpus, ec))
    if (entry.is_regular_file() && entry.path().extension() == ".yaml") files.push_back(entry.path());
  std::sort(files.begin(), files.end());
  return files;
}

struct Expectation {
  std::string expect;
  int line = -1;
  std::string code;
  int errors = -1;  ///< how many errors in all, when the header says (-1: not checked)
};

/// Reads the header: the leading comment lines "# key: value".
Expectation ReadHeader(const fs::path& file) {
  Expectation x;
  for (const auto& [key, value] : testing::ReadCorpusHeader(file)) {
    if (key == "expect") x.expect = value;
    else if (key == "line") x.line = std::stoi(value);
    else if (key == "code") x.code = value;
    else if (key == "errors") x.errors = std::stoi(value);
  }
  return x;
}

TEST(BadModels, CorpusHasAtLeast45Files) { EXPECT_GE(CorpusFiles().size(), 45u) << "in " << kCorpus; }

class BadModel : public ::testing::TestWithParam<fs::path> {};

TEST_P(BadModel, IsRejectedWithTheExpectedDiagnostic) {
  const fs::path& file = GetParam();
  const Expectation x = ReadHeader(file);
  ASSERT_FALSE(x.expect.empty()) << file << " has no '# expect:' header line";
  ASSERT_GE(x.line, 0) << file << " has no '# line:' header line";

  std::vector<Diagnostic> diagnostics;
  try {
    const LoadedModel lm = LoadModelFile(file.string());
    const auto model = CompiledModel::Compile(lm.graph, lm.compile);
    (void)MakeColumns(*model, false);  // the output layout: reports unknown output variables
    FAIL() << file.filename() << " loaded, compiled and laid out its outputs: the mistake was not caught";
  } catch (const ModelError& e) {
    diagnostics = e.diagnostics();
  }

  std::string all;
  for (const Diagnostic& d : diagnostics) all += d.ToString() + "\n";
  const auto it = std::find_if(diagnostics.begin(), diagnostics.end(),
                               [&](const Diagnostic& d) { return d.ToString().find(x.expect) != std::string::npos; });
  ASSERT_NE(it, diagnostics.end()) << "no diagnostic contains \"" << x.expect << "\"; got:\n" << all;
  if (x.line != 0) {
    EXPECT_EQ(it->where.line, x.line) << it->ToString();
  }
  if (!x.code.empty()) {
    EXPECT_EQ(it->code, x.code) << it->ToString();
  }
  // Every diagnostic carries a code of the catalogue (docs/model-format.md#diagnostic-codes): a
  // script or an editor can act on it without reading the words.
  for (const Diagnostic& d : diagnostics) EXPECT_FALSE(d.code.empty()) << "a diagnostic without a code: " << d.ToString();
  // One mistake, one error: no follow-on errors from what the first one refused.
  if (x.errors >= 0) {
    const auto errors = std::count_if(diagnostics.begin(), diagnostics.end(), [](const Diagnostic& d) { return d.severity == Diagnostic::Severity::kError; });
    EXPECT_EQ(errors, x.errors) << all;
  }
}

std::string TestName(const ::testing::TestParamInfo<fs::path>& info) {
  std::string name = info.param.stem().string();
  for (char& c : name)
    if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
  return name;
}

INSTANTIATE_TEST_SUITE_P(Corpus, BadModel, ::testing::ValuesIn(CorpusFiles()), TestName);
// An empty corpus is reported by CorpusHasAtLeast45Files, not as an uninstantiated suite.
GTEST_ALLOW_UNINSTANTIATED_PARAMETERIZED_TEST(BadModel);

}  // namespace
}  // namespace multibond
