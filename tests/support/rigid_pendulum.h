#pragma once
// A model text shared by the tests of gravity's potential (tests/physics/gravity_potential_test.cc)
// and of formulas with ideal constraints (tests/compile/constraint_formulas_test.cc).

namespace multibond::testing {

/// A bar of 1 m (CoM 0.5 m below the pivot) on a rigid hinge about y, released at rest from 30
/// degrees under gravity, no damping. m = 2700 * 0.02 * 0.02 * 1 = 1.08 kg,
/// I_y = m (0.02^2 + 1^2) / 12. A test may append top-level keys (signals, outputs).
inline constexpr const char* kRigidPendulum = R"(
model: pendulum
gravity: [0, 0, -9.81]
bodies:
  bar: {shape: {box: {size: [0.02, 0.02, 1.0]}}, density: 2700,
        position: [-0.25, 0, -0.4330127018922193], orientation: {axis: y, degrees: 30}}
joints:
  hinge: {type: revolute, parent: ground, child: bar, at: [0, 0, 0], child_at: [0, 0, 0.5], axis: y, rigid: true}
)";

}  // namespace multibond::testing
