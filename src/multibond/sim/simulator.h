#pragma once
/// \file
/// Runs a compiled model: drives an integrator from output time to output time, evaluates the
/// output columns (states, declared outputs, every effort and flow on request, the energy
/// account) and hands each sample to an observer. Solver failures and interruptions do not throw:
/// they end the run with a status, and the samples computed until then have been delivered.

#include <atomic>
#include <cmath>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "multibond/compile/compiled_model.h"
#include "multibond/core/joint_tree.h"
#include "multibond/solve/integrator.h"

namespace multibond {

/// Thrown from inside an integration when the run's stop flag is set (RunOptions::stop).
struct RunInterrupted : std::runtime_error {
  RunInterrupted() : std::runtime_error("interrupted") {}
};

/// The compiled model as an OdeSystem, with its own workspace (one per simulation). With a stop
/// flag, every evaluation looks at it and throws RunInterrupted once it is set, so that a run
/// stops within a step, not at the end of an output interval that may take minutes.
class ModelSystem : public OdeSystem {
 public:
  /// `code`: the model's generated code (compile/generated_rhs.h), which evaluates once it is
  /// loaded; null: the interpreter.
  explicit ModelSystem(const CompiledModel& model, const std::atomic<bool>* stop = nullptr, const GeneratedRhs* code = nullptr)
      : model_(model), ws_(model.MakeWorkspace(code)), stop_(stop) {}
  int num_states() const override { return model_.num_states(); }
  void CalcDerivatives(double t, const double* x, double* xdot) override {
    if (stop_ && stop_->load(std::memory_order_relaxed)) throw RunInterrupted();
    t = LeftOfTimeEvent(t);
    model_.CalcStateDerivatives(t, x, xdot, ws_);
    if (model_.has_formulas()) CheckFormulas(t, x, xdot);
  }
  bool has_invariants() const override { return model_.has_invariants(); }
  /// Orientations onto SO(3) and, with ideal constraints, momenta onto the constraints at t.
  void Project(double t, double* x) override { model_.Project(t, x, ws_); }
  const JacobianPattern* jacobian_pattern() const override { return model_.jacobian_pattern(); }
  /// The switching elements' event functions (docs/events.md).
  int num_roots() const override { return model_.num_event_functions(); }
  void CalcRoots(double t, const double* x, double* g) override { model_.CalcEventFunctions(LeftOfTimeEvent(t), x, ws_, g); }
  /// The time event the integration is heading for (infinity: none). An evaluation at that very
  /// time (the last stage of the step that ends there, an implicit method's end point) is made
  /// just before it: a step up to a source's jump integrates the value before the jump, and the
  /// value after it counts from the restart on. Without it the last step before a voltage step
  /// at 0.3 s saw 1 V in its last stage (u_C 1.7e-2 V too high under rk4 at a step of 0.01 s).
  void set_time_event(double t) {
    time_event_ = t;
    left_of_event_ = std::nextafter(t, -std::numeric_limits<double>::infinity());
  }
  /// The switching elements' events are downward crossings; a formula's kink changes branch
  /// at a crossing either way.
  void RootDirections(int* direction) const override {
    const int n = model_.num_event_functions(), switching = model_.num_switch_event_functions();
    for (int i = 0; i < n; ++i) direction[i] = i < switching ? -1 : 0;
  }
  Workspace& workspace() { return ws_; }
  /// Thrown when a formula gives a value that is not finite from finite inputs (a division by
  /// zero, the root of a negative number): the run stops there with the element, the formula and
  /// the time, instead of the integrator's step-size failure.
  struct FormulaFault : std::runtime_error {
    using std::runtime_error::runtime_error;
  };

