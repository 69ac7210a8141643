// Elements whose laws are formulas (io/element_reader.cc): the graph's fields are filled with the
// formula's text, its tree (every parameter a number, every other name kept, names of a submodel
// instance qualified) and the place of its first character; what is not a law stays as it was.

#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "multibond/io/model_loader.h"
#include "support/load_errors.h"

namespace multibond {
namespace {

using ::testing::ElementsAre;
using ::testing::HasSubstr;

using testing::LoadErrors;

const Element& Find(const LoadedModel& lm, const std::string& name) { return lm.graph.element(lm.graph.Find(name)); }

/// The names a formula's tree still refers to.
std::vector<std::string> NamesOf(const Formula& f) {
  std::vector<std::string> out;
  for (const expr::Node* n : expr::Names(*f.root)) out.push_back(n->name);
  return out;
}

const char* kLaws = R"y(model: laws
parameters: {k1: 100.0, k3: 2.0e4, m: 0.5, R0: 3.0, F0: 2.0, w: 6.0, n: 0.1}
signals: {drive: "F0*sin(w*t)"}
elements:
  force:  {type: Se, effort: "drive + 0*t"}
  j:      {type: "1"}
  spring: {type: C, effort: "k1*q + k3*q^3", q0: 0.01}
  well:   {type: C, energy: "k1*q^2/2"}
  mass:   {type: I, flow: "p/m"}
  coil:   {type: I, energy: "p^2/(2*m)"}
  drag:   {type: R, effort: "R0*f*abs(f)", flow: "sign(e)*sqrt(abs(e)/R0)"}
  pump:   {type: R, flow: "-e/R0", active: true}
  lever:  {type: TF, ratio: "n*(1 + 0.1*sin(t))"}
  gear:   {type: GY, ratio: "2*n"}
  motion: {type: Sf, flow: [0.0, "spring.q*w", {step: 1.0}, "F0"]}
bonds: [force -> j, j -> spring]
)y";

TEST(ElementReader, LawsFillTheGraphsFormulaFields) {
  // Loading only: the layers that use the laws are not asked here.
  const LoadedModel lm = LoadModelString(kLaws, "m.yaml");
  const Element& spring = Find(lm, "spring");
  EXPECT_EQ(spring.law_effort.text, "k1*q + k3*q^3");
  EXPECT_THAT(NamesOf(spring.law_effort), ElementsAre("q"));  // k1 and k3 became numbers
  EXPECT_EQ(expr::Format(*spring.law_effort.root), "100*q + 20000*q^3");
  EXPECT_EQ(spring.law_effort.where.line, 7);
  EXPECT_EQ(spring.law_effort.where.column, 30);  // the 'k' past the quote
  EXPECT_EQ(spring.initial[0], 0.01);
  EXPECT_FALSE(spring.energy.given());
  EXPECT_EQ(expr::Format(*Find(lm, "well").energy.root), "100*q^2/2");
  EXPECT_EQ(expr::Format(*Find(lm, "mass").law_effort.root), "p/0.5");  // an I's flow law
  EXPECT_EQ(expr::Format(*Find(lm, "coil").energy.root), "p^2/(2*0.5)");
  const Element& drag = Find(lm, "drag");
  EXPECT_THAT(NamesOf(drag.law_effort), ElementsAre("f"));
  EXPECT_THAT(NamesOf(drag.law_flow), ElementsAre("e"));
  EXPECT_FALSE(drag.active);
  EXPECT_TRUE(Find(lm, "pump").active);
  EXPECT_EQ(expr::Format(*Find(lm, "force").value.at(0).root), "drive + 0*t");  // signals and t are kept
  // A ratio that changes is a formula; one of parameters only is a number like any ratio.
  const Element& lever = Find(lm, "lever");
  ASSERT_EQ(lever.value.size(), 1u);
  EXPECT_THAT(NamesOf(lever.value[0]), ElementsAre("t"));
  const Element& gear = Find(lm, "gear");
  EXPECT_TRUE(gear.value.empty());
  EXPECT_TRUE(gear.param.is_scalar);
  EXPECT_EQ(gear.param.scalar, 0.2);
}

TEST(ElementReader, ASourceListMayMixFormulasAndTimeFunctions) {
  const LoadedModel lm = LoadModelString(kLaws, "m.yaml");
  const Element& motion = Find(lm, "motion");
  // One entry per component in both: a formula given where the component is one, else the time
  // function (a formula of parameters only is a constant time function).
  ASSERT_EQ(motion.source.components.size(), 4u);
  ASSERT_EQ(motion.value.size(), 4u);
  EXPECT_FALSE(motion.value[0].given());
  EXPECT_THAT(NamesOf(motion.value[1]), ElementsAre("spring.q"));
  EXPECT_FALSE(motion.value[2].given());
  EXPECT_FALSE(motion.value[3].given());
  EXPECT_EQ(motion.source.components[0](1.0), 0.0);
  EXPECT_EQ(motion.source.components[2](1.0), 1.0);
  EXPECT_EQ(motion.source.components[3](1.0), 2.0);
  // A source of constants only has no formulas at all.
  EXPECT_TRUE(LoadModelString(R"y(model: m
parameters: {F0: 2.0}
elements:
  force: {type: Se, effort: "F0/4"}
  j: {type: "1"}
  mass: {type: I, inertia: 1}
bonds: [force -> j, j -> mass]
)y", "m.yaml").graph.element(0).value.empty());
}

TEST(ElementReader, NamesInASubmodelsLawsAreLocalToTheInstance) {
  const std::string yaml = R"y(model: m
parameters: {k: 100.0}
submodels:
  cell:
    parameters: {c: 2.0}
    ports: [v]
    elements:
      v:      {type: "1"}
      spring: {type: C, effort: "k*q + c*x + c*mass.p"}
      mass:   {type: I, inertia: 1.0}
    states:
      x: {kind: integral, rate: "spring.q"}
    bonds: [v -> spring, v -> mass]
elements:
  push: {type: Se, effort: 1.0}
  a:    {type: cell, c: 3.0}
bonds: [push -> a.v]
)y";
  const LoadedModel lm = LoadModelString(yaml, "m.yaml");
  EXPECT_EQ(expr::Format(*Find(lm, "a.spring").law_effort.root), "100*q + 3*a.x + 3*a.mass.p");
  const AuxState& x = lm.graph.aux_states()[lm.graph.FindAux("a.x")];
  EXPECT_THAT(NamesOf(x.rate), ElementsAre("a.spring.q"));
}

TEST(ElementReader, OneWayToGiveALawAndScalarBondsOnly) {
  const auto ds = LoadErrors(R"y(model: m
elements:
  force:  {type: Se, effort: 1.0}
  j:      {type: "1"}
  a:      {type: C, stiffness: 1.0, effort: "q"}
  b:      {type: I, inertia: 1.0, flow: "p"}
  c:      {type: R, resistance: 1.0, flow: "e"}
  d:      {type: C, effort: "2*q", dim: 2}
  e:      {type: I, flow: "p", p0: [1, 2]}
bonds: [force -> j, j -> a, j -> b, j -> c, j -> d, j -> e]
)y");
  std::vector<std::string> messages;
  for (const Diagnostic& d : ds) messages.push_back(d.element + ": " + d.message + (d.code.empty() ? "" : " [" + d.code + "]"));
  EXPECT_THAT(messages, ElementsAre("a: give one of 'stiffness', 'compliance', 'effort' and 'energy' [key.conflict]",
                                    "b: give one of 'inertia', 'flow' and 'energy' [key.conflict]",
                                    "c: give either 'resistance' or a law ('effort' and/or 'flow'), not both [key.conflict]",
                                    "d: a law ('effort') is for a scalar bond, but 'dim' is 2 [structure.dimension]",
                                    "e: a law ('flow') is for a scalar bond, but its initial value has 2 entries [structure.dimension]"));
  const auto turning = LoadErrors(R"y(model: m
elements:
  torque: {type: Se, effort: [0, 0, 1]}
  w:      {type: "1"}
  g:      {type: I, energy: "p^2", rotation: R}
states:
  R: {kind: orientation, of: w}
bonds: [torque -> w, w -> g]
)y");
  ASSERT_EQ(turning.size(), 1u);
  EXPECT_EQ(turning[0].message, "a law ('energy') is for a scalar bond, but it turns with an orientation (a 3-dimensional bond)");
}

TEST(ElementReader, ALawNamesOnlyItsOwnVariableBare) {
  // "  s: {type: C, effort: "k*f"}": f is not a C's effort law's variable (q is).
  const auto ds = LoadErrors(R"y(model: m
parameters: {k: 1.0}
elements:
  force: {type: Se, effort: 1.0}
  j:     {type: "1"}
  s:     {type: C, effort: "k*f"}
  r:     {type: R, effort: "k*fl"}
bonds: [force -> j, j -> s, j -> r]
)y");
  ASSERT_EQ(ds.size(), 2u);
  EXPECT_EQ(ds[0].code, "param.unknown");
  EXPECT_EQ(ds[0].where.line, 6);
  EXPECT_EQ(ds[0].where.column, 31);
  EXPECT_THAT(ds[0].hint, HasSubstr("in a C's effort law (a formula of its displacement q) the element's own variable is 'q'"));
  EXPECT_EQ(ds[1].code, "param.unknown");
  EXPECT_EQ(ds[1].hint, "did you mean 'f'?");
}

TEST(ElementReader, FormulaErrorsInLawsAreLocated) {
  const auto ds = LoadErrors(R"y(model: m
elements:
  force: {type: Se, effort: "sin(2*pi*t"}
  j:     {type: "1"}
  s:     {type: C, effort: "hypot(q)"}
bonds: [force -> j, j -> s]
)y");
  ASSERT_EQ(ds.size(), 2u);
  EXPECT_EQ(ds[0].code, "expr.syntax");
  EXPECT_EQ(ds[0].where.column, 40);  // where the ')' is missing: the end of the text
  EXPECT_THAT(ds[0].message, HasSubstr("the formula 'sin(2*pi*t' does not read"));
  EXPECT_EQ(ds[1].code, "expr.arity");
  EXPECT_EQ(ds[1].where.column, 29);
}

TEST(ElementReader, AFoldedRatioKeepsItsChecks) {
  const auto ds = LoadErrors(R"y(model: m
parameters: {n: 0.0}
elements:
  force: {type: Se, effort: 1.0}
  g:     {type: TF, ratio: "2*n"}
  j:     {type: "1"}
  mass:  {type: I, inertia: 1}
bonds: [force -> g, g -> j, j -> mass]
)y");
  ASSERT_EQ(ds.size(), 1u);
  EXPECT_THAT(ds[0].message, HasSubstr("ratio must not be 0"));
}

}  // namespace
}  // namespace multibond
