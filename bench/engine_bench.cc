// Engine benchmarks (Google Benchmark):
//  - BM_ChainRhs/N: ns per right-hand-side evaluation of a chain of N mass-spring-dampers
//    (cost must grow linearly with N);
//  - BM_ChainCompile/N: causality + plan for the chain (N = 10,000 must take under 1 s);
//  - BM_ChainSimulate/N/J: wall time per simulated second (BDF, rtol 1e-6), with the dense
//    (J = 0) or the sparse (J = 1) Jacobian: dense costs N evaluations and an N^3 LU per
//    Jacobian, sparse a few evaluations (the chain's column groups) and KLU.
// Run: build/release/bench/multibond_bench  (or --benchmark_filter=Rhs)

#include <string>

#include <benchmark/benchmark.h>
#include <fmt/format.h>

#include "multibond/compile/compiled_model.h"
#include "multibond/sim/simulator.h"

namespace mb = multibond;

namespace {

/// N masses on 1-junctions; neighbours joined by a spring and a damper in parallel on their
/// relative velocity (a 0-junction and a 1-junction); a force step on the first mass.
mb::BondGraph MakeChain(int n) {
  mb::BondGraph g("chain");
  g.AddSe("force", {{mb::TimeFunction::Step(1.0)}});
  // Names by fmt::format: GCC 12's -Wrestrict misfires on "literal" + std::string temporaries.
  for (int i = 0; i < n; ++i) {
    const std::string v = fmt::format("v{}", i), m = fmt::format("m{}", i);
    g.AddJunction(v, mb::ElementKind::kOne);
    g.AddI(m, mb::Param::Scalar(1.0 + 0.01 * i));
    g.Connect(v, m);
    if (i == 0) g.Connect("force", v);
    if (i > 0) {
      const std::string node = fmt::format("n{}", i), rel = fmt::format("rel{}", i), k = fmt::format("k{}", i),
                        c = fmt::format("c{}", i);
      g.AddJunction(node, mb::ElementKind::kZero);
      g.AddJunction(rel, mb::ElementKind::kOne);
      g.AddC(k, mb::Param::Scalar(100.0));
      g.AddR(c, mb::Param::Scalar(0.5));
      g.Connect(fmt::format("v{}", i - 1), node);
      g.Connect(node, v);
      g.Connect(node, rel);
      g.Connect(rel, k);
      g.Connect(rel, c);
    }
  }
  return g;
}

void BM_ChainRhs(benchmark::State& state) {
  const auto model = mb::CompiledModel::Compile(MakeChain(static_cast<int>(state.range(0))));
  mb::Workspace ws = model->MakeWorkspace();
  Eigen::VectorXd x = model->MakeInitialState(), xdot(x.size());
  for (int i = 0; i < x.size(); ++i) x[i] = 1e-3 * (i % 7);
  double t = 0.0;
  for (auto _ : state) {
    model->CalcDerivatives(t, x.data(), xdot.data(), ws);
    benchmark::DoNotOptimize(xdot.data());
    t += 1e-9;
  }
  state.counters["states"] = static_cast<double>(model->num_states());
  state.counters["ns_per_state"] = benchmark::Counter(static_cast<double>(model->num_states()),
                                                      benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
  state.SetComplexityN(state.range(0));
}
BENCHMARK(BM_ChainRhs)->Arg(10)->Arg(100)->Arg(1000)->Arg(10000)->Complexity(benchmark::oN);

void BM_ChainCompile(benchmark::State& state) {
  const mb::BondGraph g = MakeChain(static_cast<int>(state.range(0)));
  for (auto _ : state) {
    auto model = mb::CompiledModel::Compile(g);
    benchmark::DoNotOptimize(model.get());
  }
  state.SetComplexityN(state.range(0));
}
BENCHMARK(BM_ChainCompile)->Arg(10)->Arg(100)->Arg(1000)->Arg(10000)->Unit(benchmark::kMillisecond)->Complexity();

void BM_ChainSimulate(benchmark::State& state) {
  const auto model = mb::CompiledModel::Compile(MakeChain(static_cast<int>(state.range(0))));
  mb::RunOptions o;
  o.t_end = 1.0;
  o.dt = 0.01;
  o.integrator.method = mb::Method::kBdf;
  o.integrator.rtol = 1e-6;
  o.integrator.atol = 1e-9;
  o.integrator.jacobian = state.range(1) ? mb::JacobianKind::kSparse : mb::JacobianKind::kDense;
  mb::IntegratorStats stats;
  for (auto _ : state) {
    mb::NullObserver obs;
    stats = mb::Simulate(*model, o, obs).stats;
  }
  state.counters["steps"] = static_cast<double>(stats.steps);
  state.counters["rhs_evals"] = static_cast<double>(stats.rhs_evals);
  state.counters["jac_evals"] = static_cast<double>(stats.jac_evals);
  state.counters["evals_per_jacobian"] = static_cast<double>(stats.evals_per_jacobian);
  state.SetLabel(std::string(state.range(1) ? "sparse" : "dense") + " Jacobian; wall time per simulated second");
}
BENCHMARK(BM_ChainSimulate)
    ->Args({10, 0})->Args({100, 0})->Args({100, 1})->Args({1000, 0})->Args({1000, 1})->Args({10000, 1})
    ->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
