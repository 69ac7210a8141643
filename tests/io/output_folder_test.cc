// OutputFolder: one command at a time writes into a results folder; the temporaries of commands
// that died are removed once nobody can be writing them.

#include "multibond/io/output_folder.h"

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "support/temp_dir.h"

namespace multibond {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using ::testing::UnorderedElementsAre;
using testing::ReadFile;
using testing::TempDir;

TEST(OutputFolder, ASecondHolderIsRefusedNamingTheFirst) {
  TempDir dir;
  const fs::path out = dir.path() / "out";
  {
    const OutputFolder first(out.string(), "multibond run a.yaml -o out");
    EXPECT_TRUE(fs::is_directory(out));
    try {
      const OutputFolder second(out.string(), "multibond run b.yaml -o out");
      ADD_FAILURE() << "the folder was taken twice";
    } catch (const std::runtime_error& e) {
      EXPECT_THAT(e.what(), HasSubstr("cannot write into '" + out.string() + "': another multibond command is writing into it (pid " +
                                      std::to_string(getpid())));
      EXPECT_THAT(e.what(), HasSubstr(": multibond run a.yaml -o out)"));
    }
  }
  // Released with its holder.
  EXPECT_NO_THROW(OutputFolder(out.string(), "multibond run b.yaml -o out"));
}

TEST(OutputFolder, RemovesTheTemporariesOfDeadCommandsAndNothingElse) {
  TempDir dir;
  for (const char* name : {"results.csv.partial", ".run.json.42.0badc0de.multibond-tmp", "results.csv", "model.yaml", "notes.tmp"})
    std::ofstream(dir.path() / name) << "x";
  const OutputFolder folder(dir.path().string(), "test");
  EXPECT_THAT(folder.removed_stale(), UnorderedElementsAre("results.csv.partial", ".run.json.42.0badc0de.multibond-tmp"));
  EXPECT_FALSE(fs::exists(dir.path() / "results.csv.partial"));
  for (const char* kept : {"results.csv", "model.yaml", "notes.tmp"}) EXPECT_TRUE(fs::exists(dir.path() / kept)) << kept;
}

TEST(OutputFolder, RemovesTheWorkFolderOfAnInterruptedPlotWithoutFollowingItsLinks) {
  TempDir dir, elsewhere;
  std::ofstream(elsewhere.path() / "victim") << "precious";
  const fs::path work = dir.path() / ".multibond-plot-abc123";
  fs::create_directories(work);
  std::ofstream(work / "fig03.png") << "half";
  fs::create_directory_symlink(elsewhere.path(), work / "link");
  fs::create_directories(dir.path() / "figures.partial");  // a folder of the user's: kept
  const OutputFolder folder(dir.path().string(), "test");
  EXPECT_THAT(folder.removed_stale(), UnorderedElementsAre(".multibond-plot-abc123"));
  EXPECT_FALSE(fs::exists(work));
  EXPECT_TRUE(fs::is_directory(dir.path() / "figures.partial"));
  EXPECT_EQ(ReadFile(elsewhere.path() / "victim"), "precious");
}

TEST(OutputFolder, APlantedLockLinkIsRefusedAndItsTargetUntouched) {
  TempDir dir, elsewhere;
  const fs::path victim = elsewhere.path() / "victim";
  std::ofstream(victim) << "precious";
  fs::create_symlink(victim, dir.path() / kLockFileName);
  EXPECT_THROW(OutputFolder(dir.path().string(), "test"), std::runtime_error);
  EXPECT_EQ(ReadFile(victim), "precious");
}

TEST(OutputFolder, WithoutCreateAMissingFolderIsAnError) {
  TempDir dir;
  EXPECT_THROW(OutputFolder((dir.path() / "missing").string(), "test", /*create=*/false), std::runtime_error);
  EXPECT_FALSE(fs::exists(dir.path() / "missing"));
}

}  // namespace
}  // namespace multibond
