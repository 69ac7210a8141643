#pragma once
/// \file
/// The ODE interface between a model and an integrator: dx/dt = f(t, x).

namespace multibond {

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
};

}  // namespace multibond
