#pragma once
// The mass-spring-damper of the API tests: m x'' + c x' + k x = F, from rest, and its closed form.

#include <cmath>
#include <string>

namespace multibond::test {

inline std::string MassSpringDamper(double k = 100.0, double force = 1.0) {
  return "model: msd\n"
         "domain: translation\n"
         "elements:\n"
         "  force:  {type: Se, effort: " + std::to_string(force) + "}\n"
         "  mass:   {type: I, inertia: 1.0}\n"
         "  spring: {type: C, stiffness: " + std::to_string(k) + "}\n"
         "  damper: {type: R, resistance: 2.0}\n"
         "  j:      {type: \"1\"}\n"
         "bonds: [force -> j, j -> mass, j -> spring, j -> damper]\n"
         "outputs:\n"
         "  - {name: velocity, variable: j.f}\n"
         "simulation: {t_end: 2, dt: 0.01, rtol: 1.0e-10, atol: 1.0e-12}\n";
}

/// x(t) of the underdamped oscillator with m = 1, c = 2.
inline double Position(double t, double k = 100.0, double force = 1.0) {
  const double m = 1.0, c = 2.0;
  const double w0 = std::sqrt(k / m), zeta = c / (2 * std::sqrt(k * m)), wd = w0 * std::sqrt(1 - zeta * zeta);
  return force / k * (1 - std::exp(-zeta * w0 * t) * (std::cos(wd * t) + zeta * w0 / wd * std::sin(wd * t)));
}

}  // namespace multibond::test
