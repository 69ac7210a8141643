// CsvWriter and the run record without a simulation: header cells quoted only when a name needs
// it and read back as written (through ReadResults), a write that cannot complete leaves nothing
// behind and names the file the user asked for, and run.json records any text it is given.
#include "support/errors.h"
#include "support/temp_dir.h"
#include "multibond/io/results_reader.h"
#include "multibond/io/results_writer.h"
#include "multibond/core/sha256.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace multibond {
namespace {

using testing::RuntimeErrorOf;

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using testing::ReadFile;
using testing::ListNames;
using testing::TempDir;

/// Writes a two-row results file through CsvWriter, as a run would.
void WriteResults(const fs::path& path, const std::vector<Column>& columns) {
  CsvWriter csv(path.string());
  csv.OnStart(columns);
  std::vector<double> row(columns.size());
  for (int k = 0; k < 2; ++k) {
    for (size_t c = 0; c < row.size(); ++c) row[c] = k + 0.5 * static_cast<double>(c);
    csv.OnSample(row);
  }
  csv.OnFinish(RunSummary{});
}

TEST(CsvCell, QuotesOnlyCellsThatNeedIt) {
  EXPECT_EQ(CsvCell("mass.p [N s]"), "mass.p [N s]");
  EXPECT_EQ(CsvCell(""), "");
  EXPECT_EQ(CsvCell("a,b [N]"), "\"a,b [N]\"");
  EXPECT_EQ(CsvCell("say \"hi\" [m]"), "\"say \"\"hi\"\" [m]\"");
  EXPECT_EQ(CsvCell("two\nlines"), "\"two\nlines\"");
  EXPECT_EQ(CsvCell("cr\r"), "\"cr\r\"");
}

TEST(ResultsIo, NamesWithCommaAndQuoteRoundTrip) {
  TempDir dir;
  const fs::path path = dir.path() / "results.csv";
  WriteResults(path, {{"time", "s"}, {"a,b", "N"}, {"say \"hi\"", "m"}, {"mass.p", "N s"}});
  const std::string text = ReadFile(path);
  // Plain names stay as they always were; only the two that need it are quoted.
  EXPECT_EQ(text.substr(0, text.find('\n')), "time [s],\"a,b [N]\",\"say \"\"hi\"\" [m]\",mass.p [N s]");

  const ResultsTable t = ReadResults(path.string());  // throws if a row has too few or too many cells
  EXPECT_EQ(t.names, (std::vector<std::string>{"time", "a,b", "say \"hi\"", "mass.p"}));
  EXPECT_EQ(t.units, (std::vector<std::string>{"s", "N", "m", "N s"}));
  ASSERT_EQ(t.rows.size(), 2u);
  for (const auto& row : t.rows) EXPECT_EQ(row.size(), 4u);
  EXPECT_EQ(t.At(1, "a,b"), 1.5);
  EXPECT_EQ(t.At(1, "say \"hi\""), 2.0);
  EXPECT_EQ(t.Last("mass.p"), 2.5);
}

TEST(ResultsIo, NameWithLineBreakRoundTripsAndRowsKeepTheirLineNumbers) {
  TempDir dir;
  const fs::path path = dir.path() / "results.csv";
  WriteResults(path, {{"time", "s"}, {"two\nlines", "-"}});
  const ResultsTable t = ReadResults(path.string());
  EXPECT_EQ(t.names, (std::vector<std::string>{"time", "two\nlines"}));
  EXPECT_EQ(t.rows.size(), 2u);

  // Line numbers in errors count the header's two lines.
  std::ofstream(path, std::ios::app) << "1,x\n";
  EXPECT_THAT(RuntimeErrorOf([&] { ReadResults(path.string()); }), HasSubstr(path.string() + ":5: not a number"));
}

TEST(CsvWriter, DestinationThatIsADirectoryIsReportedBeforeTheRun) {
  TempDir dir;
  const fs::path dest = dir.path() / "results.csv";
  fs::create_directory(dest);
  CsvWriter csv(dest.string());
  EXPECT_EQ(RuntimeErrorOf([&] { csv.OnStart({{"time", "s"}}); }), "cannot write '" + dest.string() + "': it is a directory");
  EXPECT_EQ(ListNames(dir.path()), std::vector<std::string>{"results.csv"});
}

TEST(CsvWriter, RenameFailingAtTheEndThrowsAndLeavesNoTemporary) {
  TempDir dir;
  const fs::path dest = dir.path() / "results.csv";
  CsvWriter csv(dest.string());
  csv.OnStart({{"time", "s"}});
  csv.OnSample({0.0});
  fs::create_directory(dest);
  fs::create_directory(dest / "full");  // appears while the run goes on (a non-empty folder: rename cannot replace it)
  EXPECT_EQ(RuntimeErrorOf([&] { csv.OnFinish(RunSummary{}); }), "cannot write '" + dest.string() + "': it is a directory");
  EXPECT_EQ(ListNames(dir.path()), std::vector<std::string>{"results.csv"});
  EXPECT_TRUE(fs::is_directory(dest / "full"));
}

// A run that never finished (an exception through Simulate, a kill) leaves nothing: no file that
// looks complete, and no temporary of hundreds of megabytes.
TEST(CsvWriter, WriterDestroyedBeforeTheRunFinishedLeavesNothing) {
  TempDir dir;
  const fs::path dest = dir.path() / "results.csv";
  {
    CsvWriter csv(dest.string());
    csv.OnStart({{"time", "s"}});
    csv.OnSample({0.0});
  }
  EXPECT_TRUE(ListNames(dir.path()).empty());
}

TEST(CsvWriter, DeferredPublicationKnowsSizeAndHashBeforeTheFileHasItsName) {
  TempDir dir;
  const fs::path dest = dir.path() / "results.csv";
  CsvWriter csv(dest.string(), /*publish=*/false);
  csv.OnStart({{"time", "s"}});
  csv.OnSample({0.25});
  csv.OnFinish(RunSummary{});
  EXPECT_FALSE(fs::exists(dest));
  EXPECT_EQ(csv.bytes(), 14u);  // "time [s]\n0.25\n"
  // sha256 of "time [s]\n0.25\n" (sha256sum)
  const std::string hash = csv.sha256();
  csv.Publish();
  EXPECT_EQ(ReadFile(dest), "time [s]\n0.25\n");
  EXPECT_EQ(hash, Sha256Hex(ReadFile(dest)));
}

TEST(RunRecord, PathsThatAreNotUtf8AreRecordedEscaped) {
  const nlohmann::json j = MakeRunRecord("mod\xE8le.yaml", "text", "m", RunOptions{}, RunSummary{}, {"multibond", "run", "mod\xE8le.yaml"});
  const std::string text = DumpRecord(j);
  EXPECT_THAT(text, HasSubstr("\"file\": \"mod\\\\xE8le.yaml\""));  // JSON of mod\xE8le.yaml
  EXPECT_EQ(j["command_line"][2], "mod\\xE8le.yaml");
}

TEST(RunRecord, InvalidUtf8IsReplacedNotThrown) {
  nlohmann::json j;
  j["model"] = std::string("caf\xe9.yaml");  // Latin-1 bytes in a path
  std::string text;
  EXPECT_NO_THROW(text = DumpRecord(j));
  EXPECT_THAT(text, HasSubstr("caf\xef\xbf\xbd.yaml"));  // U+FFFD
}

}  // namespace
}  // namespace multibond
