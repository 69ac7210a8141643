#pragma once
// The mechanisms on which the joint kinds cylindrical, planar, screw and universal are tested
// (tests/mech/joint_kinds_test.cc against closed forms, tests/sim/joint_coordinates_joints_test.cc
// in joint coordinates): a cube on each joint to the ground, a nut on a screw, a Cardan joint.

#include <cmath>
#include <string>

#include <Eigen/Dense>

#include "multibond/mech/mechanism.h"

namespace multibond::mech::joint_kind_models {

/// A cube of 0.1 m and 1 kg: the same moment of inertia (1/600 kg m^2) about every axis, so a
/// spin keeps its axis (no gyroscopic torque).
inline Body Cube(const std::string& name) {
  Body b;
  b.name = name;
  b.mass = MassProperties::Box(1000, {0.1, 0.1, 0.1});
  return b;
}

inline Drive Torque(const std::string& name, const std::string& body, const Eigen::Vector3d& axis, double value) {
  Drive d;
  d.name = name;
  d.kind = Drive::Kind::kTorque;
  d.body = body;
  d.axis = axis;
  d.value = TimeFunction::Constant(value);
  return d;
}

/// Adds `j` to `m` with its sensors on, made rigid when `rigid`.
inline void AddSensedJoint(Mechanism& m, Joint j, bool rigid) {
  j.sensors = true;
  if (rigid) MakeRigid(j);
  m.AddJoint(j);
}

// Couplings: K_t = 1e6 N/m and K_r = 1e3 N m/rad, each critically damped on the cube.
constexpr double kKt = 1e6, kRt = 2e3, kKr = 1e3, kRr = 2.6, kG = 9.81, kT = 0.5;

/// The cube on a cylindrical joint along z: it slides along the axis at 0.5 m/s and turns about it
/// at `spin` rad/s.
inline Mechanism CylinderOnZ(bool rigid, double spin = 2.0) {
  Mechanism m;
  Body b = Cube("cube");
  b.velocity = {0, 0, 0.5};  // slides along the axis
  b.omega = {0, 0, spin};    // and turns about it
  m.AddBody(b);
  AddSensedJoint(m, MakeCylindrical("J", kGround, "cube", Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitZ(), kKt, kRt, kKr, kRr), rigid);
  return m;
}

/// The cube on a planar joint of normal z, gliding in the plane and turning about the normal.
inline Mechanism PuckOnTheFloor(bool rigid) {
  Mechanism m;
  Body b = Cube("cube");
  b.position = {0.2, 0.1, 0.0};
  b.velocity = {0.3, -0.2, 0.0};  // glides in the plane
  b.omega = {0, 0, 1.5};          // and turns about the normal
  m.AddBody(b);
  AddSensedJoint(m, MakePlanar("J", kGround, "cube", b.position, Eigen::Vector3d::UnitZ(), kKt, kRt, kKr, kRr), rigid);
  return m;
}

constexpr double kLead = 0.01, kKh = 1e7, kRh = 6e3;

/// A nut (the cube, I about the axis 1/600 kg m^2) on a vertical screw of lead 10 mm, falling from
/// rest under gravity: s = lead / (2 pi) theta, so (m + I (2 pi / lead)^2) s'' = -m g.
inline Mechanism Nut(bool rigid) {
  Mechanism m;
  m.AddBody(Cube("cube"));
  AddSensedJoint(m, MakeScrew("J", kGround, "cube", Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitZ(), kLead, kKt, kRt, kKr, kRr, kKh, kRh), rigid);
  m.SetGravity({0, 0, -kG});
  return m;
}

/// A cube hanging on a universal joint from the ground at its centre: the ground's yoke about x,
/// the cube's about its y.
inline Mechanism CubeOnACross(bool rigid, const Eigen::Vector3d& omega) {
  Mechanism m;
  Body b = Cube("cube");
  b.omega = omega;
  m.AddBody(b);
  AddSensedJoint(
      m, MakeUniversal("J", kGround, "cube", Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitX(), Eigen::Vector3d::UnitY(), kKt, kRt, kKr, kRr),
      rigid);
  return m;
}

/// A Cardan joint between an input shaft along x, driven at w1, and an output shaft at the angle
/// beta to it in the x-y plane, both on bearings to the ground: the input yoke about y (in the
/// shafts' plane at t = 0), the output's about z. w2 = w1 cos(beta) / (1 - sin^2(beta) cos^2(w1 t)).
inline Mechanism Cardan(double beta, double w1, bool rigid) {
  Mechanism m;
  Body in = Cube("in"), out = Cube("out");
  in.omega = {w1, 0, 0};
  const Eigen::Vector3d s2(std::cos(beta), std::sin(beta), 0);
  out.omega = w1 / std::cos(beta) * s2;
  m.AddBody(in);
  m.AddBody(out);
  const double k = rigid ? 1.0 : 1e3;  // stiffer couplings for the compliant Cardan: 1e9 N/m, 1e6 N m/rad
  Joint bearing_in = MakeRevolute("bearing_in", kGround, "in", Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitX(), k * kKt, k * kRt,
                                  k * kKr, std::sqrt(k) * kRr);
  Joint bearing_out = MakeRevolute("bearing_out", kGround, "out", Eigen::Vector3d::Zero(), s2, k * kKt, k * kRt, k * kKr,
                                   std::sqrt(k) * kRr);
  bearing_out.translation.reset();  // the universal joint holds it to the input shaft
  Joint cross = MakeUniversal("J", "in", "out", Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitY(), Eigen::Vector3d::UnitZ(), k * kKt,
                              k * kRt, k * kKr, std::sqrt(k) * kRr);
  cross.sensors = true;
  Drive motor;
  motor.name = "motor";
  motor.body = "in";
  motor.axis = Eigen::Vector3d::UnitX();
  motor.value = TimeFunction::Constant(w1);
  motor.stiffness = k * kKr;
  motor.damping = std::sqrt(k) * kRr;
  if (rigid) {
    MakeRigid(bearing_in);
    MakeRigid(bearing_out);
    MakeRigid(cross);
    motor.rigid = true;
  }
  m.AddJoint(bearing_in);
  m.AddJoint(bearing_out);
  m.AddJoint(cross);
  m.AddDrive(motor);
  return m;
}

}  // namespace multibond::mech::joint_kind_models
