#pragma once
// Linear models built by hand for the analysis tests, in bond-graph states (momenta p of the
// inertias, displacements q of the compliances).

#include <string>
#include <vector>

#include "multibond/analysis/linear_model.h"

namespace multibond::testing {

/// Two masses m1, m2 on springs k1 (ground-m1) and k2 (m1-m2), no damping, force F on m2; states
/// (p1, p2, q1, q2), q1 = x1 and q2 = x2 - x1. Output: q1. Motions: the velocities of m1, m2.
inline linear::LinearModel TwoMasses(double m1 = 1, double m2 = 2, double k1 = 100, double k2 = 50) {
  linear::LinearModel m;
  m.model = "two-masses";
  m.states = {"m1.p", "m2.p", "k1.q", "k2.q"};
  m.state_units = {"N*s", "N*s", "m", "m"};
  m.inputs = {"F.e"};
  m.input_units = {"N"};
  m.outputs = {"k1.q"};
  m.output_units = {"m"};
  m.A.resize(4, 4);
  m.A << 0, 0, -k1, k2,     //
      0, 0, 0, -k2,         //
      1 / m1, 0, 0, 0,      //
      -1 / m1, 1 / m2, 0, 0;
  m.B = Eigen::MatrixXd::Zero(4, 1);
  m.B(1, 0) = 1;
  m.C = Eigen::MatrixXd::Zero(1, 4);
  m.C(0, 2) = 1;
  m.D = Eigen::MatrixXd::Zero(1, 1);
  m.full_states = m.states;
  m.x0 = Eigen::VectorXd::Zero(4);
  m.basis = Eigen::MatrixXd::Identity(4, 4);
  auto one = [](double h) { return Eigen::MatrixXd::Constant(1, 1, h); };
  m.storages = {{"m1", {0}, one(1 / m1)}, {"m2", {1}, one(1 / m2)}, {"k1", {2}, one(k1)}, {"k2", {3}, one(k2)}};
  m.motion_names = {"m1.v", "m2.v"};
  m.motion_units = {"m/s", "m/s"};
  m.motion = Eigen::MatrixXd::Zero(2, 4);
  m.motion(0, 0) = 1 / m1;
  m.motion(1, 1) = 1 / m2;
  return m;
}

/// A mass m on a spring k and a damper c, force F on the mass; states (p, q). Output: the spring
/// force k q.
inline linear::LinearModel MassSpringDamper(double mass = 1, double c = 2, double k = 100) {
  linear::LinearModel m;
  m.model = "msd";
  m.states = {"m.p", "k.q"};
  m.state_units = {"N*s", "m"};
  m.inputs = {"F.e"};
  m.input_units = {"N"};
  m.outputs = {"k.e"};
  m.output_units = {"N"};
  m.A.resize(2, 2);
  m.A << -c / mass, -k,  //
      1 / mass, 0;
  m.B.resize(2, 1);
  m.B << 1, 0;
  m.C.resize(1, 2);
  m.C << 0, k;
  m.D = Eigen::MatrixXd::Zero(1, 1);
  m.full_states = m.states;
  m.x0 = Eigen::VectorXd::Zero(2);
  m.basis = Eigen::MatrixXd::Identity(2, 2);
  m.storages = {{"m", {0}, Eigen::MatrixXd::Constant(1, 1, 1 / mass)}, {"k", {1}, Eigen::MatrixXd::Constant(1, 1, k)}};
  m.motion_names = {"m.v"};
  m.motion_units = {"m/s"};
  m.motion = Eigen::MatrixXd::Zero(1, 2);
  m.motion(0, 0) = 1 / mass;
  return m;
}

}  // namespace multibond::testing
