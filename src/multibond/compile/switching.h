#pragma once
/// \file
/// The switching elements of a compiled model (docs/events.md): contacts and Coulomb friction
/// (clutches and brakes among them). Each is an ideal constraint of the ConstraintSolver, a
/// scalar Sf on a relative flow g with target 0, whose multiplier lambda its discrete mode either
/// leaves to the solver (a closed contact, a sticking friction: the constraint holds) or
/// prescribes (an open contact: 0; a slipping friction: -mu_k N sign(g)). The modes live in
/// Workspace::modes; the event functions say when a mode stops holding; CompiledModel's
/// switching members (switching.cc) change the modes and apply impacts at events.

#include <functional>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "multibond/compile/state_layout.h"
#include "multibond/core/graph.h"
#include "multibond/core/time_function.h"

namespace multibond {

struct ConstraintScratch;

/// One event of a run, as the event log (events.csv) lists it.
struct EventRecord {
  double time = 0.0;
  /// impact, stick, slip, lock, unlock, contact, separation, limit or time
  std::string kind;
  std::string element;
  std::string description;
  /// A contact that closed for good because its impacts accumulated (Zeno), not because it met
  /// plastically (restitution 0) or grazing.
  bool accumulated = false;
  /// An impact the contact rebounded from (kind impact, or limit at a joint's end stop).
  bool rebound = false;
};

class SwitchTable {
 public:
  /// A switching element's discrete state.
  enum Mode : signed char {
    kOpen = 0,      ///< contact: apart, lambda = 0
    kClosed,        ///< contact: touching, the constraint holds (lambda >= 0)
    kStick,         ///< friction: the constraint holds (|lambda| <= mu_s N)
    kSlipPositive,  ///< friction: g > 0, lambda = -mu_k N
    kSlipNegative,  ///< friction: g < 0, lambda = +mu_k N
  };
  static const char* ModeName(Mode m);

  struct Entry {
    int element = -1;
    std::string name;
    Switching::Kind kind = Switching::Kind::kNone;
    bool capacity = false;  ///< a clutch or brake: lock and unlock, not stick and slip
    bool limit = false;     ///< a joint's end stop: its impacts and closings are `limit` events
    int lambda = 0;         ///< its multiplier (Workspace::lambda)
    double restitution = 0.0, mu_s = 1.0, mu_k = 1.0;
    TimeFunction normal = TimeFunction::Constant(0.0);
    int normal_slot = -1;   ///< the normal force's signal slot, or -1 (the time function)
    VariableRef gap;        ///< contact: where its gap is read (times gap_scale, plus gap_offset)
    double gap_scale = 1.0, gap_offset = 0.0;
    int dissipation = -1;   ///< the state of what it has dissipated (energy account), or -1
  };

  /// What Build reads of the compiled model: the graph, each constraint's element and
  /// multiplier, the variables' lookup, the signals' slots, the state blocks. Throws ModelError
  /// (`event.unsupported`, `name.unknown`) for a switching element it cannot make.
  struct BuildInput {
    const BondGraph& graph;
    std::vector<std::pair<int, int>> constraints;  ///< (element, multiplier offset) of each scalar constraint
    std::vector<int> constraint_sizes;             ///< parallel: the constraint's size
    std::function<std::optional<VariableRef>(const std::string&)> find_variable;
    std::function<int(const std::string&)> signal_slot;  ///< a signal's slot, or -1
    const std::vector<StateBlock>& blocks;
  };
  void Build(const BuildInput& in);

  bool empty() const { return entries_.empty(); }
  int size() const { return static_cast<int>(entries_.size()); }
  const std::vector<Entry>& entries() const { return entries_; }
  /// Two event functions per element (Roots).
  int num_roots() const { return 2 * size(); }

  /// N (or the capacity) of a friction element at t; `w` the slots (a signal's value).
  double Normal(const Entry& e, double t, const double* w) const;
  /// The multipliers the modes prescribe into the solver's mask (ConstraintScratch::fixed).
  void Prescribe(double t, const double* w, const signed char* modes, ConstraintScratch& con) const;
  /// The event functions, each > 0 while its element's mode holds, from an evaluation at (t, x):
  /// slots w, multipliers lambda, constraint values g (per multiplier). Per element:
  /// open contact: (gap, 1); closed: (1, lambda); stick: (mu_s N - lambda, mu_s N + lambda);
  /// slip: (s g, 1), s the slip's sign. No allocation.
  void Roots(double t, const double* x, const double* w, const double* lambda, const double* g, const signed char* modes,
             double* out) const;
  /// The times in (t0, t1) where a normal force or capacity jumps or kinks, with its element.
  std::vector<std::pair<double, std::string>> TimeEvents(double t0, double t1) const;

 private:
  std::vector<Entry> entries_;
};

}  // namespace multibond
