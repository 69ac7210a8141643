/// \file
/// The named joint kinds (revolute, fixed, spherical, prismatic) as sets of couplings.

#include <cmath>

#include "multibond/mech/mechanism.h"

namespace multibond::mech {

Eigen::Matrix<double, 2, 3> Perpendicular(const Eigen::Vector3d& axis) {
  const Eigen::Vector3d a = axis.normalized();
  // Start from the coordinate axis least aligned with a, so the result is well conditioned.
  int k = 0;
  for (int i = 1; i < 3; ++i)
    if (std::abs(a[i]) < std::abs(a[k])) k = i;
  const Eigen::Vector3d u = (Eigen::Vector3d::Unit(k) - a * a[k]).normalized();
  Eigen::Vector3d v = a.cross(u);
  // Along a coordinate axis the pair is the other two axes, both positive, so that the coupling's
  // columns are named .x/.z (about y, a x u is -z: it was named '.2', with its sign flipped).
  if (v.minCoeff() < -1.0 + 1e-12) v = -v;
  Eigen::Matrix<double, 2, 3> m;
  m.row(0) = u.transpose();
  m.row(1) = v.transpose();
  return m;
}

namespace {

Coupling Uniform(const Eigen::MatrixXd& rows, double k, double r, Coupling::Frame frame) {
  Coupling c;
  c.directions = rows;
  c.stiffness = Eigen::VectorXd::Constant(rows.rows(), k);
  c.damping = Eigen::VectorXd::Constant(rows.rows(), r);
  c.frame = frame;
  return c;
}

Joint Base(std::string name, std::string kind, std::string parent, std::string child, const Eigen::Vector3d& at) {
  Joint j;
  j.name = std::move(name);
  j.kind = std::move(kind);
  j.parent = std::move(parent);
  j.child = std::move(child);
  j.parent_point = at;
  return j;
}

}  // namespace

Joint MakeRevolute(std::string name, std::string parent, std::string child, const Eigen::Vector3d& at,
                   const Eigen::Vector3d& axis, double k_t, double r_t, double k_r, double r_r) {
  Joint j = Base(std::move(name), "revolute", std::move(parent), std::move(child), at);
  j.translation = Uniform(Eigen::Matrix3d::Identity(), k_t, r_t, Coupling::Frame::kWorld);
  j.rotation = Uniform(Perpendicular(axis), k_r, r_r, Coupling::Frame::kParent);
  j.axis = axis;
  return j;
}

Joint MakeFixed(std::string name, std::string parent, std::string child, const Eigen::Vector3d& at, double k_t, double r_t,
                double k_r, double r_r) {
  Joint j = Base(std::move(name), "fixed", std::move(parent), std::move(child), at);
  j.translation = Uniform(Eigen::Matrix3d::Identity(), k_t, r_t, Coupling::Frame::kWorld);
  j.rotation = Uniform(Eigen::Matrix3d::Identity(), k_r, r_r, Coupling::Frame::kParent);
  return j;
}

Joint MakeSpherical(std::string name, std::string parent, std::string child, const Eigen::Vector3d& at, double k_t,
                    double r_t) {
  Joint j = Base(std::move(name), "spherical", std::move(parent), std::move(child), at);
  j.translation = Uniform(Eigen::Matrix3d::Identity(), k_t, r_t, Coupling::Frame::kWorld);
  return j;
}

Joint MakePrismatic(std::string name, std::string parent, std::string child, const Eigen::Vector3d& at,
                    const Eigen::Vector3d& axis, double k_t, double r_t, double k_r, double r_r) {
  Joint j = Base(std::move(name), "prismatic", std::move(parent), std::move(child), at);
  j.translation = Uniform(Perpendicular(axis), k_t, r_t, Coupling::Frame::kParent);
  j.rotation = Uniform(Eigen::Matrix3d::Identity(), k_r, r_r, Coupling::Frame::kParent);
  j.axis = axis;
  return j;
}

}  // namespace multibond::mech
