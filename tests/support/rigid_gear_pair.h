#pragma once
// A model text shared by the tests of ideal constraints (tests/physics/ideal_constraints_test.cc),
// of formulas with them (tests/compile/constraint_formulas_test.cc) and of their linearisation
// (tests/analysis/linearize_test.cc): a rigid gear pair in the rotation domain.

#include <string>

namespace multibond::testing {

/// A pinion J1 = 0.01 (on the 1-junction j1) driven by the effort source 'torque' of `torque`,
/// and a wheel J2 = 0.04 (on j2) joined to it by the TF 'gear' of `ratio`: J2's speed is fixed by
/// J1's (derivative causality, cut by an ideal constraint). `options` are lines after the domain
/// (e.g. "constraints: ideal\n"); `spring`, when not empty, is the element of a torsion spring
/// 'spring' from the wheel to the ground; `tail` follows the bonds (signals, outputs).
inline std::string RigidGearPair(const std::string& name, const std::string& options, const std::string& torque,
                                 const std::string& ratio, const std::string& spring, const std::string& tail) {
  std::string text = "\nmodel: " + name + "\ndomain: rotation\n" + options +
                     "elements:\n"
                     "  torque: {type: Se, effort: " + torque + "}\n"
                     "  j1:     {type: \"1\"}\n"
                     "  J1:     {type: I, inertia: 0.01}\n"
                     "  gear:   {type: TF, ratio: " + ratio + "}\n"
                     "  j2:     {type: \"1\"}\n"
                     "  J2:     {type: I, inertia: 0.04}\n";
  if (!spring.empty()) text += "  spring: " + spring + "\n";
  text +=
      "bonds:\n"
      "  - torque -> j1\n"
      "  - j1 -> J1\n"
      "  - j1 -> gear\n"
      "  - gear -> j2\n"
      "  - j2 -> J2\n";
  if (!spring.empty()) text += "  - j2 -> spring\n";
  return text + tail;
}

}  // namespace multibond::testing
