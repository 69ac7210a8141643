// Formulas in the right-hand side: BM_ChainRhs's chain of N masses made nonlinear. Neighbours are
// joined by a hardening spring (C, `effort: "k1*q + k3*q^3"`) and a quadratic damper (R,
// `effort: "c*f*abs(f)"`) on their relative velocity; a constant force pushes the first mass.
// Every spring and damper is a kExpr instruction of the plan (compile/formulas.cc).
//
//  - BM_FormulaChainRhs/N/E/A: ns per CalcStateDerivatives (the integrator's entry point), E = 0
//    the interpreter, 1 generated code, 2 the same equations written by hand (HandChain below);
//    A = 1 with the energy account (each damper's dissipation and the force's work integrated as
//    states, the library's default), 0 without.
//  - BM_FormulaChainRatio/N/A: the three timed in turn, in blocks, within each iteration (this
//    thread's CPU time); the medians' ratios generated/hand and interpreter/hand (the VM's speed
//    drifts by tens of percent within minutes, so a ratio is taken from interleaved blocks).
// Before timing, each benchmark checks that the model's derivative and the hand-written one agree
// to rounding at a state where every nonlinear term matters (else SkipWithError).
// Run: build/release/bench/multibond_bench --benchmark_filter=FormulaChain
//
// Measured on the 2-core development machine (AMD EPYC, -march=native, GCC 12; load average 7-10
// from other builds, so CPU time, not wall time; two runs). ns per right-hand side from
// BM_FormulaChainRhs; the ratios are BM_FormulaChainRatio's medians:
//
//                             interpreter     generated     by hand       generated/hand   interpreter/hand
//   N = 1000, no account      84,600-86,600   1,657-1,669   1,203-1,212   1.36-1.39        65-67
//   N = 1000, energy account  84,600-90,000   1,871-1,896   1,388-1,402   1.35-1.36        61-64
//   N = 100, no account        5,640-5,690      109           118-119     0.92             47-48
//
// The interpreter's columns are from before its denser instruction form and the inline copy of
// short programs; after them (same machine, CPU time, medians of six alternated runs): N = 1000
// 37,134 ns (36,096-38,745), interpreter/hand 31; N = 100 3,581 ns (3,554-3,688), 30.
//
// The generated code is one straight-line function: about 21 instructions and 96 bytes per mass,
// every value in a register, mb_pow(q, 3) folded to q*q*q, abs to an and-mask, no call. At N = 100
// (9 KB of code) it beats the loop; at N = 1000 (96 KB, beyond the 32 KB instruction cache and the
// op cache) the same instructions per mass cost 1.66 ns instead of 1.09: fetch and decode of code
// that runs once per call, against a 100-byte loop. The hand-written loop also gets two FMAs per
// mass (-ffp-contract=off in the generated code keeps the interpreter's bits); without them it
// takes 1.24-1.26 ns per mass and equals the model bit for bit.

#include <algorithm>
#include <cmath>
#include <ctime>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include <benchmark/benchmark.h>
#include <fmt/format.h>

#include "multibond/compile/compiled_model.h"
#include "multibond/compile/generated_rhs.h"
#include "multibond/core/expression.h"

namespace mb = multibond;

