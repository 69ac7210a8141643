// ResultsFolder and WorkFolder: only the folder's own regular files are read, within a bound;
// output folders that are links are refused; finished files replace planted links.
#include "support/errors.h"
#include "support/temp_dir.h"
#include "multibond/io/results_folder.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <sys/stat.h>

#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>

namespace multibond {
namespace {

using testing::RuntimeErrorOf;

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using testing::ReadFile;
using testing::TempDir;

TEST(ResultsFolder, ReadsOnlyRegularFilesWithinTheBound) {
  TempDir dir;
  std::ofstream(dir.path() / "run.json") << "{\"a\": 1}";
  std::ofstream(dir.path() / "outside.txt") << "secret";
  const ResultsFolder folder(dir.path().string());
  EXPECT_EQ(folder.ReadText("run.json", 100, nullptr).value(), "{\"a\": 1}");
  EXPECT_FALSE(folder.ReadText("absent.json", 100, nullptr).has_value());
  EXPECT_THAT(RuntimeErrorOf([&] { folder.ReadText("run.json", 4, "results-size"); }),
              HasSubstr("is 8 bytes, more than the 4 bytes plot reads; if the input is meant to be this large, raise the limit with --limit results-size=N"));
  fs::create_symlink(dir.path() / "outside.txt", dir.path() / "link.json");
  EXPECT_THAT(RuntimeErrorOf([&] { folder.ReadText("link.json", 100, nullptr); }), HasSubstr("is a symbolic link"));
  ASSERT_EQ(mkfifo((dir.path() / "fifo.json").c_str(), 0600), 0);  // would block a reader
  EXPECT_THAT(RuntimeErrorOf([&] { folder.ReadText("fifo.json", 100, nullptr); }), HasSubstr("not a regular file"));
  EXPECT_THAT(RuntimeErrorOf([&] { ResultsFolder((dir.path() / "none").string()); }), HasSubstr("cannot open the results folder"));
}

TEST(ResultsFolder, OutputFoldersAreNotLinks) {
  TempDir dir;
  fs::create_directories(dir.path() / "elsewhere");
  const ResultsFolder folder(dir.path().string());
  EXPECT_GE(folder.OutputDir("figures").get(), 0);
  EXPECT_TRUE(fs::is_directory(dir.path() / "figures"));
  fs::create_directory_symlink(dir.path() / "elsewhere", dir.path() / "plots");
  EXPECT_THAT(RuntimeErrorOf([&] { folder.OutputDir("plots"); }), HasSubstr("is a symbolic link"));
  std::ofstream(dir.path() / "file");
  EXPECT_THAT(RuntimeErrorOf([&] { folder.OutputDir("file"); }), HasSubstr("is not a folder"));
  EXPECT_LT(folder.ExistingDir("plots").get(), 0);
}

TEST(WorkFolder, PublishReplacesAPlantedLinkAndLeavesNothingBehind) {
  TempDir dir;
  std::ofstream(dir.path() / "victim") << "precious";
  const ResultsFolder folder(dir.path().string());
  const Fd figures = folder.OutputDir("figures");
  fs::create_symlink(dir.path() / "victim", dir.path() / "figures" / "a.png");
  std::string work_path;
  {
    const WorkFolder work(folder);
    work_path = work.path();
    EXPECT_EQ(fs::status(work_path).permissions() & fs::perms::all, fs::perms::owner_all);
    work.Write("figures/a.png", "new");
    EXPECT_THAT(RuntimeErrorOf([&] { work.Write("figures/a.png", "again"); }), HasSubstr("cannot write"));  // O_EXCL
    EXPECT_TRUE(work.Publish("figures/a.png", figures.get(), "a.png"));
    EXPECT_FALSE(work.Publish("figures/missing.png", figures.get(), "missing.png"));
    fs::create_symlink(dir.path() / "victim", fs::path(work_path) / "figures" / "b.png");
    EXPECT_FALSE(work.Publish("figures/b.png", figures.get(), "b.png"));  // a link is never published
  }
  EXPECT_EQ(ReadFile(dir.path() / "victim"), "precious");
  EXPECT_TRUE(fs::is_regular_file(fs::symlink_status(dir.path() / "figures" / "a.png")));
  EXPECT_EQ(ReadFile(dir.path() / "figures" / "a.png"), "new");
  EXPECT_FALSE(fs::exists(work_path));
}

TEST(WorkFolder, AddInputGivesTheFileThatWasRead) {
  TempDir dir;
  std::ofstream(dir.path() / "results.csv") << "time [s]\n0\n";
  const ResultsFolder folder(dir.path().string());
  struct stat st {};
  const Fd fd = folder.OpenInput("results.csv", 100, nullptr, &st);
  const WorkFolder work(folder);
  work.AddInput(folder, "results.csv", fd.get(), st);
  EXPECT_EQ(ReadFile(fs::path(work.path()) / "results.csv"), "time [s]\n0\n");
}

}  // namespace
}  // namespace multibond
