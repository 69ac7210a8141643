#pragma once
/// \file
/// The compiled model's ODE in joint (relative) coordinates: a change of variables, not another
/// model. Every evaluation maps the joint-coordinate state y to the model's own state x (every
/// body's orientation R, position r and inertial momenta p, h; the other states as they are),
/// evaluates the model's right-hand side there (the plan generated from the graph, with the ideal
/// constraints' efforts), and maps dx/dt back to dy/dt by the kinematics of the tree.
///
/// Per body, relative to its tree parent P (JointTree): the relative orientation
/// Q = R_P^T R = Exp(psi) Rot(n, theta) C (C the relative orientation where the chart was made,
/// n the body's axis in P's frame, psi = a e1 + b e2 a rotation off n), the anchor's position in
/// P's frame d = R_P^T (r + R anchor - r_P), the relative angular velocity in P's frame
/// u = R_P^T (w - w_P), stored as S k with k = M u, M = Q W Q^T and W the body's inertia about its
/// anchor averaged about its axis (for a body symmetric about its axis: k is its angular momentum
/// about the anchor relative to P, so that a top on a fixed pivot keeps the vertical one to
/// rounding, and an error in the axis's direction does not carry the spin's momentum into it; a
/// body spinning in its bearing keeps k constant whatever its principal axes), S a fixed rotation
/// that takes n to the diagonal (1, 1, 1)/sqrt(3) (every stored component carries a third of the
/// spin, so that the error test holds the rates off the axis to rtol times the spin's momentum, as
/// the inertial momenta's components are, and not to atol), and the anchor's relative velocity in
/// P's frame d'. The axis is fixed in the
/// body (n_b = C^T n), so theta is the spin about it, whichever way a body without a bearing has
/// turned it; a body with no bearing takes the principal axis of inertia next to its initial spin.
/// A body turning steadily in its bearing has theta growing linearly and every other state
/// constant, where its inertial-frame states oscillate: the integrator's step is then no longer
/// bounded by the rotation. docs/design.md, "Joint coordinates".

#include <string>
#include <vector>

#include <Eigen/Dense>

#include "multibond/compile/compiled_model.h"
#include "multibond/core/joint_tree.h"
#include "multibond/core/ode_system.h"

namespace multibond {

class ModelSystem;

class JointCoordinateSystem : public OdeSystem {
 public:
  /// The rotation off the axis |psi| [rad] past which Rechart charts anew. The chart is regular
  /// up to pi (the axis turned over: the Jacobian's determinant is sin|psi| / |psi|).
  static constexpr double kRechartTilt = 1.5;
  /// Throws std::invalid_argument if the tree does not fit the model (a body without the states
  /// <name>.r and <name>.p, a parent after its child, a body twice). `system` is the model as an
  /// OdeSystem, whose variables this one changes: its evaluations (with its workspace and stop
  /// flag) and projection serve CalcDerivatives and Project. Without one, only the map and the
  /// layout (num_states, jacobian_pattern, FromModel, ToModel): what checking options needs.
  JointCoordinateSystem(const CompiledModel& model, const JointTree& tree, ModelSystem* system = nullptr);

  int num_states() const override { return n_; }
  void CalcDerivatives(double t, const double* y, double* ydot) override;
  bool has_invariants() const override { return model_.has_invariants(); }
  /// The momenta onto the ideal constraints (the model's projection), the velocities read back.
  void Project(double t, double* y) override;
  /// From the model's and the tree (BuildPattern): a body's coordinates reach its own and its
  /// descendants' states, a force on a body the rates of the body and its children; the other
  /// states keep the model's structure (a quadrature that nothing reads stays alone).
  const JacobianPattern* jacobian_pattern() const override { return pattern_.n > 0 ? &pattern_ : nullptr; }

  /// y from the model's state x: charts at x's orientations (psi = theta = 0), so that ToModel
  /// gives x back. Used at the start and to re-chart.
  void FromModel(const double* x, double* y);
  /// The model's state at y. No allocation.
  void ToModel(const double* y, double* x);
  /// When a body's rotation off its axis has grown past kRechartTilt (a body with no bearing
  /// whose axis has turned: a top precessing), charts again at x = ToModel(y) (just computed by
  /// the caller), about the body's own axis where it now points, and returns true: the
  /// integrator must then restart from the new y. Integrators see no jump in the motion, only
  /// in y.
  bool Rechart(const double* x, double* y);

  const std::vector<std::string>& state_names() const { return names_; }

