// The repair assistant of `multibond check --suggest`: which couplings it proposes, their K and R
// (causality/repair.h), and the repaired model file it writes (io/model_repair.h).

#include <cmath>
#include <numbers>
#include <sstream>
#include <stdexcept>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "multibond/causality/repair.h"
#include "multibond/core/structure.h"
#include "multibond/io/model_loader.h"
#include "multibond/io/model_repair.h"
#include "support/example_runner.h"
#include "support/temp_dir.h"

namespace multibond {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;

std::string TestModel(const std::string& name) { return std::string(MULTIBOND_SOURCE_DIR) + "/tests/models/" + name; }

double Inertia(const LoadedModel& lm, const std::string& name) { return lm.graph.element(lm.graph.Find(name)).param.scalar; }
double Ratio(const LoadedModel& lm, const std::string& name) { return lm.graph.element(lm.graph.Find(name)).param.scalar; }

RepairResult Suggest(const LoadedModel& lm, const CouplingTarget& t = {}) {
  return SuggestCouplings(lm.graph, lm.compile.default_domain, t);
}

/// Loads `text`, assigns causality and compiles it: what `multibond check` does.
int CheckText(const std::string& text) {
  const LoadedModel lm = LoadModelString(text, "<repaired>");
  DiagnosticSink sink;
  const BondGraph view = CausalView(lm.graph);
  const Structure s = AnalyzeStructure(view, lm.compile.default_domain, sink);
  sink.ThrowIfErrors();
  EXPECT_TRUE(AssignCausality(view, s).integral());
  return CompiledModel::Compile(lm.graph, lm.compile)->num_states();
}

TEST(SuggestCouplings, RigidGearPairGetsOneCouplingOnTheWheelsBondWithKAndRFromTheDefaults) {
  const LoadedModel lm = LoadModelFile(testing::ExamplePath("rigid_gear_pair.yaml"));
  const RepairResult r = Suggest(lm);
  ASSERT_EQ(r.couplings.size(), 1u);
  const SuggestedCoupling& c = r.couplings.front();
  EXPECT_EQ(c.storage, "J2");
  EXPECT_EQ(c.bond, "j2->J2");
  EXPECT_EQ(c.tail, "j2");
  EXPECT_EQ(c.head, "J2");
  EXPECT_EQ(c.other_end, "j2");
  EXPECT_EQ(c.original_bond, 4);
  EXPECT_EQ(c.where.line, 22);
  EXPECT_EQ(c.domain, "rotation");
  EXPECT_EQ(c.reference, "I 'J1'");
  EXPECT_TRUE(c.reflected);
  EXPECT_EQ(c.removed, 1);
  // The wheel J2 turns at n = 0.5 times the pinion's speed: J1 seen from the wheel is J1 / n^2.
  const double j1 = Inertia(lm, "J1"), j2 = Inertia(lm, "J2"), n = Ratio(lm, "gear");
  const double i_ref = j1 / (n * n), m_eff = j2 * i_ref / (j2 + i_ref);
  const double w = 2 * std::numbers::pi * 100.0, k = m_eff * w * w, d = 2 * 0.7 * std::sqrt(k * m_eff);
  EXPECT_NEAR(m_eff, 0.02, 1e-15);
  ASSERT_EQ(c.m_eff.rows(), 1);
  EXPECT_NEAR(c.m_eff(0, 0), m_eff, 1e-15);
  EXPECT_NEAR(c.stiffness(0, 0), k, 1e-9 * k);
  EXPECT_NEAR(c.damping(0, 0), d, 1e-12 * d);
  EXPECT_NEAR(k, 7895.6835, 1e-4);
  EXPECT_NEAR(d, 17.592919, 1e-6);
  EXPECT_THAT(c.m_eff_note, HasSubstr("reflected through TF 'gear'"));
  EXPECT_EQ(c.path, "I 'J1' -> 1 'j1' -> TF 'gear' -> 1 'j2' -> I 'J2'");
  // The repaired graph: the four elements added, integrally causal, compiles.
  EXPECT_TRUE(r.integral);
  EXPECT_TRUE(r.not_repaired.empty());
  EXPECT_EQ(r.repaired.num_elements(), lm.graph.num_elements() + 4);
  EXPECT_EQ(r.repaired.num_bonds(), lm.graph.num_bonds() + 4);
  for (const char* e : {"J2_coupling", "J2_deflection", "J2_K", "J2_R"}) EXPECT_GE(r.repaired.Find(e), 0) << e;
  EXPECT_EQ(r.repaired.element(r.repaired.Find("J2_coupling")).kind, ElementKind::kZero);
  EXPECT_EQ(r.repaired.element(r.repaired.Find("J2_deflection")).kind, ElementKind::kOne);
  EXPECT_EQ(CompiledModel::Compile(r.repaired)->num_states(), 5);  // J1.p, J2.p, J2_K.q, work, dissipated
}

TEST(SuggestCouplings, FrequencyAndDampingRatioSetKAndR) {
  const LoadedModel lm = LoadModelFile(testing::ExamplePath("rigid_gear_pair.yaml"));
  const RepairResult r = Suggest(lm, {25.0, 0.2});
  ASSERT_EQ(r.couplings.size(), 1u);
  const double w = 2 * std::numbers::pi * 25.0, m_eff = 0.02;
  EXPECT_NEAR(r.couplings[0].stiffness(0, 0), m_eff * w * w, 1e-9);
  EXPECT_NEAR(r.couplings[0].damping(0, 0), 2 * 0.2 * std::sqrt(m_eff * w * w * m_eff), 1e-12);
}

TEST(SuggestCouplings, TwoDependentInertiasGetTwoCouplings) {
  const LoadedModel lm = LoadModelFile(TestModel("rigid_gear_train.yaml"));
  const RepairResult r = Suggest(lm);
  ASSERT_EQ(r.couplings.size(), 2u);
  EXPECT_EQ(r.couplings[0].storage, "J2");
  EXPECT_EQ(r.couplings[0].bond, "j2->J2");
  EXPECT_EQ(r.couplings[1].storage, "J3");
  EXPECT_EQ(r.couplings[1].bond, "j3->J3");
  for (const auto& c : r.couplings) EXPECT_EQ(c.removed, 1) << c.storage;
  const double j1 = Inertia(lm, "J1"), j2 = Inertia(lm, "J2"), j3 = Inertia(lm, "J3");
  const double n12 = Ratio(lm, "mesh12"), n13 = n12 * Ratio(lm, "mesh23");
  const double m2 = j2 * (j1 / (n12 * n12)) / (j2 + j1 / (n12 * n12)), m3 = j3 * (j1 / (n13 * n13)) / (j3 + j1 / (n13 * n13));
  EXPECT_NEAR(r.couplings[0].m_eff(0, 0), m2, 1e-14);
  EXPECT_NEAR(r.couplings[1].m_eff(0, 0), m3, 1e-14);
  EXPECT_THAT(r.couplings[1].m_eff_note, HasSubstr("TF 'mesh12' (ratio 0.5, port 1 to 2), TF 'mesh23' (ratio 0.25, port 1 to 2)"));
  EXPECT_TRUE(r.integral);
  const RepairedText text = RepairModelText(lm.text, lm.file, r, {});
  EXPECT_EQ(text.states, 3 + 2 + 1 + 3);  // momenta, deflections, work, dissipation (load and two dampers)
  EXPECT_EQ(CheckText(text.text), text.states);
}

TEST(SuggestCouplings, AFlowSourceIsAnInfiniteReferenceInertia) {
  const LoadedModel lm = LoadModelString(R"(
model: shaker_on_mass
domain: translation
elements:
  shaker: {type: Sf, flow: {sine: {amplitude: 0.1, frequency: 5}}}
  v:      {type: "1"}
  mass:   {type: I, inertia: 3.0}
bonds: [shaker -> v, v -> mass]
)");
  const RepairResult r = Suggest(lm);
  ASSERT_EQ(r.couplings.size(), 1u);
  EXPECT_EQ(r.couplings[0].reference, "Sf 'shaker'");
  EXPECT_DOUBLE_EQ(r.couplings[0].m_eff(0, 0), 3.0);
  EXPECT_THAT(r.couplings[0].m_eff_note, HasSubstr("imposed by Sf 'shaker'"));
  EXPECT_TRUE(r.integral);
}

TEST(SuggestCouplings, WhenTheReflectionCannotBeComputedTheDependentInertiaAloneIsUsedAndSaidSo) {
  // A 0-junction on the causal path: the inertia's speed is the difference of two driven speeds,
  // so no single reference inertia (or source) fixes it.
  const LoadedModel lm = LoadModelString(R"(
model: summing
domain: translation
elements:
  a:   {type: Sf, flow: 1.0}
  b:   {type: Sf, flow: 2.0}
  ja:  {type: "1"}
  jb:  {type: "1"}
  sum: {type: "0"}
  out: {type: "1"}
  m:   {type: I, inertia: 5.0}
bonds: [a -> ja, b -> jb, ja -> sum, sum -> jb, sum -> out, out -> m]
)");
  const RepairResult r = Suggest(lm);
  ASSERT_EQ(r.couplings.size(), 1u);
  EXPECT_FALSE(r.couplings[0].reflected);
  EXPECT_DOUBLE_EQ(r.couplings[0].m_eff(0, 0), 5.0);
  EXPECT_THAT(r.couplings[0].m_eff_note, HasSubstr("I 'm' alone"));
  EXPECT_THAT(r.couplings[0].m_eff_note, HasSubstr("frequency will be higher"));
}

TEST(SuggestCouplings, MatrixInertiasGetMatrixCouplings) {
  // Two 2-dimensional inertias joined by a diagonal TF: m_eff = (I_dep^-1 + I_ref^-1)^-1 with
  // I_ref = T^-T I_1 T^-1, T = diag(2, 0.5).
  const LoadedModel lm = LoadModelString(R"(
model: planar_lever
domain: translation
elements:
  push:  {type: Se, effort: [1.0, 0.5]}
  v1:    {type: "1"}
  m1:    {type: I, inertia: [1.0, 2.0]}
  lever: {type: TF, ratio: [2.0, 0.5]}
  v2:    {type: "1"}
  m2:    {type: I, inertia: 4.0}
bonds: [push -> v1, v1 -> m1, v1 -> lever, lever -> v2, v2 -> m2]
simulation: {t_end: 0.1}
)");
  const RepairResult r = Suggest(lm);
  ASSERT_EQ(r.couplings.size(), 1u);
  const SuggestedCoupling& c = r.couplings[0];
  ASSERT_EQ(c.dim, 2);
  const double mx = 4.0 * 0.25 / 4.25, my = 4.0 * 8.0 / 12.0;
  EXPECT_NEAR(c.m_eff(0, 0), mx, 1e-14);
  EXPECT_NEAR(c.m_eff(1, 1), my, 1e-14);
  EXPECT_NEAR(c.m_eff(0, 1), 0.0, 1e-15);
  EXPECT_FALSE(ParamOf(c.stiffness).is_scalar);
  const double w = 2 * std::numbers::pi * 100;
  EXPECT_NEAR(c.stiffness(0, 0), mx * w * w, 1e-9 * mx * w * w);
  EXPECT_NEAR(c.stiffness(1, 1), my * w * w, 1e-9 * my * w * w);
  EXPECT_NEAR(c.damping(1, 1), 2 * 0.7 * w * my, 1e-9 * my * w);
  const RepairedText text = RepairModelText(lm.text, lm.file, r, {});
  EXPECT_THAT(text.text, HasSubstr("m2_K: {type: C, stiffness: " + ParamYaml(c.stiffness) + "}"));
  EXPECT_EQ(ParamYaml(c.stiffness).front(), '[');  // a diagonal: a list
  EXPECT_EQ(CheckText(text.text), text.states);
}

TEST(SuggestCouplings, AnIntegrallyCausalModelNeedsNothing) {
  const LoadedModel lm = LoadModelFile(testing::ExamplePath("compliant_gear_pair.yaml"));
  const RepairResult r = Suggest(lm);
  EXPECT_TRUE(r.couplings.empty());
  EXPECT_TRUE(r.integral);
  EXPECT_THROW(RepairModelText(lm.text, lm.file, r, {}), std::runtime_error);
}

// Two masses locked together by an Sf marked `constraint` (an ideal constraint the compiler solves
// for its reaction, an effort source of unknown effort), the first pushed.
const char* kRigidLink = R"(
model: rigid_link
domain: translation
elements:
  push: {type: Se, effort: 1.0}
  v1:   {type: "1"}
  m1:   {type: I, inertia: 1.0}
  link: {type: "0"}
  rel:  {type: "1"}
  lock: {type: Sf, flow: 0.0, constraint: true}
  v2:   {type: "1"}
  m2:   {type: I, inertia: 2.0}
bonds: [push -> v1, v1 -> m1, v1 -> link, link -> rel, lock -> rel, link -> v2, v2 -> m2]
)";

