// The unit grammar (core/units.h): what the examples and the generated columns use passes; what
// could reach gnuplot or HTML as code does not.

#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "multibond/core/units.h"

namespace multibond {
namespace {

using ::testing::HasSubstr;

TEST(Units, AcceptsTheUnitsMultibondWrites) {
  // core/structure.cc's domain units, the mechanism's, docs/model-format.md's parameter units.
  for (const char* u : {"-", "1", "N", "m/s", "N s", "m", "N m", "rad/s", "N m s", "rad", "V", "A", "V s", "C", "Pa", "m^3/s",
                        "Pa s", "m^3", "kg", "kg m^2", "N/m", "N m/rad", "1/F", "N s/m", "N m s/rad", "Pa s/m^3", "m s^-2",
                        "J", "W", "ohm", "\u03a9", "\u00b5m", "mm", "kN*m", "Hz", "deg", "min", "mol", "kohm", "ms"})
    EXPECT_EQ(UnitProblem(u), "") << u;
}

TEST(Units, RefusesWhatIsNoUnit) {
  EXPECT_THAT(UnitProblem("furlong/fortnight"), HasSubstr("'furlong' is not a unit symbol"));
  EXPECT_THAT(UnitProblem(""), HasSubstr("empty"));
  EXPECT_THAT(UnitProblem("m^"), HasSubstr("exponent"));
  EXPECT_THAT(UnitProblem("m^0"), HasSubstr("exponent"));
  EXPECT_THAT(UnitProblem("m^1.5"), HasSubstr("exponent"));
  EXPECT_THAT(UnitProblem("kg/m/s"), HasSubstr("more than one '/'"));
  EXPECT_THAT(UnitProblem("N  m"), HasSubstr("two separators"));
  EXPECT_THAT(UnitProblem("/s"), HasSubstr("both sides"));
  EXPECT_THAT(UnitProblem("m/1"), HasSubstr("'1' is not a unit symbol"));
  EXPECT_THAT(UnitProblem(std::string(80, 'm')), HasSubstr("at most 64"));
}

TEST(Units, RefusesWhatGnuplotOrHtmlWouldRead) {
  EXPECT_THAT(UnitProblem("m`touch /tmp/x`"), HasSubstr("'`'"));
  EXPECT_THAT(UnitProblem("m\"\nsystem(\"id\")\n#"), HasSubstr("'\"'"));
  EXPECT_THAT(UnitProblem("m\nsystem"), HasSubstr("byte 0x0a"));
  for (const char* u : {"m'", "m\\n", "$m", "<b>m</b>", "m&amp;", "m;", "(m)", "m\r"}) EXPECT_NE(UnitProblem(u), "") << u;
}

}  // namespace
}  // namespace multibond
