// Numbers written as formulas of parameters (io/formula_values.cc): their values, and every
// problem in one reported with its code at the character of the formula where it is (the
// scalar's place in the file plus the offset in its text, past an opening quote).

#include <cmath>
#include <numbers>
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

using testing::LoadErrors;

/// The first diagnostic with `code`; fails the test if there is none.
Diagnostic WithCode(const std::vector<Diagnostic>& ds, const std::string& code) {
  for (const Diagnostic& d : ds)
    if (d.code == code) return d;
  std::string all;
  for (const Diagnostic& d : ds) all += d.ToString() + "\n";
  ADD_FAILURE() << "no diagnostic with code " << code << " among:\n" << all;
  return {};
}

/// A mass-spring-damper whose mass line is `mass_line` (line 8 of the file).
std::string Msd(const std::string& mass_line, const std::string& spring = "{type: C, stiffness: 100.0}") {
  return "model: msd\n"                                   // 1
         "domain: translation\n"                          // 2
         "parameters: {L: 2.0, k: 100.0, tau: 0.5}\n"     // 3
         "elements:\n"                                    // 4
         "  force:  {type: Se, effort: 1.0}\n"            // 5
         "  j:      {type: \"1\"}\n"                      // 6
         "  spring: " + spring + "\n"                     // 7
         "  mass:   " + mass_line + "\n"                  // 8
         "bonds: [force -> j, j -> mass, j -> spring]\n";
}

const Element& Find(const LoadedModel& lm, const std::string& name) { return lm.graph.element(lm.graph.Find(name)); }

TEST(FormulaValues, ANumberMayBeAFormulaOfParametersPlainOrQuoted) {
  const LoadedModel lm = LoadModelString(Msd("{type: I, inertia: 1/12, p0: \"2*pi*L\"}", "{type: C, stiffness: k/L^2}"), "m.yaml");
  EXPECT_EQ(Find(lm, "mass").param.scalar, 1.0 / 12.0);
  EXPECT_EQ(Find(lm, "mass").initial[0], 2 * std::numbers::pi * 2.0);
  EXPECT_EQ(Find(lm, "spring").param.scalar, 100.0 / 4.0);
}

TEST(FormulaValues, SettingsMatricesAndTimeFunctionsTakeFormulasToo) {
  const std::string yaml = R"y(model: m
parameters: {tau: 0.5, F: 3.0}
elements:
  force: {type: Se, effort: {step: {value: 2*F, at: tau/2}}}
  j:     {type: "1"}
  mass:  {type: I, inertia: [[1/4, 0], [0, "tau"]]}
bonds: [force -> j, j -> mass]
simulation: {t_end: 10*tau, dt: tau/100}
)y";
  const LoadedModel lm = LoadModelString(yaml, "m.yaml");
  EXPECT_EQ(*lm.simulation.t_end, 5.0);
  EXPECT_EQ(*lm.simulation.dt, 0.005);
  EXPECT_EQ(Find(lm, "mass").param.matrix(0, 0), 0.25);
  EXPECT_EQ(Find(lm, "mass").param.matrix(1, 1), 0.5);
  const TimeFunction& f = Find(lm, "force").source.components.at(0);
  EXPECT_EQ(f(0.2), 0.0);
  EXPECT_EQ(f(0.25), 6.0);
}

TEST(FormulaValues, SubmodelParametersKeepDollarNamesAndMayBeNamedInFormulas) {
  const std::string yaml = R"y(model: m
parameters: {M: 4.0}
submodels:
  cart:
    parameters: {m: M/2, c: 0.0}
    ports: [v]
    elements:
      v:        {type: "1"}
      mass:     {type: I, inertia: 2*m}
      friction: {type: R, resistance: $c}
    bonds: [v -> mass, v -> friction]
elements:
  push: {type: Se, effort: 1.0}
  a:    {type: cart, c: M/8}
  b:    {type: cart, m: "M"}
bonds: [push -> a.v, a.v -> b.v]
)y";
  const LoadedModel lm = LoadModelString(yaml, "m.yaml");
  EXPECT_EQ(Find(lm, "a.mass").param.scalar, 4.0);  // m = M/2 = 2 by default
  EXPECT_EQ(Find(lm, "a.friction").param.scalar, 0.5);
  EXPECT_EQ(Find(lm, "b.mass").param.scalar, 8.0);
}

