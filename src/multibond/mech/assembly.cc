#include "multibond/core/diagnostic_codes.h"
#include "multibond/mech/assembly.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <unordered_map>

#include <fmt/format.h>

namespace multibond::mech {

namespace {

using Vec = Eigen::VectorXd;
using Mat = Eigen::MatrixXd;
using Given = AssemblySpec::Given;

constexpr int kGroundIndex = -1;
constexpr int kUnknownIndex = -2;

/// The rotation vector (angle times unit axis) of a rotation matrix, angle in [0, pi].
Eigen::Vector3d RotationVector(const Eigen::Matrix3d& m) {
  const Eigen::AngleAxisd aa(Eigen::Quaterniond(m).normalized());
  return aa.angle() * aa.axis();
}

Eigen::Matrix3d Exp(const Eigen::Vector3d& v) {
  const double a = v.norm();
  return a == 0.0 ? Eigen::Matrix3d::Identity() : Eigen::AngleAxisd(a, v / a).toRotationMatrix();
}

/// The bodies' positions and orientations (position level) or velocities (velocity level).
struct Pose {
  std::vector<Eigen::Vector3d> r;
  std::vector<Eigen::Matrix3d> R;
};

/// What a residual row belongs to, for messages.
struct Label {
  std::string text;    ///< "joint 'crank_pin' (translation)"
  std::string unit;    ///< "m", "rad", "m/s", "rad/s"
  SourceLocation where;
  std::string element;
};

/// Residual rows of one level: the joints' (and meshes') and the given coordinates'.
struct Rows {
  std::vector<double> joint, given;
  std::vector<Label>* joint_labels = nullptr;  ///< filled when not null (once: the rows do not depend on the pose)
  std::vector<Label>* given_labels = nullptr;
  /// A row; `label()` makes its Label, called only when the labels are asked for (the difference
  /// quotients evaluate the rows many times).
  template <class F>
  void Joint(double v, F&& label) {
    joint.push_back(v);
    if (joint_labels) joint_labels->push_back(label());
  }
  template <class F>
  void Given(double v, F&& label) {
    given.push_back(v);
    if (given_labels) given_labels->push_back(label());
  }
};

Vec ToVec(const std::vector<double>& v) { return Eigen::Map<const Vec>(v.data(), static_cast<Eigen::Index>(v.size())); }

/// One minimum-norm step d of the linearised rows G d = -g (the given coordinates, held first) and
/// J d = -j (the joints, solved in least squares within what G leaves free): d = d_G + N z with
/// d_G the minimum-norm solution of the givens, N a basis of G's null space and z the minimum-norm
/// least-squares solution of the joints there; d_G and N z are orthogonal, so |d| is the least.
Vec MinimumNormStep(const Mat& G, const Vec& g, const Mat& J, const Vec& j) {
  const Eigen::Index n = std::max(G.cols(), J.cols());
  Vec d = Vec::Zero(n);
  Mat N = Mat::Identity(n, n);
  if (G.rows() > 0) {
    d = Eigen::CompleteOrthogonalDecomposition<Mat>(G).solve(-g);
    const Eigen::ColPivHouseholderQR<Mat> qr(G.transpose());  // G^T P = Q R: Q's last n - rank columns span null(G)
    const Mat Q = qr.householderQ();
    N = Q.rightCols(n - qr.rank());
  }
  if (J.rows() > 0 && N.cols() > 0) {
    const Vec z = Eigen::CompleteOrthogonalDecomposition<Mat>(J * N).solve(-(j + J * d));
    d += N * z;
  }
  return d;
}

class Assembler {
 public:
  Assembler(const Mechanism& m, const AssemblySpec& spec) : m_(m), spec_(spec) {
    const auto& bodies = m.bodies();
    for (size_t k = 0; k < bodies.size(); ++k) index_[bodies[k].name] = static_cast<int>(k);
    for (const Body& b : bodies) {
      r0_.push_back(b.position);
      R0_.push_back(b.orientation);
    }
    for (const Joint& j : m.joints()) joints_[j.name] = &j;
    for (const Drive& d : m.drives()) drives_[d.name] = &d;
  }

