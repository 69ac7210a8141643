#pragma once
/// \file
/// A model linearised about an operating point (docs/linear-analysis.md):
///   dz/dt = A z + B u,   y = C z + D u
/// in coordinates z of the tangent space of the state's manifold at the point: the state x itself
/// where it is a vector space; three angles per orientation matrix (the rotation group has three
/// dimensions, not nine, so no spurious modes); the independent coordinates of the constraint
/// manifold when ideal constraints hold. `basis` maps z back to the full state: dx = basis z.
/// Inputs u are the sources' components (Se, Sf, drives), outputs y the model's declared outputs.

#include <string>
#include <vector>

#include <Eigen/Dense>

namespace multibond::linear {

/// One storage element's energy near the point, for energy participation: its stored energy's
/// Hessian with respect to its own state entries (M^-1 for an inertia, K for a compliance, the
/// derivative of its law for one given by a formula).
struct Storage {
  std::string element;
  std::vector<int> states;  ///< indices in the full state (rows of `basis`)
  Eigen::MatrixXd hessian;  ///< states.size() x states.size(), symmetric
};

/// How the note on an operating point that sits on a kink of a formula begins (Linearize).
inline constexpr const char* kOnKinkNote = "the operating point sits on a kink";

struct LinearModel {
  std::string model;  ///< the model's name
  double at = 0.0;    ///< the time of the operating point [s]
  bool steady = false;  ///< the point is a steady state (dx/dt = 0) found by a solver
  std::vector<std::string> states, state_units;    ///< the coordinates z
  std::vector<std::string> inputs, input_units;    ///< u
  std::vector<std::string> outputs, output_units;  ///< y
  Eigen::MatrixXd A, B, C, D;
  /// The full state's names and values at the point, and dx = basis z (full x coordinates).
  std::vector<std::string> full_states;
  Eigen::VectorXd x0;
  Eigen::MatrixXd basis;
  std::vector<Storage> storages;
  /// Mode shapes as motions: the flow of every inertia (for a mechanism, each body's velocity and
  /// angular velocity components) per unit z: motion_names.size() rows, states.size() columns.
  std::vector<std::string> motion_names, motion_units;
  Eigen::MatrixXd motion;
  /// What a user should know about this linearisation (coordinates reduced, outputs left out...).
  std::vector<std::string> notes;
};

}  // namespace multibond::linear
