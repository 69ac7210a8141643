// The structural Jacobian (CompiledModel::jacobian_pattern) against the numbers: a state
// derivative that does not depend on a state is computed by the very same operations on the very
// same inputs when that state moves, so its difference quotient is exactly zero. Every exactly
// nonzero quotient must therefore be inside the pattern, at any state.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "multibond/compile/compiled_model.h"
#include "multibond/io/model_loader.h"
#include "support/rotation_graph.h"

namespace multibond {
namespace {

std::shared_ptr<const CompiledModel> CompileExample(const std::string& name) {
  const LoadedModel lm = LoadModelFile(std::string(MULTIBOND_SOURCE_DIR) + "/examples/" + name);
  return CompiledModel::Compile(lm.graph, lm.compile);
}

/// The entries (row, column) whose difference quotient at x is nonzero.
std::vector<std::pair<int, int>> NumericNonzeros(const CompiledModel& m, const std::vector<double>& x, double t) {
  const int n = m.num_states();
  Workspace ws = m.MakeWorkspace();
  std::vector<double> f0(n), f1(n), y = x;
  m.CalcDerivatives(t, x.data(), f0.data(), ws);
  std::vector<std::pair<int, int>> out;
  for (int j = 0; j < n; ++j) {
    y[j] = x[j] + 1e-6 * (1.0 + std::abs(x[j]));
    m.CalcDerivatives(t, y.data(), f1.data(), ws);
    for (int i = 0; i < n; ++i)
      if (f1[i] != f0[i]) out.push_back({i, j});
    y[j] = x[j];
  }
  return out;
}

/// Checks the pattern at the initial state and at two perturbed ones (so that no dependence hides
/// behind a zero of the initial state: a spring at rest, a body at the identity orientation).
void ExpectPatternCoversTheNumbers(const CompiledModel* m, int* numeric_entries = nullptr) {
  const JacobianPattern* p = m->jacobian_pattern();
  ASSERT_NE(p, nullptr);
  const int n = m->num_states();
  ASSERT_EQ(p->n, n);
  for (int j = 0; j < n; ++j) EXPECT_TRUE(p->Contains(j, j)) << "diagonal " << j;
  const Eigen::VectorXd x0 = m->MakeInitialState();
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  int found = 0;
  for (int trial = 0; trial < 3; ++trial) {
    std::vector<double> x(x0.data(), x0.data() + n);
    if (trial > 0)
      for (double& v : x) v += 0.1 * u(rng) * (1.0 + std::abs(v));
    const auto nz = NumericNonzeros(*m, x, 0.3 * trial);
    found = std::max<int>(found, static_cast<int>(nz.size()));
    for (auto [i, j] : nz)
      EXPECT_TRUE(p->Contains(i, j)) << "d " << m->state_names()[i] << " / d " << m->state_names()[j]
                                     << " is nonzero but outside the pattern";
  }
  if (numeric_entries) *numeric_entries = found;
}

TEST(JacobianPattern, CoversEveryNonzeroOfTheExamples) {
  for (const char* e : {"mass_spring_damper.yaml", "mass_spring_damper_3d.yaml", "dc_motor.yaml", "rlc_circuit.yaml",
                        "compliant_gear_pair.yaml"}) {
    SCOPED_TRACE(e);
    ExpectPatternCoversTheNumbers(CompileExample(e).get());
  }
}

TEST(JacobianPattern, CoversRotationAndLeverKernels) {
  // Here R reaches the resistors' dissipation through the MTF kernels only (in the mechanisms it
  // also comes in through each body's rotated inertia).
  const auto m = CompiledModel::Compile(RotationGraph(SomeRotation(), Eigen::Vector3d(0.1, 0.0, 0.1)));
  int numeric = 0;
  ExpectPatternCoversTheNumbers(m.get(), &numeric);
  EXPECT_GE(numeric, 9 + 2 * 9);  // dR/dt on R, each dissipation on R
}

TEST(JacobianPattern, CoversTheDifferentialAndIsSparse) {
  // Orientations in MTFs and rotated inertias, lever arms, the energy account's quadratures.
  int numeric = 0;
  const auto m = CompileExample("differential.yaml");
  ExpectPatternCoversTheNumbers(m.get(), &numeric);
  const int n = m->num_states();
  const int nnz = m->jacobian_pattern()->nonzeros();
  EXPECT_LT(nnz, 0.15 * n * n);  // 196 states: about a tenth can be nonzero
  // Structural, so at least what the numbers show (3,381 at a state of the running model), and
  // not much more: an instruction's outputs are taken to depend on all its inputs.
  EXPECT_GE(nnz, numeric);
  EXPECT_LT(nnz, 1.5 * numeric);
}

TEST(JacobianPattern, GrowsLinearlyAlongAChain) {
  // N masses joined by springs and dampers: each derivative reaches its neighbours only.
  auto chain = [](int count) {
    BondGraph g("chain");
    g.AddSe("force", {{TimeFunction::Constant(1.0)}});
    for (int i = 0; i < count; ++i) {
      const std::string v = "v" + std::to_string(i), k = std::to_string(i);
      g.AddJunction(v, ElementKind::kOne);
      g.AddI("m" + k, Param::Scalar(1.0));
      g.Connect(v, "m" + k);
      if (i == 0) {
        g.Connect("force", v);
        continue;
      }
      g.AddJunction("n" + k, ElementKind::kZero);
      g.AddJunction("rel" + k, ElementKind::kOne);
      g.AddC("k" + k, Param::Scalar(10.0));
      g.AddR("c" + k, Param::Scalar(0.1));
      g.Connect("v" + std::to_string(i - 1), "n" + k);
      g.Connect("n" + k, v);
      g.Connect("n" + k, "rel" + k);
      g.Connect("rel" + k, "k" + k);
      g.Connect("rel" + k, "c" + k);
    }
    return CompiledModel::Compile(g);
  };
  const auto small = chain(10), large = chain(1000);
  const double per_state_small = double(small->jacobian_pattern()->nonzeros()) / small->num_states();
  const double per_state_large = double(large->jacobian_pattern()->nonzeros()) / large->num_states();
  EXPECT_LT(per_state_large, 4.0);
  EXPECT_NEAR(per_state_large, per_state_small, 0.5);
}

TEST(JacobianPattern, DenseWithIdealConstraintsButTheEnergyIntegrals) {
  // Each multiplier depends on every state that reaches its constraint, and feeds back into every
  // momentum it reaches: every column is full, but those of the energy account's integrals (the
  // constraints' and the drive's work), which nothing reads.
  const auto m = CompileExample("differential_ideal.yaml");
  ExpectPatternCoversTheNumbers(m.get());
  const JacobianPattern* p = m->jacobian_pattern();
  int alone = 0;
  for (int j = 0; j < p->n; ++j) {
    const int rows = p->col_start[j + 1] - p->col_start[j];
    const bool work = m->state_names()[j].ends_with(".work") || m->state_names()[j].ends_with(".dissipated");
    EXPECT_EQ(rows, work ? 1 : p->n) << m->state_names()[j];
    alone += rows == 1;
  }
  EXPECT_EQ(alone, 23);  // 21 constraints (16 rigid couplings, 5 meshes), the drive's source and its damper
}

}  // namespace
}  // namespace multibond
