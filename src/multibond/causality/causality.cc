#include "multibond/causality/causality.h"
#include "multibond/core/diagnostic_codes.h"

#include <algorithm>
#include <deque>

#include <fmt/format.h>

namespace multibond {

namespace {

class Scap {
 public:
  Scap(const BondGraph& g, const Structure& s) : g_(g), s_(s) {
    r_.stroke_at_head.assign(g.num_bonds(), false);
    r_.reason.assign(g.num_bonds(), {});
  }

  CausalAssignment Run() {
    // 0. Two-ports whose modulus cannot be inverted work in one direction only.
    for (int i = 0; i < g_.num_elements(); ++i) {
      const Element& e = g_.element(i);
      if (!IsTwoPort(e.kind) || Invertible(i)) continue;
      const bool gyrator = e.kind == ElementKind::kGY || e.kind == ElementKind::kMGY;
      // Forward: flow in at port 1, so the two-port imposes the effort there; TF passes the flow
      // on (receives effort at port 2), GY turns it into an effort (imposes effort at port 2).
      Assign(s_.port_in[i], i, false, {CausalAssignment::Why::kForcedTwoPort, i, -1});
      Assign(s_.port_out[i], i, !gyrator, {CausalAssignment::Why::kForcedTwoPort, i, -1});
      Propagate();
    }
    // 1. Sources.
    for (int i = 0; i < g_.num_elements(); ++i) {
      const Element& e = g_.element(i);
      if (!IsSource(e.kind)) continue;
      Assign(e.bonds.front(), i, e.kind == ElementKind::kSf, {CausalAssignment::Why::kSource, i, -1});
      Propagate();
    }
    // 2. Storage in integral causality, in the order of declaration.
    for (int i = 0; i < g_.num_elements(); ++i) {
      const Element& e = g_.element(i);
      if (!IsStorage(e.kind) || Known(e.bonds.front())) continue;
      Assign(e.bonds.front(), i, e.kind == ElementKind::kI, {CausalAssignment::Why::kStorage, i, -1});
      Propagate();
    }
    // 3. Resistors: resistance causality (flow in, effort out) by default.
    for (int i = 0; i < g_.num_elements(); ++i) {
      const Element& e = g_.element(i);
      if (e.kind != ElementKind::kR || Known(e.bonds.front())) continue;
      Assign(e.bonds.front(), i, false, {CausalAssignment::Why::kResistor, i, -1});
      Propagate();
    }
    // 4. Whatever is left is decided by the junction structure alone.
    for (int b = 0; b < g_.num_bonds(); ++b) {
      if (Known(b)) continue;
      const Bond& bond = g_.bond(b);
      Diagnostic d;
      d.severity = Diagnostic::Severity::kWarning;
      d.code = codes::kCausalityArbitrary;
      d.where = bond.where;
      d.element = bond.name;
      d.message = "causality of this bond is not fixed by any source, storage or resistor; chosen arbitrarily";
      d.hint = "a loop of junctions and transformers with no storage or resistor in it usually means a redundant connection";
      r_.diagnostics.push_back(d);
      Assign(b, bond.to, true, {CausalAssignment::Why::kArbitrary, bond.from, -1});
      Propagate();
    }
    // Storage elements that ended up in derivative causality.
    for (int i = 0; i < g_.num_elements(); ++i) {
      const Element& e = g_.element(i);
      if (!IsStorage(e.kind)) continue;
      const int b = e.bonds.front();
      const bool integral = r_.EffortInto(g_, b, i) == (e.kind == ElementKind::kI);
      if (!integral) ReportDerivative(i, b);
    }
    return std::move(r_);
  }

 private:
  bool Known(int b) const { return r_.reason[b].why != CausalAssignment::Why::kUnset; }

  bool Invertible(int i) const {
    const Element& e = g_.element(i);
    if (e.kind == ElementKind::kMTF || e.kind == ElementKind::kMGY) return e.modulus.invertible();
    if (!e.value.empty()) return true;  // a ratio given by a formula: divided by when run backward
    if (e.param.is_scalar) return e.param.scalar != 0.0;
    const Eigen::MatrixXd& m = e.param.matrix;
    return m.rows() == m.cols() && Eigen::FullPivLU<Eigen::MatrixXd>(m).isInvertible();
  }

  /// Sets bond b so that `element` does (effort_into) or does not receive the effort through it.
  void Assign(int b, int element, bool effort_into, CausalAssignment::Reason why) {
    const bool head = (g_.bond(b).to == element) == effort_into;
    if (Known(b)) {
      if (r_.stroke_at_head[b] != head) ReportConflict(b, why);
      return;
    }
    r_.stroke_at_head[b] = head;
    r_.reason[b] = why;
    queue_.push_back(g_.bond(b).from);
    queue_.push_back(g_.bond(b).to);
  }

  void Propagate() {
    while (!queue_.empty()) {
      const int i = queue_.front();
      queue_.pop_front();
      const Element& e = g_.element(i);
      if (IsJunction(e.kind)) PropagateJunction(i);
      else if (IsTwoPort(e.kind)) PropagateTwoPort(i);
    }
  }

