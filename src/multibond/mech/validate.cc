/// \file
/// Checks a mechanism before it is expanded: names, masses and inertias, references, couplings,
/// gear meshes and joints deflected at t = 0.

#include "multibond/core/diagnostic_codes.h"
#include "multibond/mech/expander.h"

#include <cmath>
#include <map>
#include <numbers>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

#include <fmt/format.h>

namespace multibond::mech::detail {

void Expander::Validate() {
  std::map<std::string, SourceLocation> names;
  auto unique = [&](const std::string& n, const SourceLocation& w) {
    if (n == kGround) sink_.Error(codes::kMechName, w, n, "'ground' is reserved for the inertial frame", "choose another name");
    if (names.count(n))
      sink_.Error(codes::kMechDuplicate, w, n, "duplicate name (first used at " + names[n].ToString() + ")", "give every body, joint, gear, drive and point a unique name");
    names[n] = w;
  };
  for (const Body& b : m_.bodies()) {
    unique(b.name, b.where);
    if (!(b.mass.mass > 0) || !std::isfinite(b.mass.mass))
      sink_.Error(codes::kParamRange, b.where, b.name, fmt::format("mass must be > 0 (got {:g})", b.mass.mass), "give a density and shape, or a positive mass");
    if (b.mass.has_rotation()) {
      Eigen::LLT<Eigen::Matrix3d> llt(b.mass.inertia);
      if (!b.mass.inertia.isApprox(b.mass.inertia.transpose(), 1e-12) || llt.info() != Eigen::Success) {
        sink_.Error(codes::kParamRange, b.where, b.name, "inertia tensor must be symmetric positive definite",
                    "check the principal moments (each below the sum of the other two)");
      } else {
        // Every rigid body's principal moments satisfy I_k <= I_i + I_j (a thin plate at equality).
        const Eigen::Vector3d I = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(b.mass.inertia, Eigen::EigenvaluesOnly).eigenvalues();
        if (I[2] > (I[0] + I[1]) * (1.0 + 1e-9))
          sink_.Error(codes::kParamRange, b.where, b.name,
                      fmt::format("no rigid body has the principal moments of inertia {:g}, {:g}, {:g}: the largest exceeds "
                                  "the sum of the other two", I[0], I[1], I[2]),
                      "check the inertia (each principal moment is at most the sum of the other two)");
      }
    }
    if (!(b.orientation.transpose() * b.orientation).isApprox(Eigen::Matrix3d::Identity(), 1e-9) || b.orientation.determinant() < 0)
      sink_.Error(codes::kParamRange, b.where, b.name, "initial orientation is not a rotation matrix", "give an orthonormal matrix with det +1, or an axis and angle");
  }
  auto body_ref = [&](const std::string& n, const SourceLocation& w, const std::string& owner, bool ground_ok, bool need_rotation) {
    if (IsGround(n)) {
      if (!ground_ok) sink_.Error(codes::kMechReference, w, owner, "the ground cannot be used here", "name a body");
      return;
    }
    const Body* b = FindBody(n);
    if (!b) {
      sink_.Error(codes::kMechReference, w, owner, fmt::format("refers to body '{}', which does not exist", n), "define it under 'bodies'");
      return;
    }
    if (need_rotation && !b->mass.has_rotation())
      sink_.Error(codes::kMechReference, w, owner, fmt::format("body '{}' is a point mass: it has no rotation to couple", n),
                  "give it a shape or an inertia tensor");
  };
  auto coupling = [&](const std::optional<Coupling>& c, const SourceLocation& w, const std::string& owner, const char* what) {
    if (!c) return;
    const int k = static_cast<int>(c->directions.rows());
    if (c->rigid) {
      if (k < 1 || k > 3 || c->directions.cols() != 3)
        sink_.Error(codes::kMechCoupling, w, owner, fmt::format("{} coupling needs 1 to 3 directions", what));
      else if (Eigen::FullPivLU<Eigen::MatrixXd>(c->directions).rank() < k)
        sink_.Error(codes::kMechCoupling, w, owner, fmt::format("{} directions are not independent", what));
      return;
    }
    if (k < 1 || k > 3 || c->directions.cols() != 3 || c->stiffness.size() != k || c->damping.size() != k) {
      sink_.Error(codes::kMechCoupling, w, owner, fmt::format("{} coupling needs 1 to 3 directions with one stiffness and damping each", what));
      return;
    }
    for (int i = 0; i < k; ++i) {
      if (!(c->stiffness[i] > 0))
        sink_.Error(codes::kParamRange, w, owner, fmt::format("{} stiffness must be > 0 (got {:g})", what, c->stiffness[i]),
                    "a compliant coupling needs a positive stiffness; leave a direction out to make it free");
      if (!(c->damping[i] >= 0)) sink_.Error(codes::kParamRange, w, owner, fmt::format("{} damping must be >= 0 (got {:g})", what, c->damping[i]));
    }
    if (Eigen::FullPivLU<Eigen::MatrixXd>(c->directions).rank() < k)
      sink_.Error(codes::kMechCoupling, w, owner, fmt::format("{} directions are not independent", what));
  };
  for (const Joint& j : m_.joints()) {
    unique(j.name, j.where);
    body_ref(j.parent, j.where, j.name, true, j.rotation.has_value() || !j.parent_point.isZero());
    body_ref(j.child, j.where, j.name, false, j.rotation.has_value() || !j.child_point.isZero());
    if (j.parent == j.child) sink_.Error(codes::kMechReference, j.where, j.name, "a joint needs two different bodies");
    if (!j.translation && !j.rotation) sink_.Error(codes::kMechCoupling, j.where, j.name, "the joint couples nothing", "give it a translation or a rotation coupling");
    coupling(j.translation, j.where, j.name, "translational");
    coupling(j.rotation, j.where, j.name, "rotational");
    CheckJointKind(j);
  }
  if (sink_.has_errors()) return;
  for (const Joint& j : m_.joints()) WarnIfDeflected(j);
  for (const GearMesh& gm : m_.gears()) {
    unique(gm.name, gm.where);
    body_ref(gm.carrier, gm.where, gm.name, true, true);
    body_ref(gm.body_a, gm.where, gm.name, false, true);
    body_ref(gm.body_b, gm.where, gm.name, false, !gm.rack_b);
    if (gm.rack_b && gm.contact != GearMesh::Contact::kPitch)
      sink_.Error(codes::kMechGearGeometry, gm.where, gm.name, "a rack meshes through its pitch point", "add 'contact: pitch'");
    // A tooth count is a whole number of a size gears have: a denormal or fractional count makes
    // a ratio of no meaning (and 1e-310 an infinite one).
    for (const auto& [side, teeth] : {std::pair{"a", gm.teeth_a}, std::pair{"b", gm.rack_b ? 1.0 : gm.teeth_b}})
      if (!(teeth >= 1 && teeth <= kMaxTeeth && teeth == std::floor(teeth)))
        sink_.Error(codes::kParamRange, gm.where, gm.name,
                    fmt::format("gear '{}' has {:g} teeth: a tooth count is a whole number from 1 to {:g}", side, teeth, kMaxTeeth),
                    "write the number of teeth of the gear, e.g. teeth: 24");
    if (!gm.rigid && !(gm.stiffness > 0))
      sink_.Error(codes::kParamRange, gm.where, gm.name, fmt::format("mesh stiffness must be > 0 (got {:g})", gm.stiffness),
                  "give the mesh a stiffness, or make it an ideal constraint with 'rigid: true'");
    if (!gm.rigid && !(gm.damping >= 0)) sink_.Error(codes::kParamRange, gm.where, gm.name, "mesh damping must be >= 0");
    if (gm.axis_a.norm() < 1e-12 || gm.axis_b.norm() < 1e-12) sink_.Error(codes::kParamRange, gm.where, gm.name, "gear axes must be non-zero vectors");
    // The mesh relates the two gears' spins relative to the carrier: each a different body.
    if (gm.body_a == gm.body_b)
      sink_.Error(codes::kMechReference, gm.where, gm.name, fmt::format("a gear mesh needs two different gears ('{}' meshes with itself)", gm.body_a),
                  "give 'a' and 'b' the two bodies whose teeth mesh");
    else if (gm.carrier == gm.body_a || gm.carrier == gm.body_b)
      sink_.Error(codes::kMechReference, gm.where, gm.name,
                  fmt::format("the carrier '{}' is one of the meshing gears (its spin relative to itself is always 0)", gm.carrier),
                  "the carrier is the body that holds both gears' axes (the ground, a housing, a planet carrier)");
  }
  if (!sink_.has_errors())
    for (const GearMesh& gm : m_.gears())
      if (gm.contact == GearMesh::Contact::kPitch) CheckPitchMesh(gm);
  for (const Drive& d : m_.drives()) {
    unique(d.name, d.where);
    const bool angular = d.kind == Drive::Kind::kAngularVelocity || d.kind == Drive::Kind::kTorque;
    body_ref(d.body, d.where, d.name, false, angular || !d.point.isZero());
    if (d.kind == Drive::Kind::kAngularVelocity) body_ref(d.reference, d.where, d.name, true, true);
    if (d.kind == Drive::Kind::kAngularVelocity && d.reference == d.body)
      sink_.Error(codes::kMechReference, d.where, d.name, fmt::format("the drive turns '{}' relative to itself", d.body),
                  "'reference' is the body the drive is mounted on (default: the ground)");
    if (d.kind == Drive::Kind::kVelocity && !IsGround(d.reference))
      sink_.Error(codes::kMechReference, d.where, d.name, "a velocity drive acts relative to the ground", "remove 'reference'");
    const bool velocity = d.kind == Drive::Kind::kAngularVelocity || d.kind == Drive::Kind::kVelocity;
    if (velocity && !d.rigid && !(d.stiffness > 0)) sink_.Error(codes::kParamRange, d.where, d.name, "a velocity drive acts through a coupling: its stiffness must be > 0", "give K and R (the paper's drive: K = 1000, R = 5)");
    if (velocity && !(d.damping >= 0)) sink_.Error(codes::kParamRange, d.where, d.name, "drive damping must be >= 0");
    if (d.axis.norm() < 1e-12) sink_.Error(codes::kParamRange, d.where, d.name, "drive axis must be a non-zero vector");
  }
  for (const Point& p : m_.points()) {
    unique(p.name, p.where);
    body_ref(p.body, p.where, p.name, false, !p.at.isZero());
  }
}

void Expander::CheckPitchMesh(const GearMesh& gm) {
  const MeshGeometry geo = m_.GeometryOf(gm);
  if (!geo.error.empty()) {
    sink_.Error(codes::kMechGearGeometry, gm.where, gm.name, geo.error, geo.hint);
    return;
  }
  if (!(gm.pressure_angle >= 0.0 && gm.pressure_angle < 1.2))
    sink_.Error(codes::kParamRange, gm.where, gm.name, fmt::format("the pressure angle must be in [0, 69) degrees (got {:g})", gm.pressure_angle * 180 / std::numbers::pi),
                "standard gears: 20 degrees");
  if (!(std::abs(gm.helix_angle) < 1.2))
    sink_.Error(codes::kParamRange, gm.where, gm.name, fmt::format("the helix angle must be within +-69 degrees (got {:g})", gm.helix_angle * 180 / std::numbers::pi),
                "helical gears: 15 to 30 degrees");
  geometry_[gm.name] = geo;
  // The teeth's slip at the pitch point at t = 0: t . (v_pitch,a - v_pitch,b).
  const Body* c = IsGround(gm.carrier) ? nullptr : FindBody(gm.carrier);
  const Eigen::Matrix3d rc = c ? c->orientation : Eigen::Matrix3d::Identity();
  auto pitch_velocity = [&](const std::string& name, const Eigen::Vector3d& rho) -> Eigen::Vector3d {
    const Body* b = FindBody(name);
    return b->velocity + b->omega.cross(rc * rho);
  };
  const Eigen::Vector3d va = pitch_velocity(gm.body_a, geo.rho_a), vb = pitch_velocity(gm.body_b, geo.rho_b);
  const Eigen::Vector3d t = rc * geo.t;
  const double slip = t.dot(va - vb);
  if (std::abs(slip) > 1e-9 + 1e-6 * (std::abs(t.dot(va)) + std::abs(t.dot(vb)))) {
    Diagnostic d;
    d.severity = Diagnostic::Severity::kWarning;
    d.code = codes::kMechGearSlip;
    d.where = gm.where;
    d.element = gm.name;
    d.message = fmt::format("the teeth slip at {:.6g} m/s at t = 0 (pitch-line speeds {:.6g} and {:.6g} m/s): the mesh starts deflecting",
                            slip, t.dot(va), t.dot(vb));
    d.hint = "give the gears initial speeds that roll (teeth_a s_a + teeth_b s_b = 0), or start them at rest";
    sink_.Add(d);
  }
}

Eigen::Vector3d Expander::AttachmentAtStart(const std::string& body, const Eigen::Vector3d& point) const {
  if (IsGround(body)) return point;
  const Body* b = FindBody(body);
  return b->position + b->orientation * point;
}

void Expander::WarnIfDeflected(const Joint& j) {
  if (!j.translation) return;
  const Eigen::Vector3d gap = AttachmentAtStart(j.child, j.child_point) - AttachmentAtStart(j.parent, j.parent_point);
  if (gap.norm() <= 1e-9) return;
  Diagnostic d;
  d.severity = Diagnostic::Severity::kWarning;
  d.code = codes::kMechInitialGap;
  d.where = j.where;
  d.element = j.name;
  d.message = fmt::format("the attachment points are {:.3g} m apart at t = 0; the coupling takes this offset as its rest position", gap.norm());
  d.hint = "check 'at' against the bodies' positions";
  sink_.Add(d);
}

}  // namespace multibond::mech::detail