 private:
  /// A non-finite derivative from a finite state: a formula's fault? (simulator.cc)
  void CheckFormulas(double t, const double* x, const double* xdot);
  double LeftOfTimeEvent(double t) const { return t >= time_event_ ? left_of_event_ : t; }
  const CompiledModel& model_;
  Workspace ws_;
  const std::atomic<bool>* stop_;
  double time_event_ = std::numeric_limits<double>::infinity();
  double left_of_event_ = std::numeric_limits<double>::infinity();
};

struct RunOptions {
  double t_start = 0.0;
  /// The state the run starts from (CompiledModel's state layout); empty: the model's initial
  /// values (CompiledModel::MakeInitialState). A steady state (`run --steady`) comes here.
  Eigen::VectorXd initial_state;
  double t_end = 1.0;
  double dt = 1e-3;  ///< output interval
  IntegratorOptions integrator;
  bool all_variables = false;  ///< a column for every element's effort and flow
  /// Non-empty: the integrator integrates the motion in joint coordinates over this tree
  /// (JointCoordinateSystem), a change of variables that lets it step over steady rotation. The
  /// output columns are the model's, the same as without.
  JointTree joint_coordinates;
  /// Set from another thread or a signal handler to stop the run: at the next evaluation of the
  /// model, keeping the rows written until then.
  const std::atomic<bool>* stop = nullptr;
  /// The model's generated code (GeneratedRhs::Start), which evaluates the run once it is
  /// loaded (the same bits as the interpreter, faster); null: the interpreter.
  std::shared_ptr<const GeneratedRhs> code;
  /// Called with the fraction done, at most a few times per second.
  std::function<void(double)> progress;
  /// Events (docs/events.md): a contact whose rebound would fly for less than this stays closed
  /// (impacts accumulating, Zeno); 0 = a millionth of the run.
  double event_rest_time = 0.0;
  /// More events than this per second of run (and at least 1,000 in all) is an event storm: the
  /// run stops with what it computed.
  double max_events_per_second = 1e4;
  /// The most steps a run may be made to take: fixed steps ((t_end - t_start) / step), or the
  /// fewest steps a --max-step forces. A request beyond it is refused before it starts, with the
  /// estimate (InputLimits::steps, `--limit steps=N`).
  double max_forced_steps = 1e8;
};

struct Column {
  std::string name;  ///< e.g. "mass.p", "A.omega.z", "energy.residual"
  std::string unit;  ///< e.g. "N s"; "-" when dimensionless or unknown
  std::string Header() const { return name + " [" + unit + "]"; }
};

enum class RunStatus { kOk, kFailed, kInterrupted };
const char* RunStatusName(RunStatus s);

struct RunSummary {
  RunStatus status = RunStatus::kOk;
  std::string message;   ///< why the run stopped early ("" when ok)
  double t_reached = 0.0;
  long samples = 0;
  IntegratorStats stats;
  /// Joint coordinates: how often a body's rotation had left its axis and the coordinates were
  /// charted anew (the integrator restarted).
  long recharts = 0;
  double wall_seconds = 0.0;
  double energy_work = 0.0, energy_stored = 0.0, energy_dissipated = 0.0, energy_residual = 0.0;
  double max_abs_energy_residual = 0.0;
  /// Events by kind (impact, stick, slip, lock, unlock, contact, separation, limit, time).
  std::map<std::string, long> event_counts;
  /// What a user must know about results that were computed (status ok): e.g. an energy balance
  /// that does not close, which no correct solution of the model can give.
  std::vector<std::string> warnings;
};

/// The energy residual at the end of a run above which the run is reported as inaccurate: a
/// thousandth of the energy that flowed (a correct run is at the level of its tolerances).
inline constexpr double kEnergyResidualWarning = 1e-3;

/// Receives the samples of a run as they are computed.
class Observer {
 public:
  virtual ~Observer() = default;
  virtual void OnStart(const std::vector<Column>& columns) = 0;
  virtual void OnSample(const std::vector<double>& row) = 0;
  /// An event (docs/events.md), before the sample of the output time that follows it.
  virtual void OnEvent(const EventRecord& /*event*/) {}
  virtual void OnFinish(const RunSummary& summary) = 0;
};

/// Discards every sample (benchmarks; runs whose summary is all that matters).
class NullObserver : public Observer {
 public:
  void OnStart(const std::vector<Column>&) override {}
  void OnSample(const std::vector<double>&) override {}
  void OnFinish(const RunSummary&) override {}
};

/// Keeps every sample in memory (tests, small runs, plots).
class RecordingObserver : public Observer {
 public:
  void OnStart(const std::vector<Column>& columns) override { columns_ = columns; }
  void OnSample(const std::vector<double>& row) override { rows_.push_back(row); }
  void OnFinish(const RunSummary& summary) override { summary_ = summary; }
  void OnEvent(const EventRecord& event) override { events_.push_back(event); }
  const std::vector<Column>& columns() const { return columns_; }
  const std::vector<std::vector<double>>& rows() const { return rows_; }
  const std::vector<EventRecord>& events() const { return events_; }
  const RunSummary& summary() const { return summary_; }
  /// Index of the column called `name` (without unit); throws std::out_of_range if absent.
  int Index(const std::string& name) const;
  /// The value of column `name` in the last row.
  double Last(const std::string& name) const { return rows_.back().at(Index(name)); }
  /// The value of column `name` linearly interpolated at time t.
  double At(const std::string& name, double t) const;