  // A 0-junction receives its effort through exactly one bond; a 1-junction its flow.
  void PropagateJunction(int j) {
    const Element& e = g_.element(j);
    // The "strong" bond: effort in for a 0-junction, flow in (effort out) for a 1-junction.
    const bool strong_is_effort_into = e.kind == ElementKind::kZero;
    std::vector<int> strong;
    int unknown = 0, last_unknown = -1, last_known = -1;
    for (int b : e.bonds) {
      if (!Known(b)) {
        ++unknown;
        last_unknown = b;
      } else {
        last_known = b;
        if (r_.EffortInto(g_, b, j) == strong_is_effort_into) strong.push_back(b);
      }
    }
    if (strong.size() > 1) {
      if (reported_junctions_.insert(j)) ReportJunctionConflict(j, strong);
      return;
    }
    if (strong.size() == 1) {
      for (int b : e.bonds)
        if (!Known(b)) Assign(b, j, !strong_is_effort_into, {CausalAssignment::Why::kPropagated, j, strong.front()});
    } else if (unknown == 1) {
      Assign(last_unknown, j, strong_is_effort_into, {CausalAssignment::Why::kPropagated, j, last_known});
    } else if (unknown == 0 && reported_junctions_.insert(j)) {
      Diagnostic d;
      d.where = e.where;
      d.element = e.name;
      d.code = codes::kCausalityUndetermined;
      d.message = fmt::format("causal conflict: no bond of {} determines its common {}", Describe(g_, j),
                              e.kind == ElementKind::kZero ? "effort" : "flow");
      for (int b : e.bonds) d.details.push_back("path: " + FormatPath(g_, r_.PathTo(b)));
      d.hint = e.kind == ElementKind::kZero ? "one element on a 0-junction must set the effort (a C, an Se or an I through a 1-junction)"
                                            : "one element on a 1-junction must set the flow (an I, an Sf or a C through a 0-junction)";
      r_.diagnostics.push_back(d);
    }
  }

  void PropagateTwoPort(int i) {
    const Element& e = g_.element(i);
    const int in = s_.port_in[i], out = s_.port_out[i];
    const bool gyrator = e.kind == ElementKind::kGY || e.kind == ElementKind::kMGY;
    // TF: effort passes through (into one port, out of the other); GY: effort into both or neither.
    if (Known(in) && !Known(out)) {
      const bool into = r_.EffortInto(g_, in, i);
      Assign(out, i, gyrator ? into : !into, {CausalAssignment::Why::kPropagated, i, in});
    } else if (Known(out) && !Known(in)) {
      const bool into = r_.EffortInto(g_, out, i);
      Assign(in, i, gyrator ? into : !into, {CausalAssignment::Why::kPropagated, i, out});
    } else if (Known(in) && Known(out)) {
      const bool a = r_.EffortInto(g_, in, i), b = r_.EffortInto(g_, out, i);
      if ((gyrator ? a != b : a == b) && reported_junctions_.insert(i)) {
        Diagnostic d;
        d.where = e.where;
        d.element = e.name;
        d.code = codes::kCausalityConflict;
        d.message = fmt::format("causal conflict at {}: both ports are given the {}", Describe(g_, i), a ? "effort" : "flow");
        d.details.push_back("port 1: " + FormatPath(g_, r_.PathTo(in)));
        d.details.push_back("port 2: " + FormatPath(g_, r_.PathTo(out)));
        d.hint = "one side of a transformer must set the flow and the other the effort";
        r_.diagnostics.push_back(d);
      }
    }
  }

  void ReportConflict(int b, const CausalAssignment::Reason& why) {
    // Conflicts at junctions and two-ports are reported by their own rules; here a source or a
    // forced two-port wants a bond that another one already decided.
    if (why.why == CausalAssignment::Why::kPropagated) return;
    if (!reported_bonds_.insert(b)) return;
    const std::vector<int> other = r_.PathTo(b);
    const ElementKind k = g_.element(why.element).kind;
    const char* var = k == ElementKind::kSe ? "effort" : k == ElementKind::kSf ? "flow" : "causality";
    Diagnostic d;
    d.where = g_.element(why.element).where;
    d.element = g_.element(why.element).name;
    d.code = codes::kCausalityConflict;
    d.message = fmt::format("causal conflict: {} and {} both impose the {} on {}", Describe(g_, why.element),
                            Describe(g_, other.front()), var, Describe(g_, g_.Other(b, why.element)));
    d.details.push_back("already imposed by: " + FormatPath(g_, other));
    r_.diagnostics.push_back(d);
  }

