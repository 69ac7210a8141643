// The switching elements (switching.h; docs/events.md): the table built from the constraints,
// the modes' prescribed multipliers and event functions, and CompiledModel's switching members:
// the initial modes, the event functions of an evaluation, and what happens at an event (a
// mode's change, an impact's jump of the storage states, the energy it dissipates).

#include "multibond/compile/switching.h"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "multibond/compile/compiled_model.h"
#include "multibond/compile/generated_rhs.h"
#include "multibond/compile/constraint_factor.h"
#include "multibond/core/diagnostic_codes.h"

namespace multibond {

const char* SwitchTable::ModeName(Mode m) {
  switch (m) {
    case kOpen: return "open";
    case kClosed: return "closed";
    case kStick: return "stick";
    case kSlipPositive: return "slip+";
    case kSlipNegative: return "slip-";
  }
  return "?";
}

void SwitchTable::Build(const BuildInput& in) {
  DiagnosticSink sink;
  for (size_t c = 0; c < in.constraints.size(); ++c) {
    const auto [element, lambda] = in.constraints[c];
    const Element& e = in.graph.element(element);
    const Switching& sw = e.switching;
    if (sw.kind == Switching::Kind::kNone) continue;
    const SourceLocation where = sw.where.line > 0 ? sw.where : e.where;
    if (in.constraint_sizes[c] != 1) {
      sink.Error(codes::kEventUnsupported, where, e.name,
                 fmt::format("a {} acts on one relative flow; this one has {} components",
                             sw.kind == Switching::Kind::kContact ? "contact" : "friction", in.constraint_sizes[c]),
                 "put it on a scalar bond: one contact or friction per direction");
      continue;
    }
    bool zero_target = e.value.empty();
    for (const TimeFunction& f : e.source.components) zero_target = zero_target && f.is_constant() && f.value == 0.0;
    if (!zero_target) {
      sink.Error(codes::kEventUnsupported, where, e.name, "a contact or friction holds a relative flow at zero: its flow must be 0",
                 "a moving surface is a flow source of its own, joined to the body through a 0-junction (docs/events.md)");
      continue;
    }
    Entry en;
    en.element = element;
    en.name = e.name;
    en.kind = sw.kind;
    en.capacity = sw.capacity;
    en.limit = sw.limit;
    en.lambda = lambda;
    en.restitution = sw.restitution;
    en.mu_s = sw.mu_s;
    en.mu_k = sw.mu_k;
    en.normal = sw.normal;
    if (!sw.normal_signal.empty()) {
      en.normal_slot = in.signal_slot(sw.normal_signal);
      if (en.normal_slot < 0)
        sink.Error(codes::kEventUnknownVariable, where, e.name, fmt::format("'{}' is no signal of the model", sw.normal_signal),
                   "the normal force or capacity is a number, a time function or a signal's name");
    }
    if (sw.kind == Switching::Kind::kContact) {
      const auto gap = in.find_variable(sw.gap);
      if (!gap || gap->size != 1) {
        sink.Error(codes::kEventUnknownVariable, where, e.name, fmt::format("the contact's gap '{}' is no scalar variable of the model", sw.gap),
                   "name a state that measures the gap (an integral of the separation velocity), or a signal");
        continue;
      }
      en.gap = *gap;
      en.gap_scale = sw.gap_scale;
      en.gap_offset = sw.gap_offset;
    }
    for (const StateBlock& b : in.blocks)
      if (b.kind == StateBlock::Kind::kDissipation && b.owner == element) en.dissipation = b.offset;
    entries_.push_back(std::move(en));
  }
  sink.ThrowIfErrors();
}

double SwitchTable::Normal(const Entry& e, double t, const double* w) const {
  return e.normal_slot >= 0 ? w[e.normal_slot] : e.normal(t);
}

void SwitchTable::Prescribe(double t, const double* w, const signed char* modes, ConstraintScratch& con) const {
  con.any_fixed = false;
  for (int i = 0; i < size(); ++i) {
    const Entry& e = entries_[i];
    const auto mode = static_cast<Mode>(modes[i]);
    const bool fixed = mode == kOpen || mode == kSlipPositive || mode == kSlipNegative;
    con.fixed[e.lambda] = fixed ? 1 : 0;
    con.fixed_value[e.lambda] =
        mode == kSlipPositive ? -e.mu_k * Normal(e, t, w) : (mode == kSlipNegative ? e.mu_k * Normal(e, t, w) : 0.0);
    con.any_fixed = con.any_fixed || fixed;
  }
}

void SwitchTable::Roots(double t, const double* x, const double* w, const double* lambda, const double* g, const signed char* modes,
                        double* out) const {
  for (int i = 0; i < size(); ++i) {
    const Entry& e = entries_[i];
    double* r = out + 2 * i;
    switch (static_cast<Mode>(modes[i])) {
      case kOpen:
        r[0] = e.gap_scale * (e.gap.in == VariableRef::In::kState ? x[e.gap.offset] : w[e.gap.offset]) + e.gap_offset;
        r[1] = 1.0;
        break;
      case kClosed:
        r[0] = 1.0;
        r[1] = lambda[e.lambda];
        break;
      case kStick: {
        const double limit = e.mu_s * Normal(e, t, w);
        r[0] = limit - lambda[e.lambda];
        r[1] = limit + lambda[e.lambda];
        break;
      }
      case kSlipPositive:
        r[0] = g[e.lambda];
        r[1] = 1.0;
        break;
      case kSlipNegative:
        r[0] = -g[e.lambda];
        r[1] = 1.0;
        break;
    }
  }
}

std::vector<std::pair<double, std::string>> SwitchTable::TimeEvents(double t0, double t1) const {
  std::vector<std::pair<double, std::string>> out;
  for (const Entry& e : entries_) {
    if (e.kind != Switching::Kind::kFriction || e.normal_slot >= 0) continue;
    for (const double b : e.normal.Breakpoints())
      if (b > t0 && b < t1) out.push_back({b, e.name});
  }
  return out;
}

// --- CompiledModel's switching members ---

void CompiledModel::BuildSwitches() {
  std::vector<std::pair<int, int>> constraints;
  std::vector<int> sizes;
  for (const ConstraintSolver::Group& g : constraints_.groups()) {
    constraints.push_back({g.element, g.lambda});
    sizes.push_back(g.size);
  }
  events_.switches.Build({graph_, std::move(constraints), std::move(sizes),
                   [this](const std::string& name) { return layout_.FindVariable(name); },
                   [this](const std::string& name) {
                     const auto it = slots_.signal_class.find(name);
                     return it == slots_.signal_class.end() ? -1 : slots_.class_offset[it->second];
                   },
                   layout_.blocks()});
  // A contact's gap that integrates the very flow its constraint holds must open with g, the
  // separation velocity: a bond turned the other way would make every approach a separation.
  for (const SwitchTable::Entry& e : events_.switches.entries()) {
    if (e.kind != Switching::Kind::kContact || e.gap.in != VariableRef::In::kState) continue;
    const ConstraintSolver::Group* group = nullptr;
    for (const ConstraintSolver::Group& g : constraints_.groups())
      if (g.lambda == e.lambda) group = &g;
    for (size_t b = 0; group && b < layout_.blocks().size(); ++b) {
      const StateBlock& blk = layout_.blocks()[b];
      if (blk.kind != StateBlock::Kind::kIntegral || e.gap.offset < blk.offset || e.gap.offset >= blk.offset + blk.size) continue;
      const StateGather& gt = layout_.gathers()[b];
      for (const auto& member : group->members)
        if (gt.flow + (e.gap.offset - blk.offset) == member.slot && member.sign * e.gap_scale < 0.0)
          throw ModelError(Diagnostic{Diagnostic::Severity::kError, graph_.element(e.element).switching.where, e.name,
                                      fmt::format("the contact's gap '{}' grows with the flow its bond says is the approach: it would "
                                                  "close while separating", graph_.element(e.element).switching.gap),
                                      fmt::format("turn the contact's bond so that it points from '{}' to the junction", e.name), {},
                                      codes::kEventDirection});
    }
  }
}

void CompiledModel::PrescribeSwitches(double t, Workspace& ws) const {
  if (!events_.switches.empty()) events_.switches.Prescribe(t, ws.slots.data(), ws.modes.data(), ws.con);
}

void CompiledModel::CalcEventFunctions(double t, const double* x, Workspace& ws, double* g) const {
  if (num_event_functions() == 0) return;
  if (events_.switches.empty()) {
    CalcDerivatives(t, x, ws.event_xdot.data(), ws);
  } else {
    std::vector<double>& xdot = ws.con.xdot;
    CalcDerivatives(t, x, xdot.data(), ws);
    std::vector<double>& values = ws.con.rhs;  // free after the solve
    constraints_.Values(t, ws.slots.data(), values.data());
    events_.switches.Roots(t, x, ws.slots.data(), ws.lambda.data(), values.data(), ws.modes.data(), g);
  }
  events_.kinks.Roots(t, x, ws.slots.data(), g + events_.switches.num_roots());
  // A locked sign: its switching function on its side, past the hysteresis; a sliding one: how
  // far its equivalent value is from the end of its range.
  for (int r = 0; !events_.slides.empty() && r < events_.kinks.num_roots(); ++r) {
    const KinkTable::Kink& k = events_.kinks.root_kink(r);
    if (k.slide < 0) continue;
    const double held = ws.slots[static_cast<size_t>(k.slide_slot) + 1];
    double& out = g[events_.switches.num_roots() + r];
    switch (ws.kink_modes[static_cast<size_t>(k.slide)]) {
      case Workspace::kLocked: out = held * out + ws.kink_hysteresis; break;
      case Workspace::kSliding: out = 1.0 - std::abs(held); break;
      default: break;
    }
  }
}

namespace {

/// The friction's mode after its relative flow reached zero, from the multiplier that would
/// hold it: stick if |lambda| <= mu_s N, else slip the way the rest of the model pushes.
SwitchTable::Mode AfterZeroCrossing(double lambda, double limit) {
  if (std::abs(lambda) <= limit * (1.0 + 1e-12)) return SwitchTable::kStick;
  // Holding it would take lambda; without it the relative flow moves against lambda's push.
  return lambda > 0.0 ? SwitchTable::kSlipNegative : SwitchTable::kSlipPositive;
}

}  // namespace

double CompiledModel::StoredEnergyTotal(const double* x) const {
  std::vector<double> per_term(num_energy_terms());
  const EnergyTotals e = StoredEnergies(x, per_term.data());
  return e.kinetic + e.potential;
}

void CompiledModel::InitializeModes(double t, double* x, Workspace& ws) const {
  if (events_.switches.empty()) return;
  std::vector<double> xdot(num_states()), values(num_multipliers());
  for (int i = 0; i < events_.switches.size(); ++i) {
    const SwitchTable::Entry& e = events_.switches.entries()[i];
    if (e.kind == Switching::Kind::kContact) {
      const double gap = e.gap.in == VariableRef::In::kState ? e.gap_scale * x[e.gap.offset] + e.gap_offset : 0.0;
      ws.modes[i] = gap > 0.0 || e.gap.in != VariableRef::In::kState ? SwitchTable::kOpen : SwitchTable::kClosed;
    } else {
      ws.modes[i] = SwitchTable::kStick;
    }
  }
  // Frictions that slide at the start slip; the others stick if they can.
  CalcDerivatives(t, x, xdot.data(), ws);
  constraints_.Values(t, ws.slots.data(), values.data());
  for (int i = 0; i < events_.switches.size(); ++i) {
    const SwitchTable::Entry& e = events_.switches.entries()[i];
    if (e.kind != Switching::Kind::kFriction) continue;
    const double g = values[e.lambda];
    if (g != 0.0) ws.modes[i] = g > 0.0 ? SwitchTable::kSlipPositive : SwitchTable::kSlipNegative;
  }
  CalcDerivatives(t, x, xdot.data(), ws);
  for (int i = 0; i < events_.switches.size(); ++i) {
    const SwitchTable::Entry& e = events_.switches.entries()[i];
    if (e.kind == Switching::Kind::kFriction && ws.modes[i] == SwitchTable::kStick)
      ws.modes[i] = AfterZeroCrossing(ws.lambda[e.lambda], e.mu_s * events_.switches.Normal(e, t, ws.slots.data()));
  }
}

double CompiledModel::ConstraintRate(double t, const double* x, Workspace& ws, int lambda) const {
  // dg/dt along the motion at (t, x): the tangent pass along (dx/dt, d/dt) read at the members.
  std::vector<double> xdot(num_states()), d(ws.slots.size()), dmod(ws.moduli.size()), rate(num_states()), out(num_multipliers());
  CalcDerivatives(t, x, xdot.data(), ws);
  TangentPass(t, x, xdot.data(), /*time=*/true, nullptr, rate.data(), ws, d, dmod);
  constraints_.ConstraintRates(d.data(), out.data());
  return out[lambda];
}

void CompiledModel::HandleEvents(double t, double* x, Workspace& ws, const int* roots, double rest_time,
                                 std::vector<EventRecord>& log) const {
  const GeneratedCode* code = Loaded(ws);
  const SourceTable sources = Sources(code ? code->values : nullptr);
  const ConstraintSolver::PlanView view = ConstraintPlan(&sources, code);
  std::vector<double> xdot(num_states()), values(num_multipliers());
  auto evaluate = [&] {
    CalcDerivatives(t, x, xdot.data(), ws);
    constraints_.Values(t, ws.slots.data(), values.data());
  };
  bool impulse = false;  // an impact changed the flows at once: slipping frictions may now slide the other way
  for (int i = 0; i < events_.switches.size(); ++i) {
    if (!roots[2 * i] && !roots[2 * i + 1]) continue;
    const SwitchTable::Entry& e = events_.switches.entries()[i];
    const auto mode = static_cast<SwitchTable::Mode>(ws.modes[i]);
    impulse = impulse || mode == SwitchTable::kOpen;
    evaluate();
    const double g = values[e.lambda], lambda = ws.lambda[e.lambda];
    EventRecord rec{t, "", e.name, ""};
    switch (mode) {
      case SwitchTable::kOpen: {
        // The gap closed: an impact. The relative flow jumps from g (approaching, < 0) to -e g,
        // the other constraints that hold kept; if the rebound's flight would be shorter than
        // rest_time (impacts accumulating: Zeno), it jumps to 0 and the contact stays closed.
        const double before = StoredEnergyTotal(x);
        double target = -e.restitution * g;
        ws.modes[i] = SwitchTable::kOpen;
        const bool plastic = g >= 0.0 || e.restitution == 0.0;
        bool accumulated = false;
        if (!plastic) {
          // The relative acceleration in free flight, at the state after a full rebound.
          std::vector<double> trial(x, x + num_states());
          constraints_.ApplyImpulse(view, t, trial.data(), ws, e.lambda, target);
          const double a = ConstraintRate(t, trial.data(), ws, e.lambda);
          accumulated = a < 0.0 && 2.0 * target / -a < rest_time;
        }
        const bool rest = plastic || accumulated;
        if (rest) target = 0.0;
        evaluate();
        constraints_.ApplyImpulse(view, t, x, ws, e.lambda, target);
        if (rest) ws.modes[i] = SwitchTable::kClosed;
        const double lost = before - StoredEnergyTotal(x);
        if (e.dissipation >= 0) x[e.dissipation] += lost;
        rec.kind = e.limit ? "limit" : (rest ? "contact" : "impact");
        rec.accumulated = accumulated;
        rec.rebound = !rest;
        if (accumulated)
          rec.description = fmt::format("closes at {:.6g} (impacts accumulate: the next rebound would last under {:g} s); "
                                        "held in contact; {:.6g} J dissipated",
                                        g, rest_time, lost);
        else if (rest)
          rec.description = fmt::format("closes at {:.6g} (restitution {:g}); held in contact; {:.6g} J dissipated", g, e.restitution, lost);
        else
          rec.description = fmt::format("relative velocity {:.6g} -> {:.6g} (restitution {:g}); {:.6g} J dissipated", g, target,
                                        e.restitution, lost);
        break;
      }
      case SwitchTable::kClosed:
        ws.modes[i] = SwitchTable::kOpen;
        rec.kind = "separation";
        rec.description = "the contact force reached zero";
        break;
      case SwitchTable::kStick: {
        ws.modes[i] = lambda > 0.0 ? SwitchTable::kSlipNegative : SwitchTable::kSlipPositive;
        rec.kind = e.capacity ? "unlock" : "slip";
        rec.description = fmt::format("the force {:.6g} reached the static limit {:.6g}", lambda,
                                      e.mu_s * events_.switches.Normal(e, t, ws.slots.data()));
        break;
      }
      case SwitchTable::kSlipPositive:
      case SwitchTable::kSlipNegative: {
        ws.modes[i] = SwitchTable::kStick;
        evaluate();
        const double hold = ws.lambda[e.lambda];
        const double limit = e.mu_s * events_.switches.Normal(e, t, ws.slots.data());
        ws.modes[i] = AfterZeroCrossing(hold, limit);
        if (ws.modes[i] == SwitchTable::kStick) {
          rec.kind = e.capacity ? "lock" : "stick";
          rec.description = fmt::format("holding takes {:.6g}, within the static limit {:.6g}", hold, limit);
        } else {
          rec.kind = "slip";
          rec.description = fmt::format("reverses: holding would take {:.6g}, beyond the static limit {:.6g}", hold, limit);
        }
        break;
      }
    }
    log.push_back(std::move(rec));
  }
  // A slipping friction whose relative flow an impact reversed (a slider rebounding from its stop)
  // slips the new way; one the impact brought to rest sticks if it can. Its flow jumped across zero
  // without crossing it, so no root reported it.
  for (int i = 0; impulse && i < events_.switches.size(); ++i) {
    const SwitchTable::Entry& e = events_.switches.entries()[i];
    const auto mode = static_cast<SwitchTable::Mode>(ws.modes[i]);
    if (e.kind != Switching::Kind::kFriction || (mode != SwitchTable::kSlipPositive && mode != SwitchTable::kSlipNegative)) continue;
    evaluate();
    const double g = values[e.lambda];
    if (mode == SwitchTable::kSlipPositive ? g > 0.0 : g < 0.0) continue;
    EventRecord rec{t, "slip", e.name, ""};
    if (g != 0.0) {
      ws.modes[i] = g > 0.0 ? SwitchTable::kSlipPositive : SwitchTable::kSlipNegative;
      rec.description = fmt::format("reversed by an impact: slides at {:.6g}", g);
    } else {
      ws.modes[i] = SwitchTable::kStick;
      evaluate();
      const double hold = ws.lambda[e.lambda];
      const double limit = e.mu_s * events_.switches.Normal(e, t, ws.slots.data());
      ws.modes[i] = AfterZeroCrossing(hold, limit);
      if (ws.modes[i] == SwitchTable::kStick) rec.kind = e.capacity ? "lock" : "stick";
      rec.description = fmt::format("stopped by an impact: holding takes {:.6g}, static limit {:.6g}", hold, limit);
    }
    log.push_back(std::move(rec));
  }
  Project(t, x, ws);  // the constraints that now hold, exactly
}

std::vector<std::string> CompiledModel::KinksAt(double t, const double* x, Workspace& ws) const {
  std::vector<std::string> out;
  if (events_.kinks.empty()) return out;
  std::vector<double> xdot(num_states());
  CalcDerivatives(t, x, xdot.data(), ws);
  constexpr double kTie = 1e-12;
  for (const KinkTable::Kink& k : events_.kinks.kinks())
    if (std::abs(expr::Run(k.program, t, x, ws.slots.data())) <= kTie)
      out.push_back(fmt::format("`{}` in {} ({} = 0 there)", k.formula, k.what, k.function));
  return out;
}

std::vector<double> CompiledModel::Waypoints(double t0, double t1) const {
  std::vector<double> out;
  for (const Instr& in : plan_.instrs) {
    if (in.op != Op::kSource) continue;
    for (int k = 0; k < in.n; ++k) {
      const TimeFunction& f = plan_.source_fns[in.coef + k];
      // One pass over a table for both kinds of corner.
      const TimeFunction::Corners c = f.kind == TimeFunction::Kind::kTable ? f.TableCorners() : TimeFunction::Corners{f.Breakpoints(), {}};
      for (const double b : c.waypoints)
        if (b > t0 && b <= t1) out.push_back(b);
      // A corner at the very end of the run: a step past it and back would interpolate across it.
      for (const double b : c.restarts)
        if (b == t1) out.push_back(b);
    }
  }
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

std::vector<TimeEvent> CompiledModel::TimeEvents(double t0, double t1, double resolution) const {
  std::vector<std::pair<double, std::string>> jumps = events_.switches.TimeEvents(t0, t1);
  for (const Instr& in : plan_.instrs) {
    if (in.op != Op::kSource) continue;
    for (int k = 0; k < in.n; ++k)
      for (const double b : plan_.source_fns[in.coef + k].Breakpoints())
        if (b > t0 && b < t1) jumps.push_back({b, graph_.element(in.element).name});
  }
  std::sort(jumps.begin(), jumps.end());
  jumps.erase(std::unique(jumps.begin(), jumps.end()), jumps.end());
  std::vector<TimeEvent> out = events_.kinks.TimeEvents(t0, t1, resolution);
  for (auto& [t, element] : jumps)
    out.push_back({t, "time", std::move(element), "a source's value or slope jumps: the integration restarts"});
  std::stable_sort(out.begin(), out.end());
  // One event per element and time: two kinks of one formula that change together (a law and the
  // derivative GiNaC wrote of it) are one restart.
  out.erase(std::unique(out.begin(), out.end(),
                        [](const TimeEvent& a, const TimeEvent& b) { return a.time == b.time && a.element == b.element && a.kind == b.kind; }),
            out.end());
  return out;
}

}  // namespace multibond