TEST(FormulaValues, ADollarInsideAFormulaIsExplained) {
  const std::string yaml = R"y(model: m
submodels:
  cart:
    parameters: {m: 1.0}
    ports: [v]
    elements:
      v:    {type: "1"}
      mass: {type: I, inertia: 2*$m}
    bonds: [v -> mass]
elements:
  push: {type: Se, effort: 1.0}
  a:    {type: cart}
bonds: [push -> a.v]
)y";
  const Diagnostic d = WithCode(LoadErrors(yaml), "expr.syntax");
  EXPECT_EQ(d.element, "a.mass");
  EXPECT_EQ(d.where.line, 8);
  EXPECT_EQ(d.where.column, 34);
  EXPECT_EQ(d.hint, "in a formula, a submodel's parameter is named without '$' (2*m, not 2*$m)");
}

TEST(FormulaValues, AnErrorInABlockOrEscapedFormulaIsAtItsCharacterOrTheValuesStart) {
  // A literal block: the character's own line and column; an escaped string: its start (escapes
  // change the text, so a column inside it would point at the wrong character).
  const Diagnostic block = WithCode(LoadErrors(Msd("{type: I, inertia: 1.0}\n"
                                                   "  mass2:\n"
                                                   "    type: I\n"
                                                   "    inertia: |\n"
                                                   "      1 +\n"
                                                   "      2 + @")),
                                    "expr.syntax");
  EXPECT_EQ(block.where.line, 13);
  EXPECT_EQ(block.where.column, 11);
  const Diagnostic escaped = WithCode(LoadErrors(Msd("{type: I, inertia: \"\\u0031\\u0031 + @\"}")), "expr.syntax");
  EXPECT_EQ(escaped.where.line, 8);
  EXPECT_EQ(escaped.where.column, 30);  // the opening quote
  // Before the first escape, the character itself.
  const Diagnostic before = WithCode(LoadErrors(Msd("{type: I, inertia: \"1 + @ + \\u0031\"}")), "expr.syntax");
  EXPECT_EQ(before.where.column, 35);
}

TEST(FormulaValues, UnknownParameterAtItsCharacterWithDidYouMean) {
  // Line 8 is "  mass:   {type: I, inertia: 2*LL}": the value starts at column 30, 'LL' at 32.
  Diagnostic d = WithCode(LoadErrors(Msd("{type: I, inertia: 2*LL}")), "param.unknown");
  EXPECT_EQ(d.where.line, 8);
  EXPECT_EQ(d.where.column, 32);
  EXPECT_EQ(d.element, "mass");
  EXPECT_THAT(d.message, HasSubstr("unknown parameter 'LL'"));
  EXPECT_EQ(d.hint, "did you mean 'L'?");
  // Quoted, the text starts one column later (past the quote), with either quote.
  d = WithCode(LoadErrors(Msd("{type: I, inertia: \"2*LL\"}")), "param.unknown");
  EXPECT_EQ(d.where.column, 33);
  d = WithCode(LoadErrors(Msd("{type: I, inertia: '2 * LL'}")), "param.unknown");
  EXPECT_EQ(d.where.column, 35);
}

TEST(FormulaValues, AUnknownNameSharingNoLetterSuggestsNothing) {
  const Diagnostic d = WithCode(LoadErrors(Msd("{type: I, inertia: 2*z}")), "param.unknown");
  EXPECT_THAT(d.hint, HasSubstr("the model's parameters are: L, k, tau"));
}

TEST(FormulaValues, BlockStyleValueColumns) {
  const std::string yaml = R"y(model: m
parameters:
  L: 2.0
elements:
  force: {type: Se, effort: 1.0}
  j: {type: "1"}
  mass:
    type: I
    inertia: "2 * sqrt(L, 2)"
bonds: [force -> j, j -> mass]
)y";
  const Diagnostic d = WithCode(LoadErrors(yaml), "expr.arity");
  EXPECT_EQ(d.where.line, 9);
  EXPECT_EQ(d.where.column, 19);  // the quote is at 14, 's' of sqrt at 19
  EXPECT_THAT(d.message, HasSubstr("sqrt takes 1 argument, not 2"));
}

