// The journal: lines read back exactly; a resume keeps whole lines of the same study only.

#include "multibond/sweep/journal.h"

#include <cmath>
#include <fstream>
#include <limits>

#include <gtest/gtest.h>

#include "support/temp_dir.h"

namespace multibond::sweep {
namespace {

TEST(Journal, ALineReadsBackToTheSameBits) {
  RunResult r{42, true, "", {0.1, 1.0 / 3.0, -1e-300, std::numeric_limits<double>::quiet_NaN()}};
  RunResult back;
  ASSERT_TRUE(ParseJournalLine(JournalLine(r), 4, back));
  EXPECT_EQ(back.run, 42);
  EXPECT_TRUE(back.ok);
  EXPECT_EQ(back.values[1], 1.0 / 3.0);
  EXPECT_EQ(back.values[2], -1e-300);
  EXPECT_TRUE(std::isnan(back.values[3]));
  RunResult failed{3, false, "param.range: a \"negative\", stiffness", {std::nan(""), std::nan("")}};
  ASSERT_TRUE(ParseJournalLine(JournalLine(failed), 2, back));
  EXPECT_FALSE(back.ok);
  EXPECT_EQ(back.reason, failed.reason);
  EXPECT_FALSE(ParseJournalLine("3,ok,1.0", 2, back));  // torn
}

TEST(Journal, ResumeReadsWholeLinesOfTheSameStudy) {
  testing::TempDir dir;
  const std::string path = (dir.path() / "sweep.journal").string();
  {
    Journal j(path, "abc", 1, false);
    j.Append({0, true, "", {1.5}});
    j.Append({2, false, "solver failure", {std::nan("")}});
  }
  {
    std::ofstream torn(path, std::ios::app);
    torn << "1,ok,2.";  // a crash in the middle of a line
  }
  {
    Journal j(path, "abc", 1, true);
    ASSERT_EQ(j.finished().size(), 2u);
    EXPECT_EQ(j.finished()[0].values[0], 1.5);
    EXPECT_EQ(j.finished()[1].run, 2);
    j.Append({1, true, "", {2.5}});
  }
  Journal again(path, "abc", 1, true);
  ASSERT_EQ(again.finished().size(), 3u);  // the torn line was cut, the new one whole
  EXPECT_EQ(again.finished()[2].values[0], 2.5);
  EXPECT_THROW(Journal(path, "another study", 1, true), std::invalid_argument);
  EXPECT_THROW(Journal((dir.path() / "none").string(), "abc", 1, true), std::invalid_argument);
}

}  // namespace
}  // namespace multibond::sweep