  int Index(const std::string& name) const {
    if (name == kGround) return kGroundIndex;
    const auto it = index_.find(name);
    return it == index_.end() ? kUnknownIndex : it->second;
  }
  int num_bodies() const { return static_cast<int>(r0_.size()); }

  /// The start of the position level: the bodies as written, with the given positions and orientations.
  Pose Start() const {
    Pose p{r0_, R0_};
    for (const Given& g : spec_.given) {
      const int b = Index(g.part);
      if (b < 0) continue;
      if (g.kind == Given::Kind::kBodyPosition) p.r[b] = g.vector;
      if (g.kind == Given::Kind::kBodyOrientation) p.R[b] = g.matrix;
    }
    return p;
  }

  /// The position-level rows at `p`.
  void PositionRows(const Pose& p, Rows& rows) const {
    for (const Joint& j : m_.joints()) {
      const int pi = Index(j.parent), ci = Index(j.child);
      if (ci < 0 || pi == kUnknownIndex) continue;  // said by the expansion's checks
      if (j.translation) {
        const Eigen::Vector3d g = Point(p, ci, j.child_point) - Point(p, pi, j.parent_point);
        const Eigen::VectorXd v = j.translation->directions * (Frame(p, j.translation->frame, pi, ci).transpose() * g);
        for (Eigen::Index k = 0; k < v.size(); ++k)
          rows.Joint(v[k], [&] { return Label{fmt::format("joint '{}' (translation{})", j.name, Component(*j.translation, k)), "m", j.where, j.name}; });
      }
      if (j.rotation && !j.child_axis.isZero()) {
        // A universal joint: the yokes stay perpendicular, (R_p a1) . (R_c a2) = 0 (its coupling's deflection).
        rows.Joint((Rotation(p, pi) * j.axis).dot(Rotation(p, ci) * j.child_axis),
                   [&] { return Label{fmt::format("joint '{}' (the yokes' angle)", j.name), "rad", j.where, j.name}; });
      } else if (j.rotation) {
        const Eigen::VectorXd v = j.rotation->directions * RelativeRotation(p, j.rotation->frame, pi, ci);
        for (Eigen::Index k = 0; k < v.size(); ++k)
          rows.Joint(v[k], [&] { return Label{fmt::format("joint '{}' (rotation{})", j.name, Component(*j.rotation, k)), "rad", j.where, j.name}; });
      }
      if (j.helix) {
        // A screw: the slide since the bodies as written follows the turn, lead / (2 pi) per radian.
        rows.Joint(Slide(p, j, pi, ci) - Slide(Pose{r0_, R0_}, j, pi, ci) -
                       j.lead / (2 * std::numbers::pi) * j.axis.dot(RelativeRotation(p, Coupling::Frame::kParent, pi, ci)),
                   [&] { return Label{fmt::format("joint '{}' (helix)", j.name), "m", j.where, j.name}; });
      }
    }
    for (const Given& g : spec_.given) {
      const auto l = [&] { return Label{Describe(g), Unit(g), g.where, g.part}; };
      switch (g.kind) {
        case Given::Kind::kJointAngle: {
          const Joint& j = *joints_.at(g.part);
          // The turn about the axis, in (-pi, pi] as the rotation vector has it: compared modulo 2 pi.
          rows.Given(std::remainder(j.axis.dot(RelativeRotation(p, Coupling::Frame::kParent, Index(j.parent), Index(j.child))) - g.value, 2 * std::numbers::pi), l);
          break;
        }
        case Given::Kind::kJointSlide: {
          const Joint& j = *joints_.at(g.part);
          rows.Given(Slide(p, j, Index(j.parent), Index(j.child)) - g.value, l);
          break;
        }
        case Given::Kind::kBodyPosition: {
          const Eigen::Vector3d v = p.r[Index(g.part)] - g.vector;
          for (int k = 0; k < 3; ++k) rows.Given(v[k], l);
          break;
        }
        case Given::Kind::kBodyOrientation: {
          const Eigen::Vector3d v = RotationVector(p.R[Index(g.part)] * g.matrix.transpose());
          for (int k = 0; k < 3; ++k) rows.Given(v[k], l);
          break;
        }
        default:
          break;  // velocity level
      }
    }
  }

