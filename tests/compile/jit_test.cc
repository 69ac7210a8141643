// Compiling generated code into the cache and loading it (compile/jit.cc): a private cache, and
// a stop while the compiler runs.

#include <signal.h>
#include <stdlib.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>

#include <fmt/format.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "multibond/compile/jit.h"
#include "multibond/core/interrupt.h"
#include "multibond/core/process.h"
#include "support/alive.h"
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

// ---------------------------------------------------------------------------------------------
// Several units (docs/design.md, "Generated code at scale").

std::vector<std::string> Units(int n) {
  std::vector<std::string> out;
  for (int k = 0; k < n; ++k) out.push_back(fmt::format("extern \"C\" double answer() {{ return {}.0; }}\n", k));
  return out;
}

TEST_F(JitTest, UnitsAreCachedEachUnderItsOwnHashAndLoadedOnceAProcess) {
  const JitBatch first = CompileAndLoadUnits(Units(3), "answer");
  ASSERT_TRUE(first.ok()) << first.description;
  ASSERT_EQ(first.symbols.size(), 3u);
  for (int k = 0; k < 3; ++k) EXPECT_EQ(reinterpret_cast<double (*)()>(first.symbols[k])(), k);  // each its own library
  EXPECT_EQ(first.compiled, 3);
  EXPECT_EQ(Libraries().size(), 3u);
  // The same texts again: nothing compiled, nothing read from the disk.
  const JitBatch again = CompileAndLoadUnits(Units(3), "answer");
  ASSERT_TRUE(again.ok()) << again.description;
  EXPECT_EQ(again.compiled, 0);
  EXPECT_EQ(again.from_disk, 0);
  EXPECT_EQ(again.reused, 3);
  EXPECT_EQ(again.symbols, first.symbols);
  // A unit whose cached file changed since is checked again (and, here, found intact).
  const fs::path so = Libraries().front();
  fs::permissions(so, fs::perms(0400));
  const JitBatch checked = CompileAndLoadUnits(Units(3), "answer");
  ASSERT_TRUE(checked.ok()) << checked.description;
  EXPECT_EQ(checked.reused, 2);
  EXPECT_EQ(checked.from_disk, 1);
  EXPECT_EQ(checked.compiled, 0);
}

TEST_F(JitTest, ACancelledBatchLoadsNothingAndThrowsNothing) {
  std::atomic<bool> cancel{true};
  JitControl control;
  control.cancel = &cancel;
  const JitBatch b = CompileAndLoadUnits(Units(2), "answer", control);
  EXPECT_FALSE(b.ok());
  EXPECT_THAT(b.description, ::testing::HasSubstr("cancelled"));
  EXPECT_TRUE(Libraries().empty());
}

// ---------------------------------------------------------------------------------------------
// A private cache (issue 21): nothing is loaded from a place another user can write.

const char* kPlanted = "extern \"C\" double answer() { return 666.0; }\n";

/// Compiles `source` into the shared object `so` with the system compiler (an attacker's library).
void CompileLibrary(const std::string& source, const fs::path& so) {
  const fs::path cc = so.string() + ".cc";
  std::ofstream(cc) << source;
  ASSERT_EQ(RunProcess({"c++", "-shared", "-fPIC", cc.string(), "-o", so.string()}, "", so.string() + ".log"), "");
  fs::remove(cc);
  fs::remove(so.string() + ".log");
}

/// Sets an environment variable for the test's lifetime (unset when `value` is null).
class ScopedEnv {
 public:
  ScopedEnv(const char* name, const char* value) : name_(name) {
    const char* old = std::getenv(name);
    had_ = old != nullptr;
    if (had_) old_ = old;
    if (value) setenv(name, value, 1);
    else unsetenv(name);
  }
  ~ScopedEnv() {
    if (had_) setenv(name_.c_str(), old_.c_str(), 1);
    else unsetenv(name_.c_str());
  }

 private:
  std::string name_, old_;
  bool had_ = false;
};

