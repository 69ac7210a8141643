#pragma once
/// \file
/// The evaluation plan, a part of the compiled model (docs/design.md, "The evaluation plan"):
/// the ordered instructions and the tables they index (coefficients, sums' terms, source
/// functions, formulas' programs), the MTF/MGY moduli and which of them an evaluation computes,
/// and each slot class's symbolic definition. Made by the plan passes (PlanModuli,
/// EmitInstructions, OrderPlan, plan::Specialize); the interpreter, the generated code, the
/// tangent, the constraint solver and the Jacobian pattern read it.

#include <vector>

#include "multibond/compile/expr_program.h"
#include "multibond/compile/operations.h"
#include "multibond/core/time_function.h"

namespace multibond {

/// One step of the plan, described symbolically for `multibond equations`.
struct Definition {
  enum class Kind { kSource, kMomentumFlow, kStiffnessEffort, kLinear, kSum, kFormula };
  Kind kind;
  int element;  ///< the element that computes it
  struct Term {
    int slot_class;  ///< input (kLinear, kSum)
    double sign;
    std::string coef;  ///< symbol of the coefficient ("" = 1)
  };
  std::vector<Term> terms;
  std::string formula = {};  ///< kFormula: the formula as evaluated (core/expression.h Format)
};

namespace plan {

struct Plan {
  std::vector<Instr> instrs;        ///< in evaluation order
  std::vector<double> coef;         ///< Instr::coef indexes here
  std::vector<int> sum_terms;       ///< kSum: workspace offsets of the terms
  std::vector<double> sum_signs;    ///< kSum: their signs (parallel to sum_terms)
  std::vector<TimeFunction> source_fns;
  std::vector<expr::Program> programs;  ///< the formulas' programs (kExpr, kSolve)
  std::vector<ModulusEval> moduli;
  std::vector<int> needed_moduli;  ///< indices of moduli that EvalModuli must compute
  int num_moduli = 0;              ///< the workspace's modulus entries
  std::vector<Definition> definitions;  ///< per slot class (multibond equations)

  /// The tables the instructions refer to.
  Tables tables() const {
    return {coef.data(), sum_terms.data(), sum_signs.data(), source_fns.data(), programs.data()};
  }
  int size() const { return static_cast<int>(instrs.size()); }
};

}  // namespace plan
}  // namespace multibond
