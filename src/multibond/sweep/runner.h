#pragma once
/// \file
/// One run of a study: the parameter values of the run over the model's, the model read from its
/// text held in memory (the file is read once per sweep), compiled, simulated, and its kept
/// quantities taken. The values are folded into the compiled plan at load time, so each run
/// compiles its own plan; with generated code the library is the one cache entry per code text
/// (compile/jit.h). A run's numbers depend only on its values: never on the thread, rank or order.
///
/// The Runner is built once, checked against the nominal model (the file's values with the
/// study's `set:`): every swept or set parameter must be one of the model's, every kept
/// expression must name result columns. Run() is const and may be called from many threads at
/// once, each with its own KeptObserver (its workspace).

#include <atomic>
#include <memory>
#include <string>
#include <vector>

#include "multibond/io/model_loader.h"
#include "multibond/sim/simulator.h"
#include "multibond/sweep/kept.h"
#include "multibond/sweep/study.h"

namespace multibond::sweep {

struct RunResult {
  long run = 0;
  bool ok = false;
  std::string reason;          ///< why the run failed ("" when ok)
  std::vector<double> values;  ///< the kept quantities (NaN when failed)
};

/// Where a run's time went, summed over runs.
struct RunTiming {
  double load = 0.0, compile = 0.0, simulate = 0.0;
  long runs = 0;
  void Add(const RunTiming& o) {
    load += o.load;
    compile += o.compile;
    simulate += o.simulate;
    runs += o.runs;
  }
};

/// What one thread of a sweep keeps between its runs: the model's text parsed once (no parse per
/// run), the kept quantities' workspace, and where the time went. Runner::NewWorkspace makes one.
struct RunWorkspace {
  RunWorkspace(const std::string& text, const std::string& file, const InputLimits& limits, const KeptQuantities& q)
      : parsed(text, file, limits), kept(q) {}
  ParsedModel parsed;
  KeptObserver kept;
  RunTiming timing;
};

class Runner {
 public:
  /// `model_text` the model file's content (`study.model` names it in messages); `jit` "auto",
  /// "on" or "off" (BuildOptions::jit). Throws ModelError: the study's problems against the model
  /// (sweep.unknown_parameter, sweep.keep), or the nominal model's own.
  /// `earlier`: problems of the study found before (ReadStudyString's), thrown with these, in the
  /// order of the file.
  Runner(const Study& study, std::string model_text, const InputLimits& limits, std::string jit, const DiagnosticSink& earlier = {});
  const LoadedModel& nominal() const { return nominal_; }
  const KeptQuantities& kept() const { return kept_; }
  /// The run options (the front end resolves them from the nominal model and the study);
  /// all_variables is set here when a kept quantity needs it.
  void set_run_options(RunOptions o);
  const RunOptions& run_options() const { return options_; }
  /// The run `run` with the swept parameters at `values` (in the study's axis order). Failures of
  /// the run (a parameter out of the model's range, a solver failure) are its result, not thrown.
  /// `observer` may be any Observer that forwards to `kept` (e.g. to keep the rows as well).
  RunResult Run(long run, const std::vector<double>& values, RunWorkspace& ws, const std::atomic<bool>* stop,
                Observer* also = nullptr) const;
  /// A workspace for one thread's runs.
  std::unique_ptr<RunWorkspace> NewWorkspace() const;

 private:
  const Study& study_;
  std::string text_;
  InputLimits limits_;
  std::string jit_;
  DiagnosticSink sink_;  ///< the study's problems (thrown by the constructor)
  LoadedModel nominal_;
  KeptQuantities kept_;
  RunOptions options_;
};

/// A value as the loader reads it back to the same double ("0.1", "1e+300"): shortest round trip.
std::string ExactText(double v);

}  // namespace multibond::sweep