mode_t ModeOf(const fs::path& p) {
  struct stat st {};
  EXPECT_EQ(lstat(p.c_str(), &st), 0) << p;
  return st.st_mode & 07777;
}

/// The entries of a folder, by name.
std::vector<std::string> Entries(const fs::path& dir) {
  std::vector<std::string> out;
  for (const auto& e : fs::directory_iterator(dir)) out.push_back(e.path().filename().string());
  return out;
}

TEST_F(JitTest, TheCacheFolderAndItsFilesArePrivate) {
  const fs::path dir = cache_.path() / "new" / "cache";
  ScopedEnv env("MULTIBOND_CACHE", dir.c_str());
  const JitResult r = CompileAndLoad(kSource, "answer");
  ASSERT_NE(r.symbol, nullptr) << r.description;
  EXPECT_EQ(r.warning, "");
  EXPECT_EQ(ModeOf(dir), 0700u);
  int libraries = 0;
  for (const std::string& name : Entries(dir)) {
    EXPECT_EQ(ModeOf(dir / name) & 077, 0u) << name;  // 0600: no one else reads or writes
    EXPECT_THAT(name, ::testing::Not(::testing::HasSubstr(".tmp"))) << "a temporary was left";
    libraries += fs::path(name).extension() == ".so";
  }
  EXPECT_EQ(libraries, 1);
}

// Before: without a usable cache folder the library went to $TMPDIR/multibond-cache-UID, a
// name anyone can create first; a library planted there under the expected name was loaded.
TEST_F(JitTest, ALibraryPlantedInTheOldSharedFallbackIsNeverLoaded) {
  testing::TempDir tmp("multibond-jit-tmpdir");
  ScopedEnv tmpdir("TMPDIR", tmp.path().c_str());
  ScopedEnv no_cache("MULTIBOND_CACHE", nullptr), no_xdg("XDG_CACHE_HOME", nullptr), no_home("HOME", nullptr);
  // The name today's code used: FNV-1a of the compiler command, its flags and the source.
  std::string key = "c++ -std=c++20 -O2 -march=native -fno-tree-slp-vectorize -fPIC -shared -fno-math-errno\n";
  key += kSource;
  std::uint64_t h = 1469598103934665603ULL;
  for (unsigned char c : key) h = (h ^ c) * 1099511628211ULL;
  const fs::path planted_dir = tmp.path() / ("multibond-cache-" + std::to_string(getuid()));
  fs::create_directories(planted_dir);
  char name[64];
  std::snprintf(name, sizeof name, "rhs-%016llx-%zu.so", static_cast<unsigned long long>(h), std::strlen(kSource));
  CompileLibrary(kPlanted, planted_dir / name);
  const JitResult r = CompileAndLoad(kSource, "answer");
  ASSERT_NE(r.symbol, nullptr) << r.description;
  EXPECT_EQ(Call(r), 42.0);
  EXPECT_THAT(r.warning, ::testing::HasSubstr("private temporary folder"));
  EXPECT_THAT(r.description, ::testing::HasSubstr("not cached"));
  // The private folder is gone after loading; the planted folder was not touched.
  EXPECT_THAT(Entries(tmp.path()), ::testing::ElementsAre(planted_dir.filename().string()));
  EXPECT_THAT(Entries(planted_dir), ::testing::ElementsAre(name));
}

// Before: a cache folder that others can write was used as it was.
TEST_F(JitTest, AGroupWritableCacheFolderIsRefusedAndTheRunStillWorks) {
  testing::TempDir tmp("multibond-jit-tmpdir");
  ScopedEnv tmpdir("TMPDIR", tmp.path().c_str());
  fs::permissions(cache_.path(), fs::perms(0770));
  const JitResult r = CompileAndLoad(kSource, "answer");
  ASSERT_NE(r.symbol, nullptr) << r.description;
  EXPECT_EQ(Call(r), 42.0);
  EXPECT_THAT(r.warning, ::testing::AllOf(::testing::HasSubstr(cache_.path().string()), ::testing::HasSubstr("can be written by its group"),
                                          ::testing::HasSubstr("mode 0770"), ::testing::HasSubstr("private temporary folder")));
  EXPECT_TRUE(Entries(cache_.path()).empty());  // nothing written into it
  EXPECT_TRUE(Entries(tmp.path()).empty());     // and the private folder removed
}

