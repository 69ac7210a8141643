#include "run_options.h"

#include <chrono>
#include <iostream>
#include <stdexcept>

#include <fmt/format.h>

#include "multibond/analysis/linearize.h"
#include "multibond/core/interrupt.h"

namespace multibond::cli {

void AddRunOptions(CLI::App* cmd, RunArgs& a) {
  cmd->add_option("--t-end", a.t_end, "end time [s] (default: the model's, else 1)")->check(kPositive);
  cmd->add_option("--dt", a.dt, "output interval [s] (default: the model's, else 1e-3)")->check(kPositive);
  cmd->add_option("--solver", a.solver, "bdf, adams, dopri5, bs3 (Bogacki-Shampine 3(2)), srk3 (stabilised RK 3(2), for stiff explicit runs) or rk4 (default: the model's, else bdf)");
  cmd->add_option("--rtol", a.rtol, "relative tolerance (default: the model's, else 1e-8)")->check(kPositive);
  cmd->add_option("--atol", a.atol, "absolute tolerance (default: the model's, else 1e-10)")->check(kPositive);
  cmd->add_option("--step", a.step, fmt::format("fixed step [s] for {} (required for rk4)", kFixedStepMethodNames))->check(kPositive);
  cmd->add_option("--max-step", a.max_step, "largest step [s] of the adaptive methods")->check(kPositive);
  cmd->add_option("--event-rest-time", a.event_rest_time,
                  "events: a contact whose rebound would fly shorter than this [s] stays closed, the ball at rest (impacts "
                  "accumulating, Zeno) (default: the model's, else 0 = a millionth of the run)")
      ->check(kNonNegative);
  cmd->add_option("--max-events-per-second", a.max_events_per_second,
                  "events: more than this many per second of run (and more than 1000 in all) stop the run as failed, an "
                  "event storm (default: the model's, else 1e4)")
      ->check(kPositive);
  cmd->add_flag("--all-variables", a.all_variables, "add a column for every effort and flow");
  cmd->add_option("--jit", a.jit,
                  "right-hand side as generated C++ compiled with the system compiler (auto: when one works; "
                  "off: the plan interpreter)")
      ->check(CLI::IsMember({"auto", "on", "off"}));
  cmd->add_flag("--no-projection", a.no_projection,
                "do not re-orthonormalise orientation matrices after each step (shows the raw drift)");
  cmd->add_option("--jacobian", a.jacobian,
                  "bdf and adams: the Newton matrix (sparse: difference quotients on the model's structural pattern, one "
                  "evaluation per group of columns sharing no row, KLU; dense: one evaluation per state, dense LU; auto: "
                  "sparse from 50 states when at most a quarter of the Jacobian can be nonzero)")
      ->check(CLI::IsMember({"auto", "dense", "sparse"}));
  cmd->add_option("--coordinates", a.coordinates,
                  "joint: integrate a mechanism's motion relative to its joints (each body's angle in its bearing and "
                  "its rate; steady rotation does not bound the step), inertial: the model's own states (default: the "
                  "model's 'coordinates:', else inertial); the output columns are the same")
      ->check(CLI::IsMember({"joint", "inertial"}));
  AddLoadOptions(cmd, a.load);
}

/// A model loaded and compiled, with its run options resolved: the command line over the model
/// file's `simulation:` section over the built-in defaults.
PreparedRun PrepareRun(const std::string& path, const RunArgs& a, const std::vector<std::string>& extra_sets, const char* extra_option) {
  using Clock = std::chrono::steady_clock;
  Clock::time_point mark = Clock::now();
  auto lap = [&mark] {
    const Clock::time_point now = Clock::now();
    const double seconds = std::chrono::duration<double>(now - mark).count();
    mark = now;
    return seconds;
  };
  PreparedRun p{Load(path, a.load, extra_sets, extra_option), nullptr, {}, {}, {}, {}, {}, nullptr};
  p.phase_seconds.emplace_back("load", lap());
  p.model = CompiledModel::Compile(p.lm.graph, p.lm.compile);
  (void)lap();
  p.phase_seconds.insert(p.phase_seconds.end(), p.model->compile_seconds().begin(), p.model->compile_seconds().end());
  if (a.jit != "off") {
    // auto: the run starts on the interpreter and switches when the code is loaded (same bits);
    // on: the code must be there before the run starts.
    GenerateOptions go;
    go.background = a.jit == "auto";
    p.code = GeneratedRhs::Start(p.model, go);
  }
  p.phase_seconds.emplace_back("generate_code", lap());
  // --jit on for a model that generated code does not cover is a usage error; a compiler that fails is the machine's.
  if (a.jit == "on" && !p.code->uses_generated_code())
    throw CliExit{p.model->algebraic_loops().empty() ? kExitIo : kExitUsage, "--jit on, but " + p.code->engine()};
  // --jit auto falls back to the interpreter when the compiler fails: same numbers, slower; said
  // here, not only in run.json.
  if (a.jit == "auto" && !p.code->uses_generated_code() && p.code->engine().find("code generation") != std::string::npos)
    std::cerr << "warning: running on the interpreter: " << p.code->engine() << '\n';
  const SimulationDefaults& d = p.lm.simulation;
  RunOptions& o = p.options;
  o.t_end = a.t_end.value_or(d.t_end.value_or(1.0));
  o.dt = a.dt.value_or(d.dt.value_or(1e-3));
  p.solver = a.solver.value_or(d.solver.value_or("bdf"));
  try {
    o.integrator.method = ParseMethod(p.solver);
  } catch (const std::invalid_argument& e) {
    throw CliExit{kExitUsage, e.what()};
  }
  o.integrator.rtol = a.rtol.value_or(d.rtol.value_or(1e-8));
  o.integrator.atol = a.atol.value_or(d.atol.value_or(1e-10));
  o.integrator.fixed_step = a.step.value_or(d.step.value_or(0.0));
  // The file's fixed step belongs to the file's solver: a step-choosing solver asked for on the
  // command line leaves it (only a --step given with it is refused).
  if (!a.step && a.solver && UsesNewtonMatrix(o.integrator.method))
    o.integrator.fixed_step = 0.0;
  o.integrator.max_step = a.max_step.value_or(d.max_step.value_or(0.0));
  o.event_rest_time = a.event_rest_time.value_or(d.event_rest_time.value_or(0.0));
  o.max_events_per_second = a.max_events_per_second.value_or(d.max_events_per_second.value_or(1e4));
  o.all_variables = a.all_variables;
  p.coordinates = a.coordinates.value_or(d.coordinates.value_or("inertial"));
  if (p.coordinates == "joint") {
    if (!p.lm.mechanism || p.lm.mechanism->empty())
      throw CliExit{kExitUsage, "--coordinates joint is for mechanisms: the model has no bodies"};
    o.joint_coordinates = p.lm.mechanism->MakeJointTree();
  }
  o.integrator.project = !a.no_projection;
  o.max_forced_steps = static_cast<double>(ParseLimits(a.load.limits).steps);
  o.integrator.jacobian = ParseJacobianKind(a.jacobian);
  // An explicit method forms no Newton matrix: a --jacobian for it is recorded but changes nothing.
  if (a.jacobian != "auto" && !UsesNewtonMatrix(o.integrator.method))
    std::cerr << fmt::format("warning: --jacobian {} has no effect with the explicit solver '{}' (only bdf and adams form a "
                             "Newton matrix)\n", a.jacobian, p.solver);
  o.stop = &StopFlag();
  o.code = p.code;
  // A steady start: Newton's method (KINSOL) from the initial values at the start, the sources
  // held at their values there (docs/linear-analysis.md, "Steady states").
  p.initial = a.initial.value_or(d.initial.value_or("model"));
  if (p.initial == "steady") {
    try {
      o.initial_state = linear::FindSteadyState(*p.model, o.t_start, p.model->MakeInitialState());
    } catch (const std::runtime_error& e) {
      throw CliExit{kExitSolver, fmt::format("the run starts from a steady state (initial: steady), and {}\n  hint: start from the model's "
                                             "initial values (--initial model), or give initial values nearer to the steady state",
                                             e.what())};
    }
    p.phase_seconds.emplace_back("steady_state", lap());
  }
  (void)MakeColumns(*p.model, o.all_variables);  // a bad output is a model error: before any file is touched
  try {
    CheckRunOptions(*p.model, o);  // and so are options the run would refuse
  } catch (const std::invalid_argument& e) {
    throw CliExit{kExitUsage, e.what()};
  }
  p.phase_seconds.emplace_back("setup", lap());
  return p;
}

std::string FailureHint(const RunOptions& o, const std::string& message) {
  const IntegratorOptions& i = o.integrator;
  const auto has = [&](const char* text) { return message.find(text) != std::string::npos; };
  if (has("evaluating the outputs failed")) return "check the model's parameters (an output could not be evaluated there)";
  if (has("derivatives of the initial state are not finite"))
    return "check the parameters and initial values of those states' elements (no solver or tolerance can help)";
  if (has("event storm"))
    return fmt::format("if the events are real, raise --max-events-per-second (now {:g}); if they chatter (a contact or friction "
                       "switching back and forth), look at the element the message names, or raise --event-rest-time (now {}) so "
                       "that impacts accumulate sooner", o.max_events_per_second,
                       o.event_rest_time > 0 ? fmt::format("{:g} s", o.event_rest_time) : std::string("a millionth of the run"));
  if (has("beyond machine precision")) return "loosen the tolerances (--rtol, --atol): double precision cannot resolve them";
  if (i.fixed_step > 0)
    return fmt::format("try a smaller fixed step (--step, now {:g} s): beyond its stability limit a fixed step blows up; or an adaptive "
                       "solver (--solver srk3, bs3, dopri5 or bdf without --step)", i.fixed_step);
  if (has("max_steps_per_output")) {
    // Too many steps in one output interval: a shorter interval lets them be taken; what else
    // helps depends on what held the steps short.
    std::string hint = fmt::format("a shorter output interval (--dt, now {:g} s) lets the solver take more steps", o.dt);
    if (i.max_step > 0) hint += fmt::format("; or a larger --max-step (now {:g} s)", i.max_step);
    if (!UsesNewtonMatrix(i.method)) hint += "; or, if the model is stiff, --solver bdf";
    return hint + "; or looser tolerances (--rtol, --atol), if the accuracy allows";
  }
  if (i.method == Method::kBdf) return "try a tighter tolerance (--rtol), or check the model's parameters (is the solution blowing up?)";
  return "try a stiff solver (--solver bdf), a tighter tolerance (--rtol), or check the model's parameters";
}

std::string RunSettings(const PreparedRun& p) {
  const IntegratorOptions& i = p.options.integrator;
  std::string s = fmt::format("solver {}, rtol {:g}, atol {:g}", p.solver, i.rtol, i.atol);
  if (i.fixed_step > 0) s += fmt::format(", step {:g}", i.fixed_step);
  if (i.max_step > 0) s += fmt::format(", max_step {:g}", i.max_step);
  if (p.model->has_constraints()) s += fmt::format(", ideal constraints ({} efforts)", p.model->num_multipliers());
  if (!p.model->algebraic_loops().empty()) s += ", algebraic loops solved";
  for (const ModelParameter& q : p.lm.parameters)
    if (q.set) s += fmt::format(", {} = {}", q.name, q.text);  // --set, --set-a, --set-b
  return s;
}

}  // namespace multibond::cli