namespace {

constexpr double kForce = 1.0;

/// The chain's coefficients, varied along it so that no two elements are alike. Each is exact in
/// binary (whatever FMA contraction the compiler applies here), so the generated source, and the
/// JIT cache's key, are the same from build to build.
struct ChainCoefficients {
  std::vector<double> m, k1, k3, c;  // index i: mass i; spring and damper i join masses i-1 and i (i >= 1)
  explicit ChainCoefficients(int n) : m(n), k1(n), k3(n), c(n) {
    for (int i = 0; i < n; ++i) {
      m[i] = 1.0 + i / 128.0;
      k1[i] = 100.0 + i / 4.0;
      k3[i] = 1.0e4 + 3.0 * i;
      c[i] = 0.5 + i / 1024.0;
    }
  }
};

mb::Formula Parsed(const std::string& text) {
  const mb::expr::ParseResult r = mb::expr::Parse(text);
  if (r.error) throw std::runtime_error(text + ": " + r.error->message);
  return mb::Formula{text, r.root, mb::SourceLocation{}};
}

/// As engine_bench.cc's MakeChain, with the spring and damper given by formulas. Coefficients
/// are written with fmt's shortest round-trip form, so the parsed numbers are the very doubles.
mb::BondGraph MakeFormulaChain(const ChainCoefficients& k) {
  const int n = static_cast<int>(k.m.size());
  mb::BondGraph g("formula_chain");
  g.AddSe("force", {{mb::TimeFunction::Constant(kForce)}});
  for (int i = 0; i < n; ++i) {
    const std::string v = fmt::format("v{}", i), m = fmt::format("m{}", i);
    g.AddJunction(v, mb::ElementKind::kOne);
    g.AddI(m, mb::Param::Scalar(k.m[i]));
    g.Connect(v, m);
    if (i == 0) g.Connect("force", v);
    if (i > 0) {
      const std::string node = fmt::format("n{}", i), rel = fmt::format("rel{}", i);
      g.AddJunction(node, mb::ElementKind::kZero);
      g.AddJunction(rel, mb::ElementKind::kOne);
      mb::Element spring;
      spring.name = fmt::format("k{}", i);
      spring.kind = mb::ElementKind::kC;
      spring.law_effort = Parsed(fmt::format("{}*q + {}*q^3", k.k1[i], k.k3[i]));
      g.Add(spring);
      mb::Element damper;
      damper.name = fmt::format("c{}", i);
      damper.kind = mb::ElementKind::kR;
      damper.law_effort = Parsed(fmt::format("{}*f*abs(f)", k.c[i]));
      g.Add(damper);
      g.Connect(fmt::format("v{}", i - 1), node);
      g.Connect(node, v);
      g.Connect(node, rel);
      g.Connect(rel, spring.name);
      g.Connect(rel, damper.name);
    }
  }
  return g;
}

/// The same equations by hand: a plain loop over the chain. State: p[0..n) then q[1..n) (spring
/// i's displacement at n + i - 1), then, with the account, the dissipations [1..n) and the work.
/// Spring and damper i carry F_i = k1 q + k3 q^3 + c f |f| with f = v_{i-1} - v_i; mass i feels
/// F_i - F_{i+1} (F_0 = the force, F_n = 0). Velocities by the inverse masses, computed once (as
/// the plan does); compiled with the project's flags, so GCC may contract into FMAs, which the
/// generated code (-ffp-contract=off, to give the interpreter's bits) does not.
struct HandChain {
  int n;
  std::vector<double> inv_m, k1, k3, c;
  explicit HandChain(const ChainCoefficients& k)
      : n(static_cast<int>(k.m.size())), inv_m(k.m.size()), k1(k.k1), k3(k.k3), c(k.c) {
    for (int i = 0; i < n; ++i) inv_m[i] = 1.0 / k.m[i];
  }

