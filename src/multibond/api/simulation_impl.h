#pragma once
/// \file
/// What a Simulation holds (shared by model.cc, which starts one, and simulation.cc).

#include <memory>

#include <Eigen/Dense>

#include "multibond/compile/compiled_model.h"
#include "multibond/compile/generated_rhs.h"
#include "multibond/multibond.h"
#include "multibond/sim/simulator.h"
#include "multibond/solve/integrator.h"

namespace multibond {

struct Simulation::Impl {
  BondGraph graph;          ///< the model's graph with the inputs set so far
  BondGraph initial_graph;  ///< as started (Reset)
  CompileOptions compile;
  RunOptions options;
  std::shared_ptr<const CompiledModel> model;          ///< of `graph`
  std::shared_ptr<const CompiledModel> initial_model;  ///< of `initial_graph`
  std::shared_ptr<const GeneratedRhs> code, initial_code;  ///< their generated code, or null
  std::unique_ptr<ModelSystem> system;
  std::unique_ptr<Integrator> integrator;
  Eigen::VectorXd x, xdot;
  double t = 0.0;
  bool evaluated = false;  ///< the workspace holds every effort and flow at (t, x)

  /// Starts at options.t_start from the model's initial state (constraints satisfied).
  void Start(std::shared_ptr<const CompiledModel> compiled, std::shared_ptr<const GeneratedRhs> generated);
  /// A new integrator from (t, x): after a new model or state.
  void Restart();
  /// Fills the workspace at (t, x) if it is not.
  Workspace& Evaluate();
};

}  // namespace multibond
