// StagedFile: a file a library writes by name appears under its own name only when published;
// until then it is a hidden temporary that its owner (or, after a crash, OutputFolder) removes.
#include "multibond/io/staged_file.h"

#include <unistd.h>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <stdexcept>

#include "multibond/core/sha256.h"
#include "multibond/io/output_folder.h"
#include "support/temp_dir.h"

namespace multibond {
namespace {

namespace fs = std::filesystem;
using ::testing::ElementsAre;
using ::testing::HasSubstr;
using ::testing::MatchesRegex;
using testing::ListNames;
using testing::ReadFile;
using testing::TempDir;

void WriteByName(const std::string& path, const std::string& content) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);  // as matio and HDF5 do: open by name
  out << content;
}

TEST(StagedFile, IsHiddenUntilPublishedThenHasItsNameSizeAndHash) {
  TempDir dir;
  StagedFile f((dir.path() / "results.mat").string());
  EXPECT_THAT(fs::path(f.temp_path()).filename().string(), MatchesRegex("\\.results\\.mat\\.[0-9]+\\.[0-9a-f]{8}\\.multibond-tmp"));
  WriteByName(f.temp_path(), "MATLAB 5.0 bytes");
  f.Finish();
  EXPECT_EQ(f.bytes(), 16u);
  EXPECT_EQ(f.sha256(), Sha256Hex("MATLAB 5.0 bytes"));
  EXPECT_THAT(ListNames(dir.path()), ElementsAre(fs::path(f.temp_path()).filename().string()));
  f.Publish();
  EXPECT_THAT(ListNames(dir.path()), ElementsAre("results.mat"));
  EXPECT_EQ(ReadFile(dir.path() / "results.mat"), "MATLAB 5.0 bytes");
}

TEST(StagedFile, ReplacesAnEarlierFileAndALinkWithoutFollowingIt) {
  TempDir dir;
  WriteByName((dir.path() / "target").string(), "precious");
  fs::create_symlink(dir.path() / "target", dir.path() / "results.h5");
  StagedFile f((dir.path() / "results.h5").string());
  WriteByName(f.temp_path(), "new");
  f.Publish();
  EXPECT_FALSE(fs::is_symlink(dir.path() / "results.h5"));
  EXPECT_EQ(ReadFile(dir.path() / "results.h5"), "new");
  EXPECT_EQ(ReadFile(dir.path() / "target"), "precious");
}

TEST(StagedFile, LeavesNothingUnlessPublished) {
  TempDir dir;
  {
    StagedFile f((dir.path() / "results.mat").string());
    WriteByName(f.temp_path(), "half");
    f.Finish();
  }
  EXPECT_TRUE(ListNames(dir.path()).empty());
}

TEST(StagedFile, RefusesATemporaryReplacedByALink) {
  TempDir dir;
  WriteByName((dir.path() / "elsewhere").string(), "not ours");
  StagedFile f((dir.path() / "results.mat").string());
  fs::remove(f.temp_path());
  fs::create_symlink(dir.path() / "elsewhere", f.temp_path());
  EXPECT_THAT([&] { f.Finish(); }, ::testing::ThrowsMessage<std::runtime_error>(HasSubstr("its temporary was replaced")));
  EXPECT_THAT(ListNames(dir.path()), ElementsAre("elsewhere"));
}

TEST(StagedFile, SaysWhenTheNameIsAFolderOrTheFolderIsMissing) {
  TempDir dir;
  fs::create_directory(dir.path() / "results.mat");
  EXPECT_THAT([&] { StagedFile f((dir.path() / "results.mat").string()); },
              ::testing::ThrowsMessage<std::runtime_error>(HasSubstr("it is a directory")));
  EXPECT_THAT([&] { StagedFile f((dir.path() / "missing" / "results.mat").string()); },
              ::testing::ThrowsMessage<std::runtime_error>(HasSubstr("no folder")));
}

TEST(StagedFile, ATemporaryLeftByADeadCommandIsRemovedByTheNextOne) {
  TempDir dir;
  std::string left;
  {
    StagedFile f((dir.path() / "results.h5").string());
    left = fs::path(f.temp_path()).filename().string();
    fs::copy_file(f.temp_path(), dir.path() / (left + ".copy"));  // stands for one a killed process left
  }
  fs::rename(dir.path() / (left + ".copy"), dir.path() / left);
  const OutputFolder folder(dir.path().string(), "test");
  EXPECT_THAT(folder.removed_stale(), ElementsAre(left));
}

}  // namespace
}  // namespace multibond
