#pragma once
/// \file
/// A multiport C or I given by one energy function of its vector state (docs/model-format.md,
/// "Multiport storage"): a moving-plate capacitor, E(q, x) = q^2 x / (2 c0 x0), stores energy in
/// its charge q1 and its gap q2 through one bond of two components. Its efforts (an I's flows)
/// are the energy's gradient, derived symbolically (compile/symbolic.h), so Maxwell's reciprocity
/// d e_i / d q_j = d e_j / d q_i holds by construction and the energy account stores E exactly.

#include <string>
#include <vector>

#include "multibond/core/expression.h"
#include "multibond/core/graph.h"

namespace multibond {

struct MultiportEnergy {
  expr::NodePtr energy;                 ///< E, its own variables as the states #x(state + k)
  std::vector<expr::NodePtr> gradient;  ///< dE/dq_k (dE/dp_k), likewise, one per component
};

/// The energy and its gradient of the multiport element `e` (IsMultiportEnergy) whose state
/// starts at `state` in a layout whose states are named `state_names`. Its energy may name its
/// own variables (q1 ... qn, or its states' full names) and parameters; anything else (t, a
/// signal, another state) is refused with `law.energy`, as is an energy that does not depend on
/// one of its variables (that component would store nothing: a short, or a free end).
MultiportEnergy BuildMultiportEnergy(const Element& e, const std::vector<std::string>& state_names, int state);

}  // namespace multibond