  /// The velocity-level rows at the assembled pose `p` for the bodies' velocities `u` (v_b, w_b per body).
  void VelocityRows(const Pose& p, const Vec& u, Rows& rows) const {
    for (const Joint& j : m_.joints()) {
      const int pi = Index(j.parent), ci = Index(j.child);
      if (ci < 0 || pi == kUnknownIndex) continue;
      if (j.translation) {
        const Eigen::Vector3d dv = PointVelocity(p, u, ci, j.child_point) - PointVelocity(p, u, pi, j.parent_point);
        const Eigen::VectorXd v = j.translation->directions * (Frame(p, j.translation->frame, pi, ci).transpose() * dv);
        for (Eigen::Index k = 0; k < v.size(); ++k)
          rows.Joint(v[k], [&] { return Label{fmt::format("joint '{}' (translation{} rate)", j.name, Component(*j.translation, k)), "m/s", j.where, j.name}; });
      }
      const Eigen::Vector3d dw = Omega(u, ci) - Omega(u, pi);
      if (j.rotation && !j.child_axis.isZero()) {
        const Eigen::Vector3d n = (Rotation(p, pi) * j.axis).cross(Rotation(p, ci) * j.child_axis);
        rows.Joint(n.dot(dw), [&] { return Label{fmt::format("joint '{}' (the yokes' rate)", j.name), "rad/s", j.where, j.name}; });
      } else if (j.rotation) {
        const Eigen::VectorXd v = j.rotation->directions * (Frame(p, j.rotation->frame, pi, ci).transpose() * dw);
        for (Eigen::Index k = 0; k < v.size(); ++k)
          rows.Joint(v[k], [&] { return Label{fmt::format("joint '{}' (rotation{} rate)", j.name, Component(*j.rotation, k)), "rad/s", j.where, j.name}; });
      }
      if (j.helix) {
        const Eigen::Vector3d dv = PointVelocity(p, u, ci, j.child_point) - PointVelocity(p, u, pi, j.parent_point);
        const Eigen::Matrix3d rp = Rotation(p, pi);
        rows.Joint(j.axis.dot(rp.transpose() * dv) - j.lead / (2 * std::numbers::pi) * j.axis.dot(rp.transpose() * dw),
                   [&] { return Label{fmt::format("joint '{}' (helix rate)", j.name), "m/s", j.where, j.name}; });
      }
    }
    for (const GearMesh& gm : m_.gears()) {
      const int c = Index(gm.carrier), a = Index(gm.body_a), b = Index(gm.body_b);
      if (c == kUnknownIndex || a < 0 || b < 0) continue;
      const Eigen::Matrix3d rc = Rotation(p, c);
      const auto l = [&] {
        return Label{fmt::format("gear mesh '{}' (rolling)", gm.name), gm.contact == GearMesh::Contact::kPitch ? "m/s" : "rad/s", gm.where, gm.name};
      };
      if (gm.contact == GearMesh::Contact::kPitch) {
        // The coupling's own rate: the pitch points' relative velocity along the line of action.
        if (!geometry_.count(gm.name)) continue;
        const MeshGeometry& geo = geometry_.at(gm.name);
        const Eigen::Vector3d va = Velocity(u, a) + Omega(u, a).cross(rc * geo.rho_a);
        const Eigen::Vector3d vb = Velocity(u, b) + Omega(u, b).cross(rc * geo.rho_b);
        rows.Joint((rc * geo.n).dot(va - vb), l);
      } else {
        const double sa = gm.axis_a.normalized().dot(rc.transpose() * (Omega(u, a) - Omega(u, c)));
        const double sb = gm.axis_b.normalized().dot(rc.transpose() * (Omega(u, b) - Omega(u, c)));
        rows.Joint(gm.teeth_a * sa + gm.teeth_b * sb, l);
      }
    }
    for (const Given& g : spec_.given) {
      const auto l = [&] { return Label{Describe(g), Unit(g), g.where, g.part}; };
      switch (g.kind) {
        case Given::Kind::kJointRate: {
          const Joint& j = *joints_.at(g.part);
          const int pi = Index(j.parent), ci = Index(j.child);
          rows.Given((Rotation(p, pi) * j.axis).dot(Omega(u, ci) - Omega(u, pi)) - g.value, l);
          break;
        }
        case Given::Kind::kJointSpeed: {
          const Joint& j = *joints_.at(g.part);
          const int pi = Index(j.parent), ci = Index(j.child);
          const Eigen::Vector3d dv = PointVelocity(p, u, ci, j.child_point) - PointVelocity(p, u, pi, j.parent_point);
          rows.Given((Rotation(p, pi) * j.axis).dot(dv) - g.value, l);
          break;
        }
        case Given::Kind::kBodyVelocity: {
          const Eigen::Vector3d v = Velocity(u, Index(g.part)) - g.vector;
          for (int k = 0; k < 3; ++k) rows.Given(v[k], l);
          break;
        }
        case Given::Kind::kBodyOmega: {
          const Eigen::Vector3d v = Omega(u, Index(g.part)) - g.vector;
          for (int k = 0; k < 3; ++k) rows.Given(v[k], l);
          break;
        }
        case Given::Kind::kDriveSpeed: {
          const Drive& d = *drives_.at(g.part);
          const int b = Index(d.body), ref = Index(d.reference);
          const Eigen::Vector3d axis = d.axis.normalized();
          if (d.kind == Drive::Kind::kAngularVelocity)
            rows.Given((Rotation(p, ref) * axis).dot(Omega(u, b) - Omega(u, ref)) - g.value, l);
          else
            rows.Given(axis.dot(Velocity(u, b)) - g.value, l);
          break;
        }
        default:
          break;  // position level
      }
    }
  }

