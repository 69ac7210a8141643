#pragma once
// A model that ideal constraints refuse, shared by the tests of the refusal at the compiler
// (tests/compile/constraint_formulas_test.cc) and in the physics of ideal constraints
// (tests/physics/ideal_constraints_test.cc): a mass on two springs on one 0-junction. k2 is cut (a
// flow multiplier holds its effort equal to the junction's), and the junction's effort is k1's
// formula law (its line 9): the constraint depends on a formula.

namespace multibond::testing {

inline constexpr const char* kNonlinearPair = R"(
model: nonlinear_pair
domain: translation
constraints: ideal
elements:
  mass: {type: I, inertia: 1.0}
  j:    {type: "1"}
  z:    {type: "0"}
  k1:   {type: C, effort: 10 * q + q^3}
  k2:   {type: C, stiffness: 5.0}
bonds: [j -> mass, j -> z, z -> k1, z -> k2]
)";

}  // namespace multibond::testing
