// Joint against inertial coordinates on rotating machinery: whole runs of a fast spinning top
// (examples/spinning_top.yaml, 0-10 s), a gyroscope in gimbals (examples/gyroscope.yaml,
// 0-10 s), MultiBondLib's GyroscopicEffect (examples/mechanisms/gyroscopic.yaml, 0-10 s), the
// compliant differential (examples/differential.yaml, 0-5 s) and the ideal one
// (examples/differential_ideal.yaml, 0-5 s), each compiled to generated code as the CLI does
// (--jit auto), at the file's tolerances and output interval, without file output. Reports
// wall time, steps, right-hand sides, re-charts and the energy residual.
// Run: build/release/bench/multibond_bench --benchmark_filter=JointCoordinates
//
// Measured (release build, CPU time, median of 3; docs/design.md, "Joint coordinates"):
//
//                                          inertial                    joint
//   spinning top, bdf, 10 s                106,804 steps, 156 ms       1,482 steps, 3.3 ms
//   gyroscope in gimbals, bdf, 10 s        32,358 steps, 162 ms        3,240 steps, 17 ms
//   MultiBondLib's gyroscopic, bdf, 10 s   58,155 steps, 87 ms         1,616 steps, 4.6 ms
//   ideal differential, 5 s                dopri5: 3,218 steps, 109 ms bdf: 256 steps, 47 ms
//                                          bdf: 4,174 steps, 148 ms    dopri5: 864 steps, 74 ms
//   compliant differential, srk3, 5 s      73,451 steps, 115 ms        77,209 steps, 317 ms
//   compliant differential, bdf, 5 s       27,649 steps, 334 ms        25,175 steps, 526 ms
//
// The compliant differential's steps are its couplings' (srk3 at the stability limit of the
// -7.5e4 /s modes, BDF resolving the 194 rad/s ones), in either coordinates; there the map costs
// (BM_DifferentialJointRhs: 0.69 us per evaluation in all, the map 0.57 us of it, against the
// generated right-hand side's 0.125 us) and nothing is gained.

#include <cmath>
#include <string>

#include <benchmark/benchmark.h>

#include "built.h"
#include "multibond/io/model_loader.h"
#include "multibond/sim/joint_coordinates.h"
#include "multibond/sim/simulator.h"

namespace mb = multibond;

namespace {

const char* const kModels[] = {"spinning_top.yaml", "gyroscope.yaml", "differential.yaml", "differential_ideal.yaml",
                               "mechanisms/gyroscopic.yaml"};

/// range(0): the model (kModels); range(1): 1 = joint coordinates, 0 = inertial; range(2): the
/// solver, 0 = the file's, 1 = bdf, 2 = dopri5.
void BM_JointCoordinatesRun(benchmark::State& state) {
  const std::string file = std::string(MULTIBOND_SOURCE_DIR) + "/examples/" + kModels[state.range(0)];
  const mb::LoadedModel lm = mb::LoadModelFile(file);
  const mb::bench::Built built = mb::bench::Build(lm.graph, lm.compile, true);
  const auto& model = built.model;
  if (!built.generated()) state.SkipWithError(("no generated code: " + built.engine()).c_str());
  mb::RunOptions o;
  o.code = built.code;
  o.t_end = lm.simulation.t_end.value_or(1.0);
  o.dt = lm.simulation.dt.value_or(1e-3);
  o.integrator.method = state.range(2) == 1   ? mb::Method::kBdf
                        : state.range(2) == 2 ? mb::Method::kDormandPrince
                                              : mb::ParseMethod(lm.simulation.solver.value_or("bdf"));
  o.integrator.rtol = lm.simulation.rtol.value_or(1e-8);
  o.integrator.atol = lm.simulation.atol.value_or(1e-10);
  if (state.range(1) == 1) o.joint_coordinates = lm.mechanism->MakeJointTree();
  mb::RunSummary s;
  for (auto _ : state) {
    mb::NullObserver obs;
    s = mb::Simulate(*model, o, obs);
  }
  if (s.status != mb::RunStatus::kOk) state.SkipWithError(s.message.c_str());
  state.SetLabel(std::string(kModels[state.range(0)]) + " " + mb::MethodName(o.integrator.method) +
                 (state.range(1) == 1 ? " joint" : " inertial"));
  state.counters["steps"] = static_cast<double>(s.stats.steps);
  state.counters["rhs_evals"] = static_cast<double>(s.stats.rhs_evals);
  state.counters["recharts"] = static_cast<double>(s.recharts);
  state.counters["energy_residual"] = s.max_abs_energy_residual;
}
BENCHMARK(BM_JointCoordinatesRun)
    ->Args({0, 0, 0})->Args({0, 1, 0})  // the top, bdf (the file's)
    ->Args({1, 0, 0})->Args({1, 1, 0})  // the gyroscope, bdf (the file's)
    ->Args({2, 0, 0})->Args({2, 1, 0})  // the differential, srk3 (the file's)
    ->Args({2, 0, 1})->Args({2, 1, 1})  // the differential, bdf
    ->Args({3, 0, 2})->Args({3, 1, 0})  // the ideal differential: dopri5 inertial (its best), bdf joint (the file's)
    ->Args({3, 0, 1})->Args({3, 1, 2})  // the ideal differential, the other way round
    ->Args({4, 0, 0})->Args({4, 1, 0})  // MultiBondLib's gyroscopic example, bdf (the file's)
    ->Unit(benchmark::kMillisecond)->Iterations(1)->Repetitions(3)->ReportAggregatesOnly(false);

/// One right-hand side of the compliant differential in joint coordinates, at a state off the
/// start (every coordinate nudged, the planets turned): range(0) = 0 the whole evaluation (the
/// map to the model's state, its generated right-hand side, the map back), 1 the map to the
/// model's state alone (ToModel), 2 the model's right-hand side alone at that state.
void BM_DifferentialJointRhs(benchmark::State& state) {
  const mb::LoadedModel lm = mb::LoadModelFile(std::string(MULTIBOND_SOURCE_DIR) + "/examples/differential.yaml");
  const mb::bench::Built built = mb::bench::Build(lm.graph, lm.compile, true);
  const auto& model = built.model;
  if (!built.generated()) state.SkipWithError(("no generated code: " + built.engine()).c_str());
  mb::ModelSystem system(*model, nullptr, built.code.get());
  mb::JointCoordinateSystem jc(*model, lm.mechanism->MakeJointTree(), &system);
  Eigen::VectorXd x = model->MakeInitialState(), xdot(x.size());
  Eigen::VectorXd y(jc.num_states()), ydot(jc.num_states());
  jc.FromModel(x.data(), y.data());
  for (int i = 0; i < y.size(); ++i) y[i] += 1e-4 * std::sin(1.0 + i);
  jc.ToModel(y.data(), x.data());
  double t = 0.0;
  for (auto _ : state) {
    switch (state.range(0)) {
      case 0: jc.CalcDerivatives(t, y.data(), ydot.data()); break;
      case 1: jc.ToModel(y.data(), x.data()); break;
      default: system.CalcDerivatives(t, x.data(), xdot.data()); break;
    }
    benchmark::DoNotOptimize(ydot.data());
    benchmark::DoNotOptimize(x.data());
    benchmark::DoNotOptimize(xdot.data());
    t += 1e-9;
  }
  static const char* const kWhat[] = {"joint coordinates, whole", "the map to the model's state", "the model's right-hand side"};
  state.SetLabel(kWhat[state.range(0)]);
}
BENCHMARK(BM_DifferentialJointRhs)->Arg(0)->Arg(1)->Arg(2);

}  // namespace
