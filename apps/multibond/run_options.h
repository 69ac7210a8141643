#pragma once
// The run options shared by `run` and `compare`, resolved in one place with one set of defaults:
// the command line over the model file's `simulation:` section over the built-in defaults.

#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "cli.h"
#include "multibond/compile/generated_rhs.h"
#include "multibond/sim/simulator.h"

namespace multibond::cli {

struct RunArgs {
  LoadArgs load;
  std::optional<double> t_end, dt, rtol, atol, step, max_step;
  std::optional<double> event_rest_time, max_events_per_second;
  std::optional<std::string> solver, coordinates;
  /// "model" or "steady" (SimulationDefaults::initial; `run --steady`, `run --initial`).
  std::optional<std::string> initial;
  bool all_variables = false, no_projection = false;
  std::string jit = "auto";
  std::string jacobian = "auto";
};

void AddRunOptions(CLI::App* cmd, RunArgs& a);

/// A model loaded and compiled, with its run options resolved.
struct PreparedRun {
  LoadedModel lm;
  std::shared_ptr<const CompiledModel> model;
  RunOptions options;
  std::string solver;
  std::string coordinates;  ///< "joint" or "inertial"
  std::string initial;      ///< "model" or "steady" (then options.initial_state is the steady state)
  /// The wall time of each phase so far, in order [s]: load (read, parse, expand the model),
  /// the compile passes (CompiledModel::compile_seconds), setup (the run's options and columns).
  std::vector<std::pair<std::string, double>> phase_seconds;
  /// The model's generated code (--jit auto or on; also in options.code), null with --jit off.
  std::shared_ptr<const GeneratedRhs> code;
  /// How the right-hand side is evaluated (GeneratedRhs::engine), "interpreter" without code.
  std::string engine() const { return RhsEngine(code.get()); }
};

/// Throws ModelError (bad model, bad output), CliExit 64 (unknown solver, options the run would
/// refuse) or 74 (--jit on without a working compiler).
/// `extra_sets`: parameter values for this model only (compare's --set-a, --set-b), after --set.
PreparedRun PrepareRun(const std::string& path, const RunArgs& a, const std::vector<std::string>& extra_sets = {},
                       const char* extra_option = nullptr);

/// What to try after a failed run, from what failed and with which settings.
std::string FailureHint(const RunOptions& o, const std::string& message);

/// "solver bdf, rtol 1e-08, atol 1e-10, ...": the settings a run used, for reports.
std::string RunSettings(const PreparedRun& p);

}  // namespace multibond::cli