TEST(SuggestCouplings, AnExplicitIdealConstraintIsNotDerivativeCausality) {
  // The compiler solves an Sf marked `constraint` for its reaction (an effort source of unknown
  // effort): the two masses it locks together are both independent, nothing to repair.
  const LoadedModel lm = LoadModelString(kRigidLink);
  EXPECT_EQ(CausalView(lm.graph).element(lm.graph.Find("lock")).kind, ElementKind::kSe);
  const RepairResult r = Suggest(lm);
  EXPECT_TRUE(r.couplings.empty());
  EXPECT_TRUE(r.integral);
  EXPECT_FALSE(r.causality.has_errors());
  EXPECT_EQ(r.repaired.element(r.repaired.Find("lock")).kind, ElementKind::kSf);  // the graph itself is unchanged
}

TEST(InCausalView, IsTheCausalViewInPlaceForItsScopeAndRestoresTheGraphAfter) {
  // `check` analyses the graph in place rather than through a copy. The Sf 'lock' is a constraint.
  LoadedModel lm = LoadModelString(kRigidLink);
  const BondGraph copy = CausalView(lm.graph);
  std::vector<ElementKind> before;
  for (const Element& e : lm.graph.elements()) before.push_back(e.kind);
  int turned = 0;
  for (int i = 0; i < lm.graph.num_elements(); ++i) turned += before[i] != copy.element(i).kind;
  ASSERT_EQ(turned, 1);  // 'lock'
  EXPECT_EQ(lm.graph.element(lm.graph.Find("lock")).kind, ElementKind::kSf);
  {
    const InCausalView view(lm.graph);
    EXPECT_EQ(&view.graph(), &lm.graph);
    for (int i = 0; i < lm.graph.num_elements(); ++i) EXPECT_EQ(view.graph().element(i).kind, copy.element(i).kind) << i;
    DiagnosticSink a, b;
    const Structure sv = AnalyzeStructure(view.graph(), lm.compile.default_domain, a);
    const Structure sc = AnalyzeStructure(copy, lm.compile.default_domain, b);
    EXPECT_EQ(AssignCausality(view.graph(), sv).stroke_at_head, AssignCausality(copy, sc).stroke_at_head);
  }
  for (int i = 0; i < lm.graph.num_elements(); ++i) EXPECT_EQ(lm.graph.element(i).kind, before[i]) << i;
  // Restored also when the scope is left by an exception (AnalyzeStructure's ThrowIfErrors).
  try {
    const InCausalView view(lm.graph);
    throw ModelError(Diagnostic{});
  } catch (const ModelError&) {
  }
  for (int i = 0; i < lm.graph.num_elements(); ++i) EXPECT_EQ(lm.graph.element(i).kind, before[i]) << i;
}

