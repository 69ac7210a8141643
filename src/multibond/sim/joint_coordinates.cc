#include "multibond/sim/joint_coordinates.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <stdexcept>
#include <utility>

#include <fmt/format.h>

#include "multibond/sim/simulator.h"

namespace multibond {

namespace {

using Mat3 = Eigen::Matrix3d;
using Vec3 = Eigen::Vector3d;
using RowMajor3 = Eigen::Matrix<double, 3, 3, Eigen::RowMajor>;

Mat3 Hat(const Vec3& v) {
  Mat3 m;
  m << 0.0, -v.z(), v.y(), v.z(), 0.0, -v.x(), -v.y(), v.x(), 0.0;
  return m;
}

/// A 3-vector stored in a state array (a function: `Map<Vec3>(p) = v;` declares a variable p).
Eigen::Map<Vec3> Out(double* p) { return Eigen::Map<Vec3>(p); }

/// Where S takes n, e1 and e2 (its columns): the diagonal (1, 1, 1)/sqrt(3) and the two
/// directions that complete it.
Mat3 MixTarget() {
  Mat3 to;
  to.col(0) = Vec3::Ones().normalized();
  to.col(1) = Vec3(1.0, -1.0, 0.0).normalized();
  to.col(2) = to.col(0).cross(to.col(1));
  return to;
}

}  // namespace

/// I v and I^-1 v in the body's frame: three products where the inertia is diagonal (a disc, a
/// box on its principal axes; the same numbers as the full product, whose other terms are 0 v).
Vec3 JointCoordinateSystem::Inertia(const Body& b, const Vec3& v) {
  return b.diagonal ? Vec3(b.inertia.diagonal().cwiseProduct(v)) : Vec3(b.inertia * v);
}
Vec3 JointCoordinateSystem::InverseInertia(const Body& b, const Vec3& v) {
  return b.diagonal ? Vec3(b.inertia_inv.diagonal().cwiseProduct(v)) : Vec3(b.inertia_inv * v);
}

namespace {

/// sin(f)/f, (1 - cos f)/f^2 and (f - sin f)/f^3 for f = |v|, from f2 = |v|^2, by their series
/// near 0 (where a bearing's tilt always is: no square root on that path).
void RodriguesCoefficients(double f2, double& c1, double& c2, double& c3) {
  if (f2 < 1e-6) {
    // Products with the constants' reciprocals: no divisions on the map's path.
    c1 = 1.0 + f2 * (-1.0 / 6.0 + f2 * (1.0 / 120.0));
    c2 = 0.5 + f2 * (-1.0 / 24.0 + f2 * (1.0 / 720.0));
    c3 = 1.0 / 6.0 + f2 * (-1.0 / 120.0 + f2 * (1.0 / 5040.0));
  } else {
    const double f = std::sqrt(f2), s = std::sin(f), c = std::cos(f);
    c1 = s / f;
    c2 = (1.0 - c) / f2;
    c3 = (f - s) / (f2 * f);
  }
}

/// The principal axis of `inertia` (body frame) nearest to the unit vector `a`, when it is
/// within kPrincipalSnap of it (for equal principal moments, the nearest direction of their
/// plane); else `a`. A body that spins freely (no bearing: the tree's axis is its initial spin)
/// keeps spinning about a principal axis, not about its initial angular velocity: a gyroscope
/// started in steady precession spins about its symmetry axis while its angular velocity is off
/// it by the precession. About that direction instead, the rotation off the axis would turn at
/// the spin rate. Not for a bearing's axis (TreeBody::bearing), which the body keeps: a shaft
/// whose bearing is 0.05 rad off a principal axis would otherwise wobble about the snapped axis at
/// the spin rate (rigid, 100 rad/s: 1,621 BDF steps over 1 s instead of 12).
Vec3 NearPrincipalAxis(const Mat3& inertia, const Vec3& a) {
  constexpr double kPrincipalSnap = 0.1;  // [rad]
  const Eigen::SelfAdjointEigenSolver<Mat3> eig(inertia);
  const Vec3 moments = eig.eigenvalues();
  const Mat3 axes = eig.eigenvectors();
  Vec3 best = a;
  double best_norm = -1.0;
  for (int i = 0; i < 3; ++i) {  // each group of equal moments: a's projection on their span
    Vec3 projection = Vec3::Zero();
    for (int j = 0; j < 3; ++j)
      if (std::abs(moments[j] - moments[i]) <= 1e-9 * moments.cwiseAbs().maxCoeff()) projection += axes.col(j) * axes.col(j).dot(a);
    if (projection.norm() > best_norm) best = projection, best_norm = projection.norm();
  }
  if (!(best_norm > std::cos(kPrincipalSnap))) return a;
  return best / best_norm;
}

}  // namespace

JointCoordinateSystem::JointCoordinateSystem(const CompiledModel& model, const JointTree& tree, ModelSystem* system)
    : model_(model), system_(system) {
  const int nx = model.num_states();
  std::vector<bool> covered(nx, false);
  std::map<std::string, int> index;
  auto state = [&](const std::string& name, int size, bool required) {
    const auto v = model.FindVariable(name);
    if (!v || v->in != VariableRef::In::kState || v->size != size) {
      if (!required) return -1;
      throw std::invalid_argument(fmt::format("joint coordinates: the model has no {}-component state '{}'", size, name));
    }
    for (int k = 0; k < size; ++k) {
      if (covered[v->offset + k]) throw std::invalid_argument(fmt::format("joint coordinates: state '{}' belongs to two bodies", name));
      covered[v->offset + k] = true;
    }
    return v->offset;
  };
  const BondGraph& g = model.graph();
  for (const TreeBody& tb : tree) {
    if (index.count(tb.name)) throw std::invalid_argument(fmt::format("joint coordinates: body '{}' is in the tree twice", tb.name));
    Body b;
    if (!tb.parent.empty()) {
      const auto it = index.find(tb.parent);
      if (it == index.end())
        throw std::invalid_argument(fmt::format("joint coordinates: the parent '{}' of body '{}' is not before it in the tree", tb.parent, tb.name));
      b.parent = it->second;
    }
    b.r = state(tb.name + ".r", 3, true);
    b.p = state(tb.name + ".p", 3, true);
    b.R = state(tb.name + ".R", 9, false);
    if (b.R >= 0) b.h = state(tb.name + ".h", 3, true);
    const int mass = g.Find(tb.name + ".mass");
    if (mass < 0 || !g.element(mass).param.is_scalar || !(g.element(mass).param.scalar > 0.0))
      throw std::invalid_argument(fmt::format("joint coordinates: body '{}' has no mass element '{}.mass'", tb.name, tb.name));
    b.mass = g.element(mass).param.scalar;
    if (b.rotates()) {
      const int inertia = g.Find(tb.name + ".inertia");
      if (inertia < 0) throw std::invalid_argument(fmt::format("joint coordinates: body '{}' has no element '{}.inertia'", tb.name, tb.name));
      b.inertia = g.element(inertia).param.AsMatrix(3, 3);
      b.inertia_inv = b.inertia.inverse();
      b.diagonal = b.inertia.isDiagonal(0.0);
      b.anchor = tb.anchor;
      b.anchored = !b.anchor.isZero(0.0);
      b.bearing = tb.bearing;
      const double norm = tb.axis.norm();
      if (!(norm > 0.0)) throw std::invalid_argument(fmt::format("joint coordinates: body '{}' has a zero axis", tb.name));
      SetAxis(b, tb.axis / norm);
      b.nb = b.n;  // until the first chart (FromModel) fixes it in the body
      SetWeight(b);
    }
    b.y = n_;
    const std::string& nm = tb.name;
    if (b.rotates()) {
      for (const char* s : {".tilt.1", ".tilt.2", ".angle"}) names_.push_back(nm + s);
    }
    for (const char* c : {".x", ".y", ".z"}) names_.push_back(nm + ".offset" + c);
    if (b.rotates())  // S k: its components on the basis S maps to, not on x, y, z
      for (const char* c : {".1", ".2", ".3"}) names_.push_back(nm + ".momentum_rel" + c);
    for (const char* c : {".x", ".y", ".z"}) names_.push_back(nm + ".offset_rate" + c);
    n_ += b.rotates() ? 12 : 6;
    index[tb.name] = static_cast<int>(bodies_.size());
    bodies_.push_back(b);
  }
  for (int i = 0; i < nx; ++i) {
    if (covered[i]) continue;
    others_.emplace_back(i, n_++);
    names_.push_back(model.state_names()[i]);
  }
  x_ = model.MakeInitialState();
  xdot_ = Eigen::VectorXd::Zero(nx);
  y_before_ = Eigen::VectorXd::Zero(n_);
  if (const JacobianPattern* mp = model.jacobian_pattern()) BuildPattern(*mp);
}

void JointCoordinateSystem::BuildPattern(const JacobianPattern& mp) {
  // Which entries of dy'/dy can be nonzero, from the model's pattern and the tree. Through the
  // map (parents first), a body's
  //   angles (a, b, theta) reach R, r, p, h of the body and of its descendants,
  //   offset d             reaches r, and p under a turning parent (v = v_P + w_P x R_P d + ...),
  //   rate S u             reaches p, h   (w, and v through w x arm),
  //   offset rate d'       reaches p,
  // and every y of it reaches its own y' and its descendants' rates (u', d'': the kinematics
  // read the parent's configuration and velocities). The model's x' rows reached from those x:
  // an other state's is its own y' row; a body's p' and h' enter the rates of the body and of
  // its children (CalcDerivatives reads x' there only: w_P' and v_P' are the parent's alone,
  // not the grandparent's); its R' and r' are read by nothing. Sound where the model's pattern
  // is (a test compares it with difference quotients). The compliant differential: 5.6k
  // entries of 154 x 154 (the true Jacobian 3.6k), against 17k when every body state was
  // coupled to every other: few enough for the sparse solver.
  enum Kind { kR = 1, kPosition = 2, kMomentum = 4, kSpin = 8 };
  const int nx = model_.num_states(), nb = static_cast<int>(bodies_.size());
  std::vector<int> body_of_x(nx, -1), kind_of_x(nx, 0), y_of_x(nx, -1), x_of_y(n_, -1);
  for (int i = 0; i < nb; ++i) {
    const Body& b = bodies_[i];
    auto own = [&](int offset, int size, Kind kind) {
      for (int k = 0; offset >= 0 && k < size; ++k) body_of_x[offset + k] = i, kind_of_x[offset + k] = kind;
    };
    own(b.R, 9, kR), own(b.r, 3, kPosition), own(b.p, 3, kMomentum), own(b.h, 3, kSpin);
  }
  for (const auto& [ix, iy] : others_) y_of_x[ix] = iy, x_of_y[iy] = ix;
  std::vector<std::vector<bool>> below(nb, std::vector<bool>(nb, false));  // [i][k]: k is i or under i
  for (int i = nb - 1; i >= 0; --i) {  // parents come first in bodies_
    below[i][i] = true;
    if (const int p = bodies_[i].parent; p >= 0)
      for (int k = 0; k < nb; ++k)
        if (below[i][k]) below[p][k] = true;
  }
  // A set of y' rows, gathered by marking (no n x n table: a large tree's pattern is sparse).
  std::vector<char> marked(n_, 0);
  std::vector<int> rows;
  auto mark = [&](int r) {
    if (!marked[r]) marked[r] = 1, rows.push_back(r);
  };
  auto take_rows = [&] {  // the rows marked, sorted; the marks cleared
    std::sort(rows.begin(), rows.end());
    for (const int r : rows) marked[r] = 0;
    return std::exchange(rows, {});
  };
  auto rate_rows_of = [&](int body) {  // S u and d', or d'
    const Body& b = bodies_[body];
    const int first = b.y + (b.rotates() ? 6 : 3);
    for (int r = first; r < first + (b.rotates() ? 6 : 3); ++r) mark(r);
  };
  auto add_reached = [&](int x_column) {  // the y' rows of one x column
    for (int e = mp.col_start[x_column]; e < mp.col_start[x_column + 1]; ++e) {
      const int r = mp.row_index[e];
      if (y_of_x[r] >= 0) {
        mark(y_of_x[r]);
      } else if (kind_of_x[r] & (kMomentum | kSpin)) {
        const int owner = body_of_x[r];
        for (int k = 0; k < nb; ++k)
          if (k == owner || bodies_[k].parent == owner) rate_rows_of(k);
      }
    }
  };
  std::vector<std::vector<int>> x_columns_of(nb);  // each body's own x columns
  for (int c = 0; c < nx; ++c)
    if (body_of_x[c] >= 0) x_columns_of[body_of_x[c]].push_back(c);
  // The y' rows of each group of a body's coordinates (all columns of a group alike).
  struct Group {
    int first, size, reaches;
  };
  std::vector<std::vector<int>> group_rows;
  std::vector<int> group_of(n_, -1);  // a body coordinate's group in group_rows
  for (int i = 0; i < nb; ++i) {
    const Body& b = bodies_[i];
    // The offset moves velocities only under a turning parent (w_P x R_P d).
    const int offset = kPosition | (Parent(b).rotates() ? kMomentum : 0);
    const std::vector<Group> groups =
        b.rotates() ? std::vector<Group>{{0, 3, kR | kPosition | kMomentum | kSpin}, {3, 3, offset}, {6, 3, kMomentum | kSpin}, {9, 3, kMomentum}}
                    : std::vector<Group>{{0, 3, offset}, {3, 3, kMomentum}};
    for (const Group& group : groups) {
      for (int r = b.y; r < b.y + (b.rotates() ? 12 : 6); ++r) mark(r);
      for (int k = 0; k < nb; ++k) {
        if (!below[i][k]) continue;
        rate_rows_of(k);
        for (const int c : x_columns_of[k])
          if (kind_of_x[c] & group.reaches) add_reached(c);
      }
      for (int k = 0; k < group.size; ++k) group_of[b.y + group.first + k] = static_cast<int>(group_rows.size());
      group_rows.push_back(take_rows());
    }
  }
  pattern_.n = n_;
  pattern_.col_start.assign(1, 0);
  for (int j = 0; j < n_; ++j) {
    if (group_of[j] >= 0) {  // a body's coordinate: its group's rows hold its own
      const std::vector<int>& own = group_rows[group_of[j]];
      pattern_.row_index.insert(pattern_.row_index.end(), own.begin(), own.end());
    } else {  // an other state: its own row and those its x column reaches
      mark(j);
      add_reached(x_of_y[j]);
      const std::vector<int> own = take_rows();
      pattern_.row_index.insert(pattern_.row_index.end(), own.begin(), own.end());
    }
    pattern_.col_start.push_back(static_cast<int>(pattern_.row_index.size()));
  }
}

void JointCoordinateSystem::SetWeight(Body& b) {
  // The inertia about the anchor, I + m (|a|^2 1 - a a^T), averaged over turns about the axis n_b:
  // (n^T A n) n n^T + (tr A - n^T A n) / 2 (1 - n n^T). The spin about the axis leaves it as it
  // is, so that a body spinning steadily in its bearing keeps k = M u constant whatever its
  // principal axes; for a body symmetric about its axis (a top, a gyroscope), whose anchor is on
  // it, it is that inertia itself and k the angular momentum about the anchor.
  const Mat3 about_anchor = b.inertia + b.mass * (b.anchor.squaredNorm() * Mat3::Identity() - b.anchor * b.anchor.transpose());
  const Vec3 n = b.nb.normalized();
  const double axial = n.dot(about_anchor * n);
  const Mat3 along = n * n.transpose();
  b.weight = axial * along + 0.5 * (about_anchor.trace() - axial) * (Mat3::Identity() - along);
  b.weight_inv = b.weight.inverse();
}

void JointCoordinateSystem::SetAxis(Body& b, const Vec3& n) {
  b.n = n;
  // e1, e2: completing n to a right-handed orthonormal basis.
  int smallest = 0;
  b.n.cwiseAbs().minCoeff(&smallest);
  Vec3 helper = Vec3::Zero();
  helper[smallest] = 1.0;
  b.e1 = b.n.cross(helper).normalized();
  b.e2 = b.n.cross(b.e1);
  // S: n to the diagonal (1, 1, 1)/sqrt(3), e1 and e2 to the two directions that complete it.
  Mat3 from;
  from << b.n, b.e1, b.e2;
  b.mix = MixTarget() * from.transpose();
  b.n_chart = Hat(b.n) * b.chart;
  b.n2_chart = Hat(b.n) * b.n_chart;
}

void JointCoordinateSystem::FromModel(const double* x, double* y) {
  for (Body& b : bodies_) {  // the configuration, charted at x: psi = theta = 0
    const Body& pb = Parent(b);
    b.rw = Eigen::Map<const Vec3>(x + b.r);
    double* yb = y + b.y;
    Vec3 arm = Vec3::Zero();
    if (b.rotates()) {
      b.Rw = Eigen::Map<const RowMajor3>(x + b.R);
      const Mat3 q = pb.Rw.transpose() * b.Rw;
      // The axis is the body's: fixed in its frame from the first chart on (n_b = C^T n), and
      // in the parent's frame wherever the body has turned it to (n = Q n_b). A body in a
      // bearing keeps it in both; a body with none (a top on a pivot, a tumbling body) turns
      // about it wherever it has gone, and the new chart's angle theta is still its spin.
      if (!b.axis_in_body) {
        b.nb = b.bearing ? Vec3(q.transpose() * b.n) : NearPrincipalAxis(b.inertia, q.transpose() * b.n);
        b.axis_in_body = true;
        SetWeight(b);
      }
      b.chart = q;
      SetAxis(b, (q * b.nb).normalized());
      yb[0] = yb[1] = yb[2] = 0.0;
      yb += 3;
      arm = b.Rw * b.anchor;
    }
    Out(yb) = pb.Rw.transpose() * (b.rw + arm - pb.rw);
  }
  VelocitiesFromModel(x, y);
}

void JointCoordinateSystem::ToModel(const double* y, double* x) {
  for (Body& b : bodies_) {
    const Body& pb = Parent(b);
    const Mat3& Rp = pb.Rw;
    const Vec3 &rp = pb.rw, &vp = pb.vw, &wp = pb.ww;
    const double* yb = y + b.y;
    if (b.rotates()) {
      const Vec3 psi = yb[0] * b.e1 + yb[1] * b.e2;
      const double f2 = psi.squaredNorm();
      double c1, c2, c3;
      RodriguesCoefficients(f2, c1, c2, c3);
      const Mat3 k = Hat(psi), k2 = psi * psi.transpose() - f2 * Mat3::Identity();  // [psi x]^2
      const Mat3 exp_psi = Mat3::Identity() + c1 * k + c2 * k2;
      // Rot(n, theta) C = C + sin(theta) [n x] C + (1 - cos(theta)) [n x]^2 C.
      const double st = std::sin(yb[2]), ct = std::cos(yb[2]);
      b.Rw = Rp * (exp_psi * (b.chart + st * b.n_chart + (1.0 - ct) * b.n2_chart));
      // u = J_l(psi) psi' + Exp(psi) n theta', psi' = a' e1 + b' e2 (for CalcDerivatives). On the
      // basis (e1, e2, n), where psi = (a, b, 0), the columns J_l e1, J_l e2, Exp(psi) n are
      // (1 - c3 b^2, c3 a b, -c2 b), (c3 a b, 1 - c3 a^2, c2 a), (c1 b, -c1 a, 1 - c2 (a^2 + b^2)).
      const double a = yb[0], bt = yb[1], ab = a * bt;
      Mat3 m;
      m << 1.0 - c3 * bt * bt, c3 * ab, c1 * bt,  //
          c3 * ab, 1.0 - c3 * a * a, -c1 * a,     //
          -c2 * bt, c2 * a, 1.0 - c2 * (a * a + bt * bt);
      b.rates_from_u = m.inverse();  // of (e1.u, e2.u, n.u)
      yb += 3;
      // The stored rates are S k, k = M u, M = Q W Q^T (Q = R_P^T R; W the inertia about the
      // anchor averaged about the axis, SetWeight): the body's angular momentum about its anchor
      // relative to P, in P's frame, for a body symmetric about its axis.
      b.q = Rp.transpose() * b.Rw;
      b.k = b.mix.transpose() * Eigen::Map<const Vec3>(yb + 3);
      b.u = b.q * (b.weight_inv * (b.q.transpose() * b.k));
      b.ww = wp + Rp * b.u;
      Eigen::Map<RowMajor3>(x + b.R) = b.Rw;
      Out(x + b.h) = b.Rw * Inertia(b, b.Rw.transpose() * b.ww);
    } else {
      b.Rw = Mat3::Identity();
      b.ww = Vec3::Zero();
    }
    const Vec3 rel = Rp * Eigen::Map<const Vec3>(yb);
    const Vec3 rate = Rp * Eigen::Map<const Vec3>(yb + (b.rotates() ? 6 : 3));
    b.rw = rp + rel;
    b.vw = vp + wp.cross(rel) + rate;
    if (b.anchored) {  // (most joints sit at the child's centre of mass: no arm)
      const Vec3 arm = b.Rw * b.anchor;
      b.rw -= arm;
      b.vw -= b.ww.cross(arm);
    }
    Out(x + b.r) = b.rw;
    Out(x + b.p) = b.mass * b.vw;
  }
  for (const auto& [ix, iy] : others_) x[ix] = y[iy];
}

void JointCoordinateSystem::CalcDerivatives(double t, const double* y, double* ydot) {
  MB_ASSERT(system_ != nullptr, "JointCoordinateSystem evaluated without the model's system");
  ToModel(y, x_.data());
  system_->CalcDerivatives(t, x_.data(), xdot_.data());  // looks at the stop flag
  for (Body& b : bodies_) {
    const Body& pb = Parent(b);
    const Mat3& Rp = pb.Rw;
    const Vec3 &rp = pb.rw, &vp = pb.vw, &wp = pb.ww, &vdp = pb.vdot, &wdp = pb.wdot;
    const double* yb = y + b.y;
    double* yd = ydot + b.y;
    b.vdot = Eigen::Map<const Vec3>(xdot_.data() + b.p) / b.mass;
    if (b.rotates()) {
      const Vec3 h = Eigen::Map<const Vec3>(x_.data() + b.h);
      b.wdot = b.Rw * InverseInertia(b, b.Rw.transpose() * (Eigen::Map<const Vec3>(xdot_.data() + b.h) - b.ww.cross(h)));
      Out(yd) = b.rates_from_u * Vec3(b.e1.dot(b.u), b.e2.dot(b.u), b.n.dot(b.u));
      yb += 3;
      yd += 3;
      // u = R_P^T (w - w_P):  u' = R_P^T (w' - w_P' - w_P x (w - w_P)); k = M u with Q' = [u x] Q,
      // so M' u = u x M u and k' = M u' + u x k.
      const Vec3 u_dot = Rp.transpose() * (b.wdot - wdp - wp.cross(b.ww - wp));
      Out(yd + 3) = b.mix * (b.q * (b.weight * (b.q.transpose() * u_dot)) + b.u.cross(b.k));
    } else {
      b.wdot = Vec3::Zero();
    }
    // d = R_P^T rel, rel = r + R anchor - r_P;  d' = R_P^T s, s = rel' - w_P x rel.
    Vec3 rel, rel_dot, rel_ddot;
    if (b.anchored) {
      const Vec3 arm = b.Rw * b.anchor;
      rel = b.rw + arm - rp;
      rel_dot = b.vw + b.ww.cross(arm) - vp;
      rel_ddot = b.vdot + b.wdot.cross(arm) + b.ww.cross(b.ww.cross(arm)) - vdp;
    } else {
      rel = b.rw - rp;
      rel_dot = b.vw - vp;
      rel_ddot = b.vdot - vdp;
    }
    const Vec3 s = rel_dot - wp.cross(rel);
    const Vec3 s_dot = rel_ddot - wdp.cross(rel) - wp.cross(rel_dot);
    const int rate = b.rotates() ? 6 : 3;
    Out(yd) = Eigen::Map<const Vec3>(yb + rate);
    Out(yd + rate) = Rp.transpose() * (s_dot - wp.cross(s));
  }
  for (const auto& [ix, iy] : others_) ydot[iy] = xdot_[ix];
}

void JointCoordinateSystem::VelocitiesFromModel(const double* x, double* y) {
  for (Body& b : bodies_) {
    const Body& pb = Parent(b);
    const Mat3& Rp = pb.Rw;
    const Vec3 &rp = pb.rw, &vp = pb.vw, &wp = pb.ww;
    double* yb = y + b.y;
    Vec3 arm = Vec3::Zero();
    b.vw = Eigen::Map<const Vec3>(x + b.p) / b.mass;
    if (b.rotates()) {
      b.ww = b.Rw * InverseInertia(b, b.Rw.transpose() * Eigen::Map<const Vec3>(x + b.h));
      arm = b.Rw * b.anchor;
      yb += 3;
      b.q = Rp.transpose() * b.Rw;
      b.u = Rp.transpose() * (b.ww - wp);
      b.k = b.q * (b.weight * (b.q.transpose() * b.u));
      Out(yb + 3) = b.mix * b.k;
    }
    const Vec3 rel = b.rw + arm - rp;
    const Vec3 rel_dot = b.vw + b.ww.cross(arm) - vp;
    Eigen::Map<Vec3>(yb + (b.rotates() ? 6 : 3)) = Rp.transpose() * (rel_dot - wp.cross(rel));
  }
  for (const auto& [ix, iy] : others_) y[iy] = x[ix];
}

void JointCoordinateSystem::Project(double t, double* y) {
  ToModel(y, x_.data());
  MB_ASSERT(system_ != nullptr, "JointCoordinateSystem projected without the model's system");
  system_->Project(t, x_.data());
  y_before_ = Eigen::Map<const Eigen::VectorXd>(y, n_);
  VelocitiesFromModel(x_.data(), y);
  // A rate read back from the momenta carries their rounding: an anchor's d' = v + w x (R anchor)
  // - ..., zero on a rigid joint, is computed from terms of |w| |anchor| (a body spinning at the end
  // of an arm: 500 m/s, so 1e-13 m/s of noise, and the model's projection answers a violation of
  // that size too). Written into y at every step it is a jump no step size removes, and a rate
  // held to an atol at or below it (d' is near zero) fails BDF's error test at hmin
  // (examples/mechanisms/gyroscopic.yaml at atol 1e-13). Changes of d' within its rounding are
  // dropped (u is held to rtol |u|, far above its own).
  constexpr double kRounding = 16 * std::numeric_limits<double>::epsilon();
  for (const Body& b : bodies_) {
    const Body& pb = Parent(b);
    const Vec3 arm = b.rotates() ? Vec3(b.Rw * b.anchor) : Vec3::Zero();
    const double speed = b.vw.norm() + pb.vw.norm() + b.ww.norm() * arm.norm() + pb.ww.norm() * (b.rw + arm - pb.rw).norm();
    const int d = b.y + (b.rotates() ? 9 : 3);
    for (int i = 0; i < 3; ++i)
      if (std::abs(y[d + i] - y_before_[d + i]) <= kRounding * speed) y[d + i] = y_before_[d + i];
  }
}

bool JointCoordinateSystem::Rechart(const double* x, double* y) {
  bool needed = false;
  for (const Body& b : bodies_)
    if (b.rotates() && std::hypot(y[b.y], y[b.y + 1]) > kRechartTilt) needed = true;
  if (!needed) return false;
  FromModel(x, y);
  return true;
}

}  // namespace multibond
