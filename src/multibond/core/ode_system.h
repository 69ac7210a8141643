#pragma once
/// \file
/// The ODE interface between a model and an integrator: dx/dt = f(t, x).

#include <algorithm>
#include <vector>

namespace multibond {

/// Which entries of the Jacobian df/dx can be nonzero, column by column (compressed sparse
/// column): the rows of column j are row_index[col_start[j] .. col_start[j + 1]), ascending. The
/// diagonal is always included (implicit integrators factorise I - gamma J).
struct JacobianPattern {
  int n = 0;
  std::vector<int> col_start;  ///< n + 1 entries
  std::vector<int> row_index;
  int nonzeros() const { return static_cast<int>(row_index.size()); }
  bool Contains(int row, int col) const {
    return std::binary_search(row_index.begin() + col_start[col], row_index.begin() + col_start[col + 1], row);
  }
};

class OdeSystem {
 public:
  virtual ~OdeSystem() = default;
  virtual int num_states() const = 0;
  /// Computes xdot = f(t, x). x and xdot have num_states() entries. Must not allocate.
  virtual void CalcDerivatives(double t, const double* x, double* xdot) = 0;
  /// True if the exact solution stays on a manifold that Project() can restore (for example
  /// orientation matrices, which stay orthonormal). Integrators then project after each step.
  virtual bool has_invariants() const { return false; }
  /// Moves x (num_states() entries), the state at time t, onto that manifold, in place (the
  /// manifold may move with t: ideal constraints on prescribed flows). Must not allocate.
  virtual void Project(double /*t*/, double* /*x*/) {}
  /// The structure of df/dx if the system knows it (null: unknown, treat as dense). Implicit
  /// integrators then estimate the Jacobian with one evaluation of f per group of columns that
  /// share no row, and factorise it as a sparse matrix.
  virtual const JacobianPattern* jacobian_pattern() const { return nullptr; }
  /// Event functions (docs/events.md): the integrator stops where one of them crosses zero
  /// (downwards, from > 0 to <= 0, unless RootDirections says either way), located to its time
  /// tolerance on the step's interpolant.
  virtual int num_roots() const { return 0; }
  /// The num_roots() event functions at (t, x) into g. Must not allocate.
  virtual void CalcRoots(double /*t*/, const double* /*x*/, double* /*g*/) {}
  /// Which crossings of each event function are events (num_roots() entries): -1 from > 0 to
  /// <= 0 only (the default), 0 either way (a formula's switching function, whose branch changes
  /// at a crossing in either direction).
  virtual void RootDirections(int* direction) const { std::fill(direction, direction + num_roots(), -1); }
};

}  // namespace multibond
