// NameIndex: the names a model file defines, found by name in O(1), listed in the order of
// definition, the first definition kept.

#include <string>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "multibond/io/name_index.h"

namespace multibond {
namespace {

TEST(NameIndex, FindsWhatWasAdded) {
  NameIndex index;
  EXPECT_EQ(index.Add("spring", {"m.yaml", 3, 3}), nullptr);
  EXPECT_EQ(index.Add("mass", {"m.yaml", 4, 3}), nullptr);
  ASSERT_NE(index.Find("spring"), nullptr);
  EXPECT_EQ(index.Find("spring")->line, 3);
  EXPECT_EQ(index.Find("mass")->line, 4);
  EXPECT_EQ(index.Find("damper"), nullptr);
  EXPECT_TRUE(index.contains("mass"));
  EXPECT_FALSE(index.contains("Mass"));  // names are case-sensitive
  EXPECT_FALSE(index.contains(""));
  EXPECT_EQ(index.size(), 2u);
}

TEST(NameIndex, ASecondDefinitionGetsTheFirstsPlaceAndChangesNothing) {
  NameIndex index;
  index.Add("spring", {"m.yaml", 3, 3});
  const SourceLocation* first = index.Add("spring", {"m.yaml", 9, 3});
  ASSERT_NE(first, nullptr);
  EXPECT_EQ(first->ToString(), "m.yaml:3:3");
  EXPECT_EQ(index.Find("spring")->line, 3);
  EXPECT_EQ(index.size(), 1u);
  EXPECT_EQ(index.names(), std::vector<std::string>{"spring"});
}

TEST(NameIndex, ListsTheNamesInTheOrderOfDefinition) {
  // Did-you-mean suggestions take the first of equally close names: the order must be the file's,
  // not a hash order.
  NameIndex index;
  std::vector<std::string> expected;
  for (int i = 0; i < 1000; ++i) {
    const std::string name = fmt::format("n{}", (i * 7919) % 1000);
    index.Add(name, {"m.yaml", i + 1, 1});
    expected.push_back(name);
  }
  EXPECT_EQ(index.names(), expected);
  EXPECT_EQ(index.Find("n0")->line, 1);
  EXPECT_EQ(index.Find(fmt::format("n{}", (999 * 7919) % 1000))->line, 1000);
}

}  // namespace
}  // namespace multibond
