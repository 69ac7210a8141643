// The linear analysis of the compliant differential (examples/differential.yaml, every
// coupling a stiff spring-damper: some 200 states): the exact Jacobians A, B, C, D at the initial
// state (linear::Linearize) and the modes with their energy participation (linear::ComputeModes),
// the work behind `multibond modes examples/differential.yaml`. The target: well under a second.
// Run: build/release/bench/multibond_bench --benchmark_filter=Linearize
//
// Measured on the shared 2-core development machine (ci preset, Release, with the benchmarks on):
// 15.1 ms per linearisation and modes (131 coordinates of 196 full states, 79 modes).

#include <string>
#include <vector>

#include <benchmark/benchmark.h>

#include "multibond/analysis/linearize.h"
#include "multibond/analysis/modes.h"
#include "multibond/io/model_loader.h"
#include "multibond/sim/simulator.h"

namespace mb = multibond;

namespace {

/// The model compiled once, outside the timing; each iteration linearises at the initial state
/// and computes the modes.
void BM_LinearizeDifferential(benchmark::State& state) {
  const mb::LoadedModel lm = mb::LoadModelFile(std::string(MULTIBOND_SOURCE_DIR) + "/examples/differential.yaml");
  const auto model = mb::CompiledModel::Compile(lm.graph, lm.compile);
  std::string why;
  if (!model->can_linearize(&why)) {
    state.SkipWithError(("cannot linearise: " + why).c_str());
    return;
  }
  const Eigen::VectorXd x = model->MakeInitialState();
  size_t modes = 0, states = 0;
  for (auto _ : state) {
    const mb::linear::LinearModel linear = mb::linear::Linearize(*model, 0.0, x);
    const std::vector<mb::linear::Mode> m = mb::linear::ComputeModes(linear);
    benchmark::DoNotOptimize(m.data());
    modes = m.size();
    states = linear.states.size();
  }
  state.counters["states"] = static_cast<double>(states);
  state.counters["full_states"] = static_cast<double>(model->num_states());
  state.counters["modes"] = static_cast<double>(modes);
}
BENCHMARK(BM_LinearizeDifferential)->Unit(benchmark::kMillisecond);

}  // namespace
