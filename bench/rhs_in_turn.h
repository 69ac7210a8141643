#pragma once
// The benchmarks' loop over a constrained model's right-hand side at two states in turn, which
// differ in one state by `nudge`: an evaluation at the state of the one before would reuse its
// B and factor (ConstraintSolver::SolveAt), which an integrator's stages never do.

#include <string>

#include <benchmark/benchmark.h>

#include "multibond/compile/compiled_model.h"

namespace multibond::bench {

/// `code`: the model's generated code, null for the interpreter.
inline void RhsInTurn(benchmark::State& state, const CompiledModel& model, const std::string& variable, int component, double nudge,
                      const GeneratedRhs* code = nullptr) {
  Workspace ws = model.MakeWorkspace(code);
  Eigen::VectorXd xs[2] = {model.MakeInitialState(), model.MakeInitialState()};
  xs[1][model.FindVariable(variable)->offset + component] += nudge;
  Eigen::VectorXd xdot(xs[0].size());
  double t = 0.0;
  int k = 0;
  for (auto _ : state) {
    model.CalcStateDerivatives(t, xs[k].data(), xdot.data(), ws);
    benchmark::DoNotOptimize(xdot.data());
    t += 1e-9;
    k ^= 1;
  }
}

}  // namespace multibond::bench
