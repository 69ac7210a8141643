// The paper's differential (issue 4): ns per right-hand side (plan interpreter and generated
// code) and the whole 0-5 s run at the example's default settings (dopri5, rtol 1e-8).
// Run: build/release/bench/multibond_bench --benchmark_filter=Differential

#include <benchmark/benchmark.h>

#include "multibond/io/model_loader.h"
#include "multibond/sim/simulator.h"

namespace mb = multibond;

namespace {

std::shared_ptr<const mb::CompiledModel> Differential(bool generate_code) {
  const mb::LoadedModel lm = mb::LoadModelFile(std::string(MULTIBOND_SOURCE_DIR) + "/examples/differential.yaml");
  mb::CompileOptions co = lm.compile;
  co.generate_code = generate_code;
  return mb::CompiledModel::Compile(lm.graph, co);
}

/// range(0): 0 = interpreter, 1 = generated code; range(1): 0 = the integrator's entry point
/// (CalcStateDerivatives: generated code keeps efforts and flows in registers), 1 = the one that
/// also fills the workspace (CalcDerivatives, used at output times).
void BM_DifferentialRhs(benchmark::State& state) {
  const auto model = Differential(state.range(0) != 0);
  const bool fill = state.range(1) != 0;
  mb::Workspace ws = model->MakeWorkspace();
  Eigen::VectorXd x = model->MakeInitialState(), xdot(x.size());
  for (int i = 0; i < x.size(); ++i) x[i] += 1e-6 * (i % 5);
  double t = 0.0;
  for (auto _ : state) {
    if (fill) model->CalcDerivatives(t, x.data(), xdot.data(), ws);
    else model->CalcStateDerivatives(t, x.data(), xdot.data(), ws);
    benchmark::DoNotOptimize(xdot.data());
    t += 1e-9;
  }
  state.SetLabel(std::string(model->uses_generated_code() ? "generated code" : "interpreter") +
                 (fill ? ", filling the workspace" : ", integrator entry"));
  state.counters["states"] = static_cast<double>(model->num_states());
}
BENCHMARK(BM_DifferentialRhs)->Args({0, 0})->Args({1, 0})->Args({1, 1});

void BM_DifferentialRun(benchmark::State& state) {
  const auto model = Differential(true);
  mb::RunOptions o;
  o.t_end = 5.0;
  o.dt = 1e-3;
  o.integrator.method = mb::Method::kDormandPrince;
  o.integrator.rtol = 1e-8;
  o.integrator.atol = 1e-10;
  mb::RunSummary s;
  for (auto _ : state) {
    mb::NullObserver obs;
    s = mb::Simulate(*model, o, obs);
  }
  state.counters["steps"] = static_cast<double>(s.stats.steps);
  state.counters["rhs_evals"] = static_cast<double>(s.stats.rhs_evals);
  state.counters["energy_residual"] = s.energy_residual;
}
BENCHMARK(BM_DifferentialRun)->Unit(benchmark::kMillisecond)->Iterations(3);

}  // namespace
