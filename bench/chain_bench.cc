// The scaling benchmark (docs/scaling.md): the chain of bench/make_chain.py, N bodies on
// compliant or ideal (rigid) revolute joints, on the plan interpreter (no generated code, so that
// the figures do not include a compiler's time or its limits).
//   BM_ScalingChainRhs/N         one right-hand side of the compliant chain: the CPU time per
//                                state (per_state) should be flat
//   BM_ScalingRigidChainSolve/N  one right-hand side of the rigid chain at a new state: the
//                                constraint solve (B, W, its sparse L D L^T, the multipliers)
//                                each time; the CPU time per multiplier (per_multiplier) should be
//                                flat (the factor's order keeps a chain's W without fill-in)
// Run: build/release/bench/multibond_bench --benchmark_filter=Scaling

#include <benchmark/benchmark.h>

#include <stdlib.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "multibond/core/process.h"
#include "multibond/io/model_loader.h"
#include "multibond/sim/simulator.h"
#include "rhs_in_turn.h"

namespace mb = multibond;

namespace {

/// bench/make_chain.py's model text for n bodies: the script run with an argument vector (no
/// shell), its output in a private temporary folder.
std::string ChainText(int n, bool rigid) {
  char dir_template[] = "/tmp/multibond-chain-XXXXXX";
  const char* dir = mkdtemp(dir_template);
  if (!dir) throw std::runtime_error("cannot make a temporary folder");
  const std::string out = std::string(dir) + "/chain.yaml";
  std::vector<std::string> argv = {"python3", std::string(MULTIBOND_SOURCE_DIR) + "/bench/make_chain.py", std::to_string(n)};
  if (rigid) argv.push_back("--rigid");
  const std::string why = mb::RunProcess(argv, "", out, /*merge_stdout=*/true);
  std::ifstream in(out, std::ios::binary);
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  std::filesystem::remove_all(dir);
  if (!why.empty()) throw std::runtime_error("bench/make_chain.py: " + why);
  return text;
}

std::shared_ptr<const mb::CompiledModel> Chain(int n, bool rigid) {
  const mb::LoadedModel lm = mb::LoadModelString(ChainText(n, rigid), "chain.yaml");
  return mb::CompiledModel::Compile(lm.graph, lm.compile);  // the interpreter
}

void BM_ScalingChainRhs(benchmark::State& state) {
  const auto model = Chain(static_cast<int>(state.range(0)), false);
  mb::Workspace ws = model->MakeWorkspace();
  const Eigen::VectorXd x = model->MakeInitialState();
  Eigen::VectorXd xdot(x.size());
  double t = 0.0;
  for (auto _ : state) {
    model->CalcStateDerivatives(t, x.data(), xdot.data(), ws);
    benchmark::DoNotOptimize(xdot.data());
    t += 1e-9;
  }
  state.counters["states"] = static_cast<double>(model->num_states());
  state.counters["per_state"] = benchmark::Counter(static_cast<double>(model->num_states()),
                                                      benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}
BENCHMARK(BM_ScalingChainRhs)->RangeMultiplier(10)->Range(10, 10000)->Unit(benchmark::kMicrosecond);

void BM_ScalingRigidChainSolve(benchmark::State& state) {
  const auto model = Chain(static_cast<int>(state.range(0)), true);
  // Two states in turn, a momentum moved by a hair (rhs_in_turn.h): each evaluation forms B and
  // W and factorises W again, as an integrator's stages do.
  mb::bench::RhsInTurn(state, *model, "b0.p", 0, 1e-9);
  state.counters["multipliers"] = static_cast<double>(model->num_multipliers());
  state.counters["per_multiplier"] = benchmark::Counter(static_cast<double>(model->num_multipliers()),
                                                           benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}
BENCHMARK(BM_ScalingRigidChainSolve)->Arg(10)->Arg(30)->Arg(100)->Arg(300)->Arg(1000)->Unit(benchmark::kMicrosecond);

}  // namespace
