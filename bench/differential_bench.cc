// The paper's differential: ns per right-hand side (plan interpreter and generated
// code) and the whole 0-5 s run, at the example's settings (examples/differential.yaml:
// srk3, rtol 1e-8, atol 1e-10) and with Dormand-Prince at the same tolerances for comparison.
// Run: build/release/bench/multibond_bench --benchmark_filter=Differential
//
// Measured on the 2-core development machine (AMD EPYC, shared with other builds: medians of
// 7 interleaved runs; generated code compiled by GCC 12). Sessions 2-10, then session 11 (a
// slower day of the VM: the RK4 reference loop took 438-608 ms):
//
//                                              before (dopri5)        bs3 (session 2)        srk3 (session 11)
//   right-hand side, integrator entry          213 ns                 172 ns (best 153)      235-245 ns
//   right-hand side, filling the workspace     391 ns                 255 ns                 367-381 ns
//   whole run, the example's settings          593 ms (dopri5)        272 ms                 164-225 ms
//     steps / right-hand sides / rejected      129,889 / 914,232 / 1  160,185 / 486,178 / 0  73,451 / 298,590 / 34
//     right-hand sides per step                7.04                   3.04 (5,125 projections) 4.07 (4,413)
//   BM_DifferentialRunVsReference median ratio                        0.58-0.75 (session 11) 0.36-0.39 (target 0.568)
//   whole run, dopri5 at the same tolerances                          352 ms (784,343 rhs, 6.04/step)
//   the CLI with 5,001 rows of CSV (wall)      0.84 s                 0.53 s

#include <algorithm>
#include <chrono>
#include <cmath>
#include <vector>

#include <benchmark/benchmark.h>

#include "built.h"
#include "multibond/io/model_loader.h"
#include "multibond/sim/simulator.h"

namespace mb = multibond;

