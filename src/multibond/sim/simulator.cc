#include "multibond/core/diagnostic_codes.h"
#include "multibond/sim/simulator.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <map>
#include <string>
#include <utility>
#include <optional>

#include <fmt/format.h>

#include "multibond/compile/generated_rhs.h"
#include "multibond/sim/joint_coordinates.h"

namespace multibond {

void ModelSystem::CheckFormulas(double t, const double* x, const double* xdot) {
  const int n = model_.num_states();
  bool finite = true;
  for (int i = 0; i < n; ++i) finite = finite && std::isfinite(xdot[i]);
  if (finite) return;
  for (int i = 0; i < n; ++i)
    if (!std::isfinite(x[i])) return;  // a diverging trial state: the integrator's to reject
  const std::string why = model_.DiagnoseFormulas(t, x, ws_);
  if (!why.empty()) throw FormulaFault(why);
}

namespace {

/// How to compute one output column. Built together with the column names, so that a name and
/// its value cannot drift apart. Variables, sums of variables and body points are all linear
/// combinations of state entries and workspace slots.
struct ColumnSource {
  enum class Kind { kTime, kLinear, kOrthonormality, kStored, kWork, kKinetic, kPotential, kDissipated, kResidual };
  struct Term {
    bool state;
    int offset;
    double coef;
  };
  Kind kind;
  int index = 0;  ///< element for kStored, state offset of R for kOrthonormality
  std::vector<Term> terms;
};

struct Layout {
  std::vector<Column> columns;
  std::vector<ColumnSource> sources;
  void Add(std::string name, std::string unit, ColumnSource src) {
    columns.push_back({std::move(name), unit.empty() ? "-" : std::move(unit)});
    sources.push_back(std::move(src));
  }
  /// One column per component of sum_k coef_k * var_k.
  void AddLinear(const std::string& base, const std::vector<std::pair<VariableRef, double>>& vars, const std::string& unit,
                 const std::vector<std::string>& components) {
    const VariableRef& first = vars.front().first;
    const std::vector<std::string>& comps = components.empty() ? first.components : components;
    for (int k = 0; k < first.size; ++k) {
      ColumnSource src{ColumnSource::Kind::kLinear, 0, {}};
      for (const auto& [v, c] : vars) src.terms.push_back({v.in == VariableRef::In::kState, v.offset + k, c});
      Add(comps.empty() || first.size == 1 ? base : base + "." + comps[k], unit.empty() ? first.unit : unit, std::move(src));
    }
  }
};

Layout MakeLayout(const CompiledModel& model, bool all_variables) {
  Layout l;
  l.Add("time", "s", {ColumnSource::Kind::kTime, 0, {}});
  for (int i = 0; i < model.num_states(); ++i)
    l.Add(model.state_names()[i], model.state_units()[i], {ColumnSource::Kind::kLinear, 0, {{true, i, 1.0}}});
  DiagnosticSink sink;
  auto find = [&](const OutputDecl& o, const std::string& var) -> std::optional<VariableRef> {
    auto v = model.FindVariable(var);
    if (!v)
      sink.Error(codes::kOutputUnknownVariable, o.where, o.name, fmt::format("output refers to '{}', which is no variable of the model", var),
                 "name '<element>.e' or '.f' (two-ports: .e1 .f1 .e2 .f2), '<bond>.e', '<I>.p', '<C>.q' or a state");
    return v;
  };
  for (const OutputDecl& o : model.graph().outputs()) {
    switch (o.kind) {
      case OutputDecl::Kind::kVariable:
        if (auto v = find(o, o.variable)) l.AddLinear(o.name, {{*v, 1.0}}, o.unit, o.components);
        break;
      case OutputDecl::Kind::kSum: {
        std::vector<std::pair<VariableRef, double>> vars;
        for (const auto& [var, c] : o.terms)
          if (auto v = find(o, var)) vars.push_back({*v, c});
        if (vars.size() != o.terms.size() || vars.empty()) break;
        bool same = true;
        for (const auto& [v, c] : vars) same = same && v.size == vars.front().first.size;
        if (!same) {
          sink.Error(codes::kOutputSize, o.where, o.name, "the terms of a sum output have different sizes");
          break;
        }
        l.AddLinear(o.name, vars, o.unit, o.components);
        break;
      }
      case OutputDecl::Kind::kPoint: {
        const auto r = find(o, o.position), rot = find(o, o.rotation);
        if (!r || !rot) break;
        if (r->size != 3 || rot->size != 9) {
          sink.Error(codes::kOutputSize, o.where, o.name, "a point needs a 3-component position and an orientation");
          break;
        }
        static const char* kXyz[] = {"x", "y", "z"};
        for (int i = 0; i < 3; ++i) {
          ColumnSource src{ColumnSource::Kind::kLinear, 0, {{true, r->offset + i, 1.0}}};
          for (int j = 0; j < 3; ++j) src.terms.push_back({true, rot->offset + 3 * i + j, o.point[j]});
          l.Add(o.name + "." + kXyz[i], o.unit.empty() ? r->unit : o.unit, std::move(src));
        }
        break;
      }
      case OutputDecl::Kind::kOrthonormality:
        if (const auto rot = find(o, o.rotation)) l.Add(o.name, "-", {ColumnSource::Kind::kOrthonormality, rot->offset, {}});
        break;
    }
  }
  if (all_variables) {
    for (int c = 0; c < model.num_slot_classes(); ++c) {
      const auto v = model.FindVariable(model.slot_class_name(c));
      if (v) l.AddLinear(model.slot_class_name(c), {{*v, 1.0}}, "", {});
    }
  }
  if (model.has_energy_account()) {
    for (const StateBlock& b : model.state_blocks())
      if (b.kind == StateBlock::Kind::kMomentum || b.kind == StateBlock::Kind::kDisplacement)
        l.Add(model.graph().element(b.owner).name + ".energy", "J", {ColumnSource::Kind::kStored, b.owner, {}});
    l.Add("energy.work", "J", {ColumnSource::Kind::kWork, 0, {}});
    l.Add("energy.kinetic", "J", {ColumnSource::Kind::kKinetic, 0, {}});
    l.Add("energy.potential", "J", {ColumnSource::Kind::kPotential, 0, {}});
    l.Add("energy.dissipated", "J", {ColumnSource::Kind::kDissipated, 0, {}});
    l.Add("energy.residual", "-", {ColumnSource::Kind::kResidual, 0, {}});
  }
  std::map<std::string, size_t> seen;
  for (size_t c = 0; c < l.columns.size(); ++c) {
    if (seen.emplace(l.columns[c].name, c).second) continue;
    const OutputDecl* o = nullptr;
    for (const OutputDecl& d : model.graph().outputs())
      if (l.columns[c].name.rfind(d.name, 0) == 0) o = &d;
    sink.Error(codes::kOutputDuplicate, o ? o->where : SourceLocation{}, o ? o->name : "",
               fmt::format("two output columns would both be called '{}'", l.columns[c].name),
               "rename the output (a state or variable of that name is already a column)");
  }
  sink.ThrowIfErrors();
  return l;
}

}  // namespace

std::vector<OutputCombination> DeclaredOutputs(const CompiledModel& model, std::vector<std::string>* left_out) {
  const Layout l = MakeLayout(model, /*all_variables=*/false);
  std::vector<OutputCombination> out;
  // The columns after time and the states, up to the energy account: the declared outputs.
  for (size_t c = 1 + model.num_states(); c < l.columns.size(); ++c) {
    const ColumnSource& src = l.sources[c];
    if (src.kind == ColumnSource::Kind::kOrthonormality) {
      if (left_out) left_out->push_back(l.columns[c].name);
      continue;
    }
    if (src.kind != ColumnSource::Kind::kLinear) break;
    OutputCombination o{l.columns[c].name, l.columns[c].unit, {}};
    for (const ColumnSource::Term& t : src.terms) o.terms.push_back({t.state, t.offset, t.coef});
    out.push_back(std::move(o));
  }
  return out;
}

namespace {

/// The layout as flat lists, for the output rows (5,001 of them in the differential's run): most
/// columns are one state or one workspace slot, read directly; the rest are sums of terms, or
/// computed once per row (energies, orthonormality, time).
struct RowPlan {
  struct Copy {
    int column, offset;
  };
  struct Sum {
    int column, begin, end;  ///< its terms: terms[begin, end)
  };
  std::vector<Copy> from_state, from_slot;
  std::vector<Sum> sums;
  std::vector<ColumnSource::Term> terms;
  std::vector<Copy> stored;  ///< column, and its I's or C's energy term (offset -1: none)
  std::vector<int> other;    ///< the columns computed from the row's totals

