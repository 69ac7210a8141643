// Multiport storage from one energy function (compile/multiport_energy.cc): the efforts are the
// energy's gradient (against the closed form at a state), Maxwell's reciprocity holds (the
// cross derivatives agree), a state named by its full name is an own variable, and what is
// refused (an energy that reads time, one that a component does not enter) is a located
// law.energy; through the loader and the compiler, a C and an I of two components given by a
// quadratic energy run as the same elements given by their stiffness and inertia matrices, and
// a law of a vector bond is refused with the multiport's form as the hint.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "multibond/compile/compiled_model.h"
#include "multibond/compile/multiport_energy.h"
#include "multibond/compile/symbolic.h"
#include "multibond/io/model_loader.h"
#include "multibond/sim/simulator.h"
#include "support/load_errors.h"



namespace multibond {
namespace {

using ::testing::HasSubstr;
using testing::LoadErrors;

Element Multiport(const std::string& energy, ElementKind kind = ElementKind::kC) {
  Element e;
  e.name = "plates";
  e.kind = kind;
  e.dim = 2;
  const expr::ParseResult parsed = expr::Parse(energy);
  EXPECT_TRUE(parsed.root) << energy;
  e.energy.root = parsed.root;
  e.energy.text = energy;
  e.energy.where = SourceLocation{"m.yaml", 7, 20};
  return e;
}

double At(const expr::NodePtr& n, const std::map<std::string, double>& v) {
  return expr::Evaluate(*n, [&](const std::string& name) -> std::optional<double> {
    const auto it = v.find(name);
    return it == v.end() ? std::nullopt : std::optional<double>(it->second);
  });
}

const std::vector<std::string> kNames = {"a.q", "b.p", "c.q", "plates.q.charge", "plates.q.gap"};

TEST(MultiportEnergy, TheEffortsAreTheGradientAndTheCrossDerivativesAgree) {
  // The moving-plate capacitor with eps A = 0.25: voltage q x / (eps A), force q^2 / (2 eps A).
  const MultiportEnergy m = BuildMultiportEnergy(Multiport("q1^2*q2/(2*0.25)"), kNames, 3);
  ASSERT_EQ(m.gradient.size(), 2u);
  for (const auto& [q, x] : std::vector<std::pair<double, double>>{{0.3, 2.0}, {-1.5, 0.01}, {2.0, 7.0}}) {
    const std::map<std::string, double> v = {{"#x3", q}, {"#x4", x}};
    EXPECT_DOUBLE_EQ(At(m.energy, v), q * q * x / 0.5);
    EXPECT_DOUBLE_EQ(At(m.gradient[0], v), q * x / 0.25);
    EXPECT_DOUBLE_EQ(At(m.gradient[1], v), q * q / 0.5);
    // Maxwell: d e_q / dx = d e_x / dq (= q / (eps A)).
    const expr::NodePtr de_q_dx = expr::Differentiate(*m.gradient[0], "#x4"), de_x_dq = expr::Differentiate(*m.gradient[1], "#x3");
    EXPECT_DOUBLE_EQ(At(de_q_dx, v), q / 0.25);
    EXPECT_DOUBLE_EQ(At(de_x_dq, v), At(de_q_dx, v));
  }
}

TEST(MultiportEnergy, AStateByItsFullNameIsAnOwnVariable) {
  const MultiportEnergy m = BuildMultiportEnergy(Multiport("plates.q.charge^2/2 + 3*q1*plates.q.gap"), kNames, 3);
  const std::map<std::string, double> v = {{"#x3", 2.0}, {"#x4", 5.0}};
  EXPECT_DOUBLE_EQ(At(m.gradient[0], v), 2.0 + 15.0);
  EXPECT_DOUBLE_EQ(At(m.gradient[1], v), 6.0);
}

TEST(MultiportEnergy, AnIsFlowsAreTheGradientInItsMomenta) {
  const MultiportEnergy m = BuildMultiportEnergy(Multiport("(p1^2 + p1*p2 + p2^2)/2", ElementKind::kI), kNames, 0);
  const std::map<std::string, double> v = {{"#x0", 1.0}, {"#x1", 4.0}};
  EXPECT_DOUBLE_EQ(At(m.gradient[0], v), 1.0 + 2.0);
  EXPECT_DOUBLE_EQ(At(m.gradient[1], v), 0.5 + 4.0);
}

Diagnostic Refusal(const Element& e) {
  try {
    BuildMultiportEnergy(e, kNames, 3);
  } catch (const ModelError& err) {
    return err.diagnostics().front();
  }
  ADD_FAILURE() << "accepted " << e.energy.text;
  return {};
}

TEST(MultiportEnergy, AnEnergyThatReadsTimeOrAnotherStateIsRefusedAtTheName) {
  const Diagnostic d = Refusal(Multiport("q1^2*q2*(1 + t)"));
  EXPECT_EQ(d.code, "law.energy");
  EXPECT_EQ(d.element, "plates");
  EXPECT_THAT(d.message, HasSubstr("reads 't'"));
  EXPECT_EQ(d.where.line, 7);
  EXPECT_EQ(d.where.column, 20 + 13);  // at the t
  EXPECT_EQ(Refusal(Multiport("q1^2*q2 + a.q")).code, "law.energy");
}

TEST(MultiportEnergy, AComponentTheEnergyDoesNotEnterIsRefused) {
  const Diagnostic d = Refusal(Multiport("q1^2/2 + q2 - q2"));
  EXPECT_EQ(d.code, "law.energy");
  EXPECT_THAT(d.message, HasSubstr("is not a function of q2"));
}

// --- through the loader and the compiler ---

/// Two coupled mounts under a force, as a C of stiffness K and an I of inertia M (matrices), or
/// as a C and an I given by their energies q'Kq/2 and p'M^-1 p/2.
std::string Mounts(bool energies) {
  const std::string c = energies ? R"y(energy: "(3000*q1^2 - 2000*q1*q2 + 2000*q2^2)/2")y" : "stiffness: [[3000, -1000], [-1000, 2000]]";
  // M = [[2, 0.5], [0.5, 1]], M^-1 = [[1, -0.5], [-0.5, 2]] / 1.75.
  const std::string i = energies ? R"y(energy: "(p1^2 - p1*p2 + 2*p2^2)/(2*1.75)")y" : "inertia: [[2, 0.5], [0.5, 1]]";
  return R"(model: mounts
domain: translation
elements:
  load:    {type: Se, effort: [{ramp: {slope: 10.0}}, 0.0]}
  v:       {type: "1", dim: 2}
  plate:   {type: I, dim: 2, )" + i + R"(}
  mounts:  {type: C, dim: 2, )" + c + R"(, q0: [0.001, 0.0]}
  damping: {type: R, resistance: [[20.0, -5.0], [-5.0, 10.0]]}
bonds: [load -> v, v -> plate, v -> mounts, v -> damping]
)";
}

TEST(MultiportEnergy, QuadraticEnergiesRunAsTheirStiffnessAndInertiaMatrices) {
  RunOptions o;
  o.t_end = 0.5;
  o.dt = 0.01;
  o.integrator.rtol = 1e-11;
  o.integrator.atol = 1e-14;
  RecordingObserver matrices, energies;
  const LoadedModel a = LoadModelString(Mounts(false)), b = LoadModelString(Mounts(true));
  Simulate(*CompiledModel::Compile(a.graph, a.compile), o, matrices);
  Simulate(*CompiledModel::Compile(b.graph, b.compile), o, energies);
  ASSERT_EQ(matrices.summary().status, RunStatus::kOk);
  ASSERT_EQ(energies.summary().status, RunStatus::kOk);
  ASSERT_EQ(matrices.rows().size(), energies.rows().size());
  for (const char* column : {"plate.p.1", "plate.p.2", "mounts.q.1", "mounts.q.2", "energy.kinetic", "energy.potential", "energy.work"}) {
    SCOPED_TRACE(column);
    const int ia = matrices.Index(column), ib = energies.Index(column);
    double scale = 0.0;
    for (const auto& row : matrices.rows()) scale = std::max(scale, std::abs(row[ia]));
    ASSERT_GT(scale, 0.0);
    for (size_t k = 0; k < matrices.rows().size(); ++k)
      EXPECT_NEAR(energies.rows()[k][ib], matrices.rows()[k][ia], 1e-8 * scale) << "t = " << matrices.rows()[k][0];
  }
  // The relative residual of the energy balance (docs/model-format.md, "Output files").
  double residual = 0.0;
  for (const auto& row : energies.rows()) residual = std::max(residual, std::abs(row[energies.Index("energy.residual")]));
  EXPECT_LT(residual, 1e-9);
}

TEST(MultiportEnergy, ALawOfAVectorBondIsRefusedWithTheMultiportAsTheHint) {
  const auto errors = LoadErrors(R"y(model: m
elements:
  f: {type: Se, effort: [1, 0]}
  c: {type: C, dim: 2, effort: "q"}
bonds: [f -> c]
)y");
  ASSERT_EQ(errors.size(), 1u);
  EXPECT_EQ(errors[0].code, "structure.dimension");
  EXPECT_THAT(errors[0].hint, HasSubstr("energy: of q1 ... qn"));
}

TEST(MultiportEnergy, AnInitialValueOfTheWrongSizeIsLocated) {
  const LoadedModel lm = LoadModelString(R"y(model: m
elements:
  f: {type: Se, effort: [1, 0]}
  c: {type: C, dim: 2, energy: "q1^2 + q2^2", q0: [1, 2, 3]}
bonds: [f -> c]
)y",
                                         "m.yaml");
  try {
    CompiledModel::Compile(lm.graph, lm.compile);
    ADD_FAILURE() << "compiled";
  } catch (const ModelError& e) {
    ASSERT_EQ(e.diagnostics().size(), 1u);
    const Diagnostic& d = e.diagnostics().front();
    EXPECT_EQ(d.element, "c");
    EXPECT_EQ(d.where.line, 4);
    EXPECT_THAT(d.message, HasSubstr("initial value has 3 components, the bond 2"));
  }
}

