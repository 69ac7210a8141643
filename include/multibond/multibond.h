#pragma once
/// \file
/// multibond's public C++ API (docs/api.md): load a model, set its parameters, build it, simulate
/// it in one run or step by step, read the results and events, linearise it and find its modes. Only std types cross it: Eigen, SUNDIALS,
/// yaml-cpp and the rest stay inside libmultibond. Errors are exceptions: ModelError (bad model,
/// with structured Diagnostics: file, line, column, element, code, message, hint), SolverError
/// (a failed integration step), std::invalid_argument (bad options or names).

#include <atomic>
#include <complex>
#include <cstddef>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "multibond/core/error.h"  // Diagnostic, SourceLocation, ModelError, SolverError
#include "multibond/io/limits.h"   // InputLimits
#include "multibond/version.h"     // kVersion

namespace multibond {

/// How to build a model. An unset field takes the model file's setting.
struct BuildOptions {
  std::string jit = "auto";  ///< generated C++ for the right-hand side: "auto" (when a compiler works), "on", "off"
  std::optional<bool> ideal_constraints;      ///< the file's `constraints: ideal`
  std::optional<bool> solve_algebraic_loops;  ///< the file's `algebraic_loops: solve`
};

/// How to simulate. An unset field takes the model file's `simulation:` value, else the default
/// named (the command line's `multibond run` has the same).
struct SimulationOptions {
  double t_start = 0.0;
  std::optional<double> t_end;         ///< 1 s
  std::optional<double> dt;            ///< output interval, 1e-3 s
  std::optional<std::string> solver;   ///< "bdf", "adams", "dopri5", "bs3", "srk3", "rk4"; bdf
  std::optional<double> rtol, atol;    ///< 1e-8, 1e-10
  std::optional<double> step;          ///< fixed step of rk4, dopri5, bs3, srk3; none
  std::optional<double> max_step;      ///< none
  std::optional<std::string> coordinates;  ///< "inertial" or "joint" (mechanisms; Model::Simulate only)
  std::string jacobian = "auto";       ///< bdf, adams: "auto", "dense", "sparse"
  bool project = true;                 ///< keep orientations orthonormal (and momenta on ideal constraints)
  bool all_variables = false;          ///< Simulate: a column for every effort and flow
  /// Events (docs/events.md): a contact whose rebound would fly shorter stays closed (0: a
  /// millionth of the run); more events per second of run than the limit stop it. The file's
  /// `simulation:` keys, else these defaults.
  std::optional<double> event_rest_time;        ///< 0
  std::optional<double> max_events_per_second;  ///< 1e4
  const std::atomic<bool>* stop = nullptr;  ///< set from another thread to stop a run
};

/// An event of a run (docs/events.md), as events.csv lists it.
struct Event {
  double time = 0.0;
  std::string kind;     ///< impact, stick, slip, lock, unlock, contact, separation, limit or time
  std::string element;  ///< the switching element
  std::string description;
};

/// The output of a run: columns by name ("time" first, then states, declared outputs, energy).
class Results {
 public:
  enum class Status { kOk, kFailed, kInterrupted };
  struct Summary {
    Status status = Status::kOk;
    std::string message;  ///< why the run stopped early ("" when ok)
    double t_reached = 0.0;
    long steps = 0, rhs_evals = 0;
    double wall_seconds = 0.0;
    double energy_residual = 0.0;  ///< work - stored - dissipated, relative (0 without energy account)
    std::vector<std::string> warnings;
    std::vector<Event> events;  ///< in time order
  };
  Results(std::vector<std::string> names, std::vector<std::string> units, std::vector<std::vector<double>> columns, Summary summary);

