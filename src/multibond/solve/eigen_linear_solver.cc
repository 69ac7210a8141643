#include "multibond/solve/eigen_linear_solver.h"

#include <new>

#include <Eigen/Dense>
#include <nvector/nvector_serial.h>
#include <sunmatrix/sunmatrix_dense.h>

namespace multibond::sun {
namespace {

struct Content {
  explicit Content(long n) : lu(n) {}
  Eigen::PartialPivLU<Eigen::MatrixXd> lu;  // sized once: compute() and solve() then allocate nothing
  sunindextype last_flag = SUNLS_SUCCESS;
};

Content& Of(SUNLinearSolver s) { return *static_cast<Content*>(s->content); }

SUNLinearSolver_Type Type(SUNLinearSolver /*s*/) { return SUNLINEARSOLVER_DIRECT; }
SUNLinearSolver_ID Id(SUNLinearSolver /*s*/) { return SUNLINEARSOLVER_CUSTOM; }

int Setup(SUNLinearSolver s, SUNMatrix a) {
  Content& c = Of(s);
  const Eigen::Map<const Eigen::MatrixXd> m(SM_DATA_D(a), SM_ROWS_D(a), SM_COLUMNS_D(a));
  c.lu.compute(m);
  // Eigen does not stop at a zero pivot; SUNDIALS' dense LU reports it as a recoverable failure
  // (the integrator then retries with a smaller step), and so does this.
  const auto& u = c.lu.matrixLU();
  c.last_flag = SUNLS_SUCCESS;
  for (Eigen::Index i = 0; i < u.rows(); ++i)
    if (u(i, i) == 0.0) {
      c.last_flag = i + 1;
      return SUNLS_LUFACT_FAIL;
    }
  return SUNLS_SUCCESS;
}

int Solve(SUNLinearSolver s, SUNMatrix /*a*/, N_Vector x, N_Vector b, sunrealtype /*tol*/) {
  Content& c = Of(s);
  const sunindextype n = NV_LENGTH_S(b);
  Eigen::Map<Eigen::VectorXd> xm(NV_DATA_S(x), n);
  const Eigen::Map<const Eigen::VectorXd> bm(NV_DATA_S(b), n);
  xm.noalias() = c.lu.permutationP() * bm;  // then the triangular solves in place
  c.lu.matrixLU().triangularView<Eigen::UnitLower>().solveInPlace(xm);
  c.lu.matrixLU().triangularView<Eigen::Upper>().solveInPlace(xm);
  c.last_flag = SUNLS_SUCCESS;
  return SUNLS_SUCCESS;
}

sunindextype LastFlag(SUNLinearSolver s) { return Of(s).last_flag; }

int Free(SUNLinearSolver s) {
  if (s == nullptr) return SUNLS_SUCCESS;
  delete static_cast<Content*>(s->content);
  s->content = nullptr;
  SUNLinSolFreeEmpty(s);
  return SUNLS_SUCCESS;
}

}  // namespace

SUNLinearSolver MakeEigenDenseSolver(long n, SUNContext ctx) {
  SUNLinearSolver s = SUNLinSolNewEmpty(ctx);
  if (s == nullptr) return nullptr;
  try {
    s->content = new Content(n);
  } catch (const std::bad_alloc&) {
    SUNLinSolFreeEmpty(s);
    return nullptr;
  }
  s->ops->gettype = Type;
  s->ops->getid = Id;
  s->ops->setup = Setup;
  s->ops->solve = Solve;
  s->ops->lastflag = LastFlag;
  s->ops->free = Free;
  return s;
}

}  // namespace multibond::sun
