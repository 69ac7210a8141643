#pragma once
/// \file
/// The state equations of a compiled model in readable form, for `multibond equations`.
///
/// Each equation is obtained by substituting the plan's definitions (compiled_model.h,
/// Definition) into the state derivative until only leaves remain: source values (`force(t)`),
/// inertia flows (`mass.p/mass.I`), compliance efforts (`spring.K spring.q`). Big expressions
/// are cut at junction variables, which are then listed under the equation ("where ..."), so the
/// output stays readable on large models. Every equation is followed by the causal paths it came
/// from, from each leaf through the elements whose definitions were traversed to the state.

#include <string>

#include "multibond/compile/compiled_model.h"

namespace multibond {

/// Output flavour of FormatEquations.
enum class EquationFormat {
  kText,   ///< plain text: `d(mass.p)/dt = force(t) - spring.K spring.q - ...`
  kLatex,  ///< rows for an `align*` environment, paths as `% path:` comment lines
};

/// The state equations of a compiled model, one per state block, named by element, each with
/// the causal paths it came from.
///
/// Momentum, displacement, integral and orientation states get one equation each (orientation:
/// `dR/dt = [w x] R` with the expression of `w`). The energy-account states (work, dissipation)
/// are only mentioned in a closing line. The output is deterministic.
std::string FormatEquations(const CompiledModel& model, EquationFormat format);

}  // namespace multibond
