#pragma once
/// \file
/// Causality assignment by the Sequential Causality Assignment Procedure (SCAP) with priorities:
///  0. two-ports that can only work one way (non-square or singular moduli, e.g. a lever arm),
///  1. sources, 2. storage elements in integral causality, 3. resistors,
///  4. bonds still open (zero-order causal paths), each followed by propagation through
///     junctions, TF/MTF and GY/MGY.
/// Every assignment records why it was made, so that a conflict (derivative causality, two
/// sources fighting over a junction) is explained by the causal path that forced it.

#include <string>
#include <vector>

#include "multibond/core/graph.h"
#include "multibond/core/structure.h"

namespace multibond {

struct CausalAssignment {
  enum class Why { kUnset, kForcedTwoPort, kSource, kStorage, kResistor, kArbitrary, kPropagated };
  struct Reason {
    Why why = Why::kUnset;
    int element = -1;        ///< element that set the bond's causality
    int trigger_bond = -1;   ///< for kPropagated: the bond whose causality implied this one
  };

  /// Per bond: the causal stroke is at the head, i.e. the tail element imposes the effort on the
  /// head element (which in turn imposes the flow on the tail).
  std::vector<bool> stroke_at_head;
  std::vector<Reason> reason;
  /// Storage elements in derivative causality, with a diagnostic each in `diagnostics`.
  std::vector<int> derivative;
  /// Derivative causality, conflicts (errors) and arbitrary choices (warnings).
  std::vector<Diagnostic> diagnostics;

  bool integral() const { return derivative.empty(); }
  bool has_errors() const;
  /// True if `element` receives its effort through `bond` (the stroke is at its end).
  bool EffortInto(const BondGraph& g, int bond, int element) const;
  /// The elements of the causal path that decided `bond`, from its origin (a source, a storage
  /// element, ...) to the element that set it.
  std::vector<int> PathTo(int bond) const;
};

/// Assigns causality to every bond of `g` (whose structure must have been analysed without
/// errors). Never throws for modelling problems: they are in the result's diagnostics.
CausalAssignment AssignCausality(const BondGraph& g, const Structure& s);

/// "Sf 'drive' -> 1 'G.w' -> TF 'mesh' -> I 'A.J'".
std::string FormatPath(const BondGraph& g, const std::vector<int>& elements);
/// "I 'mass'".
std::string Describe(const BondGraph& g, int element);

}  // namespace multibond
