#pragma once
// The front end of `multibond run` as the fuzzer drives it (fuzz/model_loader_fuzzer.cc) and its
// regression test replays it (tests/io/fuzz_regression_test.cc): what apps/multibond/main.cc
// PrepareRun does before the output folder is touched and the integrator starts, on the model
// file's own simulation settings.
//
//   load (with the default InputLimits: file size, YAML nodes, depth, instances, elements, bonds)
//   -> structure and causality checks, compile (the interpreter: no generated code)
//   -> run options from the file's 'simulation' section (solver, tolerances, step, coordinates)
//   -> MakeColumns (the output layout) and CheckRunOptions (what Simulate would refuse)
//   -> one right-hand side at the initial state, for models small enough to do it quickly.
//
// A ModelError (a diagnosed bad model) is the expected answer to bad input and is thrown on; an
// std::invalid_argument from CheckRunOptions (the CLI's usage error, exit 64) is an expected
// answer too and is caught here. Anything else escaping is a bug.

#include <stdexcept>
#include <string>

#include <Eigen/Dense>

#include "multibond/io/model_loader.h"
#include "multibond/sim/simulator.h"

namespace multibond::fuzz {

inline void RunFrontEnd(const std::string& text, const std::string& file) {
  const LoadedModel lm = LoadModelString(text, file, InputLimits{});
  // As `run --jit off`: no generated code, no compiler started (RunOptions::code stays null).
  const auto model = CompiledModel::Compile(lm.graph, lm.compile);
  // The file's settings with the CLI's defaults (PrepareRun without command-line options).
  const SimulationDefaults& d = lm.simulation;
  RunOptions o;
  o.t_end = d.t_end.value_or(1.0);
  o.dt = d.dt.value_or(1e-3);
  o.integrator.method = ParseMethod(d.solver.value_or("bdf"));  // the loader has checked the name
  o.integrator.rtol = d.rtol.value_or(1e-8);
  o.integrator.atol = d.atol.value_or(1e-10);
  o.integrator.fixed_step = d.step.value_or(0.0);
  o.integrator.max_step = d.max_step.value_or(0.0);
  if (d.coordinates.value_or("inertial") == "joint" && lm.mechanism && !lm.mechanism->empty())
    o.joint_coordinates = lm.mechanism->MakeJointTree();
  (void)MakeColumns(*model, o.all_variables);  // a bad output is a model error
  try {
    CheckRunOptions(*model, o);
  } catch (const std::invalid_argument&) {
    return;  // options the run refuses: the CLI's exit 64
  }
  if (model->num_states() < 2000) {
    Workspace ws = model->MakeWorkspace();
    const Eigen::VectorXd x = model->MakeInitialState();
    Eigen::VectorXd xdot(x.size());
    model->CalcDerivatives(0.0, x.data(), xdot.data(), ws);
  }
}

}  // namespace multibond::fuzz
