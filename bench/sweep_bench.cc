// Sweep benchmarks: 1,000 short runs of the mass-spring-damper (k over a log grid, 1 s at
// 10 ms output, the interpreter) through the sweep's runner and thread pool.
//   BM_SweepThreads/T    the 1,000 runs on T threads: the speed-up and efficiency against T = 1
//   BM_SweepRunParts     one run's parts: loading the model text with the run's values, compiling
//                        the plan, simulating (counters load_us, compile_us, simulate_us)
//   BM_ParseModelYaml    the YAML parse alone, the part of `load` a loader that started from a
//                        parsed document would not repeat
// Under MPI the same runs: `mpirun -n N multibond sweep ...` (docs/sweeps.md has the figures).
// Run: build/release/bench/multibond_bench --benchmark_filter=Sweep

#include <benchmark/benchmark.h>
#include <yaml-cpp/yaml.h>

#include <filesystem>

#include "multibond/io/yaml_document.h"
#include "multibond/sweep/samples.h"
#include "multibond/sweep/sweep.h"

namespace mb = multibond;
namespace sw = multibond::sweep;

namespace {

const std::string kModel = std::string(MULTIBOND_SOURCE_DIR) + "/examples/sweeps/mass_spring_damper_model.yaml";

sw::Study ShortRuns(int runs) {
  sw::Study s;
  mb::DiagnosticSink sink;
  s.model = kModel;
  sw::AddAxisSpec(s, "--grid", "k=10:1000:log:" + std::to_string(runs), sink);
  sw::AddKeepSpec(s, "x_final=final:spring.q", sink);
  sw::AddKeepSpec(s, "x_max=max:spring.q", sink);
  return s;
}

mb::RunOptions Options() {
  mb::RunOptions o;
  o.t_end = 1.0;
  o.dt = 0.01;
  o.integrator.method = mb::ParseMethod("bdf");
  o.integrator.rtol = 1e-8;
  o.integrator.atol = 1e-10;
  return o;
}

void BM_SweepThreads(benchmark::State& state) {
  const sw::Study s = ShortRuns(1000);
  const std::string text = mb::ReadModelText(kModel, {});
  sw::Runner runner(s, text, {}, "off");
  runner.set_run_options(Options());
  const std::string dir = (std::filesystem::temp_directory_path() / "multibond-sweep-bench").string();
  sw::SweepOptions o;
  o.dir = dir;
  o.threads = static_cast<int>(state.range(0));
  for (auto _ : state) {
    const sw::SweepOutcome out = sw::RunSweep(s, runner, text, o, nullptr);
    benchmark::DoNotOptimize(out.facts.runs);
    state.counters["runs_per_s"] = benchmark::Counter(static_cast<double>(out.facts.runs) / out.facts.wall_seconds);
    state.counters["simulate_share"] = out.facts.timing.simulate / (out.facts.timing.load + out.facts.timing.compile + out.facts.timing.simulate);
  }
  std::filesystem::remove_all(dir);
}
BENCHMARK(BM_SweepThreads)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(3);

void BM_SweepRunParts(benchmark::State& state) {
  const sw::Study s = ShortRuns(20);
  const std::string text = mb::ReadModelText(kModel, {});
  sw::Runner runner(s, text, {}, "off");
  runner.set_run_options(Options());
  const auto ws = runner.NewWorkspace();
  const sw::RunTiming& t = ws->timing;
  const auto design = sw::Design(s);
  long i = 0;
  for (auto _ : state) {
    const sw::RunResult r = runner.Run(i % 20, design[i % 20], *ws, nullptr);
    benchmark::DoNotOptimize(r.values.data());
    ++i;
  }
  state.counters["load_us"] = 1e6 * t.load / static_cast<double>(t.runs);
  state.counters["compile_us"] = 1e6 * t.compile / static_cast<double>(t.runs);
  state.counters["simulate_us"] = 1e6 * t.simulate / static_cast<double>(t.runs);
}
BENCHMARK(BM_SweepRunParts)->Unit(benchmark::kMicrosecond);

void BM_ParseModelYaml(benchmark::State& state) {
  const std::string text = mb::ReadModelText(kModel, {});
  for (auto _ : state) benchmark::DoNotOptimize(YAML::Load(text).size());
}
BENCHMARK(BM_ParseModelYaml)->Unit(benchmark::kMicrosecond);

}  // namespace