  RowPlan(const Layout& l, const CompiledModel& model) {
    for (int c = 0; c < static_cast<int>(l.sources.size()); ++c) {
      const ColumnSource& s = l.sources[c];
      if (s.kind == ColumnSource::Kind::kLinear) {
        if (s.terms.size() == 1 && s.terms[0].coef == 1.0) {
          (s.terms[0].state ? from_state : from_slot).push_back({c, s.terms[0].offset});
        } else {
          sums.push_back({c, static_cast<int>(terms.size()), static_cast<int>(terms.size() + s.terms.size())});
          terms.insert(terms.end(), s.terms.begin(), s.terms.end());
        }
      } else if (s.kind == ColumnSource::Kind::kStored) {
        stored.push_back({c, model.energy_term(s.index)});
      } else {
        other.push_back(c);
      }
    }
  }
};

/// The energy balance: (work - (stored - stored at start) - dissipated) relative to the largest
/// energy the run has handled so far (|work|, kinetic, |potential|, dissipated). For a driven run
/// whose work grows, that is the work itself; dividing by the current work instead would blow up
/// whenever a conservative source's work passes through zero. Kinetic and potential energy count
/// apart: a pendulum under gravity (its potential stored, no work) trades one for the other and
/// their sum stays at its start.
class EnergyBalance {
 public:
  explicit EnergyBalance(double stored0) : stored0_(stored0), scale_(std::abs(stored0)) {}
  double Residual(double work, double kinetic, double potential, double dissipated) {
    scale_ = std::max({scale_, std::abs(work), std::abs(kinetic), std::abs(potential), std::abs(dissipated)});
    const double stored = kinetic + potential;
    const double num = work - (stored - stored0_) - dissipated;
    // Until some energy has flowed there is nothing to balance: a body held still by friction
    // moves by rounding (1e-41 J), and that over itself would read as a residual of -1.
    if (scale_ < kNegligibleEnergy) return 0.0;
    return num / scale_;
  }
  static constexpr double kNegligibleEnergy = 1e-30;  ///< J: below any energy a model stores (a MEMS stores 1e-15 J)

