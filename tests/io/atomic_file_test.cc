// AtomicFile: a file appears complete or not at all, under the name asked for, whatever was
// planted there; a write that cannot complete (a full disk) leaves nothing.

#include "multibond/io/atomic_file.h"

#include <signal.h>
#include <sys/resource.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "multibond/core/sha256.h"
#include "support/temp_dir.h"

namespace multibond {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using testing::ReadFile;
using testing::ListNames;
using testing::TempDir;


TEST(AtomicFile, HasNoNameUntilPublishedAndThenTheWholeContent) {
  TempDir dir;
  const fs::path dest = dir.path() / "run.json";
  AtomicFile f(dest.string());
  f.Write("{\"a\": ");
  f.Write("1}\n");
  EXPECT_TRUE(ListNames(dir.path()).empty());
  f.Finish();
  EXPECT_EQ(f.bytes(), 9u);
  EXPECT_EQ(f.sha256(), Sha256Hex("{\"a\": 1}\n"));
  EXPECT_TRUE(ListNames(dir.path()).empty());
  f.Publish();
  EXPECT_EQ(ReadFile(dest), "{\"a\": 1}\n");
  EXPECT_EQ(ListNames(dir.path()), std::vector<std::string>{"run.json"});
}

TEST(AtomicFile, APlantedLinkAtTheNameIsReplacedAndItsTargetUntouched) {
  TempDir dir, elsewhere;
  const fs::path victim = elsewhere.path() / "victim";
  std::ofstream(victim) << "precious";
  const fs::path dest = dir.path() / "index.html";
  fs::create_symlink(victim, dest);
  fs::create_symlink(victim, dest.string() + ".partial");  // where earlier versions wrote first
  WriteFileAtomic(dest.string(), "new");
  EXPECT_EQ(ReadFile(victim), "precious");
  EXPECT_FALSE(fs::is_symlink(dest));
  EXPECT_EQ(ReadFile(dest), "new");
}

TEST(AtomicFile, TwoWritersOfOneNameDoNotMix) {
  TempDir dir;
  const fs::path dest = dir.path() / "results.csv";
  AtomicFile a(dest.string()), b(dest.string());
  a.Write(std::string(100000, 'a'));
  b.Write(std::string(50, 'b'));
  a.Commit();
  EXPECT_EQ(ReadFile(dest), std::string(100000, 'a'));
  b.Commit();
  EXPECT_EQ(ReadFile(dest), std::string(50, 'b'));
  EXPECT_EQ(ListNames(dir.path()), std::vector<std::string>{"results.csv"});
}

TEST(AtomicFile, DestinationThatIsADirectoryThrowsAndLeavesNothing) {
  TempDir dir;
  const fs::path dest = dir.path() / "run.json";
  fs::create_directory(dest);
  try {
    WriteFileAtomic(dest.string(), std::string(1 << 20, 'x'));
    ADD_FAILURE() << "no error";
  } catch (const std::runtime_error& e) {
    EXPECT_EQ(std::string(e.what()), "cannot write '" + dest.string() + "': it is a directory");
  }
  EXPECT_EQ(ListNames(dir.path()), std::vector<std::string>{"run.json"});
}

TEST(AtomicFile, NoFolderIsSaid) {
  TempDir dir;
  const fs::path dest = dir.path() / "nope" / "a.csv";
  EXPECT_THROW(
      {
        try {
          AtomicFile f(dest.string());
        } catch (const std::runtime_error& e) {
          EXPECT_THAT(e.what(), HasSubstr("no folder '" + (dir.path() / "nope").string() + "'"));
          throw;
        }
      },
      std::runtime_error);
}

/// A full disk, as this process sees it: a file size limit (writes past it fail with EFBIG).
class FileSizeLimit {
 public:
  explicit FileSizeLimit(rlim_t bytes) {
    getrlimit(RLIMIT_FSIZE, &saved_);
    old_handler_ = signal(SIGXFSZ, SIG_IGN);
    rlimit l = saved_;
    l.rlim_cur = bytes;
    setrlimit(RLIMIT_FSIZE, &l);
  }
  ~FileSizeLimit() {
    setrlimit(RLIMIT_FSIZE, &saved_);
    signal(SIGXFSZ, old_handler_);
  }

 private:
  rlimit saved_{};
  sighandler_t old_handler_;
};

TEST(AtomicFile, AFullDiskIsSaidAtFinishAndLeavesNothing) {
  TempDir dir;
  const fs::path dest = dir.path() / "results.csv";
  std::string message;
  {
    const FileSizeLimit limit(64 * 1024);
    try {
      AtomicFile f(dest.string());
      for (int i = 0; i < 100; ++i) f.Write(std::string(4096, 'x'));
      f.Finish();
    } catch (const std::runtime_error& e) {
      message = e.what();
    }
  }
  EXPECT_EQ(message, "cannot write '" + dest.string() + "': File too large");
  EXPECT_TRUE(ListNames(dir.path()).empty());
}

}  // namespace
}  // namespace multibond
