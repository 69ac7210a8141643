// What events cost: the stick-slip (examples/events/stick_slip.yaml, 0-20 s) and the bouncing ball
// (examples/events/bouncing_ball.yaml, 0-10 s) at the examples' tolerances (rtol 1e-10, atol
// 1e-12, dt 1e-3), with bdf and dopri5: wall time, steps, right-hand sides and events, and per
// event. Against them, the same dynamics without events: the steps per second of simulated time
// of each smooth phase (stick-slip: the first stick interval, 0-0.5 s, and the slip oscillation
// alone, with the friction a constant kinetic force; ball: the free fall before the first impact,
// 0-0.45 s, and the rest after the impacts, a 0-10 s run less a 0-4.07 s one). "excess" is what
// the events added: (steps of the run - the phases' steps at those rates) / events.
// Run: build/release/bench/multibond_bench --benchmark_filter='StickSlip|BouncingBall'
//
// Measured on the 2-core development machine (shared; generated code, 5 iterations):
//
//                     steps   rhs      events  steps/event  rhs/event  excess steps/event  excess rhs/event  wall
//   stick-slip bdf     4,867    6,317  49      99           129        23                  40                14-23 ms
//   stick-slip dopri5 20,233  181,631  49      413          3,707      1.4                 420 (*)           33-49 ms
//   ball bdf           1,001    1,411  52      19           27         14                  21                5-8 ms
//   ball dopri5       10,379   92,909  52      200          1,787      5.8                 125               16-20 ms
//
// dopri5 stops at every output time (1 ms) when the model has event functions: about 1,000 steps
// per second whatever the dynamics, 8 right-hand sides per step. bdf restarts at order 1 with a
// small step after each event: some 15-25 steps to regain its stride. (*) the slip baseline's
// only event function is the idle contact's gap, cheaper than the friction's: part of this
// excess is the friction's event function evaluated at every step, not the events.

#include <map>
#include <string>
#include <utility>
#include <vector>

#include <benchmark/benchmark.h>

#include "built.h"
#include "multibond/io/model_loader.h"
#include "multibond/sim/simulator.h"

namespace mb = multibond;

namespace {

const std::string kExamples = std::string(MULTIBOND_SOURCE_DIR) + "/examples/events/";

/// The stick-slip's slip phase alone: the friction a constant kinetic force mu_k m g, the block
/// starting where slip starts (x = mu_s m g / k at the belt's speed); it oscillates about
/// mu_k m g / k for ever. An idle contact that never closes (its gap 1e6 m, nothing moves it)
/// keeps the model's event functions, so that the integrators run as in the stick-slip (dopri5
/// stopping at the output times).
const char* kSlipOnly = R"(model: stick_slip_slipping
parameters:
  m:      {value: 1.0,   unit: kg}
  k:      {value: 100.0, unit: N/m}
  v_belt: {value: 0.1,   unit: m/s}
  mu_s:   {value: 0.6,   unit: "1"}
  mu_k:   {value: 0.4,   unit: "1"}
  g:      {value: 9.81,  unit: m/s^2}
domain: translation
elements:
  belt:     {type: Sf, flow: v_belt}
  vb:       {type: "1"}
  v:        {type: "1"}
  block:    {type: I, inertia: m, p0: "m*v_belt"}
  spring:   {type: C, stiffness: k, q0: "mu_s*m*g/k"}
  c:        {type: "0"}
  rel:      {type: "1"}
  friction: {type: Se, effort: "mu_k*m*g"}
  idle:     {type: "1"}
  weight:   {type: I, inertia: m}
  floor:    {type: Sf, flow: 0, contact: {gap: gap, restitution: 0.5}}
states:
  gap: {kind: integral, of: idle, initial: 1.0e6}
bonds:
  - belt -> vb
  - v -> block
  - v -> spring
  - v -> c
  - c -> vb
  - c -> rel
  - friction -> rel
  - floor -> idle
  - idle -> weight
simulation: {t_end: 20, dt: 1.0e-3, rtol: 1.0e-10, atol: 1.0e-12}
)";

struct Prepared {
  std::shared_ptr<const mb::CompiledModel> model;
  mb::RunOptions options;  ///< with the generated code (options.code)
};

/// Compiled to generated code (the interpreter when no compiler works), with the file's settings.
Prepared Prepare(const mb::LoadedModel& lm, mb::Method method, double t_end) {
  const mb::bench::Built b = mb::bench::Build(lm.graph, lm.compile, true);
  Prepared p{b.model, {}};
  p.options.code = b.code;
  p.options.t_end = t_end;
  p.options.dt = lm.simulation.dt.value_or(1e-3);
  p.options.integrator.method = method;
  p.options.integrator.rtol = lm.simulation.rtol.value_or(1e-8);
  p.options.integrator.atol = lm.simulation.atol.value_or(1e-10);
  // The rest time fixed, not a millionth of each run: the shorter runs below bounce as the long one.
  p.options.event_rest_time = 1e-6 * t_end;
  return p;
}

/// Keeps the events (time and kind), nothing else.
class EventLog : public mb::NullObserver {
 public:
  void OnEvent(const mb::EventRecord& e) override { events.emplace_back(e.time, e.kind); }
  std::vector<std::pair<double, std::string>> events;
};

struct Run {
  mb::RunSummary summary;
  std::vector<std::pair<double, std::string>> events;
};