  template <bool kAccount>
  void Rhs(const double* x, double* xdot) const {
    const double* p = x;
    const double* q = x + n;
    double* dp = xdot;
    double* dq = xdot + n;
    double* dd = xdot + 2 * n - 1;
    double v_prev = inv_m[0] * p[0];
    double f_prev = kForce;
    for (int i = 1; i < n; ++i) {
      const double v = inv_m[i] * p[i];
      const double f = v_prev - v;
      const double qi = q[i - 1];
      const double damper = c[i] * f * std::abs(f);
      const double force = k1[i] * qi + k3[i] * (qi * qi * qi) + damper;
      dp[i - 1] = f_prev - force;
      dq[i - 1] = f;
      if constexpr (kAccount) dd[i - 1] = damper * f;
      f_prev = force;
      v_prev = v;
    }
    dp[n - 1] = f_prev;
    if constexpr (kAccount) dd[n - 1] = kForce * (inv_m[0] * p[0]);
  }
  void Rhs(bool account, const double* x, double* xdot) const {
    if (account) Rhs<true>(x, xdot);
    else Rhs<false>(x, xdot);
  }
};

/// For each hand-written state, its index in the model's state.
std::vector<int> ModelIndexOfHandState(const mb::CompiledModel& model, int n, bool account) {
  std::vector<int> at;
  auto state = [&](const std::string& name) {
    const auto v = model.FindVariable(name);
    if (!v || v->in != mb::VariableRef::In::kState) throw std::runtime_error("no state " + name);
    at.push_back(v->offset);
  };
  for (int i = 0; i < n; ++i) state(fmt::format("m{}.p", i));
  for (int i = 1; i < n; ++i) state(fmt::format("k{}.q", i));
  if (account) {
    for (int i = 1; i < n; ++i) state(fmt::format("c{}.dissipated", i));
    state("force.work");
  }
  if (static_cast<int>(at.size()) != model.num_states()) throw std::runtime_error("the model has other states");
  return at;
}

/// A state where every term matters: springs stretched and compressed into their cubic range
/// (k3 q^2 / k1 from 0.8 to 2.3 at |q| = 0.15), relative velocities of both signs.
std::vector<double> HandState(int n, bool account) {
  std::vector<double> x(static_cast<size_t>(account ? 3 * n - 1 : 2 * n - 1), 0.0);
  for (int i = 0; i < n; ++i) x[i] = 0.7 * std::sin(0.37 * i) * (1.0 + 0.01 * i);
  for (int i = 1; i < n; ++i) x[n + i - 1] = 0.15 * std::cos(1.3 * i);
  return x;
}

struct Setup {
  std::shared_ptr<const mb::CompiledModel> model;
  std::shared_ptr<const mb::GeneratedRhs> code;  ///< null: the interpreter
  HandChain hand;
  std::vector<double> hand_x;
  Eigen::VectorXd model_x;
  double max_rel_diff = 0.0;  ///< max |model - hand| / max |hand| over the derivative's entries
  std::string error;
};

/// Compiles the chain (generated code or the interpreter), and checks once that the model's
/// derivative is the hand-written one at HandState.
Setup Prepare(int n, bool generated, bool account) {
  const ChainCoefficients k(n);
  mb::CompileOptions co;
  co.energy_account = account;
  Setup s{mb::CompiledModel::Compile(MakeFormulaChain(k), co), nullptr, HandChain(k), {}, {}, 0.0, {}};
  if (generated) {
    s.code = mb::GeneratedRhs::Start(s.model);
    if (!s.code->ready()) {
      s.error = "no generated code: " + s.code->engine();
      return s;
    }
  }
  const std::vector<int> at = ModelIndexOfHandState(*s.model, n, account);
  s.hand_x = HandState(n, account);
  s.model_x = Eigen::VectorXd::Zero(s.model->num_states());
  for (size_t j = 0; j < at.size(); ++j) s.model_x[at[j]] = s.hand_x[j];
  std::vector<double> hand_dot(s.hand_x.size());
  Eigen::VectorXd model_dot(s.model->num_states());
  mb::Workspace ws = s.model->MakeWorkspace(s.code.get());
  s.model->CalcStateDerivatives(0.0, s.model_x.data(), model_dot.data(), ws);
  s.hand.Rhs(account, s.hand_x.data(), hand_dot.data());
  double largest = 0.0, worst = 0.0;
  for (size_t j = 0; j < at.size(); ++j) {
    largest = std::max(largest, std::abs(hand_dot[j]));
    worst = std::max(worst, std::abs(model_dot[at[j]] - hand_dot[j]));
  }
  s.max_rel_diff = worst / largest;
  // Rounding only: the model sums a junction's terms in its own order and is compiled without FMA
  // contraction, which the hand-written loop may use; a wrong or missing term would be O(1).
  if (!(s.max_rel_diff <= 1e-14))
    s.error = fmt::format("model and hand-written derivatives differ: {:.3g} (relative)", s.max_rel_diff);
  return s;
}

const char* EngineName(int engine) { return engine == 0 ? "interpreter" : engine == 1 ? "generated code" : "hand-written"; }

void BM_FormulaChainRhs(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0)), engine = static_cast<int>(state.range(1));
  const bool account = state.range(2) != 0;
  Setup s = Prepare(n, engine == 1, account);
  if (!s.error.empty()) {
    state.SkipWithError(s.error.c_str());
    return;
  }
  mb::Workspace ws = s.model->MakeWorkspace(s.code.get());
  std::vector<double> hand_dot(s.hand_x.size());
  Eigen::VectorXd model_dot(s.model->num_states());
  double t = 0.0;
  for (auto _ : state) {
    if (engine == 2) {
      s.hand.Rhs(account, s.hand_x.data(), hand_dot.data());
      benchmark::DoNotOptimize(hand_dot.data());
    } else {
      s.model->CalcStateDerivatives(t, s.model_x.data(), model_dot.data(), ws);
      benchmark::DoNotOptimize(model_dot.data());
    }
    benchmark::ClobberMemory();
    t += 1e-9;
  }
  state.SetLabel(std::string(EngineName(engine)) + (account ? ", energy account" : ", no account"));
  state.counters["states"] = static_cast<double>(s.model->num_states());
  state.counters["ns_per_mass"] =
      benchmark::Counter(n, benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
  state.counters["max_rel_diff"] = s.max_rel_diff;
}
BENCHMARK(BM_FormulaChainRhs)
    ->ArgsProduct({{1000}, {0, 1, 2}, {0, 1}})
    ->ArgsProduct({{100}, {0, 1, 2}, {0}});

