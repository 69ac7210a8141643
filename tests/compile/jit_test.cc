// Compiling generated code into the cache and loading it (compile/jit.cc).

#include <stdlib.h>

#include <filesystem>
#include <fstream>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "multibond/compile/jit.h"
#include "support/temp_dir.h"

namespace multibond {
namespace {

namespace fs = std::filesystem;

/// Points the cache at a fresh folder for the test's lifetime.
class JitTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const char* old = std::getenv("MULTIBOND_CACHE");
    had_cache_ = old != nullptr;
    if (had_cache_) old_cache_ = old;
    setenv("MULTIBOND_CACHE", cache_.path().c_str(), 1);
  }
  void TearDown() override {
    if (had_cache_) {
      setenv("MULTIBOND_CACHE", old_cache_.c_str(), 1);
    } else {
      unsetenv("MULTIBOND_CACHE");
    }
  }
  std::vector<fs::path> Libraries() const {
    std::vector<fs::path> out;
    for (const auto& e : fs::directory_iterator(cache_.path()))
      if (e.path().extension() == ".so") out.push_back(e.path());
    return out;
  }
  testing::TempDir cache_{"multibond-jit"};
  bool had_cache_ = false;
  std::string old_cache_;
};

const char* kSource = "extern \"C\" double answer() { return 42.0; }\n";

double Call(const JitResult& r) { return reinterpret_cast<double (*)()>(r.symbol)(); }

TEST_F(JitTest, CompilesLoadsAndReusesTheCache) {
  const JitResult first = CompileAndLoad(kSource, "answer");
  ASSERT_NE(first.symbol, nullptr) << first.description;
  EXPECT_EQ(Call(first), 42.0);
  ASSERT_EQ(Libraries().size(), 1u);
  const auto stamp = fs::last_write_time(Libraries().front());
  const JitResult again = CompileAndLoad(kSource, "answer");
  ASSERT_NE(again.symbol, nullptr) << again.description;
  EXPECT_EQ(fs::last_write_time(Libraries().front()), stamp);  // loaded, not built again
}

// A cached library cut short (a full disk, an interrupted copy) used to send every later run to
// the interpreter, and every --jit on run to an error: it is built again.
TEST_F(JitTest, ADamagedCachedLibraryIsBuiltAgain) {
  ASSERT_NE(CompileAndLoad(kSource, "answer").symbol, nullptr);
  ASSERT_EQ(Libraries().size(), 1u);
  const fs::path so = Libraries().front();
  std::ofstream(so, std::ios::trunc).close();  // zero bytes
  ASSERT_EQ(fs::file_size(so), 0u);
  const JitResult r = CompileAndLoad(kSource, "answer");
  ASSERT_NE(r.symbol, nullptr) << r.description;
  EXPECT_EQ(Call(r), 42.0);
  EXPECT_GT(fs::file_size(so), 0u);
}

TEST_F(JitTest, ACompileErrorIsReportedNotThrown) {
  const JitResult r = CompileAndLoad("this is not C++\n", "answer");
  EXPECT_EQ(r.symbol, nullptr);
  EXPECT_THAT(r.description, ::testing::HasSubstr("compiling the generated code"));
  EXPECT_TRUE(Libraries().empty());
}

}  // namespace
}  // namespace multibond
