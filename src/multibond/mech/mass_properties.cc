#include "multibond/mech/mass_properties.h"

#include <numbers>

namespace multibond::mech {

MassProperties MassProperties::Cylinder(double density, double diameter, double length, int axis) {
  const double r = diameter / 2.0;
  const double m = density * std::numbers::pi * r * r * length;
  const double axial = m * r * r / 2.0, diametral = m * (3.0 * r * r + length * length) / 12.0;
  Eigen::Vector3d d = Eigen::Vector3d::Constant(diametral);
  d[axis] = axial;
  return {m, d.asDiagonal()};
}

MassProperties MassProperties::Box(double density, const Eigen::Vector3d& size) {
  const double m = density * size.prod();
  const Eigen::Vector3d s2 = size.cwiseProduct(size);
  return {m, Eigen::Vector3d(s2.y() + s2.z(), s2.x() + s2.z(), s2.x() + s2.y()).asDiagonal() * (m / 12.0)};
}

MassProperties MassProperties::Sphere(double density, double diameter) {
  const double r = diameter / 2.0;
  const double m = density * 4.0 / 3.0 * std::numbers::pi * r * r * r;
  return {m, Eigen::Matrix3d::Identity() * (0.4 * m * r * r)};
}

MassProperties MassProperties::PointMass(double mass) { return {mass, Eigen::Matrix3d::Zero()}; }

MassProperties MassProperties::Given(double mass, const Eigen::Matrix3d& inertia) { return {mass, inertia}; }

}  // namespace multibond::mech
