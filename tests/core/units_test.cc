// The unit grammar (core/units.h): what the examples and the generated columns use passes; what
// could reach gnuplot or HTML as code does not. What a unit means (its SI dimension and scale,
// from the SI's definitions), and the dimension analysis of formulas: each rule, the place of
// each mismatch (the byte of its operator or function) and the units it names.

#include <cmath>
#include <map>
#include <numbers>
#include <optional>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "multibond/core/expression.h"
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

/// A dimension from whole exponents of m, kg, s, A, K, mol, cd.
Dimension Dim(int m, int kg, int s, int a = 0, int k = 0, int mol = 0, int cd = 0) {
  Dimension d;
  const int e[kBaseUnits] = {m, kg, s, a, k, mol, cd};
  for (int i = 0; i < kBaseUnits; ++i) d[i] = Exponent{e[i], 1};
  return d;
}

Unit Of(const std::string& unit) {
  const std::optional<Unit> u = ParseUnit(unit);
  EXPECT_TRUE(u.has_value()) << unit;
  return u.value_or(Unit{});
}

TEST(Units, DerivedUnitsAreTheirSIDefinitions) {
  EXPECT_EQ(Of("N").dim, Dim(1, 1, -2));
  EXPECT_EQ(Of("kg m/s^2").dim, Of("N").dim);
  EXPECT_EQ(Of("Pa").dim, Dim(-1, 1, -2));
  EXPECT_EQ(Of("N/m^2").dim, Of("Pa").dim);
  EXPECT_EQ(Of("J").dim, Of("N m").dim);
  EXPECT_EQ(Of("W").dim, Of("J/s").dim);
  EXPECT_EQ(Of("C").dim, Of("A s").dim);
  EXPECT_EQ(Of("V").dim, Of("W/A").dim);
  EXPECT_EQ(Of("F").dim, Of("C/V").dim);
  EXPECT_EQ(Of("ohm").dim, Of("V/A").dim);
  EXPECT_EQ(Of("\u03a9").dim, Of("ohm").dim);
  EXPECT_EQ(Of("S").dim, Of("1/ohm").dim);
  EXPECT_EQ(Of("Wb").dim, Of("V s").dim);
  EXPECT_EQ(Of("T").dim, Of("Wb/m^2").dim);
  EXPECT_EQ(Of("H").dim, Of("Wb/A").dim);
  EXPECT_EQ(Of("Hz").dim, Of("1/s").dim);
  EXPECT_EQ(Of("Bq").dim, Of("Hz").dim);
  EXPECT_EQ(Of("Gy").dim, Of("J/kg").dim);
  EXPECT_EQ(Of("Sv").dim, Of("J/kg").dim);
  EXPECT_EQ(Of("kat").dim, Of("mol/s").dim);
  EXPECT_EQ(Of("lm").dim, Of("cd sr").dim);
  EXPECT_EQ(Of("lx").dim, Of("lm/m^2").dim);
  EXPECT_EQ(Of("K").dim, Dim(0, 0, 0, 0, 1));
  // The radian and steradian are numbers: a torque per radian is a torque, rad/s is Hz.
  EXPECT_EQ(Of("rad").dim, Dimension{});
  EXPECT_EQ(Of("N m/rad").dim, Of("N m").dim);
  EXPECT_EQ(Of("rad/s").dim, Of("Hz").dim);
  EXPECT_EQ(Of("-").dim, Dimension{});
  EXPECT_EQ(Of("1").scale, 1.0);
  // The domains' units (docs/model-format.md, "Domains and units"): momentum = effort * time,
  // inertia = momentum / flow.
  EXPECT_EQ(Of("N s").dim, Of("kg m/s").dim);
  EXPECT_EQ(Of("N m s").dim, Of("kg m^2/s").dim);
  EXPECT_EQ(Of("Pa s/m^3").dim, Of("kg/m^4 s").dim);
  EXPECT_EQ(Of("V s/A").dim, Of("H").dim);
  EXPECT_EQ(Of("1/F").dim, Of("V/C").dim);
}