 private:
  double stored0_, scale_;
};

/// More events than the run allows (RunOptions::max_events_per_second): ends it as failed.
struct EventStorm : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// The first five states whose entries in v are infinite or NaN, by name.
std::string NonFiniteNames(const CompiledModel& model, const Eigen::VectorXd& v) {
  std::string names;
  int shown = 0;
  for (int i = 0; i < v.size() && shown < 5; ++i)
    if (!std::isfinite(v[i])) names += (shown++ ? ", " : "") + model.state_names()[i];
  return names;
}

}  // namespace

const char* RunStatusName(RunStatus s) {
  switch (s) {
    case RunStatus::kOk: return "ok";
    case RunStatus::kFailed: return "failed";
    case RunStatus::kInterrupted: return "interrupted";
  }
  return "?";
}

int RecordingObserver::Index(const std::string& name) const {
  for (size_t i = 0; i < columns_.size(); ++i)
    if (columns_[i].name == name) return static_cast<int>(i);
  throw std::out_of_range("no column '" + name + "'");
}

double RecordingObserver::At(const std::string& name, double t) const {
  const int c = Index(name);
  for (size_t k = 1; k < rows_.size(); ++k) {
    if (rows_[k][0] >= t) {
      const double t0 = rows_[k - 1][0], t1 = rows_[k][0];
      const double w = t1 > t0 ? (t - t0) / (t1 - t0) : 1.0;
      return rows_[k - 1][c] + w * (rows_[k][c] - rows_[k - 1][c]);
    }
  }
  return rows_.back()[c];
}

std::vector<Column> MakeColumns(const CompiledModel& model, bool all_variables) {
  return MakeLayout(model, all_variables).columns;
}

long NumOutputIntervals(const RunOptions& options) {
  const double ratio = (options.t_end - options.t_start) / options.dt;
  return std::max(1L, static_cast<long>(std::ceil(ratio - 1e-9 * ratio)));
}

namespace {

/// "3.2 hours", "12 days": how long a number of seconds is, for a person.
std::string HumanDuration(double seconds) {
  if (seconds < 120) return fmt::format("{:.3g} seconds", seconds);
  if (seconds < 7200) return fmt::format("{:.3g} minutes", seconds / 60);
  if (seconds < 2 * 86400) return fmt::format("{:.3g} hours", seconds / 3600);
  if (seconds < 730 * 86400) return fmt::format("{:.3g} days", seconds / 86400);
  return fmt::format("{:.3g} years", seconds / (365.25 * 86400));
}

}  // namespace

void CheckEndTime(double t_start, double t_end) {
  // Time is in seconds and a double's spacing grows with it: beyond 1e15 s (31.7 million years)
  // no step below 0.125 s can be told from the next, and a run's states (a work, an angle) grow
  // past what they can hold; the integrator then fails at t = 0 with nothing said of the span.
  constexpr double kLatestTime = 1e15;
  if (std::max(std::abs(t_start), std::abs(t_end)) > kLatestTime)
    throw std::invalid_argument(fmt::format("a run to {:g} s goes beyond {:g} s ({}), where time in seconds resolves no step below "
                                            "{:g} s; run a shorter span, or write the model in a slower time unit (scale its "
                                            "parameters)", std::max(std::abs(t_start), std::abs(t_end)), kLatestTime,
                                            HumanDuration(kLatestTime), std::nextafter(kLatestTime, HUGE_VAL) - kLatestTime));
}

void CheckOutputGrid(double t_start, double t_end, double dt) {
  if (!(std::isfinite(dt) && dt > 0.0))
    throw std::invalid_argument(fmt::format("the output interval must be a finite number > 0 (got {})", dt));
  if (!std::isfinite(t_start) || !std::isfinite(t_end) || !(t_end > t_start))
    throw std::invalid_argument(fmt::format("the end time ({}) must be a finite time after the start time ({})", t_end, t_start));
  CheckEndTime(t_start, t_end);
  // Beyond this many rows the grid is a mistake (a billion 8-byte numbers per column), and the
  // count itself would overflow a long further on.
  constexpr double kMaxOutputIntervals = 1e8;
  const double ratio = (t_end - t_start) / dt;
  if (!(ratio <= kMaxOutputIntervals))
    throw std::invalid_argument(fmt::format("{:g} s of run at an output interval of {:g} s is {:.3g} output rows, more than {:g}; "
                                            "use a larger output interval (--dt)", t_end - t_start, dt, ratio, kMaxOutputIntervals));
  CheckResolvableStep(dt, t_start, t_end, "the output interval (dt)");
}

void CheckResolvableStep(double h, double t_start, double t_end, const char* what) {
  const double t = std::max(std::abs(t_start), std::abs(t_end));
  const double smallest = std::max(std::numeric_limits<double>::min(), 64 * std::numeric_limits<double>::epsilon() * t);
  if (!(h >= smallest))
    throw std::invalid_argument(fmt::format("{} of {:g} s is below what time near {:g} s can resolve ({:.3g} s): use a larger one", what,
                                            h, t, smallest));
}

void CheckFixedStep(double fixed_step, double dt) {
  if (fixed_step > dt * (1.0 + 1e-12))
    throw std::invalid_argument(fmt::format("the fixed step ({:g} s) is longer than the output interval ({:g} s): the steps end "
                                            "at every output time; use a step no longer than --dt", fixed_step, dt));
}

void CheckRunOptions(const CompiledModel& model, const RunOptions& options) {
  CheckOutputGrid(options.t_start, options.t_end, options.dt);
  if (options.code && &options.code->model() != &model)
    throw std::invalid_argument("the generated code given for the run (RunOptions::code) is another model's");
  if (options.initial_state.size() > 0 && (options.initial_state.size() != model.num_states() || !options.initial_state.allFinite()))
    throw std::invalid_argument(fmt::format("the initial state has {} entries{}, the model {} states", options.initial_state.size(),
                                            options.initial_state.allFinite() ? "" : " (not all finite)", model.num_states()));
  if (!model.switches().empty() && !options.joint_coordinates.empty())
    throw std::invalid_argument("a model with contacts or friction runs in inertial coordinates (their events are not mapped to joint coordinates)");
  if (!(options.event_rest_time >= 0.0) || !std::isfinite(options.event_rest_time))
    throw std::invalid_argument(fmt::format("the rest time of contacts must be a finite number >= 0 (got {})", options.event_rest_time));
  if (!(options.max_events_per_second > 0.0))
    throw std::invalid_argument(fmt::format("the event limit must be > 0 events per second (got {})", options.max_events_per_second));
  if (options.joint_coordinates.empty()) {
    // The pattern only for a method that forms a Newton matrix (found on request: dense n x n for a constrained model).
    CheckIntegratorOptions(model.num_states(), UsesNewtonMatrix(options.integrator.method) ? model.jacobian_pattern() : nullptr,
                           options.integrator);
  } else {
    // The integrator sees the joint-coordinate state: its own size and pattern.
    const JointCoordinateSystem chart(model, options.joint_coordinates);
    if (!options.integrator.atol_per_state.empty())
      throw std::invalid_argument("per-state absolute tolerances name the model's states, which joint coordinates replace");
    CheckIntegratorOptions(chart.num_states(), chart.jacobian_pattern(), options.integrator);
  }
  CheckFixedStep(options.integrator.fixed_step, options.dt);
  // Steps a request forces, estimated before anything runs: --solver rk4 --step 1e-12 over 5 s
  // would be 5e12 steps (weeks); the same for a --max-step that small.
  const double span = options.t_end - options.t_start;
  for (const auto& [h, what] : {std::pair{options.integrator.fixed_step, "fixed step (--step)"},
                                std::pair{options.integrator.max_step, "largest step (--max-step)"}}) {
    if (h <= 0) continue;
    CheckResolvableStep(h, options.t_start, options.t_end, fmt::format("the {}", what).c_str());
    const double steps = span / h;
    if (steps > options.max_forced_steps)
      throw std::invalid_argument(fmt::format(
          "{:g} s of run with a {} of {:g} s is {:.3g} steps, more than the limit of {:.3g} (at 1 microsecond a step, {}); use a "
          "larger step, or raise the limit with --limit steps=N",
          span, what, h, steps, options.max_forced_steps, HumanDuration(steps * 1e-6)));
  }
}

RunSummary Simulate(const CompiledModel& model, const RunOptions& options, Observer& observer) {
  CheckRunOptions(model, options);
  const auto wall_start = std::chrono::steady_clock::now();
  const Layout layout = MakeLayout(model, options.all_variables);
  ModelSystem system(model, options.stop, options.code.get());
  Workspace& ws = system.workspace();
  Eigen::VectorXd x = options.initial_state.size() > 0 ? options.initial_state : model.MakeInitialState();
  Eigen::VectorXd xdot(x.size());
  // Ideal constraints start satisfied: initial momenta are projected onto them (after the
  // switching elements' modes are known: only the constraints that hold).
  model.InitializeModes(options.t_start, x.data(), ws);
  // The signs of the state: locked at their side, or sliding (compile/sliding.cc); a locked
  // one's event lies the absolute tolerance past its surface.
  model.InitializeKinks(options.t_start, x.data(), ws, options.integrator.atol);
  if (model.has_constraints()) model.Project(options.t_start, x.data(), ws);
  // In joint coordinates the integrator advances y, and every output time maps it back to x.
  std::optional<JointCoordinateSystem> chart;
  Eigen::VectorXd y;
  if (!options.joint_coordinates.empty()) {
    chart.emplace(model, options.joint_coordinates, &system);  // its evaluations, workspace and stop flag
    y.resize(chart->num_states());
    chart->FromModel(x.data(), y.data());
  }
  Eigen::VectorXd& advanced = chart ? y : x;
  const std::vector<std::string>& advanced_names = chart ? chart->state_names() : model.state_names();
  auto integrator = chart ? MakeIntegrator(*chart, options.integrator) : MakeIntegrator(system, options.integrator);
  integrator->Reset(options.t_start, advanced.data());
  EnergyBalance balance(model.KineticEnergy(options.t_start, x.data()) + model.PotentialEnergy(options.t_start, x.data()));

  RunSummary summary;
  std::vector<double> row(layout.columns.size());
  const RowPlan plan(layout, model);
  std::vector<double> energies(model.num_energy_terms());
  const bool project = options.integrator.project && model.has_invariants();
  auto sample = [&](double t) {
    // Between steps the integrator reports an interpolant; with projection on, the reported
    // orientations are its nearest rotations, like the integrated state itself.
    if (project) model.Project(t, x.data(), ws);
    model.CalcDerivatives(t, x.data(), xdot.data(), ws);  // fills every effort and flow at (t, x)
    if (model.has_formulas())
      if (const std::string why = model.FindActiveResistor(ws); !why.empty()) throw std::runtime_error(why);
    const CompiledModel::EnergyTotals stored = model.StoredEnergies(t, x.data(), energies.data());
    const double work = model.Work(x.data()), kin = stored.kinetic, pot = stored.potential;
    const double diss = model.Dissipated(x.data());
    const double residual = balance.Residual(work, kin, pot, diss);
    for (const RowPlan::Copy& k : plan.from_state) row[k.column] = x[k.offset];
    for (const RowPlan::Copy& k : plan.from_slot) row[k.column] = ws.slots[k.offset];
    for (const RowPlan::Sum& k : plan.sums) {
      double v = 0.0;
      for (int i = k.begin; i < k.end; ++i) {
        const ColumnSource::Term& term = plan.terms[i];
        v += term.coef * (term.state ? x[term.offset] : ws.slots[term.offset]);
      }
      row[k.column] = v;
    }
    for (const RowPlan::Copy& k : plan.stored) row[k.column] = k.offset < 0 ? 0.0 : energies[k.offset];
    for (const int c : plan.other) {
      const ColumnSource& s = layout.sources[c];
      switch (s.kind) {
        case ColumnSource::Kind::kTime: row[c] = t; break;
        case ColumnSource::Kind::kOrthonormality: {
          const Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> r(x.data() + s.index);
          row[c] = (r.transpose() * r - Eigen::Matrix3d::Identity()).norm();
          break;
        }
        case ColumnSource::Kind::kWork: row[c] = work; break;
        case ColumnSource::Kind::kKinetic: row[c] = kin; break;
        case ColumnSource::Kind::kPotential: row[c] = pot; break;
        case ColumnSource::Kind::kDissipated: row[c] = diss; break;
        case ColumnSource::Kind::kResidual: row[c] = residual; break;
        case ColumnSource::Kind::kLinear:
        case ColumnSource::Kind::kStored: break;  // in the lists above
      }
    }
    summary.t_reached = t;
    summary.energy_work = work;
    summary.energy_stored = kin + pot;
    summary.energy_dissipated = diss;
    summary.energy_residual = residual;
    summary.max_abs_energy_residual = std::max(summary.max_abs_energy_residual, std::abs(summary.energy_residual));
    ++summary.samples;
    observer.OnSample(row);
  };

  observer.OnStart(layout.columns);
  // An output row evaluates the model too (an algebraic loop can have no solution there): a failure
  // ends the run like a solver failure, with what was computed until then.
  auto sample_or_fail = [&](double t) {
    try {
      sample(t);
      return true;
    } catch (const std::exception& e) {
      summary.status = RunStatus::kFailed;
      summary.message = fmt::format("at t = {:.9g} s: evaluating the outputs failed: {}", t, e.what());
      return false;
    }
  };
  bool started = sample_or_fail(options.t_start);
  // Derivatives that are already infinite or NaN at the start (parameters or initial values that
  // overflow) would only make the solver fail at a step size of zero, or at t = NaN, with its own
  // words: said here by name.
  if (started && !xdot.allFinite() && model.has_formulas() && x.allFinite()) {
    if (const std::string why = model.DiagnoseFormulas(options.t_start, x.data(), ws); !why.empty()) {
      summary.status = RunStatus::kFailed;
      summary.message = fmt::format("at t = {:.9g} s: {}", options.t_start, why);
      started = false;
    }
  }
  if (started && !xdot.allFinite()) {
    summary.status = RunStatus::kFailed;
    summary.message = fmt::format("at t = {:.9g} s: the derivatives of the initial state are not finite (infinite or NaN): {}; "
                                  "the model's parameters or initial values overflow double precision",
                                  options.t_start, NonFiniteNames(model, xdot));
    started = false;
  }
  const long n_out = NumOutputIntervals(options);
  IntegratorStats carried;
  // Events (docs/events.md): the time events (a source's or a normal force's jumps and corners,
  // where the integration stops exactly and restarts) and the switching elements' event
  // functions (located by the integrator's root finding; the model changes modes and applies
  // impacts; the integration restarts).
  // A formula's switching function of time alone is sampled at least four times per output
  // interval (KinkTable::TimeEvents).
  const std::vector<TimeEvent> time_events = model.TimeEvents(options.t_start, options.t_end, options.dt / 4);
  size_t next_time_event = 0;
  // A table's gentle corners: no step crosses one, and the integration goes on from it.
  const std::vector<double> waypoints = model.Waypoints(options.t_start, options.t_end);
  size_t next_waypoint = 0;
  std::vector<int> roots(chart ? 0 : model.num_event_functions());
  const double span = options.t_end - options.t_start;
  const double rest_time = options.event_rest_time > 0.0 ? options.event_rest_time : 1e-6 * span;
  const double max_events = std::max(1000.0, options.max_events_per_second * span);
  long num_events = 0;
  std::map<std::string, std::pair<double, long>> rested;  // contact -> (time it came to rest, impacts before)
  std::map<std::string, long> impacts;
  // The time events listed before the run (`scheduled`: a table's corners, a step, a formula of
  // time's sampled kinks) are as many as the model and the output grid make them and cannot
  // chatter: they do not count towards a storm, which guards the events the motion triggers.
  auto record = [&](const EventRecord& r, bool scheduled = false) {
    ++summary.event_counts[r.kind];
    if (r.rebound) ++impacts[r.element];
    if (r.accumulated) rested.emplace(r.element, std::pair{r.time, impacts[r.element]});
    observer.OnEvent(r);
    if (!scheduled && ++num_events > max_events)
      throw EventStorm(fmt::format("event storm: more than {:.0f} events ({:g} per second of run); the last at t = {:.9g} s, "
                                           "{} '{}'; raise the limit with --max-events-per-second, or look for chattering",
                                           max_events, options.max_events_per_second, r.time, r.kind, r.element));
  };
  std::vector<EventRecord> log;
  auto advance = [&](double tout) {
    if (time_events.empty() && waypoints.empty() && roots.empty()) {
      integrator->AdvanceTo(tout, advanced.data());
      return;
    }
    while (true) {
      // Never a step past the next time event: up to it, or to tout and no further than it.
      double target = tout;
      const double event_time = next_time_event < time_events.size() ? time_events[next_time_event].time : std::numeric_limits<double>::infinity();
      const double stop_time = std::min(event_time, next_waypoint < waypoints.size() ? waypoints[next_waypoint] : event_time);
      const bool stop = stop_time <= tout;
      if (stop) target = stop_time;
      system.set_time_event(event_time);
      const double reached = integrator->AdvanceUntil(target, stop_time, advanced.data(), roots.empty() ? nullptr : roots.data());
      if (std::any_of(roots.begin(), roots.end(), [](int r) { return r != 0; })) {
        const auto switched = roots.begin() + model.num_switch_event_functions();
        if (std::any_of(roots.begin(), switched, [](int r) { return r != 0; })) {
          log.clear();
          model.HandleEvents(reached, x.data(), ws, roots.data(), rest_time, log);
          for (const EventRecord& r : log) record(r);
        }
        // A formula's switching function changed sign: its branch changed, nothing jumps (a sign
        // the motion drives back from both sides starts to slide, or one that slid leaves); the
        // integration restarts there (below).
        std::string last_kink;  // one `kink` entry per element and time (a law and its derivative's kinks)
        for (int r = 0; r < model.kinks().num_roots(); ++r)
          if (roots[static_cast<size_t>(model.num_switch_event_functions() + r)] != 0) {
            const EventRecord e = model.HandleKink(reached, x.data(), ws, r);
            if (e.kind == "kink" && e.element == last_kink) continue;
            if (e.kind == "kink") last_kink = e.element;
            record(e);
          }
        // A restart estimates its first step anew, small: a first step as long as the last could
        // start and end on the same side of an event function (a whole rebound) and miss it.
        carried.AddCounts(integrator->stats());  // a restart zeroes the integrator's counters
        integrator->Reset(reached, advanced.data());
        continue;
      }
      if (stop)
        while (next_waypoint < waypoints.size() && waypoints[next_waypoint] <= target) ++next_waypoint;
      if (stop && target < event_time) {  // a waypoint: the step ended there, nothing restarts
        if (target < tout) continue;
        return;
      }
      if (stop) {
        for (; next_time_event < time_events.size() && time_events[next_time_event].time == target; ++next_time_event) {
          const TimeEvent& e = time_events[next_time_event];
          record({target, e.kind, e.element, e.description}, /*scheduled=*/true);
        }
        if (chart) chart->ToModel(y.data(), x.data());
        model.BookModulationJumps(target, x.data());  // a modulated storage's energy that jumps here: work
        model.Project(target, x.data(), ws);  // the constraints that hold at the restart (new targets)
        if (chart) chart->FromModel(x.data(), y.data());
        carried.AddCounts(integrator->stats());
        integrator->Reset(target, advanced.data());
        if (target < tout) continue;
      }
      return;
    }
  };
  auto last_progress = wall_start;
  for (long k = 1; started && k <= n_out; ++k) {
    const double tout = k == n_out ? options.t_end : options.t_start + static_cast<double>(k) * options.dt;
    try {
      advance(tout);
      if (chart) {
        chart->ToModel(y.data(), x.data());
        if (chart->Rechart(x.data(), y.data())) {  // a restart zeroes the integrator's counters: carried over
          carried.AddCounts(integrator->stats());
          ++summary.recharts;
          integrator->Reset(tout, y.data());
        }
      }
    } catch (const SolverError& e) {
      summary.status = RunStatus::kFailed;
      summary.message = e.what();
      if (!e.states().empty()) {
        std::string names;
        for (int i : e.states())
          if (i >= 0 && i < static_cast<int>(advanced_names.size())) names += (names.empty() ? "" : ", ") + advanced_names[i];
        summary.message += "; the states that failed first: " + names;
      }
      break;
    } catch (const RunInterrupted&) {
      summary.status = RunStatus::kInterrupted;
      summary.message = fmt::format("interrupted at t = {:.9g} s", summary.t_reached);
      break;
    } catch (const EventStorm& e) {
      summary.status = RunStatus::kFailed;
      summary.message = e.what();
      break;
    } catch (const std::exception& e) {
      summary.status = RunStatus::kFailed;
      summary.message = fmt::format("at t = {:.9g} s: the right-hand side failed: {}", integrator->time(), e.what());
      break;
    }
    if (!x.allFinite()) {
      summary.status = RunStatus::kFailed;
      summary.message = fmt::format("at t = {:.9g} s: the state is no longer finite ({})", tout, NonFiniteNames(model, x));
      break;
    }
    if (!sample_or_fail(tout)) break;
    if (k < n_out && options.stop && options.stop->load()) {  // a run that reached t_end is complete
      summary.status = RunStatus::kInterrupted;
      summary.message = fmt::format("interrupted at t = {:.9g} s", tout);
      break;
    }
    if (options.progress) {
      const auto now = std::chrono::steady_clock::now();
      if (now - last_progress > std::chrono::milliseconds(200) || k == n_out) {
        options.progress(static_cast<double>(k) / static_cast<double>(n_out));
        last_progress = now;
      }
    }
  }
  for (const auto& [element, at] : rested)
    summary.warnings.push_back(fmt::format("contact '{}': impacts accumulated (Zeno) and it came to rest at t = {:.9g} s after {} "
                                           "impacts; held in contact from there (a rebound shorter than {:g} s is not followed)",
                                           element, at.first, at.second, rest_time));
  summary.stats = integrator->stats();
  summary.stats.AddCounts(carried);
  summary.wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  // A failed run has its own message; a NaN residual is a balance that does not close too.
  if (model.has_energy_account() && summary.samples > 1 && summary.status != RunStatus::kFailed &&
      !(std::abs(summary.energy_residual) <= kEnergyResidualWarning))
    summary.warnings.push_back(fmt::format(
        "the energy balance does not close: at t = {:.9g} s, work - stored - dissipated is {:.3g} of the energy that flowed "
        "(energy.residual); the results are not accurate: {}",
        summary.t_reached, summary.energy_residual,
        options.integrator.fixed_step > 0 ? "take a smaller fixed step"
                                          : "lower rtol and atol (atol below the smallest state that matters), or try another solver"));
  observer.OnFinish(summary);
  return summary;
}

}  // namespace multibond
