// The public Results: columns by name, interpolation.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <multibond/multibond.h>

namespace multibond {
namespace {

Results Line() {
  return Results({"time", "x"}, {"s", "m"}, {{0.0, 1.0, 3.0}, {0.0, 10.0, 50.0}}, {});
}

TEST(ApiResults, ColumnsByName) {
  const Results r = Line();
  EXPECT_EQ(r.rows(), 3u);
  EXPECT_THAT(r.column("x"), ::testing::ElementsAre(0.0, 10.0, 50.0));
  EXPECT_THAT(r.times(), ::testing::ElementsAre(0.0, 1.0, 3.0));
  EXPECT_EQ(r.units()[1], "m");
  try {
    (void)r.column("y");
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), ::testing::HasSubstr("no column called 'y'"));
  }
}

TEST(ApiResults, AtInterpolatesLinearlyAndClampsAtTheEnds) {
  const Results r = Line();
  EXPECT_DOUBLE_EQ(r.At("x", 0.5), 5.0);
  EXPECT_DOUBLE_EQ(r.At("x", 2.0), 30.0);
  EXPECT_DOUBLE_EQ(r.At("x", 1.0), 10.0);
  EXPECT_DOUBLE_EQ(r.At("x", -1.0), 0.0);
  EXPECT_DOUBLE_EQ(r.At("x", 9.0), 50.0);
}

TEST(ApiResults, RefusesColumnsWithoutNames) {
  EXPECT_THROW(Results({"time"}, {"s"}, {{0.0}, {1.0}}, {}), std::invalid_argument);
}

}  // namespace
}  // namespace multibond
