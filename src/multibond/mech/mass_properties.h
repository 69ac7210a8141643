#pragma once
/// \file
/// Mass and inertia tensor (about the centre of mass, in the body frame) from shapes.

#include <Eigen/Dense>

namespace multibond::mech {

struct MassProperties {
  double mass = 0.0;                               ///< [kg]
  Eigen::Matrix3d inertia = Eigen::Matrix3d::Zero();  ///< [kg m^2], body frame, about the CoM

  /// Solid cylinder (a disc when thin) of `density` [kg/m^3], `diameter` and `length` [m],
  /// symmetry axis along body axis `axis` (0 = x, 1 = y, 2 = z):
  /// m = rho pi r^2 L, axial m r^2 / 2, diametral m (3 r^2 + L^2) / 12.
  static MassProperties Cylinder(double density, double diameter, double length, int axis);
  /// Solid box with edge lengths `size` [m] along the body axes: I_xx = m (b^2 + c^2) / 12, ...
  static MassProperties Box(double density, const Eigen::Vector3d& size);
  /// Solid sphere: m = rho 4/3 pi r^3, I = 2/5 m r^2.
  static MassProperties Sphere(double density, double diameter);
  /// A point mass: no rotational inertia (the body has no rotational states).
  static MassProperties PointMass(double mass);
  static MassProperties Given(double mass, const Eigen::Matrix3d& inertia);

  bool has_rotation() const { return inertia.squaredNorm() > 0.0; }
};

}  // namespace multibond::mech
