#pragma once
/// \file
/// A SUNDIALS direct linear solver on a dense matrix, factorised by Eigen's blocked, vectorised
/// LU with partial pivoting. Internal to solve/ (it includes SUNDIALS headers).

#include <sundials/sundials_context.h>
#include <sundials/sundials_linearsolver.h>

namespace multibond::sun {

/// For CVODE's Newton iteration on a SUNDenseMatrix of size n. Why not SUNDIALS' own
/// SUNLinSol_Dense: its LU is an unblocked column loop; on the ideal differential (150 states)
/// its factorisations and solves were 53% of a BDF run (perf). Debian's SUNDIALS has no LAPACK
/// solver. The matrix is column-major in both libraries, so it is read in place.
/// Returns null if out of memory. Freed by SUNLinSolFree.
SUNLinearSolver MakeEigenDenseSolver(long n, SUNContext ctx);

}  // namespace multibond::sun