 private:
  struct Body {
    int parent = -1;  ///< index into bodies_, -1 for the ground
    int R = -1, r = -1, p = -1, h = -1;  ///< offsets in x (R, h: -1 for a point mass)
    int y = 0;        ///< offset in y: [a, b, theta, d(3), S u(3), d'(3)] or, point mass, [d(3), d'(3)]
    double mass = 0.0;
    Eigen::Matrix3d inertia = Eigen::Matrix3d::Zero(), inertia_inv = Eigen::Matrix3d::Zero();
    Eigen::Vector3d anchor = Eigen::Vector3d::Zero();
    bool anchored = false;  ///< anchor != 0 (else the arm's terms are skipped)
    bool diagonal = false;  ///< the inertia is diagonal in the body's frame
    Eigen::Vector3d n = Eigen::Vector3d::UnitZ(), e1 = Eigen::Vector3d::UnitX(), e2 = Eigen::Vector3d::UnitY();
    Eigen::Matrix3d chart = Eigen::Matrix3d::Identity();  ///< C
    Eigen::Matrix3d n_chart = Eigen::Matrix3d::Zero(), n2_chart = Eigen::Matrix3d::Zero();  ///< [n x] C, [n x]^2 C
    /// The axis in the body's frame (C^T n), set by the first chart and kept by every other.
    Eigen::Vector3d nb = Eigen::Vector3d::UnitZ();
    bool axis_in_body = false;
    bool bearing = false;  ///< TreeBody::bearing: the axis is kept, not moved to a principal axis
    Eigen::Matrix3d mix = Eigen::Matrix3d::Identity();  ///< S (SetAxis)
    /// W, the inertia about the anchor averaged about the axis n_b (body frame), and its inverse
    /// (SetWeight): the stored rates are S Q W Q^T u.
    Eigen::Matrix3d weight = Eigen::Matrix3d::Identity(), weight_inv = Eigen::Matrix3d::Identity();
    // Kinematics at the current y (ToModel), inertial frame.
    Eigen::Matrix3d Rw = Eigen::Matrix3d::Identity();
    Eigen::Vector3d rw = Eigen::Vector3d::Zero(), vw = Eigen::Vector3d::Zero(), ww = Eigen::Vector3d::Zero();
    Eigen::Vector3d vdot = Eigen::Vector3d::Zero(), wdot = Eigen::Vector3d::Zero();
    /// The relative orientation Q = R_P^T R, the relative angular velocity u and momentum
    /// k = M u about the anchor, in P's frame (ToModel, VelocitiesFromModel).
    Eigen::Matrix3d q = Eigen::Matrix3d::Identity();
    Eigen::Vector3d u = Eigen::Vector3d::Zero(), k = Eigen::Vector3d::Zero();
    /// [J_l(psi) e1, J_l(psi) e2, Exp(psi) n]^-1 on the basis (e1, e2, n) at the current y:
    /// (a', b', theta') from (e1.u, e2.u, n.u).
    Eigen::Matrix3d rates_from_u = Eigen::Matrix3d::Identity();
    bool rotates() const { return R >= 0; }
  };
  /// n, the basis e1, e2 that completes it, S, and [n x] C, [n x]^2 C (C already set).
  static void SetAxis(Body& b, const Eigen::Vector3d& n);
  /// W from the inertia, the anchor and n_b.
  static void SetWeight(Body& b);
  static Eigen::Vector3d Inertia(const Body& b, const Eigen::Vector3d& v);
  static Eigen::Vector3d InverseInertia(const Body& b, const Eigen::Vector3d& v);
  /// pattern_ from the model's Jacobian pattern and the tree (the constructor's last step).
  void BuildPattern(const JacobianPattern& mp);
  /// Velocities (u, d') of y from the momenta in x, with the configuration already in bodies_.
  void VelocitiesFromModel(const double* x, double* y);
  /// The body's tree parent, or the ground (at rest at the origin).
  const Body& Parent(const Body& b) const { return b.parent >= 0 ? bodies_[b.parent] : ground_; }

  const CompiledModel& model_;
  ModelSystem* system_;
  std::vector<Body> bodies_;
  Body ground_;  ///< identity orientation, at rest at the origin
  std::vector<std::pair<int, int>> others_;  ///< (offset in x, offset in y) of the other states
  std::vector<std::string> names_;
  int n_ = 0;
  Eigen::VectorXd x_, xdot_;
  Eigen::VectorXd y_before_;  ///< Project: y as it came
  JacobianPattern pattern_;
};

}  // namespace multibond