/// This thread's CPU time in ns: time the VM gives to other processes is not counted.
double ThreadNs() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return 1e9 * static_cast<double>(ts.tv_sec) + static_cast<double>(ts.tv_nsec);
}

/// range(0): N; range(1): 1 = with the energy account. Each iteration times blocks of about
/// 0.2 ms of each of the three in turn (this thread's CPU time); the counters are the medians
/// over iterations (ns per evaluation) and their ratios.
void BM_FormulaChainRatio(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  const bool account = state.range(1) != 0;
  Setup gen = Prepare(n, true, account), interp = Prepare(n, false, account);
  for (const Setup* s : {&gen, &interp})
    if (!s->error.empty()) {
      state.SkipWithError(s->error.c_str());
      return;
    }
  const int calls = std::max(1, 200'000 / n), interp_calls = std::max(1, 2'000 / n);
  mb::Workspace ws_gen = gen.model->MakeWorkspace(gen.code.get()), ws_interp = interp.model->MakeWorkspace();
  std::vector<double> hand_dot(gen.hand_x.size());
  Eigen::VectorXd gen_dot(gen.model->num_states()), interp_dot(interp.model->num_states());
  std::vector<double> ns[3];
  double t = 0.0;
  for (auto _ : state) {
    const double t0 = ThreadNs();
    for (int k = 0; k < calls; ++k) {
      gen.hand.Rhs(account, gen.hand_x.data(), hand_dot.data());
      benchmark::DoNotOptimize(hand_dot.data());
      benchmark::ClobberMemory();
    }
    const double t1 = ThreadNs();
    for (int k = 0; k < calls; ++k) {
      gen.model->CalcStateDerivatives(t, gen.model_x.data(), gen_dot.data(), ws_gen);
      benchmark::DoNotOptimize(gen_dot.data());
      benchmark::ClobberMemory();
      t += 1e-9;
    }
    const double t2 = ThreadNs();
    for (int k = 0; k < interp_calls; ++k) {
      interp.model->CalcStateDerivatives(t, interp.model_x.data(), interp_dot.data(), ws_interp);
      benchmark::DoNotOptimize(interp_dot.data());
      benchmark::ClobberMemory();
      t += 1e-9;
    }
    const double t3 = ThreadNs();
    ns[0].push_back((t1 - t0) / calls);
    ns[1].push_back((t2 - t1) / calls);
    ns[2].push_back((t3 - t2) / interp_calls);
  }
  auto median = [](std::vector<double> v) {
    std::sort(v.begin(), v.end());
    return v.empty() ? 0.0 : v[v.size() / 2];
  };
  const double hand = median(ns[0]), generated = median(ns[1]), interpreted = median(ns[2]);
  state.counters["hand_ns"] = hand;
  state.counters["generated_ns"] = generated;
  state.counters["interpreter_ns"] = interpreted;
  state.counters["generated_over_hand"] = generated / hand;
  state.counters["interpreter_over_hand"] = interpreted / hand;
  state.counters["best_generated_over_hand"] =
      *std::min_element(ns[1].begin(), ns[1].end()) / *std::min_element(ns[0].begin(), ns[0].end());
  state.SetLabel(std::string("medians of interleaved blocks") + (account ? ", energy account" : ", no account"));
}
BENCHMARK(BM_FormulaChainRatio)->Args({1000, 0})->Args({1000, 1})->Args({100, 0})->Iterations(200)->Unit(benchmark::kMillisecond);

}  // namespace
