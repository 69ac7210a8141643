// ReadResults: a results.csv read back, header cells "name [unit]" (CSV-quoted where needed), and a
// malformed header said with its file and line.
#include "support/errors.h"
#include "support/temp_dir.h"
#include "multibond/io/results_reader.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

namespace multibond {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using testing::RuntimeErrorOf;
using testing::TempDir;

TEST(ResultsIo, HeaderCellSplitsIntoNameAndUnit) {
  const auto check = [](const std::string& cell, const std::string& name, const std::string& unit) {
    const NameAndUnit nu = SplitNameAndUnit(cell);
    EXPECT_EQ(nu.name, name) << cell;
    EXPECT_EQ(nu.unit, unit) << cell;
  };
  check("A.omega.z [rad/s]", "A.omega.z", "rad/s");
  check("t [s]\r", "t", "s");                  // a CRLF file's last cell
  check("G.R.23 []", "G.R.23", "");             // dimensionless
  check("energy.residual", "energy.residual", "");
  check("a [b] c", "a [b] c", "");              // brackets inside a name, no unit
  check("x [m] [N]", "x [m]", "N");             // the last bracket is the unit
}

TEST(ResultsIo, ReaderTakesQuotedCellsAndQuotesInsidePlainCells) {
  TempDir dir;
  const fs::path path = dir.path() / "results.csv";
  // A file written before names were quoted can hold a quote inside a cell: it is part of the name.
  std::ofstream(path) << "time [s],\"a,b [N]\",say \"hi\" [m],\"\" [-]\n0,1,2,3\n";
  const ResultsTable t = ReadResults(path.string());
  EXPECT_EQ(t.names, (std::vector<std::string>{"time", "a,b", "say \"hi\"", ""}));
  EXPECT_EQ(t.units, (std::vector<std::string>{"s", "N", "m", "-"}));
  EXPECT_EQ(t.Last("say \"hi\""), 2.0);
}

TEST(ResultsIo, UnclosedQuoteInHeaderIsReported) {
  TempDir dir;
  const fs::path path = dir.path() / "results.csv";
  std::ofstream(path) << "time [s],\"a [m]\n0,1\n";
  EXPECT_THAT(RuntimeErrorOf([&] { ReadResults(path.string()); }),
              HasSubstr(path.string() + ":1: a quoted column name is not closed"));
}

}  // namespace
}  // namespace multibond
