// The ideal differential: examples/differential_ideal.yaml, every joint and mesh an
// ideal constraint, over 0-5 s. Reports wall time, steps, right-hand sides (each one solves for
// the 46 constraint efforts) and Jacobian evaluations, per solver and tolerance, and the cost of
// one right-hand side.
// Run: build/release/bench/multibond_bench --benchmark_filter=Ideal

#include <benchmark/benchmark.h>

#include "multibond/io/model_loader.h"
#include "built.h"
#include "rhs_in_turn.h"
#include "multibond/sim/joint_coordinates.h"
#include "multibond/sim/simulator.h"

namespace mb = multibond;

namespace {

mb::LoadedModel LoadIdeal() {
  return mb::LoadModelFile(std::string(MULTIBOND_SOURCE_DIR) + "/examples/differential_ideal.yaml");
}

mb::bench::Built IdealDifferential() {
  const mb::LoadedModel lm = LoadIdeal();
  return mb::bench::Build(lm.graph, lm.compile, true);  // as the CLI does (--jit auto)
}

void BM_IdealDifferentialRhs(benchmark::State& state) {
  const mb::bench::Built built = IdealDifferential();
  const auto& model = built.model;
  if (!built.generated()) state.SkipWithError(("no generated code: " + built.engine()).c_str());
  // Two states that differ in an orientation, in turn (rhs_in_turn.h).
  mb::bench::RhsInTurn(state, *model, "G.R", 1, 1e-9, built.code.get());
  state.counters["states"] = static_cast<double>(model->num_states());
  state.counters["multipliers"] = static_cast<double>(model->num_multipliers());
}
BENCHMARK(BM_IdealDifferentialRhs);

// The same right-hand side in joint coordinates (JointCoordinateSystem): the model's, plus the
// map from joint coordinates to the model's state and the derivatives back.
void BM_IdealDifferentialJointRhs(benchmark::State& state) {
  const mb::bench::Built built = IdealDifferential();
  const auto& model = built.model;
  if (!built.generated()) state.SkipWithError(("no generated code: " + built.engine()).c_str());
  mb::ModelSystem system(*model, nullptr, built.code.get());
  mb::JointCoordinateSystem jc(*model, LoadIdeal().mechanism->MakeJointTree(), &system);
  Eigen::VectorXd x = model->MakeInitialState();
  Eigen::VectorXd ys[2] = {Eigen::VectorXd(jc.num_states()), Eigen::VectorXd(jc.num_states())};
  jc.FromModel(x.data(), ys[0].data());
  ys[1] = ys[0];
  ys[1][2] += 1e-9;  // G's angle: a stage never evaluates at the state of the one before
  Eigen::VectorXd ydot(jc.num_states());
  double t = 0.0;
  int k = 0;
  for (auto _ : state) {
    jc.CalcDerivatives(t, ys[k].data(), ydot.data());
    benchmark::DoNotOptimize(ydot.data());
    t += 1e-9;
    k ^= 1;
  }
  state.counters["states"] = static_cast<double>(jc.num_states());
}
BENCHMARK(BM_IdealDifferentialJointRhs);

/// range(0): 0 = dopri5, 1 = bdf; range(1): -log10(rtol); range(2): 1 = joint coordinates (the
/// example's), 0 = inertial; range(3): output rows (5,000: the example's 1 ms; 1: t_end only,
/// the integration alone; each row evaluates the model with its reactions).
void BM_IdealDifferentialRun(benchmark::State& state) {
  const mb::bench::Built built = IdealDifferential();
  const auto& model = built.model;
  if (!built.generated()) state.SkipWithError(("no generated code: " + built.engine()).c_str());
  mb::RunOptions o;
  o.code = built.code;
  o.t_end = 5.0;
  o.dt = o.t_end / static_cast<double>(state.range(3));
  if (state.range(2) == 1) o.joint_coordinates = LoadIdeal().mechanism->MakeJointTree();
  o.integrator.method = state.range(0) == 0 ? mb::Method::kDormandPrince : mb::Method::kBdf;
  o.integrator.rtol = std::pow(10.0, -static_cast<double>(state.range(1)));
  o.integrator.atol = o.integrator.rtol * 1e-2;
  mb::RunSummary s;
  for (auto _ : state) {
    mb::NullObserver obs;
    s = mb::Simulate(*model, o, obs);
  }
  state.SetLabel(std::string(state.range(0) == 0 ? "dopri5" : "bdf") + (state.range(2) == 1 ? " joint" : " inertial") +
                 (state.range(3) == 1 ? " t_end only" : " 1 ms rows"));
  state.counters["steps"] = static_cast<double>(s.stats.steps);
  state.counters["rhs_evals"] = static_cast<double>(s.stats.rhs_evals);
  state.counters["jac_evals"] = static_cast<double>(s.stats.jac_evals);
  state.counters["energy_residual"] = s.energy_residual;
}
BENCHMARK(BM_IdealDifferentialRun)
    ->Args({0, 8, 1, 5000})->Args({0, 8, 1, 1})->Args({1, 8, 1, 5000})->Args({1, 8, 1, 1})
    ->Args({0, 10, 1, 5000})->Args({1, 10, 1, 5000})
    ->Args({0, 8, 0, 5000})->Args({0, 8, 0, 1})->Args({1, 8, 0, 5000})
    ->Unit(benchmark::kMillisecond)->Iterations(1);

}  // namespace