TEST(SuggestCouplings, ACompliancesDerivativeCausalityIsReportedNotRepaired) {
  const LoadedModel lm = LoadModelString(R"(
model: two_capacitors
domain: electrical
elements:
  V:  {type: Se, effort: 1.0}
  n:  {type: "0"}
  C1: {type: C, compliance: 1.0e-3}
  C2: {type: C, compliance: 2.0e-3}
bonds: [V -> n, n -> C1, n -> C2]
)");
  const RepairResult r = Suggest(lm);
  EXPECT_TRUE(r.couplings.empty());
  EXPECT_FALSE(r.integral);
  ASSERT_FALSE(r.not_repaired.empty());
  EXPECT_THAT(r.not_repaired.front(), HasSubstr("dual repair"));
}

TEST(RepairModelText, KeepsTheFileAndReplacesTheBondInItsPlace) {
  const LoadedModel lm = LoadModelFile(testing::ExamplePath("rigid_gear_pair.yaml"));
  const RepairResult r = Suggest(lm);
  const RepairedText out = RepairModelText(lm.text, lm.file, r, {});
  EXPECT_EQ(out.states, 5);
  EXPECT_EQ(CheckText(out.text), 5);
  // Every line of the original is still there but the replaced bond.
  std::istringstream in(lm.text);
  for (std::string line; std::getline(in, line);) {
    if (line == "  - j2 -> J2") continue;
    EXPECT_THAT(out.text, HasSubstr(line));
  }
  EXPECT_THAT(out.text, Not(HasSubstr("  - j2 -> J2\n")));
  EXPECT_THAT(out.text, HasSubstr("  - j2 -> J2_coupling\n  - J2_coupling -> J2\n  - J2_coupling -> J2_deflection\n"
                                  "  - J2_deflection -> J2_K\n  - J2_deflection -> J2_R\n"));
  EXPECT_THAT(out.text, HasSubstr("  J2_K: {type: C, stiffness: 7895.68"));
  EXPECT_THAT(out.text, HasSubstr("# Repaired by 'multibond check --suggest --write'"));
  // The bond comes in its place: the new elements follow J2 in the elements mapping.
  EXPECT_LT(out.text.find("J2:     {type: I"), out.text.find("J2_coupling: {type: \"0\"}"));
  EXPECT_LT(out.text.find("J2_coupling: {type: \"0\"}"), out.text.find("bonds:"));
}