TEST(FormulaValues, SyntaxErrorsAndUnknownFunctionsHaveTheirCodes) {
  Diagnostic d = WithCode(LoadErrors(Msd("{type: I, inertia: \"2*\"}")), "expr.syntax");
  EXPECT_EQ(d.where.column, 33);  // where the formula ends early
  EXPECT_THAT(d.message, HasSubstr("expected a number, got '2*': as a formula, the formula ends early"));
  d = WithCode(LoadErrors(Msd("{type: I, inertia: 2 L}")), "expr.syntax");
  EXPECT_EQ(d.where.column, 32);
  EXPECT_THAT(d.message, HasSubstr("missing operator"));
  d = WithCode(LoadErrors(Msd("{type: I, inertia: \"sn(L)\"}")), "expr.unknown_function");
  EXPECT_EQ(d.where.column, 31);
  EXPECT_EQ(d.hint, "did you mean 'sin'?");
  d = WithCode(LoadErrors(Msd("{type: I, inertia: \"L*atan2(L)\"}")), "expr.arity");
  EXPECT_EQ(d.where.column, 33);
  // In a law (line 7, the formula from column 30): a word of the grammar where it cannot stand,
  // before '(', is a syntax error, not a function; comparisons do not chain.
  d = WithCode(LoadErrors(Msd("{type: I, inertia: 1.0}", "{type: C, effort: \"q < not (L)\"}")), "expr.syntax");
  EXPECT_EQ(d.where.column, 34);
  EXPECT_THAT(d.hint, HasSubstr("a < (not b)"));
  d = WithCode(LoadErrors(Msd("{type: I, inertia: 1.0}", "{type: C, effort: \"0 < q < 3\"}")), "expr.syntax");
  EXPECT_EQ(d.where.column, 36);
  EXPECT_EQ(d.hint, "write 0 < q and q < 3");
  // A number may be a formula with switches of parameters: it is folded.
  const LoadedModel lm = LoadModelString(Msd("{type: I, inertia: \"if(L > 1 and not tau > 1, 3, 4) + (k == 100)\"}"), "m.yaml");
  EXPECT_EQ(Find(lm, "mass").param.scalar, 4.0);
}

TEST(FormulaValues, TimeOrAVariableWhereAConstantIsNeededNamesTheLawKeys) {
  Diagnostic d = WithCode(LoadErrors(Msd("{type: I, inertia: 1.0}", "{type: C, stiffness: \"k*(1 + t)\"}")), "expr.not_constant");
  EXPECT_EQ(d.where.line, 7);
  EXPECT_EQ(d.where.column, 40);  // the 't'
  EXPECT_THAT(d.message, HasSubstr("'t' (time)"));
  EXPECT_THAT(d.hint, HasSubstr("'effort:' (a formula of q) or 'energy:'"));
  d = WithCode(LoadErrors(Msd("{type: I, inertia: \"1 + spring.q\"}")), "expr.not_constant");
  EXPECT_EQ(d.where.column, 35);
  EXPECT_THAT(d.message, HasSubstr("'spring.q' is a variable of the model"));
  EXPECT_THAT(d.hint, HasSubstr("'flow:' (a formula of p)"));
}

TEST(FormulaValues, AFormulaWhoseValueIsNotFiniteIsOutOfRange) {
  const Diagnostic d = WithCode(LoadErrors(Msd("{type: I, inertia: \"1/(L - 2)\"}")), "param.range");
  EXPECT_EQ(d.where.column, 31);
  EXPECT_THAT(d.message, HasSubstr("the formula '1/(L - 2)' gives inf: not a finite number"));
}

// Units where they are declared, in element numbers and laws (docs/model-format.md, "Units in
// formulas"): the parameters with a unit have it, the element's own variables, time and the
// parameters without a unit are free.

