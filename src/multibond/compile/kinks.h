#pragma once
/// \file
/// The kinks and switches of formulas (docs/events.md, "Kinks and switches in formulas"): every
/// call of a function that is not smooth (`abs`, `sign`, `min`, `max`, `clamp`, and the
/// comparisons and `if`) has a switching function, the argument whose sign decides the branch
/// (`x` of abs(x), `a - b` of max(a, b) and of a < b, `x - lo` and `x - hi` of clamp(x, lo, hi)). The
/// integrators must not step across a change of branch, where the right-hand side or its
/// derivative jumps: a switching function of time alone gives time events, found ahead of the
/// integration (KinkTable::TimeEvents), where the integration stops exactly and restarts; any
/// other is an event function of the root finder (KinkTable::Roots), which stops the
/// integration where it changes sign, either way, so that it restarts there. Each such event is
/// a `kink` entry of the event log.

#include <string>
#include <utility>
#include <vector>

#include "multibond/compile/expr_program.h"
#include "multibond/core/expression.h"

namespace multibond {

/// A time event of a run: where the integration must stop exactly and restart.
struct TimeEvent {
  double time = 0.0;
  std::string kind;     ///< "time" (a source's jump or corner) or "kink" (a formula's switching function of t)
  std::string element;  ///< the element, signal or state whose value jumps or kinks
  std::string description;
  bool operator<(const TimeEvent& o) const { return time < o.time || (time == o.time && element < o.element); }
};

/// The switching functions of a node of a formula's tree: none for a smooth node; the argument
/// of abs and sign; a - b for min and max and for each comparison a < b, a == b, ...; x - lo and
/// x - hi for clamp; a number used as a truth value (the condition of `if`, an operand of `and`,
/// `or`, `not` that is no comparison) itself. Each is a new tree over the call's own arguments.
std::vector<expr::NodePtr> SwitchingFunctions(const expr::Node& node);

class KinkTable {
 public:
  struct Kink {
    std::string owner;     ///< the element, signal or state whose formula it is in
    std::string what;      ///< "the effort of push"
    std::string formula;   ///< the formula as written (or as the engine wrote it, readable)
    std::string function;  ///< the switching function, readable: "(t - 0.5)/0.1 - 1"
    expr::Program program; ///< the switching function's program
    bool time_only = false;  ///< reads t and constants only: its changes are time events
    /// A `sign` of the state (compile/sliding.cc): the first of its two workspace slots, m and
    /// s, the formula's sign(x) compiled as sign(x)*m + s (m = 1, s = 0 off a sliding surface; m =
    /// 0, s = the equivalent value on it); -1 for every other kink.
    int slide_slot = -1;
    int slide = -1;  ///< its index among the kinks that may slide (Workspace::kink_modes), or -1
  };

  /// Adds a switching function unless an equal one of the same owner is already there (a
  /// formula compiled twice, a transformer's ratio in both of its equations). Constant switching
  /// functions (of parameters only) are dropped: their branch never changes.
  /// Returns its index (or that of the equal one), -1 for a constant one.
  int Add(Kink kink);
  /// Gives kink `k` its slide slots (Kink::slide_slot).
  void SetSlideSlot(int k, int slot, int slide) {
    kinks_[static_cast<size_t>(k)].slide_slot = slot;
    kinks_[static_cast<size_t>(k)].slide = slide;
  }

  bool empty() const { return kinks_.empty(); }
  const std::vector<Kink>& kinks() const { return kinks_; }
  /// The switching functions that are event functions of the root finder (all but those of time
  /// alone), in the order of Roots.
  int num_roots() const { return static_cast<int>(roots_.size()); }
  const Kink& root_kink(int r) const { return kinks_[static_cast<size_t>(roots_[static_cast<size_t>(r)])]; }
  /// The event functions at (t, x) with the workspace slots w of an evaluation there. No allocation.
  void Roots(double t, const double* x, const double* w, double* out) const;
  /// The times in (t0, t1) where a switching function of time alone changes sign (a touch of
  /// zero is none): each the first double at which it has left the side it was on, found
  /// by sampling at most `resolution` apart (and at least 4,096 samples over the span, at most
  /// 4 million) and bisection to adjacent doubles; a sampling interval in which the function
  /// turns (its derivative changes sign) is searched at its extremum too, so that a function
  /// that touches or crosses zero twice between two samples is found.
  std::vector<TimeEvent> TimeEvents(double t0, double t1, double resolution) const;
  /// "max(f, 0) in the effort law of damper: f changes sign" for an event's log entry.
  static std::string Describe(const Kink& k);

 private:
  std::vector<Kink> kinks_;
  std::vector<int> roots_;  ///< indices of the kinks that are root functions
};

}  // namespace multibond