TEST(RepairModelText, FlowStyleMapBondsAndWindowsLineEndsAreEdited) {
  const std::string text =
      "model: styles\r\ndomain: translation\r\n"
      "elements: {s: {type: Se, effort: 1.0}, j: {type: \"1\"}, a: {type: I, inertia: 1.0}, b: {type: I, inertia: 2.0}}\r\n"
      "bonds:\r\n  - s -> j\r\n  - [j, a]\r\n  - {from: j, to: b, name: tyre, dim: 1}   # a comment\r\n"
      "outputs: [tyre.f]\r\n";
  const LoadedModel lm = LoadModelString(text, "styles.yaml");
  const RepairResult r = Suggest(lm);
  ASSERT_EQ(r.couplings.size(), 1u);
  EXPECT_EQ(r.couplings[0].storage, "b");
  const RepairedText out = RepairModelText(text, "styles.yaml", r, {});
  EXPECT_THAT(out.text, HasSubstr("  - {from: j, to: b_coupling, dim: 1}   # a comment\r\n  - {from: b_coupling, to: b, name: tyre, dim: 1}\r\n"));
  EXPECT_THAT(out.text, HasSubstr(", b_coupling: {type: \"0\"}, b_deflection: {type: \"1\"}, b_K: {type: C, stiffness: "));
  EXPECT_THAT(out.text, Not(HasSubstr("\n\n")));  // no bare line feed in a CRLF file
  for (size_t k = out.text.find('\n'); k != std::string::npos; k = out.text.find('\n', k + 1)) EXPECT_EQ(out.text[k - 1], '\r');
  EXPECT_EQ(CheckText(out.text), out.states);
}