  bool ok() const { return summary_.status == Status::kOk; }
  const Summary& summary() const { return summary_; }
  const std::vector<std::string>& names() const { return names_; }
  const std::vector<std::string>& units() const { return units_; }
  std::size_t rows() const { return columns_.empty() ? 0 : columns_.front().size(); }
  /// A column; throws std::invalid_argument for an unknown name (with a did-you-mean).
  std::span<const double> column(std::string_view name) const;
  std::span<const double> times() const { return column("time"); }
  /// The column's value at time t, linearly interpolated between rows (clamped at the ends).
  double At(std::string_view name, double t) const;

 private:
  std::vector<std::string> names_, units_;
  std::vector<std::vector<double>> columns_;
  Summary summary_;
};

/// A simulation advanced step by step. It owns its integrator; moving it is cheap.
class Simulation {
 public:
  Simulation(Simulation&&) noexcept;
  Simulation& operator=(Simulation&&) noexcept;
  ~Simulation();

  double time() const;
  /// Back to t_start, the initial state and the model's inputs.
  void Reset();
  /// Integrates to t >= time(). Throws SolverError when a step fails (the state is then the last
  /// one reached), std::invalid_argument for t < time().
  void AdvanceTo(double t);

  const std::vector<std::string>& state_names() const;
  std::vector<double> state() const;
  /// Replaces the state (num states entries) and restarts the integrator at time().
  void SetState(std::span<const double> x);
  /// The value at time() of a state ("mass.p"), any effort, flow or momentum of an element
  /// ("spring.e", "j.f", "gear.f2"), one component of a vector ("A.omega.z"), or a declared output
  /// that names one variable. Throws std::invalid_argument for other names (with a did-you-mean).
  double Value(std::string_view name) const;
  /// Every component of such a variable (one entry for a scalar).
  std::vector<double> Values(std::string_view name) const;

  /// The sources (Se, Sf) whose value SetInput can set.
  std::vector<std::string> input_names() const;
  /// Holds the source at `value` (each component) from time() on. The model is rebuilt with the
  /// new value and the integrator restarted at time(), so an input changes between AdvanceTo calls.
  void SetInput(std::string_view source, double value);
  void SetInput(std::string_view source, std::span<const double> values);

