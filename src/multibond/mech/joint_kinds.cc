/// \file
/// The named joint kinds (revolute, fixed, spherical, prismatic, cylindrical, planar, screw,
/// universal) as sets of couplings.

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

/// A unit row perpendicular to `axis` (the universal joint's rotation coupling is one direction).
Eigen::MatrixXd UniversalNormalRow(const Eigen::Vector3d& axis) { return Perpendicular(axis).row(0); }

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

Joint MakeCylindrical(std::string name, std::string parent, std::string child, const Eigen::Vector3d& at,
                      const Eigen::Vector3d& axis, double k_t, double r_t, double k_r, double r_r) {
  Joint j = Base(std::move(name), "cylindrical", std::move(parent), std::move(child), at);
  j.translation = Uniform(Perpendicular(axis), k_t, r_t, Coupling::Frame::kParent);
  j.rotation = Uniform(Perpendicular(axis), k_r, r_r, Coupling::Frame::kParent);
  j.axis = axis;
  return j;
}

Joint MakePlanar(std::string name, std::string parent, std::string child, const Eigen::Vector3d& at,
                 const Eigen::Vector3d& normal, double k_t, double r_t, double k_r, double r_r) {
  Joint j = Base(std::move(name), "planar", std::move(parent), std::move(child), at);
  j.translation = Uniform(normal.normalized().transpose(), k_t, r_t, Coupling::Frame::kParent);
  j.rotation = Uniform(Perpendicular(normal), k_r, r_r, Coupling::Frame::kParent);
  j.axis = normal;
  return j;
}

Joint MakeScrew(std::string name, std::string parent, std::string child, const Eigen::Vector3d& at, const Eigen::Vector3d& axis,
                double lead, double k_t, double r_t, double k_r, double r_r, double k_h, double r_h) {
  Joint j = MakeCylindrical(std::move(name), std::move(parent), std::move(child), at, axis, k_t, r_t, k_r, r_r);
  j.kind = "screw";
  j.lead = lead;
  j.helix = Uniform(axis.normalized().transpose(), k_h, r_h, Coupling::Frame::kParent);
  return j;
}

Joint MakeUniversal(std::string name, std::string parent, std::string child, const Eigen::Vector3d& at,
                    const Eigen::Vector3d& axis, const Eigen::Vector3d& child_axis, double k_t, double r_t, double k_r,
                    double r_r) {
  Joint j = Base(std::move(name), "universal", std::move(parent), std::move(child), at);
  j.translation = Uniform(Eigen::Matrix3d::Identity(), k_t, r_t, Coupling::Frame::kWorld);
  // One direction: the spider's third axis, which turns with both bodies; the expansion builds
  // it from `axis` and `child_axis` (the row here stands for it in the checks).
  j.rotation = Uniform(UniversalNormalRow(axis), k_r, r_r, Coupling::Frame::kParent);
  j.axis = axis;
  j.child_axis = child_axis;
  return j;
}

void MakeRigid(Joint& j) {
  for (std::optional<Coupling>* c : {&j.translation, &j.rotation, &j.helix})
    if (*c) {
      (*c)->rigid = true;
      (*c)->damping.setZero();
    }
}

}  // namespace multibond::mech
