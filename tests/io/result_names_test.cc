// Names of result columns in results.mat and results.h5: whatever a model file's names hold, the
// MATLAB names are valid and unique and the HDF5 names hold no '/' and stay distinct.
#include "multibond/io/result_names.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <set>
#include <string>
#include <vector>

namespace multibond {
namespace {

TEST(MatlabNames, DotsAndOtherCharactersBecomeUnderscores) {
  EXPECT_EQ(MatlabNames({"time", "A.omega.z", "mass.p", "j.f"}),
            (std::vector<std::string>{"time", "A_omega_z", "mass_p", "j_f"}));
  // One underscore per character: a two-byte and a four-byte UTF-8 character alike.
  EXPECT_EQ(MatlabNames({"ω.z", "a\xF0\x9F\x98\x80" "b"}), (std::vector<std::string>{"x__z", "a_b"}));
  // A byte that is not UTF-8 is one character.
  EXPECT_EQ(MatlabNames({"a\xFF\xFE" "b"}), (std::vector<std::string>{"a__b"}));
}

TEST(MatlabNames, ANameStartsWithALetter) {
  EXPECT_EQ(MatlabNames({"_q", "1st", "", ".x"}), (std::vector<std::string>{"x_q", "x1st", "x", "x_x"}));
}

TEST(MatlabNames, CollisionsKeywordsAndReservedNamesGetNumbers) {
  EXPECT_EQ(MatlabNames({"a.b", "a_b", "a;b", "a_b_2"}), (std::vector<std::string>{"a_b", "a_b_2", "a_b_3", "a_b_2_2"}));
  EXPECT_EQ(MatlabNames({"end", "for", "meta", "units"}, {"meta", "units"}),
            (std::vector<std::string>{"end_2", "for_2", "meta_2", "units_2"}));
}

TEST(MatlabNames, LongNamesAreCutAt63CharactersSuffixIncluded) {
  const std::string long_name(80, 'a');
  const std::vector<std::string> names = MatlabNames({long_name, long_name, long_name + "b"});
  EXPECT_EQ(names[0], std::string(63, 'a'));
  EXPECT_EQ(names[1], std::string(61, 'a') + "_2");
  EXPECT_EQ(names[2], std::string(61, 'a') + "_3");  // cut to the same 63 characters as the first
}

TEST(MatlabNames, HostileNamesGiveValidDistinctNames) {
  std::vector<std::string> hostile = {"x\"; system('rm -rf ~'); %",  "a'b", "line\nbreak", "tab\there", "nul\0byte",
                                      "ünïcødé.ω",                  "$(reboot)", "`id`",        "../../etc/passwd",
                                      std::string(200, '.'),        "",          " ",           "end",
                                      "function",                   "time",      "time"};
  hostile[4] = std::string("nul\0byte", 8);
  const std::vector<std::string> names = MatlabNames(hostile, {"units", "columns", "meta"});
  ASSERT_EQ(names.size(), hostile.size());
  std::set<std::string> distinct;
  for (const std::string& n : names) {
    EXPECT_TRUE(IsMatlabName(n)) << n;
    distinct.insert(n);
  }
  EXPECT_EQ(distinct.size(), names.size());
  EXPECT_EQ(names[14], "time");
  EXPECT_EQ(names[15], "time_2");
}

TEST(IsMatlabName, FollowsMatlabsRule) {
  EXPECT_TRUE(IsMatlabName("A_omega_z"));
  EXPECT_TRUE(IsMatlabName(std::string(63, 'a')));
  EXPECT_FALSE(IsMatlabName(std::string(64, 'a')));
  EXPECT_FALSE(IsMatlabName("_a"));
  EXPECT_FALSE(IsMatlabName("1a"));
  EXPECT_FALSE(IsMatlabName("a.b"));
  EXPECT_FALSE(IsMatlabName("end"));
  EXPECT_FALSE(IsMatlabName(""));
}

TEST(Hdf5Name, EscapesSlashAndPercentOnly) {
  EXPECT_EQ(Hdf5Name("A.omega.z"), "A.omega.z");
  EXPECT_EQ(Hdf5Name("a/b"), "a%2Fb");
  EXPECT_EQ(Hdf5Name("100%"), "100%25");
  EXPECT_EQ(Hdf5Name("%2F"), "%252F");
  EXPECT_EQ(Hdf5Name("."), "%2E");
  EXPECT_EQ(Hdf5Name(".."), "..");
  EXPECT_EQ(Hdf5Name(""), "%");
  EXPECT_EQ(Hdf5Name("ω \"q\";"), "ω \"q\";");
}

TEST(Hdf5Name, DistinctNamesStayDistinct) {
  const std::vector<std::string> names = {"a/b", "a%2Fb", "a%b", "a%25b", ".", "%2E", "", "%", "/", "%2F", "//", "a/"};
  std::set<std::string> escaped;
  for (const std::string& n : names) {
    const std::string e = Hdf5Name(n);
    EXPECT_EQ(e.find('/'), std::string::npos) << n;
    EXPECT_NE(e, ".");
    EXPECT_FALSE(e.empty());
    escaped.insert(e);
  }
  EXPECT_EQ(escaped.size(), names.size());
}

TEST(StoredText, EscapesBytesThatAreNotUtf8AndNul) {
  EXPECT_EQ(StoredText("N s"), "N s");
  EXPECT_EQ(StoredText("ω"), "ω");
  EXPECT_EQ(StoredText("a\xFF"), "a\\xFF");
  EXPECT_EQ(StoredText(std::string("a\0b", 3)), "a\\x00b");
}

}  // namespace
}  // namespace multibond
