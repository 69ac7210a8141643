#pragma once
/// \file
/// Algebraic loops solved at every evaluation (CompileOptions::solve_algebraic_loops), a part of
/// the compiled model (docs/design.md, "Algebraic loops"): each loop torn at one variable, the
/// plan instructions that depend on an unknown, and whether a formula makes the loop nonlinear.
/// Made by OrderPlan; the evaluation (EvalTorn), the tangent and the Jacobian pattern read it.

#include <string>
#include <vector>

namespace multibond {

struct TornLoops {
  /// Per torn variable: its slot (which holds the unknown), its size and the slot its writer
  /// writes to instead (beyond the classes' slots).
  struct Tear {
    int slot, size, shadow;
  };
  /// One loop by its elements and the variable it is torn at, the unknown of its system.
  struct Loop {
    std::string path;     ///< "R1 -> n0 -> R2 -> ..."
    std::string torn;     ///< the slot class solved for, "n0.e"
    int element = -1;     ///< the loop's first element (index in graph())
    int slot_class = -1;  ///< of the torn variable
  };
  std::vector<Tear> tears;
  int num_unknowns = 0;      ///< the torn variables' total size
  std::vector<int> closure;  ///< plan indices that depend on an unknown, in order
  std::vector<Loop> loops;
  /// A torn variable's closure runs through a formula (kExpr, kSolve): the loop is nonlinear, and
  /// EvalTorn solves it by Newton's method instead of one linear solve.
  bool nonlinear = false;

  bool empty() const { return tears.empty(); }
};

}  // namespace multibond