  /// The meshes through their pitch point of the assembled mechanism `m` (their geometry at t = 0).
  void SetGeometry(const Mechanism& m) {
    for (const GearMesh& gm : m.gears())
      if (gm.contact == GearMesh::Contact::kPitch && Index(gm.body_a) >= 0 && Index(gm.body_b) >= 0 && Index(gm.carrier) != kUnknownIndex) {
        const MeshGeometry geo = m.GeometryOf(gm);
        if (geo.error.empty()) geometry_[gm.name] = geo;
      }
  }

 private:
  Eigen::Vector3d Point(const Pose& p, int b, const Eigen::Vector3d& at) const {
    return b == kGroundIndex ? at : Eigen::Vector3d(p.r[b] + p.R[b] * at);
  }
  Eigen::Matrix3d Rotation(const Pose& p, int b) const { return b == kGroundIndex ? Eigen::Matrix3d::Identity() : p.R[b]; }
  /// A joint's slide along its axis (parent frame): from the parent's point to the child's.
  double Slide(const Pose& p, const Joint& j, int pi, int ci) const {
    return j.axis.dot(Rotation(p, pi).transpose() * (Point(p, ci, j.child_point) - Point(p, pi, j.parent_point)));
  }
  Eigen::Matrix3d Written(int b) const { return b == kGroundIndex ? Eigen::Matrix3d::Identity() : R0_[b]; }
  static Eigen::Vector3d Velocity(const Vec& u, int b) { return b == kGroundIndex ? Eigen::Vector3d::Zero() : Eigen::Vector3d(u.segment<3>(6 * b)); }
  static Eigen::Vector3d Omega(const Vec& u, int b) { return b == kGroundIndex ? Eigen::Vector3d::Zero() : Eigen::Vector3d(u.segment<3>(6 * b + 3)); }
  Eigen::Vector3d PointVelocity(const Pose& p, const Vec& u, int b, const Eigen::Vector3d& at) const {
    return b == kGroundIndex ? Eigen::Vector3d::Zero() : Eigen::Vector3d(Velocity(u, b) + Omega(u, b).cross(p.R[b] * at));
  }
  /// The rotation from a coupling's frame to the inertial frame.
  Eigen::Matrix3d Frame(const Pose& p, Coupling::Frame f, int parent, int child) const {
    switch (f) {
      case Coupling::Frame::kParent: return Rotation(p, parent);
      case Coupling::Frame::kChild: return Rotation(p, child);
      case Coupling::Frame::kWorld: break;
    }
    return Eigen::Matrix3d::Identity();
  }
  /// The rotation vector of the joint's relative rotation since the bodies as written, in the
  /// coupling's frame: what its rotation coupling integrates from R_p^T (w_c - w_p) (parent),
  /// R_c^T (w_c - w_p) (child) or w_c - w_p (world).
  Eigen::Vector3d RelativeRotation(const Pose& p, Coupling::Frame f, int parent, int child) const {
    const Eigen::Matrix3d rp = Rotation(p, parent), rc = Rotation(p, child), rp0 = Written(parent), rc0 = Written(child);
    switch (f) {
      case Coupling::Frame::kParent: return RotationVector(rp.transpose() * rc * rc0.transpose() * rp0);
      case Coupling::Frame::kChild: return RotationVector(rc0.transpose() * rp0 * rp.transpose() * rc);
      case Coupling::Frame::kWorld: break;
    }
    return RotationVector(rc * rc0.transpose() * rp0 * rp.transpose());
  }
  static std::string Component(const Coupling& c, Eigen::Index k) {
    return k < static_cast<Eigen::Index>(c.components.size()) ? " " + c.components[k] : fmt::format(" direction {}", k + 1);
  }
  static std::string Describe(const Given& g) {
    switch (g.kind) {
      case Given::Kind::kJointAngle: return fmt::format("the given angle of joint '{}'", g.part);
      case Given::Kind::kJointRate: return fmt::format("the given rate of joint '{}'", g.part);
      case Given::Kind::kJointSlide: return fmt::format("the given slide of joint '{}'", g.part);
      case Given::Kind::kJointSpeed: return fmt::format("the given speed of joint '{}'", g.part);
      case Given::Kind::kBodyPosition: return fmt::format("the given position of body '{}'", g.part);
      case Given::Kind::kBodyOrientation: return fmt::format("the given orientation of body '{}'", g.part);
      case Given::Kind::kBodyVelocity: return fmt::format("the given velocity of body '{}'", g.part);
      case Given::Kind::kBodyOmega: return fmt::format("the given angular velocity of body '{}'", g.part);
      case Given::Kind::kDriveSpeed: return fmt::format("the speed of drive '{}'", g.part);
    }
    return {};
  }
  static std::string Unit(const Given& g) {
    switch (g.kind) {
      case Given::Kind::kJointAngle:
      case Given::Kind::kBodyOrientation: return "rad";
      case Given::Kind::kJointRate:
      case Given::Kind::kBodyOmega: return "rad/s";
      case Given::Kind::kJointSlide:
      case Given::Kind::kBodyPosition: return "m";
      case Given::Kind::kJointSpeed:
      case Given::Kind::kBodyVelocity: return "m/s";
      case Given::Kind::kDriveSpeed: return "rad/s or m/s";
    }
    return {};
  }

