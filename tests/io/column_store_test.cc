// ColumnStore: the rows of a run kept column by column, without allocating per sample.
#include "multibond/io/column_store.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <limits>

namespace multibond {
namespace {

TEST(ColumnStore, KeepsRowsAsColumns) {
  ColumnStore s(3);
  s.OnStart({{"time", "s"}, {"x", "m"}});
  s.OnSample({0.0, 1.5});
  s.OnSample({0.1, -2.5});
  s.OnFinish(RunSummary{});
  ASSERT_EQ(s.rows(), 2);
  EXPECT_EQ(s.values(0), (std::vector<double>{0.0, 0.1}));
  EXPECT_EQ(s.values(1), (std::vector<double>{1.5, -2.5}));
  EXPECT_EQ(s.columns()[1].unit, "m");
}

TEST(ColumnStore, ReservesTheExpectedRowsSoASampleDoesNotAllocate) {
  ColumnStore s(1000);
  s.OnStart({{"time", "s"}, {"x", "m"}});
  const double* before = s.values(1).data();
  for (int k = 0; k < 1000; ++k) s.OnSample({k * 1e-3, 1.0 * k});
  EXPECT_EQ(s.values(1).data(), before);  // never moved: never reallocated
  EXPECT_EQ(s.values(1)[999], 999.0);
}

TEST(ColumnStore, AShortRowIsPaddedWithNaN) {
  ColumnStore s;
  s.OnStart({{"time", "s"}, {"x", "m"}});
  s.OnSample({1.0});
  EXPECT_TRUE(std::isnan(s.values(1)[0]));
}

TEST(ColumnStoreBytes, IsRowsTimesColumnsTimesEightAndSaturates) {
  EXPECT_EQ(ColumnStoreBytes(5001, 200), 5001u * 200u * 8u);
  EXPECT_EQ(ColumnStoreBytes(0, 200), 0u);
  EXPECT_EQ(ColumnStoreBytes(std::uint64_t{1} << 62, 4), std::numeric_limits<std::uint64_t>::max());
}

}  // namespace
}  // namespace multibond
