// Formulas typeset as LaTeX mathematics (compile/formula_latex.h; #43: `equations --format latex`
// printed nonlinear laws verbatim in \mathtt{}).

#include "multibond/compile/formula_latex.h"

#include <gtest/gtest.h>

namespace multibond {
namespace {

std::string Tex(const char* formula) {
  const auto t = FormulaLatex(formula);
  EXPECT_TRUE(t.has_value()) << formula;
  return t.value_or("");
}

TEST(FormulaLatex, FunctionsAreOperatorsAndNamesAreUprightUnlessOneLetter) {
  EXPECT_EQ(Tex("c_bump*max(f, 0) + c_reb*min(f, 0)"),
            "\\mathrm{c\\_bump} \\, \\max\\left(f, 0\\right) + \\mathrm{c\\_reb} \\, \\min\\left(f, 0\\right)");
  EXPECT_EQ(Tex("k1*q + k3*q^3"), "\\mathrm{k1} \\, q + \\mathrm{k3} \\, q^{3}");
  EXPECT_EQ(Tex("sin(w*t) + exp(-t/tau) + log(x)"), "\\sin\\left(w \\, t\\right) + \\exp\\left(\\frac{-t}{\\tau}\\right) + \\ln\\left(x\\right)");
  EXPECT_EQ(Tex("abs(v)*sign(v)"), "\\left|v\\right| \\, \\operatorname{sign}\\left(v\\right)");
  EXPECT_EQ(Tex("spring.q*K"), "\\mathrm{spring.q} \\, K");
}

TEST(FormulaLatex, QuotientsAreFractionsPowersSuperscriptsAndGreekNamesLetters) {
  EXPECT_EQ(Tex("sqrt(2*g*h)/A"), "\\frac{\\sqrt{2 \\, g \\, h}}{A}");
  EXPECT_EQ(Tex("omega_0^2*x"), "\\omega_{\\mathrm{0}}^{2} \\, x");
  EXPECT_EQ(Tex("(a/b)^2"), "\\left(\\frac{a}{b}\\right)^{2}");
  EXPECT_EQ(Tex("2*pi*f"), "2 \\, \\pi \\, f");
  EXPECT_EQ(Tex("1.5e-4*x + 1e6 + 0.0015"), "1.5 \\cdot 10^{-4} \\, x + 10^{6} + 0.0015");
}

TEST(FormulaLatex, TheFewestBracketsThePrecedenceNeeds) {
  EXPECT_EQ(Tex("-(a + b)"), "-\\left(a + b\\right)");
  EXPECT_EQ(Tex("a - (b - c)"), "a - \\left(b - c\\right)");
  EXPECT_EQ(Tex("a - b + c"), "a - b + c");
  EXPECT_EQ(Tex("(a + b)*c"), "\\left(a + b\\right) \\, c");
  EXPECT_EQ(Tex("-x^2"), "-x^{2}");
}

TEST(FormulaLatex, ConditionsAreCasesAndComparisonsTheirSigns) {
  EXPECT_EQ(Tex("if(q > 0, 100*q, 0)"), "\\begin{cases} 100 \\, q & \\text{if } q > 0 \\\\ 0 & \\text{otherwise} \\end{cases}");
  EXPECT_EQ(Tex("x <= 1 and not (y != 2)"), "x \\le 1 \\land \\lnot \\left(y \\ne 2\\right)");
}

TEST(FormulaLatex, ALawIsShownAtTheStateItIsEvaluatedAt) {
  EXPECT_EQ(Tex("(k0*q^2 at q = spring.q)"), "\\left.\\mathrm{k0} \\, q^{2}\\right|_{q = \\mathrm{spring.q}}");
  EXPECT_EQ(Tex("-(d(1/2*k1*q^2)/dq at q = spring.q)"),
            "-\\left.\\frac{\\partial}{\\partial q}\\left(\\frac{1}{2} \\, \\mathrm{k1} \\, q^{2}\\right)\\right|_{q = \\mathrm{spring.q}}");
}

TEST(FormulaLatex, ADescriptionThatIsNoFormulaIsNotTypeset) {
  EXPECT_FALSE(FormulaLatex("D.e solved from D.f = Is*(exp(D.e/Vt) - 1)").has_value());
  EXPECT_FALSE(FormulaLatex("").has_value());
}

}  // namespace
}  // namespace multibond