  const Mechanism& m_;
  const AssemblySpec& spec_;
  std::unordered_map<std::string, int> index_;
  std::unordered_map<std::string, const Joint*> joints_;
  std::unordered_map<std::string, const Drive*> drives_;
  std::unordered_map<std::string, MeshGeometry> geometry_;
  std::vector<Eigen::Vector3d> r0_;
  std::vector<Eigen::Matrix3d> R0_;
};

Pose Moved(const Pose& p, const Vec& d, double t) {
  Pose q = p;
  for (size_t b = 0; b < p.r.size(); ++b) {
    q.r[b] += t * d.segment<3>(6 * static_cast<Eigen::Index>(b));
    q.R[b] = Exp(t * d.segment<3>(6 * static_cast<Eigen::Index>(b) + 3)) * p.R[b];
  }
  return q;
}

double Merit(const Rows& rows) { return ToVec(rows.joint).squaredNorm() + ToVec(rows.given).squaredNorm(); }

double MaxAbs(const std::vector<double>& v) {
  double m = 0.0;
  for (double x : v) m = std::max(m, std::abs(x));
  return m;
}

/// The rows above the tolerance, worst first, as "joint 'J' (translation y): 0.05 m".
std::vector<std::string> Violations(const std::vector<double>& v, const std::vector<Label>& labels, double tol, size_t* worst) {
  std::vector<size_t> order;
  for (size_t k = 0; k < v.size(); ++k)
    if (std::abs(v[k]) > tol) order.push_back(k);
  std::sort(order.begin(), order.end(), [&](size_t a, size_t b) { return std::abs(v[a]) > std::abs(v[b]); });
  std::vector<std::string> out;
  for (size_t k : order) out.push_back(fmt::format("{} is off by {:.3g} {}", labels[k].text, std::abs(v[k]), labels[k].unit));
  if (worst) *worst = order.empty() ? 0 : order.front();
  return out;
}

/// When a row of `v` misses by more than the tolerance, a `mech.assembly` error at the worst row
/// (the violated rows as its details), and true.
bool Refused(DiagnosticSink& sink, const AssemblySpec& spec, const std::string& message, const std::vector<double>& v,
             const std::vector<Label>& labels, std::string hint) {
  if (!(MaxAbs(v) > spec.tolerance)) return false;
  size_t worst = 0;
  std::vector<std::string> details = Violations(v, labels, spec.tolerance, &worst);
  Diagnostic d;
  d.code = codes::kMechAssembly;
  d.where = labels.empty() || !labels[worst].where.known() ? spec.where : labels[worst].where;
  d.element = labels.empty() ? "assembly" : labels[worst].element;
  d.message = fmt::format("{}: {}", message, details.empty() ? "" : details.front());
  if (details.size() > 1) d.details.assign(details.begin() + 1, details.begin() + static_cast<std::ptrdiff_t>(std::min<size_t>(details.size(), 6)));
  d.hint = std::move(hint);
  sink.Add(std::move(d));
  return true;
}

}  // namespace

AssemblyReport Assemble(Mechanism& m, const AssemblySpec& spec, DiagnosticSink& sink) {
  AssemblyReport report;
  // An ideal velocity drive imposes its value from t = 0: its speed at t = 0 is a given of the
  // velocity level (unless the model gives that drive's speed itself).
  AssemblySpec full = spec;
  for (const Drive& d : m.drives()) {
    const bool velocity = d.kind == Drive::Kind::kAngularVelocity || d.kind == Drive::Kind::kVelocity;
    const bool given = std::any_of(spec.given.begin(), spec.given.end(), [&](const Given& g) { return g.part == d.name; });
    if (velocity && d.rigid && !d.formula.given() && !given) {
      Given g;
      g.kind = Given::Kind::kDriveSpeed;
      g.part = d.name;
      g.value = d.value(0.0);
      g.where = d.where;
      full.given.push_back(g);
    }
  }
  Assembler as(m, full);
  const int n = 6 * as.num_bodies();

  // --- position level: Gauss-Newton with minimum-norm steps ---------------------------------
  std::vector<Label> joint_labels, given_labels;
  Pose pose = as.Start();
  Rows rows;
  rows.joint_labels = &joint_labels;
  rows.given_labels = &given_labels;
  as.PositionRows(pose, rows);
  double length = 1.0;  // the mechanism's size, for the difference quotients' step
  for (const Eigen::Vector3d& r : pose.r) length = std::max(length, r.norm());
  const double h = 1e-6 * length;
  for (; report.iterations < spec.max_iterations; ++report.iterations) {
    if (std::max(MaxAbs(rows.joint), MaxAbs(rows.given)) <= 1e-3 * spec.tolerance) break;
    // The Jacobians by central differences (the residuals are smooth; the error, ~h^2, only slows
    // the last digits of a Newton step).
    Mat J(rows.joint.size(), n), G(rows.given.size(), n);
    for (int k = 0; k < n; ++k) {
      Vec e = Vec::Zero(n);
      e[k] = (k % 6 < 3 ? 1.0 : 1.0 / length) * h;
      Rows plus, minus;
      as.PositionRows(Moved(pose, e, 1.0), plus);
      as.PositionRows(Moved(pose, e, -1.0), minus);
      J.col(k) = (ToVec(plus.joint) - ToVec(minus.joint)) / (2 * e[k]);
      G.col(k) = (ToVec(plus.given) - ToVec(minus.given)) / (2 * e[k]);
    }
    const Vec d = MinimumNormStep(G, ToVec(rows.given), J, ToVec(rows.joint));
    if (d.lpNorm<Eigen::Infinity>() <= 1e-15 * length) break;  // stationary: nothing left to gain
    // Full steps near the solution; halved while they make things worse far from it.
    const double before = Merit(rows);
    double t = 1.0;
    Rows next;
    for (int halving = 0; halving < 30; ++halving, t *= 0.5) {
      next = Rows{};
      as.PositionRows(Moved(pose, d, t), next);
      if (Merit(next) < before) break;
    }
    if (!(Merit(next) < before)) break;
    pose = Moved(pose, d, t);
    rows = std::move(next);
  }
  report.position_residual = std::max(MaxAbs(rows.joint), MaxAbs(rows.given));
  if (Refused(sink, spec, "no assembly: the given coordinates contradict each other", rows.given, given_labels,
              "give each coordinate once: a body's position or orientation fixes the joint angles and slides that reach it") ||
      Refused(sink, spec,
              fmt::format("no assembly satisfies the joints{} (after {} iterations)", full.given.empty() ? "" : " at the given coordinates",
                          report.iterations),
              rows.joint, joint_labels,
              "check the joints' points ('at', 'child_at') against the links' lengths, and the given coordinates (a crank longer "
              "than its rod allows cannot reach every angle)"))
    return report;

  // --- velocity level: one linear least-squares problem --------------------------------------
  Mechanism assembled = m;
  for (int b = 0; b < as.num_bodies(); ++b) {
    assembled.bodies_mutable()[b].position = pose.r[b];
    assembled.bodies_mutable()[b].orientation = pose.R[b];
  }
  as.SetGeometry(assembled);
  Vec u0(n);
  for (int b = 0; b < as.num_bodies(); ++b) {
    u0.segment<3>(6 * b) = m.bodies()[b].velocity;
    u0.segment<3>(6 * b + 3) = m.bodies()[b].omega;
  }
  std::vector<Label> vjoint_labels, vgiven_labels;
  Rows at0;
  at0.joint_labels = &vjoint_labels;
  at0.given_labels = &vgiven_labels;
  as.VelocityRows(pose, u0, at0);
  // The rows are affine in u: their matrix column by column (exact up to rounding).
  Mat J(at0.joint.size(), n), G(at0.given.size(), n);
  for (int k = 0; k < n; ++k) {
    Vec u = u0;
    u[k] += 1.0;
    Rows r;
    as.VelocityRows(pose, u, r);
    J.col(k) = ToVec(r.joint) - ToVec(at0.joint);
    G.col(k) = ToVec(r.given) - ToVec(at0.given);
  }
  Vec u = u0 + MinimumNormStep(G, ToVec(at0.given), J, ToVec(at0.joint));
  Rows vel;
  as.VelocityRows(pose, u, vel);
  u += MinimumNormStep(G, ToVec(vel.given), J, ToVec(vel.joint));  // one refinement of the rounding
  vel = Rows{};
  as.VelocityRows(pose, u, vel);
  report.velocity_residual = std::max(MaxAbs(vel.joint), MaxAbs(vel.given));
  if (Refused(sink, spec, "no assembly: the given speeds contradict each other", vel.given, vgiven_labels,
              "give each rate once: an ideal velocity drive's speed at t = 0 is given too") ||
      Refused(sink, spec, "no assembly: the given speeds contradict the joints", vel.joint, vjoint_labels,
              "a mechanism that cannot move cannot take a speed: check the given rates and the ideal drives' speeds at t = 0"))
    return report;

  // --- the result and what moved --------------------------------------------------------------
  std::vector<std::string> lines;
  for (int b = 0; b < as.num_bodies(); ++b) {
    Body& body = m.bodies_mutable()[b];
    AssemblyReport::Move mv;
    mv.body = body.name;
    mv.displacement = (pose.r[b] - body.position).norm();
    mv.rotation = RotationVector(pose.R[b] * body.orientation.transpose()).norm();
    mv.velocity = (u.segment<3>(6 * b) - body.velocity).norm();
    mv.omega = (u.segment<3>(6 * b + 3) - body.omega).norm();
    report.moves.push_back(mv);
    body.position = pose.r[b];
    body.orientation = pose.R[b];
    body.velocity = u.segment<3>(6 * b);
    body.omega = u.segment<3>(6 * b + 3);
    // Changes within the tolerance are rounding: said as 0.
    auto shown = [&](double x) { return x > spec.tolerance ? x : 0.0; };
    if (std::max({mv.displacement, mv.rotation, mv.velocity, mv.omega}) > spec.tolerance)
      lines.push_back(fmt::format("{}: moved {:.6g} m, turned {:.6g} deg, velocity changed by {:.6g} m/s, angular velocity by {:.6g} rad/s",
                                  body.name, shown(mv.displacement), shown(mv.rotation) * 180 / std::numbers::pi, shown(mv.velocity),
                                  shown(mv.omega)));
  }
  // A joint whose translation coupling leaves directions free (prismatic) keeps its points apart
  // along them; the coupling acts on nothing there, so its parent point is put onto the child's
  // point: the same joint, starting with no gap.
  for (Joint& j : m.joints_mutable()) {
    const int pi = as.Index(j.parent), ci = as.Index(j.child);
    if (!j.translation || j.translation->directions.rows() >= 3 || ci < 0 || pi == kUnknownIndex) continue;
    const Eigen::Vector3d child_point = pose.r[ci] + pose.R[ci] * j.child_point;
    j.parent_point = pi == kGroundIndex ? child_point : Eigen::Vector3d(pose.R[pi].transpose() * (child_point - pose.r[pi]));
  }
  report.ok = true;
  Diagnostic d;
  d.severity = Diagnostic::Severity::kWarning;
  d.code = codes::kMechAssembled;
  d.where = spec.where;
  d.element = "assembly";
  d.message = fmt::format("assembled in {} iteration{} (largest violation left {:.2g} m or rad, {:.2g} m/s or rad/s): {}", report.iterations,
                          report.iterations == 1 ? "" : "s", report.position_residual, report.velocity_residual,
                          lines.empty() ? "nothing moved" : fmt::format("{} bod{} moved", lines.size(), lines.size() == 1 ? "y" : "ies"));
  d.details = std::move(lines);
  sink.Add(std::move(d));
  return report;
}

}  // namespace multibond::mech
