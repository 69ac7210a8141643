#pragma once
/// \file
/// The linearisation of a compiled model about an operating point (docs/linear-analysis.md):
/// exact Jacobians, column by column, from the model's tangent pass (CompiledModel::CalcTangent),
/// in the coordinates of the state's manifold (linear_model.h), and a steady state found by
/// Newton's method (SUNDIALS KINSOL) with those Jacobians.

#include <string>

#include <Eigen/Dense>

#include "multibond/analysis/linear_model.h"
#include "multibond/sim/simulator.h"

namespace multibond::linear {

/// The linear model at (t, x). Inputs: every source component; outputs: the declared outputs.
/// With ideal constraints, in the independent coordinates of the constraint manifold. Throws
/// std::invalid_argument (with why) for what cannot be linearised yet (solved algebraic loops)
/// and for a state that is not finite.
LinearModel Linearize(const CompiledModel& model, double t, const Eigen::VectorXd& x);

/// A steady state near x_start at time t (the sources held at their values at t): dz/dt = 0 in
/// the manifold's coordinates (the energy account's integrals, which grow in any steady state
/// with dissipation, excluded), by KINSOL's Newton iteration with a line search and the exact
/// Jacobian. Throws std::runtime_error saying why when none is found.
Eigen::VectorXd FindSteadyState(const CompiledModel& model, double t, const Eigen::VectorXd& x_start);

/// The run that reaches an operating point at time `at` from `options`: its end time `at`, an
/// output interval no longer than it. Throws std::invalid_argument, naming the run's span, when
/// `at` is not within (t_start, t_end] (`what` names the option in the message: "--at").
RunOptions RunToOperatingPoint(const RunOptions& options, double at, const char* what);

/// Keeps the last sample of a run: the state at its end (the operating point), and its summary.
class FinalState : public Observer {
 public:
  void OnStart(const std::vector<Column>&) override {}
  void OnSample(const std::vector<double>& row) override { row_ = row; }
  void OnFinish(const RunSummary& s) override { summary_ = s; }
  /// The model's n states at the last sample (its columns: time, then the states).
  Eigen::VectorXd State(int n) const { return Eigen::Map<const Eigen::VectorXd>(row_.data() + 1, n); }
  const RunSummary& summary() const { return summary_; }

 private:
  std::vector<double> row_;
  RunSummary summary_;
};

}  // namespace multibond::linear
