// Disjoint sets: classes and roots independent of the order of the unions; values per class.

#include "multibond/core/union_find.h"

#include <string>

#include <gtest/gtest.h>

namespace multibond {
namespace {

TEST(UnionFind, TheSmallestMemberIsTheRootWhateverTheOrder) {
  UnionFind a(6), b(6);
  a.Unite(4, 2), a.Unite(2, 5), a.Unite(1, 3);
  b.Unite(5, 2), b.Unite(3, 1), b.Unite(2, 4);
  for (int i = 0; i < 6; ++i) EXPECT_EQ(a.Root(i), b.Root(i)) << i;
  EXPECT_EQ(a.Root(5), 2);
  EXPECT_EQ(a.Root(3), 1);
  EXPECT_EQ(a.Root(0), 0);
}

TEST(ValueUnion, ValuesSpreadOverUnionsAndConflictsAreSaid) {
  ValueUnion<int> dims(5);
  EXPECT_TRUE(dims.Set(3, 3));
  EXPECT_TRUE(dims.Merge(0, 3));  // 0 takes 3's dimension
  EXPECT_TRUE(dims.Has(0));
  EXPECT_EQ(dims.Get(0), 3);
  EXPECT_FALSE(dims.Set(0, 1));  // a second value for the class
  EXPECT_TRUE(dims.Set(4, 1));
  EXPECT_FALSE(dims.Merge(4, 0));  // 1 against 3: a conflict, and the first class's value is kept
  EXPECT_EQ(dims.Get(3), 1);
  EXPECT_FALSE(dims.Has(2));
  ValueUnion<std::string> domains(2);
  EXPECT_TRUE(domains.Merge(0, 1));
  EXPECT_TRUE(domains.Set(1, "rotation"));
  EXPECT_EQ(domains.Get(0), "rotation");
}

}  // namespace
}  // namespace multibond