TEST(RepairModelText, ABondInsideASubmodelDefinitionIsNotEditedButSaidSo) {
  const std::string text = R"(
model: inner
domain: rotation
submodels:
  pair:
    ports: [j1]
    elements:
      j1: {type: "1"}
      J1: {type: I, inertia: 1.0}
      g:  {type: TF, ratio: 2.0}
      j2: {type: "1"}
      J2: {type: I, inertia: 1.0}
    bonds: [j1 -> J1, j1 -> g, g -> j2, j2 -> J2]
elements:
  drive: {type: Se, effort: 1.0}
  p:     {type: pair}
bonds: [drive -> p.j1]
)";
  const LoadedModel lm = LoadModelString(text, "inner.yaml");
  const RepairResult r = Suggest(lm);
  ASSERT_EQ(r.couplings.size(), 1u);
  EXPECT_EQ(r.couplings[0].storage, "p.J2");
  EXPECT_EQ(r.couplings[0].zero, "p_J2_coupling");  // no dot: it would read as a part of instance 'p'
  EXPECT_TRUE(r.integral);
  try {
    RepairModelText(text, "inner.yaml", r, {});
    ADD_FAILURE() << "expected an error";
  } catch (const std::runtime_error& e) {
    EXPECT_THAT(e.what(), HasSubstr("submodel definition"));
  }
}

}  // namespace
}  // namespace multibond
