// Loader benchmarks: BM_LoadMechanismChain/N, wall time to read a model file of N bodies joined by
// N revolute joints (tests/support/mechanism_chain.h) into a bond graph; BM_PrepareMechanismChain/N,
// the same then compiled with its output columns laid out. Every name is resolved
// through a hash index, so the time grows linearly with N (5,000 bodies: well under a second).
// Run: build/release/bench/multibond_bench --benchmark_filter=Load

#include <benchmark/benchmark.h>

#include "../tests/support/mechanism_chain.h"
#include "multibond/io/model_loader.h"
#include "multibond/sim/simulator.h"

namespace mb = multibond;

namespace {

void BM_LoadMechanismChain(benchmark::State& state) {
  const std::string text = mb::testing::MechanismChainText(static_cast<int>(state.range(0)));
  for (auto _ : state) {
    const mb::LoadedModel model = mb::LoadModelString(text, "chain.yaml");
    benchmark::DoNotOptimize(model.graph.num_elements());
  }
}
BENCHMARK(BM_LoadMechanismChain)->Arg(500)->Arg(1000)->Arg(5000)->Unit(benchmark::kMillisecond)->Iterations(1);

// What `multibond check` and `run` do before integrating: load, compile (no generated code) and
// lay out the output columns, each of which finds its variable by name (FindVariable). With a
// search over every state block per name this was quadratic: 35.6 s for 5,000 bodies through the
// CLI; with the index 1.8 s.
void BM_PrepareMechanismChain(benchmark::State& state) {
  const std::string text = mb::testing::MechanismChainText(static_cast<int>(state.range(0)));
  for (auto _ : state) {
    const mb::LoadedModel lm = mb::LoadModelString(text, "chain.yaml");
    const auto model = mb::CompiledModel::Compile(lm.graph, lm.compile);
    benchmark::DoNotOptimize(mb::MakeColumns(*model, false).size());
  }
}
BENCHMARK(BM_PrepareMechanismChain)->Arg(1000)->Arg(5000)->Unit(benchmark::kMillisecond)->Iterations(1);

}  // namespace