Run Simulate(const Prepared& p, double t_end) {
  mb::RunOptions o = p.options;
  o.t_end = t_end;
  EventLog log;
  Run r{mb::Simulate(*p.model, o, log), {}};
  r.events = std::move(log.events);
  return r;
}

/// Steps and right-hand sides per second of simulated time of a run without events.
std::pair<double, double> Rates(const Run& r, double span) {
  if (!r.events.empty() || r.summary.status != mb::RunStatus::kOk) return {-1.0, -1.0};  // said by the counters
  return {static_cast<double>(r.summary.stats.steps) / span, static_cast<double>(r.summary.stats.rhs_evals) / span};
}

/// The timed loop and the counters common to both models; `expected`: the steps and right-hand
/// sides the run's smooth phases would take at their event-free rates.
void Report(benchmark::State& state, const Run& r, const std::pair<double, double>& expected) {
  const mb::IntegratorStats& s = r.summary.stats;
  const double events = static_cast<double>(r.events.size());
  state.counters["wall_ms"] = 1e3 * r.summary.wall_seconds;
  state.counters["steps"] = static_cast<double>(s.steps);
  state.counters["rhs_evals"] = static_cast<double>(s.rhs_evals);
  state.counters["events"] = events;
  state.counters["steps_per_event"] = static_cast<double>(s.steps) / events;
  state.counters["rhs_per_event"] = static_cast<double>(s.rhs_evals) / events;
  state.counters["smooth_steps"] = expected.first;
  state.counters["excess_steps_per_event"] = (static_cast<double>(s.steps) - expected.first) / events;
  state.counters["excess_rhs_per_event"] = (static_cast<double>(s.rhs_evals) - expected.second) / events;
  if (r.summary.status != mb::RunStatus::kOk) state.SkipWithError(r.summary.message.c_str());
}

/// range(0): 0 = bdf, 1 = dopri5.
mb::Method MethodOf(const benchmark::State& state) { return state.range(0) == 0 ? mb::Method::kBdf : mb::Method::kDormandPrince; }

void BM_StickSlip(benchmark::State& state) {
  const mb::Method method = MethodOf(state);
  const Prepared p = Prepare(mb::LoadModelFile(kExamples + "stick_slip.yaml"), method, 20.0);
  Run r;
  for (auto _ : state) r = Simulate(p, 20.0);
  // The smooth phases: stuck from 0 to the first slip, then alternately slipping and stuck.
  double stuck = 0.0, slipping = 0.0, since = 0.0;
  bool slips = false;
  for (const auto& [t, kind] : r.events) {
    if (kind != "slip" && kind != "stick") continue;
    (slips ? slipping : stuck) += t - since;
    since = t;
    slips = kind == "slip";
  }
  (slips ? slipping : stuck) += 20.0 - since;
  const auto stick_rate = Rates(Simulate(p, 0.5), 0.5);
  const auto slip_rate = Rates(Simulate(Prepare(mb::LoadModelString(kSlipOnly, "slip_only.yaml"), method, 20.0), 20.0), 20.0);
  Report(state, r, {stick_rate.first * stuck + slip_rate.first * slipping, stick_rate.second * stuck + slip_rate.second * slipping});
  state.counters["stuck_s"] = stuck;
  state.counters["slipping_s"] = slipping;
  state.counters["stick_steps_per_s"] = stick_rate.first;
  state.counters["slip_steps_per_s"] = slip_rate.first;
  state.counters["stick_rhs_per_s"] = stick_rate.second;
  state.counters["slip_rhs_per_s"] = slip_rate.second;
  state.SetLabel(std::string(mb::MethodName(method)) + (p.options.code->ready() ? ", generated code" : ", interpreter"));
}
BENCHMARK(BM_StickSlip)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->Iterations(5);

void BM_BouncingBall(benchmark::State& state) {
  const mb::Method method = MethodOf(state);
  const Prepared p = Prepare(mb::LoadModelFile(kExamples + "bouncing_ball.yaml"), method, 10.0);
  Run r;
  for (auto _ : state) r = Simulate(p, 10.0);
  // Free flight until the ball rests (the last event, the contact closing); resting after.
  const double rest = r.events.empty() ? 10.0 : r.events.back().first;
  const auto flight_rate = Rates(Simulate(p, 0.45), 0.45);  // the first impact is at 0.4515 s
  // The resting phase's own steps: the whole run less one that ends just after the rest.
  const double bounced = rest + 0.005;
  const Run until_rest = Simulate(p, bounced);
  const double rest_steps = static_cast<double>(r.summary.stats.steps - until_rest.summary.stats.steps);
  const double rest_rhs = static_cast<double>(r.summary.stats.rhs_evals - until_rest.summary.stats.rhs_evals);
  Report(state, r, {flight_rate.first * rest + rest_steps, flight_rate.second * rest + rest_rhs});
  state.counters["flying_s"] = rest;
  state.counters["flight_steps_per_s"] = flight_rate.first;
  state.counters["flight_rhs_per_s"] = flight_rate.second;
  state.counters["rest_rhs_per_s"] = rest_rhs / (10.0 - bounced);
  state.counters["rest_steps_per_s"] = rest_steps / (10.0 - bounced);
  state.SetLabel(std::string(mb::MethodName(method)) + (p.options.code->ready() ? ", generated code" : ", interpreter"));
}
BENCHMARK(BM_BouncingBall)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->Iterations(5);

}  // namespace