TEST_F(JitTest, AnOtherWritableCacheFolderIsRefused) {
  fs::permissions(cache_.path(), fs::perms(0757));
  const JitResult r = CompileAndLoad(kSource, "answer");
  ASSERT_NE(r.symbol, nullptr) << r.description;
  EXPECT_THAT(r.warning, ::testing::HasSubstr("can be written by other users"));
  EXPECT_TRUE(Entries(cache_.path()).empty());
}

// Before: the link was followed, to wherever it pointed.
TEST_F(JitTest, ASymbolicLinkAsCacheFolderIsRefused) {
  const fs::path target = cache_.path() / "elsewhere", link = cache_.path() / "link";
  fs::create_directory(target);
  fs::permissions(target, fs::perms(0700));
  fs::create_directory_symlink(target, link);
  ScopedEnv env("MULTIBOND_CACHE", link.c_str());
  const JitResult r = CompileAndLoad(kSource, "answer");
  ASSERT_NE(r.symbol, nullptr) << r.description;
  EXPECT_EQ(Call(r), 42.0);
  EXPECT_THAT(r.warning, ::testing::HasSubstr(link.string() + " is a symbolic link"));
  EXPECT_TRUE(Entries(target).empty());
}

// Before: a folder of another user was used (and its libraries loaded). Needs root to give the
// folder away (CI runs as root); as another user the mode tests above stand in for it.
TEST_F(JitTest, ACacheFolderOfAnotherUserIsRefused) {
  if (geteuid() != 0) GTEST_SKIP() << "needs root to chown";
  const fs::path dir = cache_.path() / "theirs";
  fs::create_directory(dir);
  fs::permissions(dir, fs::perms(0700));
  ASSERT_EQ(chown(dir.c_str(), 54321, 54321), 0);
  ScopedEnv env("MULTIBOND_CACHE", dir.c_str());
  const JitResult r = CompileAndLoad(kSource, "answer");
  ASSERT_NE(r.symbol, nullptr) << r.description;
  EXPECT_THAT(r.warning, ::testing::HasSubstr("belongs to user 54321"));
  EXPECT_TRUE(Entries(dir).empty());
}

// Before: any library under the expected name was loaded, whatever its bytes.
TEST_F(JitTest, ATamperedCachedLibraryIsNotLoaded) {
  ASSERT_NE(CompileAndLoad(kSource, "answer").symbol, nullptr);
  ASSERT_EQ(Libraries().size(), 1u);
  const fs::path so = Libraries().front();
  const fs::path evil = cache_.path() / "evil.bin";
  CompileLibrary(kPlanted, evil);
  {
    // Same file, same owner and mode, other bytes: a valid library that answers 666.
    std::ifstream in(evil, std::ios::binary);
    std::ofstream out(so, std::ios::binary | std::ios::trunc);
    out << in.rdbuf();
  }
  fs::remove(evil);
  const JitResult r = CompileAndLoad(kSource, "answer");
  ASSERT_NE(r.symbol, nullptr) << r.description;
  EXPECT_EQ(Call(r), 42.0);
  EXPECT_THAT(r.description, ::testing::AllOf(::testing::HasSubstr("does not match the SHA-256"), ::testing::HasSubstr("built again")));
}