TEST(Units, EverythingAfterTheSlashIsTheDenominator) {
  EXPECT_EQ(Of("N/m s").dim, Dim(0, 1, -3));  // N/(m s), not (N/m) s
  EXPECT_EQ(Of("N s/m").dim, Dim(0, 1, -1));
  EXPECT_EQ(Of("N*m").dim, Of("N m").dim);
  EXPECT_EQ(Of("m s^-2").dim, Of("m/s^2").dim);
}

TEST(Units, PrefixesAndNonSIUnitsHaveTheirScale) {
  EXPECT_DOUBLE_EQ(Of("mm").scale, 1e-3);
  EXPECT_DOUBLE_EQ(Of("km").scale, 1e3);
  EXPECT_DOUBLE_EQ(Of("\u00b5m").scale, 1e-6);
  EXPECT_DOUBLE_EQ(Of("\u03bcm").scale, 1e-6);
  EXPECT_DOUBLE_EQ(Of("um").scale, 1e-6);
  EXPECT_DOUBLE_EQ(Of("dam").scale, 10.0);  // deca, not deci-ampere-metre
  EXPECT_DOUBLE_EQ(Of("dm").scale, 0.1);
  EXPECT_DOUBLE_EQ(Of("kohm").scale, 1e3);
  EXPECT_EQ(Of("kohm").dim, Of("ohm").dim);
  EXPECT_DOUBLE_EQ(Of("hPa").scale, 100.0);
  EXPECT_DOUBLE_EQ(Of("g").scale, 1e-3);
  EXPECT_DOUBLE_EQ(Of("kg").scale, 1.0);
  EXPECT_DOUBLE_EQ(Of("t").scale, 1e3);
  EXPECT_DOUBLE_EQ(Of("km^2").scale, 1e6);  // (km)^2
  EXPECT_DOUBLE_EQ(Of("mm^-1").scale, 1e3);
  EXPECT_DOUBLE_EQ(Of("km/h").scale, 1000.0 / 3600.0);
  EXPECT_EQ(Of("km/h").dim, Of("m/s").dim);
  EXPECT_DOUBLE_EQ(Of("min").scale, 60.0);  // a minute, not a milli-inch
  EXPECT_EQ(Of("min").dim, Of("s").dim);
  EXPECT_DOUBLE_EQ(Of("ms").scale, 1e-3);
  EXPECT_DOUBLE_EQ(Of("L").scale, 1e-3);
  EXPECT_EQ(Of("L").dim, Of("m^3").dim);
  EXPECT_DOUBLE_EQ(Of("mL").scale, 1e-6);
  EXPECT_DOUBLE_EQ(Of("bar").scale, 1e5);
  EXPECT_EQ(Of("bar").dim, Of("Pa").dim);
  EXPECT_DOUBLE_EQ(Of("eV").scale, 1.602176634e-19);
  EXPECT_EQ(Of("eV").dim, Of("J").dim);
  EXPECT_DOUBLE_EQ(Of("deg").scale, std::numbers::pi / 180.0);
  EXPECT_DOUBLE_EQ(Of("rev/min").scale, 2.0 * std::numbers::pi / 60.0);
  EXPECT_EQ(Of("rev/min").dim, Of("rad/s").dim);
  EXPECT_FALSE(ParseUnit("furlong").has_value());
  EXPECT_FALSE(ParseUnit("m/1").has_value());
}

TEST(Units, FormatDimensionWritesSIBaseUnits) {
  EXPECT_EQ(FormatDimension(Of("N").dim), "m kg/s^2");
  EXPECT_EQ(FormatDimension(Of("Hz").dim), "1/s");
  EXPECT_EQ(FormatDimension(Of("rad").dim), "1");
  EXPECT_EQ(FormatDimension(Of("kg m^2").dim), "m^2 kg");
  EXPECT_EQ(FormatDimension(Of("ohm").dim), "m^2 kg/s^3 A^2");
  Dimension root;
  root[0] = Exponent{1, 2};
  root[2] = Exponent{-3, 2};
  EXPECT_EQ(FormatDimension(root), "m^(1/2)/s^(3/2)");
}

