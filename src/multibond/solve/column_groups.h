#pragma once
/// \file
/// Groups of a Jacobian's columns that share no row, so that one evaluation of f, with every
/// state of a group perturbed at once, gives all their difference quotients (Curtis, Powell and
/// Reid, 1974). Internal to solve/.

#include <vector>

#include "multibond/core/ode_system.h"

namespace multibond {

/// The columns of group g are column[start[g] .. start[g + 1]).
struct ColumnGroups {
  std::vector<int> start{0};
  std::vector<int> column;
  int count() const { return static_cast<int>(start.size()) - 1; }
};

/// Greedy colouring in column order: each column joins the first group in which no column shares
/// a row with it. At least as many groups as the densest row has entries.
ColumnGroups GroupColumns(const JacobianPattern& p);

}  // namespace multibond
