// Regression tests for what fuzzing found (scripts/fuzz, fuzz/model_loader_fuzzer.cc).
//
// Every file in tests/models/fuzz/ is a minimised input that once crashed, hung or tripped a
// sanitizer. Each goes through what the fuzzer does (fuzz/run_front_end.h: load, compile, the
// file's run options, lay out the outputs, one right-hand side at the initial state) and must end
// in a ModelError or in success: never in another exception, a crash or a hang. So must every
// model file of the hostile corpus (tests/models/hostile/, run through the CLI by
// tests/cli/hostile_test.cc), in process here.
//
// A file whose header has a line
//   # status: open
// reproduces a bug that is not fixed yet (the header says where it is). Those files run in the
// DISABLED_ instantiation below, so that the suite stays green and `--gtest_also_run_disabled_tests`
// shows them; when the bug is fixed, change the line to `# status: fixed`.

#include <algorithm>
#include <cctype>
#include <exception>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <typeinfo>
#include <vector>

#include <gtest/gtest.h>

#include "../../fuzz/run_front_end.h"

namespace multibond {
namespace {

namespace fs = std::filesystem;

constexpr const char* kDir = MULTIBOND_SOURCE_DIR "/tests/models/fuzz";
constexpr const char* kHostile = MULTIBOND_SOURCE_DIR "/tests/models/hostile";

bool IsOpen(const fs::path& file) {
  std::ifstream in(file);
  std::string line;
  while (std::getline(in, line) && line.rfind('#', 0) == 0)
    if (line.find("status:") != std::string::npos) return line.find("open") != std::string::npos;
  return false;
}

std::vector<fs::path> Files(bool open, const char* dir = kDir) {
  std::vector<fs::path> files;
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(dir, ec))
    if (entry.is_regular_file() && entry.path().extension() == ".yaml" && IsOpen(entry.path()) == open)
      files.push_back(entry.path());
  std::sort(files.begin(), files.end());
  return files;
}

std::string ReadFile(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

class FuzzRegression : public ::testing::TestWithParam<fs::path> {};

TEST_P(FuzzRegression, ThrowsModelErrorOrSucceeds) {
  const std::string text = ReadFile(GetParam());
  try {
    fuzz::RunFrontEnd(text, GetParam().filename().string());
  } catch (const ModelError&) {
    SUCCEED();  // a diagnosed bad model
  } catch (const std::exception& e) {
    FAIL() << "escaped as " << typeid(e).name() << ", not as a ModelError: " << e.what();
  }
}

std::string TestName(const ::testing::TestParamInfo<fs::path>& info) {
  std::string name = info.param.stem().string();
  for (char& c : name)
    if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
  return name;
}

INSTANTIATE_TEST_SUITE_P(Fixed, FuzzRegression, ::testing::ValuesIn(Files(false)), TestName);
// Known, not yet fixed bugs (see each file's header): disabled until fixed.
INSTANTIATE_TEST_SUITE_P(Hostile, FuzzRegression, ::testing::ValuesIn(Files(false, kHostile)), TestName);
INSTANTIATE_TEST_SUITE_P(DISABLED_Open, FuzzRegression, ::testing::ValuesIn(Files(true)), TestName);
GTEST_ALLOW_UNINSTANTIATED_PARAMETERIZED_TEST(FuzzRegression);

TEST(FuzzRegression, ReproducersAreThere) {
  std::error_code ec;
  EXPECT_TRUE(fs::is_directory(kDir, ec)) << kDir;
}

}  // namespace
}  // namespace multibond