/// A mass-spring-damper whose parameters have units, with the mass line `mass_line` and the
/// spring line `spring` (lines 12 and 11).
std::string MsdWithUnits(const std::string& mass_line, const std::string& spring = "{type: C, stiffness: k}") {
  return "model: msd\n"                                     // 1
         "domain: translation\n"                            // 2
         "parameters:\n"                                    // 3
         "  m:   {value: 2.0, unit: kg}\n"                  // 4
         "  L:   {value: 0.5, unit: m}\n"                   // 5
         "  k:   {value: 100.0, unit: N/m}\n"               // 6
         "  tau: {value: 0.5, unit: s}\n"                   // 7
         "elements:\n"                                      // 8
         "  force:  {type: Se, effort: \"k*L*exp(-t/tau)\"}\n"  // 9
         "  j:      {type: \"1\"}\n"                        // 10
         "  spring: " + spring + "\n"                       // 11
         "  mass:   " + mass_line + "\n"                    // 12
         "bonds: [force -> j, j -> mass, j -> spring]\n";
}

TEST(FormulaValues, AnElementNumberWithUnitsThatDoNotFitIsAnError) {
  // Line 12 is '  mass:   {type: I, inertia: "m + L"}': the quote at 30, '+' at 33.
  const auto ds = LoadErrors(MsdWithUnits("{type: I, inertia: \"m + L\"}"));
  ASSERT_EQ(ds.size(), 1u) << ds[0].ToString();
  EXPECT_EQ(ds[0].code, "expr.units");
  EXPECT_EQ(ds[0].element, "mass");
  EXPECT_EQ(ds[0].where.line, 12);
  EXPECT_EQ(ds[0].where.column, 33);
  EXPECT_EQ(ds[0].message, "the two sides of '+' have different units: 'm' is kg, 'L' is m");
  // A number of the element: its initial momentum. The quote at 37, the '-' at 47.
  const Diagnostic p0 = WithCode(LoadErrors(MsdWithUnits("{type: I, inertia: m, p0: \"m*sqrt(L - tau)\"}")), "expr.units");
  EXPECT_EQ(p0.where.column, 47);
  EXPECT_EQ(p0.message, "the two sides of '-' have different units: 'L' is m, 'tau' is s");
}

TEST(FormulaValues, ALawWithUnitsThatDoNotFitIsAnErrorAndItsOwnVariableIsFree) {
  // Line 11 is '  spring: {type: C, effort: "k*q + sin(L)"}': the quote at 29, 'sin' at 36.
  const auto ds = LoadErrors(MsdWithUnits("{type: I, inertia: m}", "{type: C, effort: \"k*q + sin(L)\"}"));
  ASSERT_EQ(ds.size(), 1u) << ds[0].ToString();
  EXPECT_EQ(ds[0].code, "expr.units");
  EXPECT_EQ(ds[0].element, "spring");
  EXPECT_EQ(ds[0].where.line, 11);
  EXPECT_EQ(ds[0].where.column, 36);
  EXPECT_EQ(ds[0].message, "sin of 'L', which is m: sin takes a number without dimension (an angle in rad)");
  // The same model with laws that fit loads: q, t and p are free; L^2 with L in m is an area.
  const LoadedModel lm = LoadModelString(
      MsdWithUnits("{type: I, flow: \"p/m\"}", "{type: C, energy: \"k*q^2/2 + k*L^2*(1 - cos(q/L))\"}"), "m.yaml");
  EXPECT_EQ(lm.graph.element(lm.graph.Find("spring")).energy.text, "k*q^2/2 + k*L^2*(1 - cos(q/L))");
}