// A vector bond whose components belong to different domains gives its states their units by
// `units:` (the electrostatic transducer's charge in C and gap in m; they were '-'); a list of
// the wrong length or a unit outside the grammar is refused where it is.
TEST(MultiportEnergy, UnitsNameTheUnitOfEachComponentsState) {
  const LoadedModel lm = LoadModelFile(std::string(MULTIBOND_SOURCE_DIR) + "/examples/equations/electrostatic_transducer.yaml");
  const auto model = CompiledModel::Compile(lm.graph, lm.compile);
  const auto& names = model->state_names();
  const auto at = [&](const std::string& n) { return model->state_units()[std::find(names.begin(), names.end(), n) - names.begin()]; };
  EXPECT_EQ(at("plates.q.charge"), "C");
  EXPECT_EQ(at("plates.q.gap"), "m");
  auto refusal = [](const std::string& units, const std::string& dim) {
    try {
      (void)LoadModelString("model: m\nelements:\n  c: {type: C, " + dim + "energy: \"q1^2 + q2^2\", units: " + units +
                            "}\n  z: {type: \"0\", dim: 2}\nbonds: [z -> c]\n");
    } catch (const ModelError& e) {
      return e.diagnostics().front().code + " " + e.diagnostics().front().message;
    }
    return std::string("loaded");
  };
  EXPECT_EQ(refusal("[C, m]", "dim: 2, "), "loaded");
  EXPECT_THAT(refusal("[C]", "dim: 2, "), ::testing::HasSubstr("param.shape 'units' has 1 entries for 2 components"));
  EXPECT_THAT(refusal("[C, furlong]", "dim: 2, "), ::testing::HasSubstr("unit.invalid the unit 'furlong' is refused"));
}

}  // namespace
}  // namespace multibond
