// The top-level 'parameters' section (io/model_parameters_reader.cc): numbers and formulas of
// each other in any order, units and descriptions, cycles, names that are not parameters, and the
// values given from outside the file (--set, the API).

#include <chrono>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "multibond/io/model_loader.h"
#include "support/load_errors.h"

namespace multibond {
namespace {

using ::testing::HasSubstr;

/// A model of one mass pushed by a force, with `parameters` (YAML lines, indented by 2) and the
/// mass's inertia `inertia`.
std::string Model(const std::string& parameters, const std::string& inertia = "1.0") {
  return "model: m\n"
         "parameters:\n" +
         parameters +
         "elements:\n"
         "  force: {type: Se, effort: 1.0}\n"
         "  j:     {type: \"1\"}\n"
         "  mass:  {type: I, inertia: " + inertia + "}\n"
         "bonds: [force -> j, j -> mass]\n";
}

using testing::LoadErrors;

const ModelParameter& Param(const LoadedModel& lm, const std::string& name) {
  for (const ModelParameter& p : lm.parameters)
    if (p.name == name) return p;
  throw std::out_of_range(name);
}

/// The message of the std::invalid_argument that loading with `sets` throws ("" if none).
std::string SetError(const std::string& yaml, const std::vector<ParameterOverride>& sets) {
  try {
    (void)LoadModelString(yaml, "m.yaml", {}, sets);
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

TEST(ModelParametersReader, FormulasOfEachOtherInAnyOrderWithUnitsAndDescriptions) {
  const LoadedModel lm = LoadModelString(Model("  k: {value: \"m*w0^2\", unit: N/m, description: the spring}\n"
                                               "  w0: 2*pi*f0\n"
                                               "  m: 2.0\n"
                                               "  f0: {value: 1.5, unit: Hz}\n",
                                               "m"),
                                         "m.yaml");
  ASSERT_EQ(lm.parameters.size(), 4u);
  EXPECT_EQ(lm.parameters[0].name, "k");  // in the order of the file
  const double w0 = 2 * std::numbers::pi * 1.5;
  EXPECT_EQ(Param(lm, "w0").value, w0);
  EXPECT_EQ(Param(lm, "k").value, 2.0 * (w0 * w0));
  EXPECT_EQ(Param(lm, "k").unit, "N/m");
  EXPECT_EQ(Param(lm, "k").description, "the spring");
  EXPECT_EQ(Param(lm, "k").text, "m*w0^2");
  EXPECT_TRUE(Param(lm, "k").is_formula());
  EXPECT_FALSE(Param(lm, "m").is_formula());
  EXPECT_EQ(Param(lm, "k").where.line, 3);
  EXPECT_EQ(Param(lm, "k").where.column, 3);
  EXPECT_FALSE(Param(lm, "k").set);
  EXPECT_EQ(lm.graph.element(lm.graph.Find("mass")).param.scalar, 2.0);
}

TEST(ModelParametersReader, ACycleIsNamedOnceAtItsFirstParameter) {
  const auto ds = LoadErrors(Model("  x: 1.0\n  a: c + x\n  b: 2*a\n  c: b/2\n  d: a + 1\n"));
  ASSERT_EQ(ds.size(), 1u) << ds[0].ToString();  // d, which needs the cycle, is not said again
  EXPECT_EQ(ds[0].code, "param.cycle");
  EXPECT_EQ(ds[0].where.line, 4);
  EXPECT_EQ(ds[0].element, "a");
  EXPECT_THAT(ds[0].message, HasSubstr("a -> c -> b -> a"));
  const auto self = LoadErrors(Model("  a: a + 1\n"));
  ASSERT_EQ(self.size(), 1u);
  EXPECT_THAT(self[0].message, HasSubstr("a -> a"));
}

TEST(ModelParametersReader, TimeOrAVariableInAParameterIsNotConstant) {
  // "  T: 2*t": the 't' at column 8; "  U: "1 + mass.p"": 'mass.p' at 11 (past the quote).
  const auto ds = LoadErrors(Model("  T: 2*t\n  U: \"1 + mass.p\"\n"));
  ASSERT_EQ(ds.size(), 2u);
  EXPECT_EQ(ds[0].code, "expr.not_constant");
  EXPECT_EQ(ds[0].where.line, 3);
  EXPECT_EQ(ds[0].where.column, 8);
  EXPECT_THAT(ds[0].message, HasSubstr("cannot depend on 't' (time)"));
  EXPECT_EQ(ds[1].code, "expr.not_constant");
  EXPECT_EQ(ds[1].where.column, 11);
  EXPECT_THAT(ds[1].hint, HasSubstr("signal"));
}

TEST(ModelParametersReader, AnUnknownNameIsSaidWithDidYouMeanAndItsUsesAreNotSaidAgain) {
  const auto ds = LoadErrors(Model("  mass0: 2.0\n  m: 2*mas0\n", "m"));
  ASSERT_EQ(ds.size(), 1u);
  EXPECT_EQ(ds[0].code, "param.unknown");
  EXPECT_EQ(ds[0].where.column, 8);
  EXPECT_EQ(ds[0].hint, "did you mean 'mass0'?");
}

TEST(ModelParametersReader, ReservedNamesUnitsAndShapesAreChecked) {
  const auto ds = LoadErrors(Model("  t: 1.0\n  q: 2.0\n  L: {value: 1.0, unit: furlong}\n  M: [1, 2]\n  N: {unit: m}\n"));
  ASSERT_EQ(ds.size(), 5u);
  EXPECT_EQ(ds[0].code, "name.invalid");
  EXPECT_THAT(ds[0].message, HasSubstr("'t' is time"));
  EXPECT_EQ(ds[1].code, "name.invalid");
  EXPECT_THAT(ds[1].message, HasSubstr("own variable"));
  EXPECT_EQ(ds[2].code, "unit.invalid");
  EXPECT_THAT(ds[3].message, HasSubstr("a parameter is a number or a formula, not a list"));
  EXPECT_THAT(ds[4].message, HasSubstr("needs 'value'"));
}

TEST(ModelParametersReader, AFormulaWhoseValueIsNotFiniteIsOutOfRange) {
  const auto ds = LoadErrors(Model("  a: 0.0\n  b: \"log(a)\"\n"));
  ASSERT_EQ(ds.size(), 1u);
  EXPECT_EQ(ds[0].code, "param.range");
  EXPECT_EQ(ds[0].where.column, 7);
  EXPECT_THAT(ds[0].message, HasSubstr("gives -inf"));
}

TEST(ModelParametersReader, ValuesSetFromOutsideReplaceTheFilesAndEverythingFollows) {
  const std::string yaml = Model("  m0: 2.0\n  m: {value: 2*m0, unit: kg}\n", "m");
  LoadedModel lm = LoadModelString(yaml, "m.yaml", {}, {{"m0", "3"}});
  EXPECT_EQ(Param(lm, "m").value, 6.0);
  EXPECT_TRUE(Param(lm, "m0").set);
  EXPECT_FALSE(Param(lm, "m").set);
  EXPECT_EQ(lm.graph.element(lm.graph.Find("mass")).param.scalar, 6.0);
  // A formula of the other parameters, and the last of two values for one name.
  lm = LoadModelString(yaml, "m.yaml", {}, {{"m", "1"}, {"m", "m0/4"}});
  EXPECT_EQ(Param(lm, "m").value, 0.5);
  EXPECT_EQ(Param(lm, "m").text, "m0/4");
  EXPECT_EQ(Param(lm, "m").unit, "kg");  // the unit stays the file's
}

TEST(ModelParametersReader, ABadValueSetFromOutsideIsTheCallersMistake) {
  const std::string yaml = Model("  m0: 2.0\n  m: 2*m0\n", "m");
  EXPECT_EQ(SetError(yaml, {{"m1", "3"}}), "the model has no parameter 'm1': did you mean 'm0'?");
  EXPECT_EQ(SetError(yaml, {{"x", "3"}}), "the model has no parameter 'x' (its parameters: m0, m)");
  EXPECT_EQ(SetError(Model("  {}\n"), {{"x", "3"}}), "the model has no parameter 'x' (it declares no parameters)");
  EXPECT_THAT(SetError(yaml, {{"m", "2*"}}), HasSubstr("parameter 'm' set to '2*': the formula ends early"));
  EXPECT_THAT(SetError(yaml, {{"m", "2*mo"}}), HasSubstr("the model has no parameter 'mo': did you mean 'm0'?"));
  EXPECT_THAT(SetError(yaml, {{"m", "sin(t)"}}), HasSubstr("'t' is time: a parameter is a constant"));
  EXPECT_THAT(SetError(yaml, {{"m0", "m/2"}}), HasSubstr("the parameters set make a cycle: m0 (set) -> m -> m0"));
  EXPECT_THAT(SetError(yaml, {{"m0", "1/0"}}), HasSubstr("not a finite number"));
  EXPECT_THAT(SetError(yaml, {{"m0", "1e-320"}}), HasSubstr("not a finite, normal number"));
}

// Units where they are declared (docs/model-format.md, "Units in formulas"): a mismatch is an
// error at the character of its operator or function, naming the units on both sides.

TEST(ModelParametersReader, ASumOfALengthAndATimeIsAnErrorAtItsOperator) {
  // Line 5 is '  x: "L + T"': the quote at column 6, 'L' at 7, '+' at 9.
  const auto ds = LoadErrors(Model("  L: {value: 1.0, unit: m}\n  T: {value: 2.0, unit: s}\n  x: \"L + T\"\n"));
  ASSERT_EQ(ds.size(), 1u) << ds[0].ToString();
  EXPECT_EQ(ds[0].code, "expr.units");
  EXPECT_EQ(ds[0].element, "x");
  EXPECT_EQ(ds[0].where.line, 5);
  EXPECT_EQ(ds[0].where.column, 9);
  EXPECT_EQ(ds[0].message, "the two sides of '+' have different units: 'L' is m, 'T' is s");
  EXPECT_THAT(ds[0].hint, HasSubstr("one dimension"));
  // Unquoted, the formula starts at the column of its value.
  const auto plain = LoadErrors(Model("  L: {value: 1.0, unit: m}\n  T: {value: 2.0, unit: s}\n  x: 2*L - T/1\n"));
  ASSERT_EQ(plain.size(), 1u);
  EXPECT_EQ(plain[0].where.column, 10);
  EXPECT_EQ(plain[0].message, "the two sides of '-' have different units: '2*L' is m, 'T/1' is s");
}

TEST(ModelParametersReader, AFormulaGivesTheUnitDeclaredForIt) {
  const std::string units = "  L: {value: 1.0, unit: m}\n  T: {value: 2.0, unit: s}\n";
  const LoadedModel lm = LoadModelString(Model(units + "  v: {value: \"L/T\", unit: m/s}\n"), "m.yaml");
  EXPECT_EQ(Param(lm, "v").value, 0.5);
  // Line 5 is '  v: {value: "L/T", unit: m}': the quote at column 14, the formula at 15.
  const auto ds = LoadErrors(Model(units + "  v: {value: \"L/T\", unit: m}\n"));
  ASSERT_EQ(ds.size(), 1u) << ds[0].ToString();
  EXPECT_EQ(ds[0].code, "expr.units");
  EXPECT_EQ(ds[0].element, "v");
  EXPECT_EQ(ds[0].where.line, 5);
  EXPECT_EQ(ds[0].where.column, 15);
  EXPECT_EQ(ds[0].message, "its formula 'L/T' gives m/s, not the unit declared for it, m");
  // One dimension, another size: the value is not converted.
  const auto mm = LoadErrors(Model("  d: {value: 5.0, unit: mm}\n  L: {value: d, unit: m}\n"));
  ASSERT_EQ(mm.size(), 1u);
  EXPECT_EQ(mm[0].where.column, 14);
  EXPECT_THAT(mm[0].message, HasSubstr("gives mm: the dimension of the unit declared for it, m, but another size"));
  // A number factor converts.
  EXPECT_EQ(Param(LoadModelString(Model("  d: {value: 5.0, unit: mm}\n  L: {value: d/1000, unit: m}\n"), "m.yaml"), "L").value, 0.005);
  // A unit declared "-" is a number.
  const auto none = LoadErrors(Model(units + "  r: {value: L, unit: \"-\"}\n"));
  ASSERT_EQ(none.size(), 1u);
  EXPECT_EQ(none[0].message, "its formula 'L' gives m, not the unit declared for it, - (a number)");
}

TEST(ModelParametersReader, AFunctionOfALengthIsAnErrorAtTheFunction) {
  // Line 4 is '  s: "1 + sin(L)"': the quote at column 6, 's' of sin at 11.
  const auto ds = LoadErrors(Model("  L: {value: 1.0, unit: m}\n  s: \"1 + sin(L)\"\n  ex: \"exp(L/L0)\"\n  L0: 1.0\n"));
  ASSERT_EQ(ds.size(), 1u) << ds[0].ToString();  // L/L0: L0 has no unit, nothing is checked through it
  EXPECT_EQ(ds[0].code, "expr.units");
  EXPECT_EQ(ds[0].where.line, 4);
  EXPECT_EQ(ds[0].where.column, 11);
  EXPECT_EQ(ds[0].message, "sin of 'L', which is m: sin takes a number without dimension (an angle in rad)");
  // An angle in deg is no angle in rad: the value is not converted.
  const auto deg = LoadErrors(Model("  th: {value: 30, unit: deg}\n  s: cos(th)\n  c: cos(th*pi/180)\n"));
  ASSERT_EQ(deg.size(), 1u);
  EXPECT_EQ(deg[0].element, "s");
  EXPECT_EQ(deg[0].where.column, 6);
  EXPECT_THAT(deg[0].hint, HasSubstr("times pi/180"));
}

TEST(ModelParametersReader, AModelWithConsistentUnitsLoads) {
  // docs/model-format.md's tuned oscillator, with units on everything.
  const LoadedModel lm = LoadModelString(Model("  m:    {value: 2.0, unit: kg}\n"
                                               "  f0:   {value: 1.5, unit: Hz}\n"
                                               "  k:    {value: \"m*(2*pi*f0)^2\", unit: N/m}\n"
                                               "  zeta: {value: 0.05, unit: \"-\"}\n"
                                               "  c:    {value: \"2*zeta*sqrt(k*m)\", unit: N s/m}\n"
                                               "  g:    {value: 9.81, unit: m/s^2}\n"
                                               "  x0:   {value: \"m*g/k + 0.001\", unit: m}\n"
                                               "  E:    {value: \"k*x0^2/2\", unit: J}\n"
                                               "  w:    {value: \"sqrt(k/m)\", unit: rad/s}\n"
                                               "  n:    {value: \"min(hypot(k, c*w)/(m*w^2), 2)\", unit: \"1\"}\n"
                                               "  T:    {value: \"2*pi*sqrt(x0/g)\", unit: s}\n"
                                               "  ph:   {value: \"atan2(c*w, k) + 0.1\", unit: rad}\n",
                                               "m"),
                                         "m.yaml");
  const double k = 2.0 * std::pow(2 * std::numbers::pi * 1.5, 2);
  EXPECT_EQ(Param(lm, "k").value, k);
  EXPECT_EQ(Param(lm, "c").value, 2 * 0.05 * std::sqrt(k * 2.0));
  // A number has no dimension in a product: 9.81 is not g.
  const auto ds = LoadErrors(Model("  m: {value: 2.0, unit: kg}\n  k: {value: 100, unit: N/m}\n  x0: {value: \"m*9.81/k\", unit: m}\n"));
  ASSERT_EQ(ds.size(), 1u);
  EXPECT_EQ(ds[0].message, "its formula 'm*9.81/k' gives s^2, not the unit declared for it, m");
}

// rad/s and Hz are both 1/s to the units (the radian is a number), so sqrt(k/m) declared in Hz
// agrees with its unit and a 2 pi error would pass: it is a located error with the fix.
TEST(ModelParametersReader, AnAngularFrequencyDeclaredInHzIsAnError) {
  const std::string km = "  k: {value: 400, unit: N/m}\n  m: {value: 1, unit: kg}\n";
  auto loads = [&](const std::string& line) {
    try {
      (void)LoadModelString(Model(km + line), "m.yaml");
      return true;
    } catch (const ModelError&) {
      return false;
    }
  };
  const std::vector<Diagnostic> ds = LoadErrors(Model(km + "  w0: {value: \"sqrt(k/m)\", unit: Hz}\n"));
  ASSERT_EQ(ds.size(), 1u);
  EXPECT_EQ(ds[0].code, "expr.angular_frequency_in_hz");
  EXPECT_EQ(ds[0].element, "w0");
  EXPECT_EQ(ds[0].where.line, 5);
  EXPECT_EQ(ds[0].where.column, 16);
  EXPECT_THAT(ds[0].message, HasSubstr("rad/s"));
  EXPECT_THAT(ds[0].hint, HasSubstr("(sqrt(k/m))/(2*pi)"));
  EXPECT_FALSE(loads("  w0: {value: \"k^0.5/m^0.5\", unit: Hz}\n"));
  // --set w0=... is checked the same way, as the caller's mistake.
  EXPECT_THAT(SetError(Model(km + "  w0: {value: 3, unit: Hz}\n"), {{"w0", "sqrt(k/m)"}}), HasSubstr("an angular frequency is in rad/s"));
  // Taken as written: the same in rad/s, the frequency with its 2 pi, a period's inverse, a mean
  // of frequencies in Hz, and 1/s written as such.
  EXPECT_EQ(Param(LoadModelString(Model(km + "  w0: {value: \"sqrt(k/m)\", unit: rad/s}\n"), "m.yaml"), "w0").value, 20.0);
  EXPECT_TRUE(loads("  f0: {value: \"sqrt(k/m)/(2*pi)\", unit: Hz}\n"));
  EXPECT_TRUE(loads("  T: {value: 0.5, unit: s}\n  fT: {value: \"1/T\", unit: Hz}\n"));
  EXPECT_TRUE(loads("  f1: {value: 2, unit: Hz}\n  f2: {value: 8, unit: Hz}\n  fm: {value: \"sqrt(f1*f2)\", unit: Hz}\n"));
  EXPECT_TRUE(loads("  w0: {value: \"sqrt(k/m)\", unit: 1/s}\n"));
}

TEST(ModelParametersReader, AValueSetFromOutsideIsCheckedForUnitsToo) {
  const std::string yaml = Model("  L: {value: 1.0, unit: m}\n  T: {value: 2.0, unit: s}\n  v: {value: L/T, unit: m/s}\n");
  EXPECT_EQ(SetError(yaml, {{"v", "L + T"}}), "parameter 'v' set to 'L + T': the two sides of '+' have different units: 'L' is m, "
                                              "'T' is s (at character 3)");
  EXPECT_EQ(SetError(yaml, {{"v", "L*T"}}), "parameter 'v' set to 'L*T': its formula 'L*T' gives m s, not the unit declared for it, m/s");
  EXPECT_EQ(SetError(yaml, {{"v", "2*L/T"}}), "");
  EXPECT_EQ(SetError(yaml, {{"v", "7"}}), "");  // a number is a value in the unit declared
}

TEST(ModelParametersReader, ParseParameterAssignment) {
  const ParameterOverride o = ParseParameterAssignment(" k = 2*L0 ");
  EXPECT_EQ(o.name, "k");
  EXPECT_EQ(o.value, "2*L0");
  EXPECT_THROW(ParseParameterAssignment("k"), std::invalid_argument);
  EXPECT_THROW(ParseParameterAssignment("=3"), std::invalid_argument);
  EXPECT_THROW(ParseParameterAssignment("k="), std::invalid_argument);
}

TEST(ModelParametersReader, ALongChainIsEvaluatedWithoutDeepRecursion) {
  // p0 <- p1 <- ... <- p19999, written last first: a recursive walk would be 20,000 frames deep.
  std::string parameters;
  const int n = 20000;
  for (int i = n - 1; i > 0; --i) parameters += fmt::format("  p{}: p{} + 1\n", i, i - 1);
  parameters += "  p0: 1.0\n";
  const auto start = std::chrono::steady_clock::now();
  const LoadedModel lm = LoadModelString(Model(parameters, fmt::format("p{}", n - 1)), "m.yaml");
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), 10.0);
  EXPECT_EQ(lm.graph.element(lm.graph.Find("mass")).param.scalar, static_cast<double>(n));
}

}  // namespace
}  // namespace multibond