// --- the analysis of formulas ------------------------------------------------------------------

/// Declared units and values of the names of a test formula; a name not in `units` is free.
struct Names {
  std::map<std::string, std::string> units;
  std::map<std::string, double> values;
};

FormulaUnits Check(const std::string& text, const Names& names) {
  const expr::ParseResult r = expr::Parse(text);
  EXPECT_TRUE(r.root) << text;
  if (!r.root) return {};
  return CheckFormulaUnits(
      *r.root, text,
      [&](const std::string& id) -> std::optional<DeclaredUnit> {
        const auto it = names.units.find(id);
        if (it == names.units.end()) return std::nullopt;
        return DeclaredUnit{Of(it->second), it->second};
      },
      [&](const std::string& id) -> std::optional<double> {
        const auto it = names.values.find(id);
        if (it == names.values.end()) return std::nullopt;
        return it->second;
      });
}

const Names kNames{{{"L", "m"}, {"L2", "m"}, {"T", "s"}, {"m", "kg"}, {"d", "mm"}, {"th", "deg"}, {"w", "rev/min"}, {"A", "m^2"},
                    {"f", "Hz"}, {"k", "N/m"}, {"z", "-"}},
                   {{"L", 1.0}, {"L2", 2.0}, {"T", 2.0}, {"m", 3.0}, {"n", 2.0}, {"d", 5.0}, {"A", 4.0}, {"z", 0.5}}};

/// The offset of the first mismatch of `text` (-1: none).
int MismatchAt(const std::string& text) {
  const FormulaUnits u = Check(text, kNames);
  return u.mismatch ? u.mismatch->offset : -1;
}

std::string Message(const std::string& text) {
  const FormulaUnits u = Check(text, kNames);
  return u.mismatch ? u.mismatch->message : "";
}

/// The unit of a formula without mismatch, as DescribeUnit says it.
std::string UnitOf(const std::string& text) {
  const FormulaUnits u = Check(text, kNames);
  EXPECT_FALSE(u.mismatch) << text << ": " << (u.mismatch ? u.mismatch->message : "");
  return DescribeUnit(u.unit);
}

TEST(FormulaUnits, ASumNeedsOneDimensionAndIsReportedAtItsOperator) {
  EXPECT_EQ(MismatchAt("L + T"), 2);
  EXPECT_EQ(Message("L + T"), "the two sides of '+' have different units: 'L' is m, 'T' is s");
  EXPECT_EQ(MismatchAt("L-T"), 1);
  EXPECT_EQ(MismatchAt("(L + L2) - 2*T/1"), 9);
  EXPECT_THAT(Message("(L + L2) - 2*T/1"), HasSubstr("'L + L2' is m, '2*T/1' is s"));
  // Signs between the operator and its right operand: the operator is the first of them.
  EXPECT_EQ(MismatchAt("L - -T"), 2);
  EXPECT_EQ(MismatchAt("L - +T"), 2);
  EXPECT_EQ(MismatchAt("L -(-(T))"), 2);
  EXPECT_EQ(MismatchAt("L*T + m"), 4);
  EXPECT_THAT(Message("L*T + m"), HasSubstr("'L*T' is m s, 'm' is kg"));
  EXPECT_EQ(UnitOf("L + L2 - L"), "m");
  EXPECT_EQ(UnitOf("k*L + m*L/T^2"), "m kg/s^2");
}

