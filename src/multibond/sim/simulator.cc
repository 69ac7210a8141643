#include "multibond/sim/simulator.h"

#include <chrono>
#include <cmath>

#include <fmt/format.h>

namespace multibond {

namespace {

/// How to compute one output column. Built together with the column names, so that a name and
/// its value cannot drift apart.
struct ColumnSource {
  enum class Kind { kTime, kState, kSlot, kStored, kWork, kKinetic, kPotential, kDissipated, kResidual };
  Kind kind;
  int index = 0;  ///< state or slot offset, or element for kStored
};

struct Layout {
  std::vector<Column> columns;
  std::vector<ColumnSource> sources;
  void Add(std::string name, std::string unit, ColumnSource src) {
    columns.push_back({std::move(name), unit.empty() ? "-" : std::move(unit)});
    sources.push_back(src);
  }
  void AddVariable(const std::string& base, const VariableRef& v) {
    const auto kind = v.in == VariableRef::In::kState ? ColumnSource::Kind::kState : ColumnSource::Kind::kSlot;
    for (int k = 0; k < v.size; ++k)
      Add(v.components.empty() ? base : base + "." + v.components[k], v.unit, {kind, v.offset + k});
  }
};

Layout MakeLayout(const CompiledModel& model, bool all_variables) {
  Layout l;
  l.Add("time", "s", {ColumnSource::Kind::kTime});
  for (int i = 0; i < model.num_states(); ++i)
    l.Add(model.state_names()[i], model.state_units()[i], {ColumnSource::Kind::kState, i});
  DiagnosticSink sink;
  for (const OutputDecl& o : model.graph().outputs()) {
    const auto v = model.FindVariable(o.variable);
    if (!v) {
      sink.Error(o.where, o.name, fmt::format("output refers to '{}', which is no variable of the model", o.variable),
                 "name '<element>.e' or '.f' (two-ports: .e1 .f1 .e2 .f2), '<I>.p', '<C>.q' or a state");
      continue;
    }
    l.AddVariable(o.name, *v);
  }
  sink.ThrowIfErrors();
  if (all_variables) {
    for (int c = 0; c < model.num_slot_classes(); ++c) {
      const auto v = model.FindVariable(model.slot_class_name(c));
      if (v) l.AddVariable(model.slot_class_name(c), *v);
    }
  }
  if (model.has_energy_account()) {
    for (const StateBlock& b : model.state_blocks())
      if (b.kind == StateBlock::Kind::kMomentum || b.kind == StateBlock::Kind::kDisplacement)
        l.Add(model.graph().element(b.owner).name + ".energy", "J", {ColumnSource::Kind::kStored, b.owner});
    l.Add("energy.work", "J", {ColumnSource::Kind::kWork});
    l.Add("energy.kinetic", "J", {ColumnSource::Kind::kKinetic});
    l.Add("energy.potential", "J", {ColumnSource::Kind::kPotential});
    l.Add("energy.dissipated", "J", {ColumnSource::Kind::kDissipated});
    l.Add("energy.residual", "-", {ColumnSource::Kind::kResidual});
  }
  return l;
}

/// (work - (stored - stored at start) - dissipated), relative to the larger of |work| and the
/// energy stored at the start (the plain energy error when both are zero).
double Residual(double work, double stored, double stored0, double dissipated) {
  const double num = work - (stored - stored0) - dissipated;
  const double scale = std::max(std::abs(work), std::abs(stored0));
  return scale > 0.0 ? num / scale : num;
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

RunSummary Simulate(const CompiledModel& model, const RunOptions& options, Observer& observer) {
  if (!(options.dt > 0.0)) throw std::invalid_argument(fmt::format("the output interval must be > 0 (got {})", options.dt));
  if (!(options.t_end > options.t_start))
    throw std::invalid_argument(fmt::format("the end time ({}) must be after the start time ({})", options.t_end, options.t_start));
  const auto wall_start = std::chrono::steady_clock::now();
  const Layout layout = MakeLayout(model, options.all_variables);
  ModelSystem system(model);
  Workspace& ws = system.workspace();
  Eigen::VectorXd x = model.MakeInitialState();
  Eigen::VectorXd xdot(x.size());
  auto integrator = MakeIntegrator(system, options.integrator);
  integrator->Reset(options.t_start, x.data());
  const double stored0 = model.KineticEnergy(x.data()) + model.PotentialEnergy(x.data());

  RunSummary summary;
  std::vector<double> row(layout.columns.size());
  auto sample = [&](double t) {
    model.CalcDerivatives(t, x.data(), xdot.data(), ws);  // fills every effort and flow at (t, x)
    const double work = model.Work(x.data()), kin = model.KineticEnergy(x.data());
    const double pot = model.PotentialEnergy(x.data()), diss = model.Dissipated(x.data());
    for (size_t c = 0; c < row.size(); ++c) {
      const ColumnSource& s = layout.sources[c];
      switch (s.kind) {
        case ColumnSource::Kind::kTime: row[c] = t; break;
        case ColumnSource::Kind::kState: row[c] = x[s.index]; break;
        case ColumnSource::Kind::kSlot: row[c] = ws.slots[s.index]; break;
        case ColumnSource::Kind::kStored: row[c] = model.StoredEnergy(s.index, x.data()); break;
        case ColumnSource::Kind::kWork: row[c] = work; break;
        case ColumnSource::Kind::kKinetic: row[c] = kin; break;
        case ColumnSource::Kind::kPotential: row[c] = pot; break;
        case ColumnSource::Kind::kDissipated: row[c] = diss; break;
        case ColumnSource::Kind::kResidual: row[c] = Residual(work, kin + pot, stored0, diss); break;
      }
    }
    summary.t_reached = t;
    summary.energy_work = work;
    summary.energy_stored = kin + pot;
    summary.energy_dissipated = diss;
    summary.energy_residual = Residual(work, kin + pot, stored0, diss);
    summary.max_abs_energy_residual = std::max(summary.max_abs_energy_residual, std::abs(summary.energy_residual));
    ++summary.samples;
    observer.OnSample(row);
  };

  observer.OnStart(layout.columns);
  sample(options.t_start);
  const long n_out = std::max(1L, std::lround((options.t_end - options.t_start) / options.dt));
  auto last_progress = wall_start;
  for (long k = 1; k <= n_out; ++k) {
    const double tout = k == n_out ? options.t_end : options.t_start + static_cast<double>(k) * options.dt;
    try {
      integrator->AdvanceTo(tout, x.data());
    } catch (const SolverError& e) {
      summary.status = RunStatus::kFailed;
      summary.message = e.what();
      break;
    } catch (const std::exception& e) {
      summary.status = RunStatus::kFailed;
      summary.message = fmt::format("at t = {:.9g} s: the right-hand side failed: {}", integrator->time(), e.what());
      break;
    }
    if (!x.allFinite()) {
      std::string names;
      int shown = 0;
      for (int i = 0; i < x.size() && shown < 5; ++i)
        if (!std::isfinite(x[i])) names += (shown++ ? ", " : "") + model.state_names()[i];
      summary.status = RunStatus::kFailed;
      summary.message = fmt::format("at t = {:.9g} s: the state is no longer finite ({})", tout, names);
      break;
    }
    sample(tout);
    if (options.stop && options.stop->load()) {
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
  summary.stats = integrator->stats();
  summary.wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  observer.OnFinish(summary);
  return summary;
}

}  // namespace multibond
