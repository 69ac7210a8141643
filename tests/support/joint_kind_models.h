#pragma once
// The mechanisms on which the joint kinds cylindrical, planar, screw and universal are tested
// (tests/mech/joint_kinds_test.cc against closed forms, tests/sim/joint_coordinates_joints_test.cc
// in joint coordinates): a cube on each joint to the ground, a nut on a screw, a Cardan joint.

#include <algorithm>
#include <cstdio>
#include <cmath>
#include <numbers>
#include <string>

#include <Eigen/Dense>

#include <gtest/gtest.h>

#include "multibond/mech/mechanism.h"
#include "multibond/sim/simulator.h"

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

/// The statics of a run of the cube on J,
/// loaded by gravity `g` and kT about `torque_axis`: the reactions carry the load, the
/// deflection along g is m g / K_t (rigid: none). Returns the largest error over its closed form.
inline double ExpectHeldStatics(const RecordingObserver& rec, const Eigen::Vector3d& g, const Eigen::Vector3d& torque_axis, bool rigid) {
  const double mass = 1.0;
  const Eigen::Vector3d f{rec.Last("J.F.x"), rec.Last("J.F.y"), rec.Last("J.F.z")};
  const Eigen::Vector3d moment{rec.Last("J.M.x"), rec.Last("J.M.y"), rec.Last("J.M.z")};
  // The joint's force on the child balances its weight, its moment the torque (steady state).
  EXPECT_LT((f + mass * g).norm(), 1e-6 * mass * kG) << f.transpose();
  EXPECT_LT((moment + kT * torque_axis).norm(), 1e-6 * kT) << moment.transpose();
  const Eigen::Vector3d r{rec.Last("cube.r.x"), rec.Last("cube.r.y"), rec.Last("cube.r.z")};
  const Eigen::Vector3d r0{rec.rows().front()[rec.Index("cube.r.x")], rec.rows().front()[rec.Index("cube.r.y")],
                           rec.rows().front()[rec.Index("cube.r.z")]};
  // The deflection along the load: m g / K_t (rigid: held to the integration error).
  const double along_g = (r - r0).dot(g.normalized()), expected = rigid ? 0.0 : mass * g.norm() / kKt;
  if (rigid) EXPECT_NEAR(along_g, 0.0, 1e-9);
  else EXPECT_NEAR(along_g, expected, 1e-6 * expected);
  return std::max({(f + mass * g).norm(), (moment + kT * torque_axis).norm(), std::abs(along_g - expected)});
}

/// Checks a run of Nut(rigid) at its last row, t s from rest, against the closed form, and
/// returns the largest error of the slide (m), its speed (m/s) and the angle over 2 pi / lead.
/// Compliant: the helix spring carries m (g - a) at the deflection d = m (g - a) / K_h, 9.8e-7 m;
/// it starts undeflected and settles (about critically damped) in ~1 ms. The common motion
/// m z + M y = -(m + M) a t^2 / 2 (M = I k^2, y = theta / k) holds from rest whatever the spring
/// does, so the nut is below the ideal fall by d M / (m + M), the spin lags by d m / (m + M).
inline double ExpectTheNutsFall(const RecordingObserver& rec, bool rigid, double t) {
  const double mass = 1.0, inertia = 1.0 / 600, k = 2 * std::numbers::pi / kLead;
  const double a = mass * kG / (mass + inertia * k * k);  // the fall's acceleration, g / 659 here
  const double deflection = rigid ? 0.0 : mass * (kG - a) / kKh * (inertia * k * k) / (mass + inertia * k * k);
  const double s = -0.5 * a * t * t;
  EXPECT_NEAR(rec.Last("J.slide"), s - deflection, 1e-11);
  EXPECT_NEAR(rec.Last("cube.r.z"), s - deflection, 1e-11);
  EXPECT_NEAR(rec.Last("J.speed"), -a * t, 1e-8);
  EXPECT_NEAR(rec.Last("J.angle"), k * s, 1e-6);
  EXPECT_NEAR(rec.Last("J.rate"), -k * a * t, 1e-6);
  // The reactions: the helix holds m (g - a) of the weight, and turns the nut by I theta''.
  EXPECT_NEAR(rec.Last("J.F.z"), mass * (kG - a), 1e-6);
  EXPECT_NEAR(rec.Last("J.M.z"), -inertia * k * a, 1e-6);
  EXPECT_NEAR(rec.Last("J.helix_force"), -mass * (kG - a), 1e-6);
  // Energy: the potential released is the kinetic energy of the fall and the spin (the spring
  // keeps m^2 (g - a)^2 / 2 K_h, 4e-6 J, and its damper takes about as much at the start).
  const double released = mass * kG * (0.5 * a * t * t);
  EXPECT_NEAR(rec.Last("energy.kinetic"), 0.5 * (mass + inertia * k * k) * a * a * t * t, 1e-6 * released);
  // No work is done (gravity's is stored): kinetic + potential (gravity's and the springs') +
  // dissipated stays 0.
  const double balance = rec.Last("energy.kinetic") + rec.Last("energy.potential") + rec.Last("energy.dissipated");
  EXPECT_NEAR(balance, 0.0, 1e-8 * released);
  std::printf("Screw (%s): slide %.12g, closed form %.12g (deflection %.3g); energy (kinetic + potential + dissipated) / released %.3g\n",
              rigid ? "rigid" : "compliant", rec.Last("J.slide"), s, deflection, balance / released);
  return std::max({std::abs(rec.Last("J.slide") - (s - deflection)), std::abs(rec.Last("J.speed") + a * t),
                   std::abs(rec.Last("J.angle") - k * s) / k});
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

/// Checks a run of Cardan(beta, w1, rigid) over one input turn against the closed form and
/// returns the largest relative error of w2. The yokes stay perpendicular, (R_in y) . (R_out z) =
/// 0, and the spider rocks on the input yoke: over a turn the output turns once too (angle_a
/// returns).
inline double ExpectCardanSpeeds(const RecordingObserver& rec, double beta, double w1, bool rigid) {
  const Eigen::Vector3d s2(std::cos(beta), std::sin(beta), 0);
  double max_error = 0.0, max_perpendicular = 0.0;
  for (const auto& row : rec.rows()) {
    const double t = row[0], c = std::cos(w1 * t), sb = std::sin(beta);
    const double expected = w1 * std::cos(beta) / (1 - sb * sb * c * c);
    const Eigen::Vector3d w2{row[rec.Index("out.omega.x")], row[rec.Index("out.omega.y")], row[rec.Index("out.omega.z")]};
    max_error = std::max(max_error, std::abs(w2.dot(s2) - expected) / expected);
    const Eigen::Vector3d a1{row[rec.Index("in.R.12")], row[rec.Index("in.R.22")], row[rec.Index("in.R.32")]};
    const Eigen::Vector3d a2{row[rec.Index("out.R.13")], row[rec.Index("out.R.23")], row[rec.Index("out.R.33")]};
    max_perpendicular = std::max(max_perpendicular, std::abs(a1.dot(a2)));
  }
  std::printf("Cardan (%s): max relative error of w2 %.3g, max |a1.a2| %.3g\n", rigid ? "rigid" : "compliant", max_error,
              max_perpendicular);
  EXPECT_LT(max_error, rigid ? 1e-9 : 1e-6);
  EXPECT_LT(max_perpendicular, rigid ? 1e-8 : 1e-7);
  EXPECT_NEAR(rec.Last("J.angle_a"), 0.0, rigid ? 1e-6 : 1e-3);
  return max_error;
}

}  // namespace multibond::mech::joint_kind_models
