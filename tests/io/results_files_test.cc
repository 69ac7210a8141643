// ResultsFiles: the formats asked for, each written completely under a hidden name and published
// together; run.json's entries describe the files published, byte for byte.
#include "multibond/io/results_files.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <stdexcept>

#include "multibond/core/sha256.h"
#include "support/temp_dir.h"

namespace multibond {
namespace {

namespace fs = std::filesystem;
using ::testing::ElementsAre;
using ::testing::HasSubstr;
using ::testing::ThrowsMessage;
using testing::ListNames;
using testing::ReadFile;
using testing::TempDir;

TEST(ParseResultFormats, ReadsAListInTheOrderOfTheFiles) {
  EXPECT_THAT(ParseResultFormats("csv"), ElementsAre(ResultFormat::kCsv));
  EXPECT_THAT(ParseResultFormats("csv,mat,h5"), ElementsAre(ResultFormat::kCsv, ResultFormat::kMat, ResultFormat::kH5));
  EXPECT_THAT(ParseResultFormats("h5, mat"), ElementsAre(ResultFormat::kMat, ResultFormat::kH5));
  EXPECT_THAT(ParseResultFormats("mat,mat"), ElementsAre(ResultFormat::kMat));
}

TEST(ParseResultFormats, RefusesUnknownAndEmptyNamesWithASuggestion) {
  EXPECT_THAT([] { ParseResultFormats("csv,hdf5"); },
              ThrowsMessage<std::invalid_argument>(HasSubstr("unknown result format 'hdf5' in --format 'csv,hdf5' (did you mean 'h5'?); "
                                                             "the formats are csv, mat, h5")));
  EXPECT_THAT([] { ParseResultFormats("xlsx"); }, ThrowsMessage<std::invalid_argument>(HasSubstr("unknown result format 'xlsx'")));
  EXPECT_THAT([] { ParseResultFormats("CSV"); }, ThrowsMessage<std::invalid_argument>(HasSubstr("did you mean 'csv'?")));
  EXPECT_THAT([] { ParseResultFormats(""); }, ThrowsMessage<std::invalid_argument>(HasSubstr("an empty name")));
  EXPECT_THAT([] { ParseResultFormats("csv,"); }, ThrowsMessage<std::invalid_argument>(HasSubstr("an empty name")));
}

void FeedThreeRows(ResultsFiles& files) {
  files.OnStart({{"time", "s"}, {"mass.p", "N s"}});
  for (int k = 0; k < 3; ++k) files.OnSample({0.5 * k, 1.0 / (k + 3)});
  files.OnFinish(RunSummary{});
}

TEST(ResultsFiles, PublishesEveryFormatTogetherAndRecordsWhatWasPublished) {
  TempDir dir;
  ResultsFiles files(dir.path().string(), {ResultFormat::kCsv, ResultFormat::kMat, ResultFormat::kH5}, 3);
  FeedThreeRows(files);
  files.Finish({{"status", "ok"}});
  for (const std::string& name : ListNames(dir.path())) EXPECT_EQ(name[0], '.') << name;  // nothing under its name yet
  files.Publish();
  EXPECT_THAT(ListNames(dir.path()), ElementsAre("results.csv", "results.h5", "results.mat"));
  const nlohmann::json record = files.FilesRecord();
  ASSERT_EQ(record.size(), 3u);
  for (const nlohmann::json& entry : record) {
    const std::string content = ReadFile(dir.path() / entry["file"].get<std::string>());
    EXPECT_EQ(entry["bytes"], content.size());
    EXPECT_EQ(entry["sha256"], Sha256Hex(content));
  }
  EXPECT_EQ(record[0]["format"], "csv");
  EXPECT_FALSE(record[0].contains("compressed"));
  EXPECT_EQ(record[1]["format"], "mat");
  EXPECT_EQ(record[1]["compressed"], false);
  EXPECT_EQ(record[2]["format"], "h5");
  // "results" is results.csv's entry, as it always was: file, bytes, sha256.
  EXPECT_EQ(files.CsvRecord(), (nlohmann::json{{"file", "results.csv"}, {"bytes", record[0]["bytes"]}, {"sha256", record[0]["sha256"]}}));
  EXPECT_EQ(ReadFile(dir.path() / "results.csv"), "time [s],mass.p [N s]\n0,0.3333333333333333\n0.5,0.25\n1,0.2\n");
}

TEST(ResultsFiles, WithoutCsvHasNoResultsEntry) {
  TempDir dir;
  ResultsFiles files(dir.path().string(), {ResultFormat::kH5}, 3, /*compress=*/true);
  FeedThreeRows(files);
  files.Finish(nlohmann::json::object());
  files.Publish();
  EXPECT_THAT(ListNames(dir.path()), ElementsAre("results.h5"));
  EXPECT_TRUE(files.CsvRecord().is_null());
  EXPECT_EQ(files.FilesRecord()[0]["compressed"], true);
}

TEST(ResultsFiles, LeavesNothingWhenNotPublished) {
  TempDir dir;
  {
    ResultsFiles files(dir.path().string(), {ResultFormat::kCsv, ResultFormat::kMat, ResultFormat::kH5}, 3);
    FeedThreeRows(files);
    files.Finish(nlohmann::json::object());
  }  // an exception between Finish and Publish (run.json could not be written) leaves this
  EXPECT_TRUE(ListNames(dir.path()).empty());
}

}  // namespace
}  // namespace multibond
