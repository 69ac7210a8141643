// The right-hand side allocates nothing (docs/design.md): counted by replacing the global
// operator new and (outside AddressSanitizer builds) malloc in this test binary. Covers the plan
// interpreter, generated code, the ideal constraints' solve and projection (with formulas that
// their equations read), and the solve of an algebraic loop.

#include <atomic>
#include <cstdlib>
#include <new>

#include <gtest/gtest.h>

#include "multibond/compile/generated_rhs.h"
#include "multibond/io/model_loader.h"
#include "multibond/sim/simulator.h"
#include "support/counting_new.h"

using multibond::testing::g_allocations;

// Eigen allocates its dynamic matrices with std::malloc, not operator new: count malloc too, by
// interposing glibc's (which exports the real ones as __libc_*). Not under AddressSanitizer, which
// interposes malloc itself.
#if !defined(__SANITIZE_ADDRESS__)
extern "C" {
void* __libc_malloc(std::size_t);
void* __libc_calloc(std::size_t, std::size_t);
void* __libc_realloc(void*, std::size_t);
void __libc_free(void*);
void* malloc(std::size_t n) {
  ++g_allocations;
  return __libc_malloc(n);
}
void* calloc(std::size_t count, std::size_t n) {
  ++g_allocations;
  return __libc_calloc(count, n);
}
void* realloc(void* p, std::size_t n) {
  ++g_allocations;
  return __libc_realloc(p, n);
}
void free(void* p) { __libc_free(p); }
}
#endif


namespace multibond {
namespace {

long AllocationsOfEvaluations(const std::string& example, bool generate_code, bool solve_loops = false) {
  const LoadedModel lm = LoadModelFile(std::string(MULTIBOND_SOURCE_DIR) + "/examples/" + example);
  CompileOptions co = lm.compile;
  co.solve_algebraic_loops = solve_loops;
  const auto model = CompiledModel::Compile(lm.graph, co);
  const auto code = generate_code ? GeneratedRhs::Start(model) : nullptr;
  if (generate_code && !code->ready()) {  // else this would measure the interpreter
    ADD_FAILURE() << code->engine();
    return -1;
  }
  Workspace ws = model->MakeWorkspace(code.get());
  Eigen::VectorXd x = model->MakeInitialState(), xdot(x.size());
  for (int i = 0; i < x.size(); ++i) x[i] += 1e-6 * (i % 5);
  const long before = g_allocations;
  for (int i = 0; i < 10; ++i) {
    model->CalcStateDerivatives(1e-3 * i, x.data(), xdot.data(), ws);
    model->CalcDerivatives(1e-3 * i, x.data(), xdot.data(), ws);
    model->Project(1e-3 * i, x.data(), ws);
  }
  return g_allocations - before;
}

TEST(RhsAllocation, CompliantDifferentialInterpreted) { EXPECT_EQ(AllocationsOfEvaluations("differential.yaml", false), 0); }
TEST(RhsAllocation, CompliantDifferentialGenerated) { EXPECT_EQ(AllocationsOfEvaluations("differential.yaml", true), 0); }
TEST(RhsAllocation, IdealDifferential) { EXPECT_EQ(AllocationsOfEvaluations("differential_ideal.yaml", false), 0); }
TEST(RhsAllocation, IdealDifferentialGenerated) { EXPECT_EQ(AllocationsOfEvaluations("differential_ideal.yaml", true), 0); }
TEST(RhsAllocation, SolvedAlgebraicLoop) { EXPECT_EQ(AllocationsOfEvaluations("algebraic_loop.yaml", false, true), 0); }
// Newton's method on a loop through a law (a diode in series) and one through a signal.
TEST(RhsAllocation, NonlinearAlgebraicLoops) {
  EXPECT_EQ(AllocationsOfEvaluations("equations/diode_charger.yaml", false, true), 0);
  EXPECT_EQ(AllocationsOfEvaluations("equations/diode_thermal.yaml", false, true), 0);
}
// A multiport storage element's gradient.
TEST(RhsAllocation, MultiportEnergy) {
  EXPECT_EQ(AllocationsOfEvaluations("equations/electrostatic_transducer.yaml", false), 0);
  EXPECT_EQ(AllocationsOfEvaluations("equations/electrostatic_transducer.yaml", true), 0);
}
// Formulas that ideal constraints read: their tangents in the solver's passes.
TEST(RhsAllocation, FormulasReachingIdealConstraints) {
  EXPECT_EQ(AllocationsOfEvaluations("equations/mtf_pendulum.yaml", false), 0);
  EXPECT_EQ(AllocationsOfEvaluations("equations/mtf_pendulum.yaml", true), 0);
}

}  // namespace
}  // namespace multibond