TEST(FormulaUnits, ALongSumIsCheckedToItsLastTerm) {
  // 1500 terms (within the 4096 bytes of a formula) nest 1500 deep to the left: they are checked
  // in a loop. The mismatch is at the last operator.
  std::string sum = "L";
  for (int i = 1; i < 1500; ++i) sum += i % 2 ? "+L" : "-L2";
  EXPECT_EQ(UnitOf(sum), "m");
  EXPECT_EQ(MismatchAt(sum + "+T"), static_cast<int>(sum.size()));
  std::string product = "L";
  for (int i = 1; i <= 1500; ++i) product += i % 2 ? "*L" : "/L2";
  EXPECT_EQ(UnitOf(product), "m");
  EXPECT_EQ(MismatchAt(product + "*T+L"), static_cast<int>(product.size()) + 2);
}

TEST(FormulaUnits, ANumberTakesTheUnitOfTheOtherSideOfASumAndHasNoneInAProduct) {
  EXPECT_EQ(UnitOf("L + 0.5"), "m");
  EXPECT_EQ(UnitOf("1 + L"), "m");
  EXPECT_EQ(UnitOf("2*L"), "m");
  EXPECT_EQ(UnitOf("1/T"), "1/s");
  EXPECT_EQ(UnitOf("2*pi*f"), "1/s");
  EXPECT_EQ(UnitOf("2 + 3"), "a number");
  EXPECT_EQ(MismatchAt("2*L + T"), 4);
  EXPECT_EQ(MismatchAt("L + 1 + T"), 6);  // L + 1 is a length
}

TEST(FormulaUnits, NamesWithoutAUnitAreFree) {
  EXPECT_EQ(UnitOf("n + L"), "m");
  EXPECT_EQ(UnitOf("n*L + T"), "s");  // n*L may be anything
  EXPECT_EQ(UnitOf("sin(n*L)"), "a number");
  EXPECT_EQ(UnitOf("q*k + t"), "of any unit");
  EXPECT_EQ(UnitOf("exp(-t/T)"), "a number");
  EXPECT_EQ(UnitOf("z + 1"), "a number");  // '-': declared without dimension
  EXPECT_EQ(MismatchAt("z + L"), 2);
}

TEST(FormulaUnits, UnitsOfOneDimensionAndOtherSizesDoNotMixUnlessANumberConvertsOne) {
  EXPECT_EQ(MismatchAt("L + d"), 2);
  EXPECT_EQ(Message("L + d"),
            "the two sides of '+' have units of one dimension but of different sizes: 'L' is m, 'd' is mm (values are not converted)");
  EXPECT_EQ(UnitOf("L + d/1000"), "m");
  EXPECT_EQ(UnitOf("d + d"), "mm");
  EXPECT_EQ(MismatchAt("L*L + d*L"), 4);
  EXPECT_EQ(UnitOf("A + L*L"), "m^2");
}

TEST(FormulaUnits, FunctionsOfANumberTakeNoDimensionAndAnAngleInRad) {
  EXPECT_EQ(MismatchAt("1 + sin(L)"), 4);
  EXPECT_EQ(Message("1 + sin(L)"), "sin of 'L', which is m: sin takes a number without dimension (an angle in rad)");
  EXPECT_EQ(MismatchAt("exp(T)"), 0);
  EXPECT_EQ(Message("exp(T)"), "exp of 'T', which is s: exp takes a number without dimension");
  for (const char* f : {"cos(L)", "tan(L)", "asin(L)", "acos(L)", "atan(L)", "sinh(L)", "cosh(L)", "tanh(L)", "log(L)"})
    EXPECT_EQ(MismatchAt(f), 0) << f;
  EXPECT_EQ(UnitOf("sin(L/L2)"), "a number");
  EXPECT_EQ(UnitOf("log(T*f)"), "a number");
  EXPECT_EQ(UnitOf("sin(2*pi*f*T)"), "a number");
  // An angle in deg is not converted: sin takes rad. Its factor converts it.
  EXPECT_EQ(MismatchAt("sin(th)"), 0);
  EXPECT_EQ(Message("sin(th)"), "sin of 'th', which is deg: sin takes an angle in rad, and values are not converted");
  EXPECT_EQ(UnitOf("sin(th*pi/180)"), "a number");
  EXPECT_EQ(MismatchAt("exp(L/d)"), 0);
  EXPECT_THAT(Message("exp(L/d)"), HasSubstr("a number in units of 1000"));
  // The value of a function of a number is a number that does not adapt.
  EXPECT_EQ(MismatchAt("L + sin(z)"), 2);
}