namespace {

const std::string kModel = std::string(MULTIBOND_SOURCE_DIR) + "/examples/differential.yaml";

mb::bench::Built Differential(bool generate_code) {
  const mb::LoadedModel lm = mb::LoadModelFile(kModel);
  return mb::bench::Build(lm.graph, lm.compile, generate_code);
}

/// range(0): 0 = interpreter, 1 = generated code; range(1): 0 = the integrator's entry point
/// (CalcStateDerivatives: generated code keeps efforts and flows in registers), 1 = the one that
/// also fills the workspace (CalcDerivatives, used at output times).
void BM_DifferentialRhs(benchmark::State& state) {
  const mb::bench::Built built = Differential(state.range(0) != 0);
  const auto& model = built.model;
  const bool fill = state.range(1) != 0;
  mb::Workspace ws = built.MakeWorkspace();
  Eigen::VectorXd x = model->MakeInitialState(), xdot(x.size());
  for (int i = 0; i < x.size(); ++i) x[i] += 1e-6 * (i % 5);
  double t = 0.0;
  for (auto _ : state) {
    if (fill) model->CalcDerivatives(t, x.data(), xdot.data(), ws);
    else model->CalcStateDerivatives(t, x.data(), xdot.data(), ws);
    benchmark::DoNotOptimize(xdot.data());
    t += 1e-9;
  }
  state.SetLabel(std::string(built.generated() ? "generated code" : "interpreter") +
                 (fill ? ", filling the workspace" : ", integrator entry"));
  state.counters["states"] = static_cast<double>(model->num_states());
}
BENCHMARK(BM_DifferentialRhs)->Args({0, 0})->Args({1, 0})->Args({1, 1});

/// The example compiled to generated code, and its own run settings (solver, tolerances, times).
std::pair<std::shared_ptr<const mb::CompiledModel>, mb::RunOptions> ExampleRun() {
  const mb::LoadedModel lm = mb::LoadModelFile(kModel);
  const mb::bench::Built b = mb::bench::Build(lm.graph, lm.compile, true);
  mb::RunOptions o;
  o.code = b.code;
  o.t_end = *lm.simulation.t_end;
  o.dt = *lm.simulation.dt;
  o.integrator.method = mb::ParseMethod(*lm.simulation.solver);
  o.integrator.rtol = *lm.simulation.rtol;
  o.integrator.atol = *lm.simulation.atol;
  return {b.model, o};
}

/// The whole 0-5 s run without file output. range(0): 0 = the example's solver settings,
/// 1 = Dormand-Prince at the same tolerances.
void BM_DifferentialRun(benchmark::State& state) {
  const auto [model, example_options] = ExampleRun();
  if (!example_options.code->ready()) state.SkipWithError(("no generated code: " + example_options.code->engine()).c_str());
  mb::RunOptions o = example_options;
  if (state.range(0) != 0) o.integrator.method = mb::Method::kDormandPrince;
  mb::RunSummary s;
  for (auto _ : state) {
    mb::NullObserver obs;
    s = mb::Simulate(*model, o, obs);
  }
  state.SetLabel(std::string(mb::MethodName(o.integrator.method)) + (state.range(0) == 0 ? " (the example's)" : ""));
  state.counters["steps"] = static_cast<double>(s.stats.steps);
  state.counters["rhs_evals"] = static_cast<double>(s.stats.rhs_evals);
  state.counters["rhs_per_step"] = static_cast<double>(s.stats.rhs_evals) / static_cast<double>(s.stats.steps);
  state.counters["projections"] = static_cast<double>(s.stats.projections);
  state.counters["rejected"] = static_cast<double>(s.stats.error_test_failures);
  state.counters["us_per_step"] = 1e6 * s.wall_seconds / static_cast<double>(s.stats.steps);
  state.counters["energy_residual"] = s.energy_residual;
}
BENCHMARK(BM_DifferentialRun)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->Iterations(3);

/// The issue's yardstick on today's machine: "a hand-written fixed-step RK4 at h = 1e-5 takes
/// 0.44 s", against which the whole run's target is 0.25 s (a ratio of 0.568). The VM this runs
/// on changes speed by tens of percent within an hour, so the target is checked as that ratio:
/// each iteration times the yardstick (RK4 at h = 1e-5 as a plain loop over the generated
/// right-hand side, no integrator library, no output: 500,000 steps, 2,000,000 evaluations)
/// and then the example's run (as BM_DifferentialRun/0), back to back.
void BM_DifferentialRunVsReference(benchmark::State& state) {
  const auto [model, o] = ExampleRun();
  if (!o.code->ready()) state.SkipWithError(("no generated code: " + o.code->engine()).c_str());
  const int n = model->num_states();
  mb::Workspace ws = model->MakeWorkspace(o.code.get());
  Eigen::VectorXd x(n), y(n), k1(n), k2(n), k3(n), k4(n);
  using Clock = std::chrono::steady_clock;
  double ref_s = 0.0, run_s = 0.0, best_ratio = 1e300;
  std::vector<double> ratios;
  double check = 0.0;
  for (auto _ : state) {
    const auto t0 = Clock::now();
    x = model->MakeInitialState();
    const double h = 1e-5;
    const long steps = std::lround(o.t_end / h);
    for (long s = 0; s < steps; ++s) {
      const double t = static_cast<double>(s) * h;
      model->CalcStateDerivatives(t, x.data(), k1.data(), ws);
      for (int i = 0; i < n; ++i) y[i] = x[i] + 0.5 * h * k1[i];
      model->CalcStateDerivatives(t + 0.5 * h, y.data(), k2.data(), ws);
      for (int i = 0; i < n; ++i) y[i] = x[i] + 0.5 * h * k2[i];
      model->CalcStateDerivatives(t + 0.5 * h, y.data(), k3.data(), ws);
      for (int i = 0; i < n; ++i) y[i] = x[i] + h * k3[i];
      model->CalcStateDerivatives(t + h, y.data(), k4.data(), ws);
      for (int i = 0; i < n; ++i) x[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
    }
    benchmark::DoNotOptimize(x.data());
    check = x[0];
    const auto t1 = Clock::now();
    mb::NullObserver obs;
    const mb::RunSummary s = mb::Simulate(*model, o, obs);
    const auto t2 = Clock::now();
    const double ref = std::chrono::duration<double>(t1 - t0).count(), run = std::chrono::duration<double>(t2 - t1).count();
    ref_s += ref;
    run_s += run;
    best_ratio = std::min(best_ratio, run / ref);
    ratios.push_back(run / ref);
    benchmark::DoNotOptimize(s.energy_residual);
  }
  const double k = static_cast<double>(state.iterations());
  state.counters["reference_ms"] = 1e3 * ref_s / k;
  state.counters["run_ms"] = 1e3 * run_s / k;
  state.counters["ratio"] = run_s / ref_s;
  state.counters["best_ratio"] = best_ratio;
  std::sort(ratios.begin(), ratios.end());  // the middle pair: one slow moment of the VM moves it least
  state.counters["median_ratio"] = ratios.empty() ? 0.0 : ratios[ratios.size() / 2];
  state.counters["target_ratio"] = 0.25 / 0.44;
  state.counters["run_ms_at_0.44s_reference"] = 440.0 * run_s / ref_s;
  state.SetLabel(std::isfinite(check) ? "RK4 h=1e-5 loop, then the example's run" : "RK4 reference diverged");
}
BENCHMARK(BM_DifferentialRunVsReference)->Unit(benchmark::kMillisecond)->Iterations(5);

}  // namespace