 private:
  std::vector<Column> columns_;
  std::vector<std::vector<double>> rows_;
  std::vector<EventRecord> events_;
  RunSummary summary_;
};

/// The output columns of a run: time, states, declared outputs, (all variables), energy.
std::vector<Column> MakeColumns(const CompiledModel& model, bool all_variables);

/// The model's declared outputs as linear combinations of state entries and workspace slots,
/// one per component, as the output columns compute them (a variable, a sum, a body point);
/// orthonormality outputs, which are no such combination, are left out (named in `left_out`).
struct OutputCombination {
  std::string name, unit;
  struct Term {
    bool state;  ///< a state entry (else a workspace slot)
    int offset;
    double coef;
  };
  std::vector<Term> terms;
};
std::vector<OutputCombination> DeclaredOutputs(const CompiledModel& model, std::vector<std::string>* left_out = nullptr);

/// The output times of a run: t_start, t_start + dt, t_start + 2 dt, ... while before t_end, and
/// t_end itself (a last interval shorter than a billionth of the run is merged into the one
/// before). Returns the number of times after t_start.
long NumOutputIntervals(const RunOptions& options);
/// The parts of CheckRunOptions that need no model, for a loader to report at the file's keys:
/// the output grid (a finite end after the start, a positive interval, at most 1e8 rows) and a
/// fixed step no longer than the output interval (0: none). Throw std::invalid_argument.
void CheckOutputGrid(double t_start, double t_end, double dt);
/// Throws std::invalid_argument for a run that reaches beyond 1e15 s (time in seconds then
/// resolves no step below 0.125 s). CheckOutputGrid calls it.
void CheckEndTime(double t_start, double t_end);
void CheckFixedStep(double fixed_step, double dt);
/// A step or interval `h` that time near `t` can resolve: a normal number (no denormal) of at least
/// 64 roundings of t. Throws std::invalid_argument naming `what` ("the output interval (--dt)").
void CheckResolvableStep(double h, double t_start, double t_end, const char* what);
/// Throws std::invalid_argument, saying what is wrong, for options that Simulate would refuse
/// (times, output interval, integrator options): a front end checks them before writing anything.
void CheckRunOptions(const CompiledModel& model, const RunOptions& options);

/// Runs the model. Throws ModelError for a declared output that names no variable and
/// std::invalid_argument for inconsistent options (CheckRunOptions); solver failures end the run
/// with kFailed.
RunSummary Simulate(const CompiledModel& model, const RunOptions& options, Observer& observer);

}  // namespace multibond