TEST(FormulaUnits, FunctionsOfOneDimension) {
  EXPECT_EQ(UnitOf("min(L, L2)"), "m");
  EXPECT_EQ(UnitOf("max(L, 0)"), "m");
  EXPECT_EQ(UnitOf("hypot(L, 2*L2)"), "m");
  EXPECT_EQ(UnitOf("clamp(0, L, L2)"), "m");
  EXPECT_EQ(UnitOf("smoothabs(L, 1e-3)"), "m");
  EXPECT_EQ(UnitOf("abs(T)"), "s");
  EXPECT_EQ(UnitOf("atan2(L, L2)"), "a number");
  EXPECT_EQ(UnitOf("smoothsign(T, 1e-3)"), "a number");
  EXPECT_EQ(UnitOf("sign(T)"), "a number");
  for (const char* f : {"min(L, T)", "max(L, T)", "hypot(L, T)", "atan2(L, T)", "smoothabs(L, T)", "smoothsign(L, T)"})
    EXPECT_EQ(MismatchAt(std::string("1 + ") + f), 4) << f;
  EXPECT_EQ(Message("min(L, T)"), "the arguments of min have different units: 'L' is m, 'T' is s");
  EXPECT_EQ(MismatchAt("clamp(L, 0, T)"), 0);
  EXPECT_EQ(MismatchAt("clamp(1, L, T)"), 0);
  EXPECT_THAT(Message("clamp(1, L, T)"), HasSubstr("'L' is m, 'T' is s"));
}

TEST(FormulaUnits, AComparisonHasOneDimensionOnBothSidesAndIsANumber) {
  EXPECT_EQ(UnitOf("L < L2"), "a number");
  EXPECT_EQ(UnitOf("L > 0"), "a number");  // a number takes the other side's unit, as in a sum
  EXPECT_EQ(UnitOf("0.5 <= L"), "a number");
  EXPECT_EQ(UnitOf("L + L2 >= 2*L"), "a number");
  EXPECT_EQ(UnitOf("T == n*T"), "a number");
  EXPECT_EQ(UnitOf("k*(L > 0)"), "kg/s^2");  // N/m
  EXPECT_EQ(UnitOf("L*(L > L2)"), "m");
  // A mismatch is at the comparison's operator, naming both units.
  EXPECT_EQ(MismatchAt("L < T"), 2);
  EXPECT_EQ(Message("L < T"), "the two sides of '<' have different units: 'L' is m, 'T' is s");
  EXPECT_THAT(Check("L < T", kNames).mismatch->hint, HasSubstr("the sides of a comparison need one dimension"));
  EXPECT_EQ(MismatchAt("L+L2 <= (T)"), 5);
  EXPECT_EQ(Message("L+L2 <= (T)"), "the two sides of '<=' have different units: 'L+L2' is m, 'T' is s");
  EXPECT_EQ(MismatchAt("(L)>=+m"), 3);
  EXPECT_EQ(MismatchAt("z != L"), 2);
  EXPECT_EQ(MismatchAt("L == m*1"), 2);
  EXPECT_EQ(MismatchAt("2*L > -T"), 4);
  EXPECT_EQ(MismatchAt("L > 0 and T>L"), 11);
  EXPECT_EQ(MismatchAt("L > d"), 2);  // one dimension, other sizes: values are not converted
  EXPECT_THAT(Message("L > d"), HasSubstr("different sizes"));
  EXPECT_EQ(UnitOf("L > d/1000"), "a number");
  // The value is a number without dimension: not a length.
  EXPECT_EQ(MismatchAt("L + (L > 0)"), 2);
}