  void ReportJunctionConflict(int j, const std::vector<int>& strong) {
    const Element& e = g_.element(j);
    const bool zero = e.kind == ElementKind::kZero;
    Diagnostic d;
    d.where = e.where;
    d.element = e.name;
    d.code = codes::kCausalityConflict;
    d.message = fmt::format("causal conflict at {}: {} bonds impose its common {}", Describe(g_, j), strong.size(), zero ? "effort" : "flow");
    for (int b : strong) d.details.push_back("path: " + FormatPath(g_, r_.PathTo(b)));
    d.hint = zero ? "two effort sources (or an effort source and a C) on one 0-junction: put an R or a C between them"
                  : "two flow sources (or a flow source and an I) on one 1-junction: put an R or a C between them";
    r_.diagnostics.push_back(d);
  }

  void ReportDerivative(int i, int b) {
    const Element& e = g_.element(i);
    r_.derivative.push_back(i);
    std::vector<int> path = r_.PathTo(b);
    path.push_back(i);
    // The element that fixes the storage's variable: the last two-port on the path, if any.
    int via = -1;
    for (size_t k = 0; k + 1 < path.size(); ++k)
      if (IsTwoPort(g_.element(path[k]).kind)) via = static_cast<int>(k);
    const int origin = path.front();
    Diagnostic d;
    d.where = e.where;
    d.element = e.name;
    d.code = codes::kCausalityDerivative;
    const char* var = e.kind == ElementKind::kI ? "flow" : "effort";
    if (via >= 0)
      d.message = fmt::format("derivative causality at {}: its {} is fixed by {} from {}", Describe(g_, i), var,
                              Describe(g_, path[via]), Describe(g_, origin));
    else
      d.message = fmt::format("derivative causality at {}: its {} is fixed by {}", Describe(g_, i), var, Describe(g_, origin));
    d.details.push_back("path: " + FormatPath(g_, path));
    if (via >= 0 && via + 1 < static_cast<int>(path.size())) {
      d.hint = fmt::format("add a compliant coupling (a C and an R on a 1-junction, joined through a 0-junction) in the bond "
                           "between {} and {}", Describe(g_, path[via]), Describe(g_, path[via + 1]));
    } else if (IsSource(g_.element(origin).kind)) {
      // A source, not a second storage element, fixes the variable: the hints below ("merge the
      // two inertias/compliances into one") made no sense here (tests/models/bad/causality_source_*).
      d.hint = e.kind == ElementKind::kI
                   ? fmt::format("{} imposes the flow of {}: drive it with an effort source (Se) instead, or put a compliant "
                                 "coupling (C and R on a 1-junction, joined through a 0-junction) between them",
                                 Describe(g_, origin), Describe(g_, i))
                   : fmt::format("{} imposes the effort on {}: drive it with a flow source (Sf) instead, or put a resistor "
                                 "or inertia between them", Describe(g_, origin), Describe(g_, i));
    } else if (e.kind == ElementKind::kI) {
      d.hint = fmt::format("{} shares its flow with {}: give it its own 1-junction joined to the other through a "
                           "compliant coupling (C and R), or merge the two inertias into one",
                           Describe(g_, i), Describe(g_, origin));
    } else {
      d.hint = fmt::format("{} shares its effort with {}: put a resistor or inertia between them, or merge the two "
                           "compliances into one", Describe(g_, i), Describe(g_, origin));
    }
    r_.diagnostics.push_back(d);
  }

  /// A small set without allocation noise for the handful of reported items.
  struct ReportedSet {
    std::vector<int> items;
    bool insert(int i) {
      if (std::find(items.begin(), items.end(), i) != items.end()) return false;
      items.push_back(i);
      return true;
    }
  };

  const BondGraph& g_;
  const Structure& s_;
  CausalAssignment r_;
  std::deque<int> queue_;
  ReportedSet reported_junctions_, reported_bonds_;
};

}  // namespace

bool CausalAssignment::has_errors() const {
  for (const auto& d : diagnostics)
    if (d.severity == Diagnostic::Severity::kError) return true;
  return false;
}

bool CausalAssignment::EffortInto(const BondGraph& g, int bond, int element) const {
  const Bond& b = g.bond(bond);
  return stroke_at_head[bond] ? b.to == element : b.from == element;
}

std::vector<int> CausalAssignment::PathTo(int bond) const {
  std::vector<int> reversed;
  int b = bond;
  for (size_t guard = 0; b >= 0 && guard <= reason.size(); ++guard) {
    reversed.push_back(reason[b].element);
    b = reason[b].why == Why::kPropagated ? reason[b].trigger_bond : -1;
  }
  return {reversed.rbegin(), reversed.rend()};
}

std::string Describe(const BondGraph& g, int element) {
  const Element& e = g.element(element);
  return fmt::format("{} '{}'", KindName(e.kind), e.name);
}

std::string FormatPath(const BondGraph& g, const std::vector<int>& elements) {
  std::string out;
  for (int e : elements) {
    if (e < 0) continue;
    if (!out.empty()) out += " -> ";
    out += Describe(g, e);
  }
  return out;
}

CausalAssignment AssignCausality(const BondGraph& g, const Structure& s) { return Scap(g, s).Run(); }

}  // namespace multibond
