// The Eigen-backed SUNDIALS linear solver that CVODE's Newton iteration uses.
#include "multibond/solve/eigen_linear_solver.h"

#include <gtest/gtest.h>

#include <array>

#include <nvector/nvector_serial.h>
#include <sunmatrix/sunmatrix_dense.h>

#include "multibond/solve/sundials_support.h"

namespace multibond::sun {
namespace {

struct Fixture {
  ContextPtr ctx = MakeContext();
  MatrixPtr a{NonNull(SUNDenseMatrix(3, 3, ctx.get()))};
  LinearSolverPtr solver{NonNull(MakeEigenDenseSolver(3, ctx.get()))};
  VectorPtr x = MakeVector(3, ctx.get()), b = MakeVector(3, ctx.get());
  void Set(const double (&rows)[3][3]) {
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) SM_ELEMENT_D(a.get(), i, j) = rows[i][j];
  }
};

TEST(EigenDenseSolver, SolvesWithPivotingAndReusesTheFactorisation) {
  Fixture f;
  EXPECT_EQ(SUNLinSolGetType(f.solver.get()), SUNLINEARSOLVER_DIRECT);
  // A zero in the first pivot position: needs a row exchange.
  f.Set({{0.0, 2.0, 1.0}, {1.0, 1.0, 0.0}, {3.0, 0.0, 4.0}});
  ASSERT_EQ(SUNLinSolSetup(f.solver.get(), f.a.get()), SUNLS_SUCCESS);
  // Two right-hand sides on one factorisation; x is checked by multiplying back.
  for (const auto& xs : {std::array<double, 3>{1.0, -2.0, 0.5}, std::array<double, 3>{-3.0, 0.25, 7.0}}) {
    double* bd = N_VGetArrayPointer(f.b.get());
    for (int i = 0; i < 3; ++i) {
      bd[i] = 0.0;
      for (int j = 0; j < 3; ++j) bd[i] += SM_ELEMENT_D(f.a.get(), i, j) * xs[j];
    }
    ASSERT_EQ(SUNLinSolSolve(f.solver.get(), f.a.get(), f.x.get(), f.b.get(), 0.0), SUNLS_SUCCESS);
    for (int i = 0; i < 3; ++i) EXPECT_NEAR(N_VGetArrayPointer(f.x.get())[i], xs[i], 1e-14);
  }
}

TEST(EigenDenseSolver, ASingularMatrixIsARecoverableFailure) {
  Fixture f;
  f.Set({{1.0, 2.0, 3.0}, {2.0, 4.0, 6.0}, {0.0, 0.0, 0.0}});
  const int flag = SUNLinSolSetup(f.solver.get(), f.a.get());
  EXPECT_EQ(flag, SUNLS_LUFACT_FAIL);
  EXPECT_GT(flag, 0) << "SUNDIALS treats positive flags as recoverable: CVODE retries with a smaller step";
  EXPECT_GT(SUNLinSolLastFlag(f.solver.get()), 0);
}

}  // namespace
}  // namespace multibond::sun