TEST(FormulaUnits, LogicTakesTruthValues) {
  EXPECT_EQ(UnitOf("L > 0 and T < 1"), "a number");
  EXPECT_EQ(UnitOf("not L > 0 or z"), "a number");  // z: '-', no dimension
  EXPECT_EQ(UnitOf("n and q"), "a number");          // free names
  EXPECT_EQ(UnitOf("not (L/d)"), "a number");         // no dimension, of any size
  EXPECT_EQ(MismatchAt("L > 0 and T"), 6);
  EXPECT_EQ(Message("L > 0 and T"),
            "'T', an operand of 'and', is s: the operands of and, or and not are truth values (comparisons, or numbers without "
            "dimension)");
  EXPECT_EQ(Check("L > 0 and T", kNames).mismatch->hint, "compare it, as in T > 0 or T != 0");
  EXPECT_EQ(MismatchAt("L or z"), 2);
  EXPECT_EQ(MismatchAt("z or  (L)"), 2);
  EXPECT_EQ(MismatchAt("1 + 2*(not m)"), 7);
  EXPECT_THAT(Message("1 + 2*(not m)"), HasSubstr("'m', an operand of 'not', is kg"));
}

TEST(FormulaUnits, TheBranchesOfIfHaveOneUnitWhichIsItsOwn) {
  EXPECT_EQ(UnitOf("if(L > 0, L, L2)"), "m");
  EXPECT_EQ(UnitOf("if(L > 0, L, 0)"), "m");
  EXPECT_EQ(UnitOf("if(L > 0, 1, 2)"), "a number");
  EXPECT_EQ(UnitOf("if(n, T, n*T)"), "s");
  EXPECT_EQ(UnitOf("if(z, k, -k)*L"), "m kg/s^2");  // N
  EXPECT_EQ(MismatchAt("1 + if(L > 0, L, T)"), 4);
  EXPECT_EQ(Message("1 + if(L > 0, L, T)"), "the two branches of if have different units: 'L' is m, 'T' is s");
  EXPECT_THAT(Check("if(L > 0, L, T)", kNames).mismatch->hint, HasSubstr("need one dimension"));
  EXPECT_EQ(MismatchAt("if(L > 0, L, d)"), 0);  // other sizes
  EXPECT_EQ(MismatchAt("T + if(L > 0, L, L2)"), 2);  // the value is a length
  // The condition is a truth value.
  EXPECT_EQ(MismatchAt("2*if(L, 1, 0)"), 2);
  EXPECT_EQ(Message("2*if(L, 1, 0)"),
            "the condition 'L' of if is m: a condition is a truth value (a comparison, or a number without dimension)");
  // A mismatch inside a branch or the condition is found where it is.
  EXPECT_EQ(MismatchAt("if(L > T, 1, 0)"), 5);
  EXPECT_EQ(MismatchAt("if(L > 0, L + T, L)"), 12);
}