 private:
  friend class Model;
  struct Impl;
  explicit Simulation(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

/// Values for a model file's top-level parameters (docs/model-format.md, "Parameters"), as
/// `multibond run --set NAME=VALUE` gives them: {name, value}, each value a number ("0.5") or a
/// formula of the other parameters ("2*L0"). They replace the file's values before anything of the
/// model is read, so every value computed from a parameter follows.
using ParameterValues = std::vector<std::pair<std::string, std::string>>;

/// A dense matrix, row-major.
struct Matrix {
  int rows = 0, cols = 0;
  std::vector<double> data;
  double operator()(int r, int c) const { return data[static_cast<std::size_t>(r) * static_cast<std::size_t>(cols) + static_cast<std::size_t>(c)]; }
};

/// A model linearised about an operating point (docs/linear-analysis.md): dz/dt = A z + B u,
/// y = C z + D u, z the state's coordinates (three angles per orientation; the independent
/// coordinates when ideal constraints hold), u every source component, y the declared outputs.
struct LinearModel {
  double at = 0.0;      ///< the operating point's time [s]
  bool steady = false;  ///< a steady state found by Newton's method
  std::vector<std::string> states, state_units, inputs, input_units, outputs, output_units;
  Matrix A, B, C, D;
  std::vector<std::string> notes;  ///< what to know about this linearisation
};

/// A mode of the linear model: a real eigenvalue of A, or a complex pair (docs/linear-analysis.md).
struct Mode {
  std::complex<double> eigenvalue;  ///< of a pair, the one with Im > 0
  double frequency_hz = 0.0;         ///< |lambda| / 2 pi
  double damped_frequency_hz = 0.0;  ///< |Im lambda| / 2 pi
  double damping_ratio = 0.0;        ///< -Re lambda / |lambda| (0 for lambda = 0)
  double time_constant_s = 0.0;      ///< -1 / Re lambda; +inf when Re lambda = 0
  /// Storage element -> share of the mode's stored energy, largest first (sums to 1; empty when
  /// the mode stores no energy).
  std::vector<std::pair<std::string, double>> participation;
  bool conjugate_pair = false;
};

/// Where to linearise: the initial state, or the state a run reaches at `at`; then, with
/// `steady`, the steady state that Newton's method finds from there (the sources held).
struct OperatingPoint {
  std::optional<double> at;
  bool steady = false;
};

/// A model: loaded from YAML (docs/model-format.md), parameters set, built, simulated.
class Model {
 public:
  /// Throws ModelError with every problem found (file:line:column, element, code, hint); an
  /// input beyond `limits` is one with the code "limit.<name>" where the loader checks it.
  /// Throws std::invalid_argument for a parameter of `parameters` that the file does not declare
  /// (with a did-you-mean) or whose value does not read.
  static Model FromFile(const std::string& path, const InputLimits& limits = {}, const ParameterValues& parameters = {});
  static Model FromString(const std::string& yaml, const std::string& file = "<string>", const InputLimits& limits = {},
                          const ParameterValues& parameters = {});
  Model(Model&&) noexcept;
  Model& operator=(Model&&) noexcept;
  ~Model();

  const std::string& name() const;
  const std::vector<Diagnostic>& warnings() const;  ///< problems that do not stop the model
  std::vector<std::string> element_names() const;
  /// The file's top-level parameters, in the order of the file, and the value of one (as loaded:
  /// the file's, or the one given to FromFile). Throws std::invalid_argument for an unknown name.
  std::vector<std::string> parameter_names() const;
  double parameter(std::string_view name) const;

  /// Sets an element's parameter: I inertia, C stiffness, R resistance, TF/GY ratio (a scalar
  /// means scalar * identity), or an Se/Sf source's constant value (every component). Unbuilds
  /// the model; the next Build checks the value (code "param.range"). Throws
  /// std::invalid_argument for an unknown element (with a did-you-mean) or one without a parameter.
  void SetParameter(std::string_view element, double value);
  /// The same with a matrix, row-major, rows x cols.
  void SetParameter(std::string_view element, std::span<const double> row_major, int rows, int cols);
  /// The initial momentum (I) or displacement (C) of an element, one entry per component.
  void SetInitial(std::string_view element, std::span<const double> values);

  /// Analyses causality and compiles the model. Throws ModelError (causality conflicts,
  /// algebraic loops, parameters out of range, ...).
  void Build(const BuildOptions& options = {});
  bool built() const;
  /// "generated code (...)" or "interpreter (...)": how the right-hand side is evaluated.
  const std::string& rhs_engine() const;
  /// The states and output columns of the built model (Build first).
  const std::vector<std::string>& state_names() const;
  std::vector<std::string> column_names(bool all_variables = false) const;

  /// Runs from t_start to t_end, keeping every output row. Builds first if needed. A solver
  /// failure or a stop ends the run with the rows until then (Results::Summary::status).
  /// Throws std::invalid_argument for options the run refuses, ModelError for a bad model.
  Results Simulate(const SimulationOptions& options = {});
  /// A simulation at t_start, to advance step by step (inertial coordinates). Builds first if needed.
  Simulation Start(const SimulationOptions& options = {});

  /// The linear model about `point` (the run to it takes `options`). Builds first if needed.
  /// Throws std::invalid_argument for a model that cannot be linearised (a solved algebraic loop)
  /// or an `at` outside the run, SolverError when the run to the point stops early,
  /// std::runtime_error when no steady state is found.
  LinearModel Linearize(const OperatingPoint& point = {}, const SimulationOptions& options = {});
  /// The modes about `point`, by frequency (the eigenvalues of A; docs/linear-analysis.md).
  std::vector<Mode> Modes(const OperatingPoint& point = {}, const SimulationOptions& options = {});

 private:
  struct Impl;
  explicit Model(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace multibond
