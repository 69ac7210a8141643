#include "multibond/solve/eigen_linear_solver.h"

#include <new>
#include <vector>

#include <Eigen/Dense>
#include <nvector/nvector_serial.h>
#include <sunmatrix/sunmatrix_dense.h>

namespace multibond::sun {
namespace {

// Decoupled states: a state that no derivative depends on (a quadrature such as the work of a
// source, integrated for the energy account) has a column of I - gamma J that is zero but for its
// diagonal. The matrix is then [[A, 0], [C, D]] in the order (coupled, decoupled), D diagonal:
// A is factorised alone and the decoupled unknowns follow by substitution. In joint coordinates
// the ideal differential has 24 such states among 108 (the constraints' and the drive's work): a
// factorisation of 84 instead of 108 unknowns, half the operations. The columns are found at
// every setup, from exact zeros of the matrix (a difference quotient of a state that nothing
// reads is exactly zero), so nothing is assumed about the system.
struct Content {
  explicit Content(long n) : lu(n) { coupled.reserve(n), decoupled.reserve(n); }
  Eigen::PartialPivLU<Eigen::MatrixXd> lu;  // sized once for all states: compute() and solve() then allocate nothing
  std::vector<int> coupled, decoupled;      // state indices; decoupled empty: lu holds the whole matrix
  Eigen::MatrixXd reduced;                  // A (resized only when the number of coupled states changes)
  Eigen::PartialPivLU<Eigen::MatrixXd> reduced_lu;
  Eigen::VectorXd rhs;
  sunindextype last_flag = SUNLS_SUCCESS;
};

Content& Of(SUNLinearSolver s) { return *static_cast<Content*>(s->content); }

SUNLinearSolver_Type Type(SUNLinearSolver /*s*/) { return SUNLINEARSOLVER_DIRECT; }
SUNLinearSolver_ID Id(SUNLinearSolver /*s*/) { return SUNLINEARSOLVER_CUSTOM; }

int Setup(SUNLinearSolver s, SUNMatrix a) {
  Content& c = Of(s);
  const Eigen::Map<const Eigen::MatrixXd> m(SM_DATA_D(a), SM_ROWS_D(a), SM_COLUMNS_D(a));
  const Eigen::Index n = m.cols();
  c.coupled.clear();
  c.decoupled.clear();
  for (Eigen::Index j = 0; j < n; ++j) {
    bool alone = true;
    for (Eigen::Index i = 0; i < n && alone; ++i) alone = i == j || m(i, j) == 0.0;
    (alone ? c.decoupled : c.coupled).push_back(static_cast<int>(j));
  }
  c.last_flag = SUNLS_SUCCESS;
  for (const int j : c.decoupled)
    if (m(j, j) == 0.0) {
      c.last_flag = j + 1;
      return SUNLS_LUFACT_FAIL;
    }
  // Eigen does not stop at a zero pivot; SUNDIALS' dense LU reports it as a recoverable failure
  // (the integrator then retries with a smaller step), and so does this.
  auto zero_pivot = [&](const Eigen::PartialPivLU<Eigen::MatrixXd>& lu) {
    const auto& u = lu.matrixLU();
    for (Eigen::Index i = 0; i < u.rows(); ++i)
      if (u(i, i) == 0.0) {
        c.last_flag = i + 1;
        return true;
      }
    return false;
  };
  if (c.decoupled.empty()) {
    c.lu.compute(m);
    return zero_pivot(c.lu) ? SUNLS_LUFACT_FAIL : SUNLS_SUCCESS;
  }
  const Eigen::Index k = static_cast<Eigen::Index>(c.coupled.size());
  if (c.reduced.rows() != k) c.reduced.resize(k, k), c.rhs.resize(k);
  for (Eigen::Index q = 0; q < k; ++q)
    for (Eigen::Index p = 0; p < k; ++p) c.reduced(p, q) = m(c.coupled[p], c.coupled[q]);
  if (k > 0) c.reduced_lu.compute(c.reduced);
  return k > 0 && zero_pivot(c.reduced_lu) ? SUNLS_LUFACT_FAIL : SUNLS_SUCCESS;
}

int Solve(SUNLinearSolver s, SUNMatrix a, N_Vector x, N_Vector b, sunrealtype /*tol*/) {
  Content& c = Of(s);
  const sunindextype n = NV_LENGTH_S(b);
  Eigen::Map<Eigen::VectorXd> xm(NV_DATA_S(x), n);
  const Eigen::Map<const Eigen::VectorXd> bm(NV_DATA_S(b), n);
  c.last_flag = SUNLS_SUCCESS;
  if (c.decoupled.empty()) {
    xm.noalias() = c.lu.permutationP() * bm;  // then the triangular solves in place
    c.lu.matrixLU().triangularView<Eigen::UnitLower>().solveInPlace(xm);
    c.lu.matrixLU().triangularView<Eigen::Upper>().solveInPlace(xm);
    return SUNLS_SUCCESS;
  }
  const Eigen::Map<const Eigen::MatrixXd> m(SM_DATA_D(a), SM_ROWS_D(a), SM_COLUMNS_D(a));
  const Eigen::Index k = static_cast<Eigen::Index>(c.coupled.size());
  if (k > 0) {
    for (Eigen::Index p = 0; p < k; ++p) c.rhs[p] = bm[c.coupled[p]];
    c.rhs = c.reduced_lu.permutationP() * c.rhs;
    c.reduced_lu.matrixLU().triangularView<Eigen::UnitLower>().solveInPlace(c.rhs);
    c.reduced_lu.matrixLU().triangularView<Eigen::Upper>().solveInPlace(c.rhs);
  }
  // x and b may be the same vector: the decoupled rows read the coupled unknowns only.
  for (const int j : c.decoupled) {
    double v = bm[j];
    for (Eigen::Index p = 0; p < k; ++p) v -= m(j, c.coupled[p]) * c.rhs[p];
    xm[j] = v / m(j, j);
  }
  for (Eigen::Index p = 0; p < k; ++p) xm[c.coupled[p]] = c.rhs[p];
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