TEST(FormulaUnits, PowersTakeAConstantFractionWhenTheBaseHasAUnit) {
  EXPECT_EQ(UnitOf("L^2"), "m^2");
  EXPECT_EQ(UnitOf("T^-1"), "1/s");
  EXPECT_EQ(UnitOf("L^n"), "m^2");  // n, a parameter without unit, is 2
  EXPECT_EQ(UnitOf("sqrt(A)"), "m");
  EXPECT_EQ(UnitOf("A^(1/2)"), "m");
  EXPECT_EQ(UnitOf("(L*L*L)^(1/3)"), "m");
  EXPECT_EQ(UnitOf("L^1.5"), "m^(3/2)");
  EXPECT_EQ(UnitOf("sqrt(L)*sqrt(L)"), "m");
  EXPECT_EQ(UnitOf("d^2"), "1e-06 m^2");
  EXPECT_EQ(UnitOf("2^z"), "a number");
  EXPECT_EQ(UnitOf("z^q"), "a number");  // no dimension: any exponent
  EXPECT_EQ(MismatchAt("L^T"), 1);
  EXPECT_EQ(Message("L^T"), "the exponent 'T' is s: an exponent is a number without dimension");
  EXPECT_EQ(MismatchAt("2 ^ L"), 2);
  EXPECT_EQ(MismatchAt("L^q"), 1);  // q: not a constant
  EXPECT_THAT(Message("L^q"), HasSubstr("'L' (m) raised to 'q', which is not a constant"));
  EXPECT_EQ(MismatchAt("1 + L^0.3719"), 5);
  EXPECT_THAT(Message("1 + L^0.3719"), HasSubstr("raised to 0.3719"));
  EXPECT_EQ(MismatchAt("L^2 + A*T"), 4);
  EXPECT_EQ(UnitOf("L^2 + A"), "m^2");
}

TEST(FormulaUnits, ADeclaredUnitMatchesByDimensionAndKnownScale) {
  auto match = [](const std::string& formula, const std::string& unit) { return MatchUnit(Check(formula, kNames).unit, Of(unit)); };
  EXPECT_EQ(match("L/T", "m/s"), UnitMatch::kSame);
  EXPECT_EQ(match("L/T", "m"), UnitMatch::kDimension);
  EXPECT_EQ(match("m*L/T^2", "N"), UnitMatch::kSame);
  EXPECT_EQ(match("k*L", "N"), UnitMatch::kSame);
  EXPECT_EQ(match("m*L^2", "kg m^2"), UnitMatch::kSame);
  EXPECT_EQ(match("m*L", "kg m^2"), UnitMatch::kDimension);
  EXPECT_EQ(match("d", "m"), UnitMatch::kScale);
  EXPECT_EQ(match("d/1000", "m"), UnitMatch::kSame);
  EXPECT_EQ(match("w", "rad/s"), UnitMatch::kScale);
  EXPECT_EQ(match("w*2*pi/60", "rad/s"), UnitMatch::kSame);
  EXPECT_EQ(match("f", "rad/s"), UnitMatch::kSame);  // rad is a number: Hz and rad/s are 1/s
  EXPECT_EQ(match("n*L", "s"), UnitMatch::kSame);    // free
  EXPECT_EQ(match("2", "s"), UnitMatch::kSame);      // a number
  EXPECT_EQ(match("2*L", "m"), UnitMatch::kSame);
  EXPECT_EQ(match("2*L", "km"), UnitMatch::kSame);   // a number may be a conversion factor
  EXPECT_EQ(match("L", "km"), UnitMatch::kScale);
}

TEST(Units, TheIntegralOverTimeMultipliesBySeconds) {
  EXPECT_EQ(TimeIntegralUnit("rad/s"), "rad");
  EXPECT_EQ(TimeIntegralUnit("m/s"), "m");
  EXPECT_EQ(TimeIntegralUnit("1/s"), "-");
  EXPECT_EQ(TimeIntegralUnit("V"), "V s");
  EXPECT_EQ(TimeIntegralUnit("N/m"), "N s/m");
  EXPECT_EQ(TimeIntegralUnit("1/m"), "s/m");
  EXPECT_EQ(TimeIntegralUnit("-"), "s");
  EXPECT_EQ(TimeIntegralUnit(""), "");
  // Each is a unit of the grammar, of the dimension times s.
  for (const char* u : {"rad/s", "m/s", "V", "N/m", "1/m", "kg m^2/s^2"}) {
    const std::string t = TimeIntegralUnit(u);
    ASSERT_EQ(UnitProblem(t), "") << t;
    Dimension want = ParseUnit(u)->dim;
    want[2].num += want[2].den;  // s is the third base unit
    EXPECT_EQ(ParseUnit(t)->dim, want) << u << " -> " << t;
  }
}

}  // namespace
}  // namespace multibond