TEST(FormulaValues, AComparisonOfOtherUnitsIsAnErrorAtItsOperator) {
  // Line 11 is '  spring: {type: C, effort: "k*q*(q > L) + (tau < L)*k*L"}': the quote at 29, the
  // formula from 30, its '<' at offset 19.
  auto ds = LoadErrors(MsdWithUnits("{type: I, inertia: m}", "{type: C, effort: \"k*q*(q > L) + (tau < L)*k*L\"}"));
  ASSERT_EQ(ds.size(), 1u) << ds[0].ToString();
  EXPECT_EQ(ds[0].code, "expr.units");
  EXPECT_EQ(ds[0].where.line, 11);
  EXPECT_EQ(ds[0].where.column, 49);
  EXPECT_EQ(ds[0].message, "the two sides of '<' have different units: 'tau' is s, 'L' is m");
  // The branches of if: at the 'if' (offset 6).
  ds = LoadErrors(MsdWithUnits("{type: I, inertia: m}", "{type: C, effort: \"k*q + if(q > 0, k*L, tau)\"}"));
  ASSERT_EQ(ds.size(), 1u) << ds[0].ToString();
  EXPECT_EQ(ds[0].code, "expr.units");
  EXPECT_EQ(ds[0].where.column, 36);
  EXPECT_EQ(ds[0].message, "the two branches of if have different units: 'k*L' is m kg/s^2, 'tau' is s");
  // Laws with switches that fit load, their text kept.
  const LoadedModel lm = LoadModelString(
      MsdWithUnits("{type: I, flow: \"if(p > 0 and not p > 10*m, p/m, 2*p/m)\"}", "{type: C, effort: \"k*q*(q > -L or q == 0)\"}"),
      "m.yaml");
  EXPECT_EQ(lm.graph.element(lm.graph.Find("spring")).law_effort.text, "k*q*(q > -L or q == 0)");
}

TEST(FormulaValues, TheWordsOfFormulasAreNoNames) {
  for (const char* word : {"and", "or", "not"}) {
    const std::string w = word;
    Diagnostic d = WithCode(LoadErrors(Msd("{type: I, inertia: 1.0}").replace(Msd("").find("{L: 2.0"), 7, "{" + w + ": 1, L: 2.0")),
                            "name.invalid");
    EXPECT_EQ(d.where.line, 3) << w;
    EXPECT_EQ(d.message, fmt::format("a parameter's name '{}' is a word of formulas: 'and', 'or' and 'not' are operators there", w));
    d = WithCode(LoadErrors(Msd("{type: I, inertia: 1.0}") + "signals: {" + w + ": \"2*t\"}\n"), "name.invalid");
    EXPECT_THAT(d.message, HasSubstr(fmt::format("a signal's name '{}' is a word of formulas", w)));
    std::string model = Msd("{type: I, inertia: 1.0}");
    for (size_t at; (at = model.find("mass")) != std::string::npos;) model.replace(at, 4, w);
    d = WithCode(LoadErrors(model), "name.invalid");
    EXPECT_EQ(d.where.line, 8) << w;
    EXPECT_THAT(d.message, HasSubstr(fmt::format("an element's name '{}' is a word of formulas", w)));
    d = WithCode(LoadErrors(Msd("{type: I, inertia: 1.0}") + "states: {" + w + ": {kind: integral, rate: \"mass.p\"}}\n"),
                 "name.invalid");
    EXPECT_THAT(d.message, HasSubstr(fmt::format("a state's name '{}' is a word of formulas", w)));
  }
  // A name that only starts like one is fine.
  const LoadedModel lm = LoadModelString(Msd("{type: I, inertia: \"android + nothing\"}").replace(Msd("").find("{L: 2.0"), 7,
                                                                                                 "{android: 1, nothing: 2, L: 2.0"),
                                         "m.yaml");
  EXPECT_EQ(Find(lm, "mass").param.scalar, 3.0);
}

TEST(FormulaValues, ASubmodelsParametersAreFreeAndShadowTheModels) {
  const std::string yaml = R"y(model: m
parameters:
  L: {value: 1.0, unit: m}
  T: {value: 1.0, unit: s}
submodels:
  body:
    parameters: {T: 1.0}
    ports: [v]
    elements:
      v: {type: "1"}
      mass: {type: I, inertia: "L + T"}
    bonds: [v -> mass]
elements:
  force: {type: Se, effort: 1.0}
  a: {type: body, T: 2.0}
bonds: [force -> a.v]
)y";
  const LoadedModel lm = LoadModelString(yaml, "m.yaml");
  EXPECT_EQ(lm.graph.element(lm.graph.Find("a.mass")).param.scalar, 3.0);
}

TEST(FormulaValues, ANumberWithAUnitIsStillSaidToBeNoNumber) {
  const Diagnostic d = WithCode(LoadErrors(Msd("{type: I, inertia: 2 kg}")), "expr.syntax");
  EXPECT_THAT(d.message, HasSubstr("expected a number, got '2 kg'"));
  EXPECT_THAT(d.hint, HasSubstr("without the unit"));
}

}  // namespace
}  // namespace multibond