TEST_F(JitTest, ACachedLibraryOthersCanWriteIsNotLoaded) {
  ASSERT_NE(CompileAndLoad(kSource, "answer").symbol, nullptr);
  ASSERT_EQ(Libraries().size(), 1u);
  fs::permissions(Libraries().front(), fs::perms(0666));
  const JitResult r = CompileAndLoad(kSource, "answer");
  ASSERT_NE(r.symbol, nullptr) << r.description;
  EXPECT_THAT(r.description, ::testing::AllOf(::testing::HasSubstr("can be written by"), ::testing::HasSubstr("built again")));
  EXPECT_EQ(ModeOf(Libraries().front()), 0600u);
}

TEST_F(JitTest, ASymbolicLinkInTheCacheIsNotFollowed) {
  ASSERT_NE(CompileAndLoad(kSource, "answer").symbol, nullptr);
  ASSERT_EQ(Libraries().size(), 1u);
  const fs::path so = Libraries().front();
  const fs::path evil = cache_.path() / "evil.bin";
  CompileLibrary(kPlanted, evil);
  fs::remove(so);
  fs::create_symlink(evil, so);
  const JitResult r = CompileAndLoad(kSource, "answer");
  ASSERT_NE(r.symbol, nullptr) << r.description;
  EXPECT_EQ(Call(r), 42.0);
  EXPECT_FALSE(fs::is_symlink(so));
}

// Loaded through /proc/self/fd/N, a library is known to dlopen by that name: a second library
// loaded through the same N (the first descriptor closed and reused) was taken for the first.
TEST_F(JitTest, TwoLibrariesLoadedOneAfterTheOtherAreBothThemselves) {
  const JitResult first = CompileAndLoad(kSource, "answer");
  ASSERT_NE(first.symbol, nullptr) << first.description;
  const JitResult second = CompileAndLoad("extern \"C\" double answer() { return 7.0; }\n", "answer");
  ASSERT_NE(second.symbol, nullptr) << second.description;
  EXPECT_EQ(Call(first), 42.0);
  EXPECT_EQ(Call(second), 7.0);
  const JitResult third = CompileAndLoad("extern \"C\" double answer() { return 8.0; }\n", "answer");
  ASSERT_NE(third.symbol, nullptr) << third.description;
  EXPECT_EQ(Call(third), 8.0);
}

// ---------------------------------------------------------------------------------------------
// A stop while the compiler runs (issue 21): the compiler is ended, nothing is left behind.

// Before: the wait blocked until the compiler ended (here 30 s), and the run went on.
TEST_F(JitTest, AStopWhileCompilingEndsTheCompilerAndRemovesTheTemporaries) {
  const fs::path script = cache_.path() / "slow-cxx.sh", pid_file = cache_.path() / "compiler.pid";
  std::ofstream(script) << "#!/bin/sh\nsleep 30 &\necho $! > \"" << pid_file.string() << "\"\nwait\n";
  fs::permissions(script, fs::perms(0700));
  const fs::path cache = cache_.path() / "cache";
  ScopedEnv cxx("MULTIBOND_CXX", script.c_str()), env("MULTIBOND_CACHE", cache.c_str());
  ResetStop();
  const auto start = std::chrono::steady_clock::now();
  std::thread stopper([] {
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
    StopFlag().store(true);
  });
  try {
    CompileAndLoad(kSource, "answer");
    ADD_FAILURE() << "CompileAndLoad returned although a stop was asked for";
  } catch (const Interrupted& e) {
    EXPECT_THAT(e.what(), ::testing::HasSubstr("while compiling the generated code"));
  }
  stopper.join();
  ResetStop();
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(2));
  pid_t compiler = 0;
  std::ifstream(pid_file) >> compiler;
  ASSERT_GT(compiler, 0);
  for (int i = 0; i < 100 && testing::Alive(compiler); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  EXPECT_FALSE(testing::Alive(compiler)) << "the compiler's child " << compiler << " is still running";
  // Only the source under its published name stays (no temporary, no log, no library).
  for (const std::string& name : Entries(cache))
    EXPECT_EQ(std::count(name.begin(), name.end(), '.'), 1) << name << " was left behind";
}

}  // namespace
}  // namespace multibond
