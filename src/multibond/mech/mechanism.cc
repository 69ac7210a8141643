#include "multibond/mech/mechanism.h"

#include <cmath>
#include <map>
#include <numbers>
#include <set>
#include <tuple>
#include <unordered_map>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

#include <fmt/format.h>

#include "multibond/core/expression.h"

namespace multibond::mech {

namespace {

/// The most teeth a gear may have (a sane bound: real gears have a few to a few thousand).
constexpr double kMaxTeeth = 100000;

const std::vector<std::string> kXyz = {"x", "y", "z"};

/// Expands a Mechanism into bond-graph elements. Each body contributes its two 1-junctions
/// (v, omega), their inertias and its R, r states; each coupling a small junction structure
/// (0-junction for relative flows, TF/MTF for frames and lever arms, a 1-junction with C and R).
class Expander {
 public:
  Expander(const Mechanism& m, BondGraph& g, DiagnosticSink& sink) : m_(m), g_(g), sink_(sink) {
    for (const Body& b : m_.bodies()) body_by_name_.emplace(b.name, &b);  // the first of a name, as a search would find
  }

  void Run() {
    Validate();
    if (sink_.has_errors()) return;
    for (const Body& b : m_.bodies()) AddBody(b);
    for (const Joint& j : m_.joints()) AddJoint(j);
    for (const GearMesh& gm : m_.gears()) AddGear(gm);
    for (const Drive& d : m_.drives()) AddDrive(d);
    for (const Point& p : m_.points()) AddPointOutput(p);
    for (const Body& b : m_.bodies()) AddBodyOutputs(b);
  }

 private:
  struct BodyInfo {
    const Body* body;
    std::vector<std::pair<std::string, double>> force_terms, moment_terms;
  };

  bool IsGround(const std::string& n) const { return n == kGround; }
  const Body* FindBody(const std::string& n) const {
    const auto it = body_by_name_.find(n);
    return it == body_by_name_.end() ? nullptr : it->second;
  }

  // --- validation -------------------------------------------------------------------------

  void Validate() {
    std::map<std::string, SourceLocation> names;
    auto unique = [&](const std::string& n, const SourceLocation& w) {
      if (n == kGround) sink_.Error("mech.name", w, n, "'ground' is reserved for the inertial frame", "choose another name");
      if (names.count(n))
        sink_.Error("mech.duplicate", w, n, "duplicate name (first used at " + names[n].ToString() + ")", "give every body, joint, gear, drive and point a unique name");
      names[n] = w;
    };
    for (const Body& b : m_.bodies()) {
      unique(b.name, b.where);
      if (!(b.mass.mass > 0) || !std::isfinite(b.mass.mass))
        sink_.Error("param.range", b.where, b.name, fmt::format("mass must be > 0 (got {:g})", b.mass.mass), "give a density and shape, or a positive mass");
      if (b.mass.has_rotation()) {
        Eigen::LLT<Eigen::Matrix3d> llt(b.mass.inertia);
        if (!b.mass.inertia.isApprox(b.mass.inertia.transpose(), 1e-12) || llt.info() != Eigen::Success) {
          sink_.Error("param.range", b.where, b.name, "inertia tensor must be symmetric positive definite",
                      "check the principal moments (each below the sum of the other two)");
        } else {
          // Every rigid body's principal moments satisfy I_k <= I_i + I_j (a thin plate at equality).
          const Eigen::Vector3d I = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(b.mass.inertia, Eigen::EigenvaluesOnly).eigenvalues();
          if (I[2] > (I[0] + I[1]) * (1.0 + 1e-9))
            sink_.Error("param.range", b.where, b.name,
                        fmt::format("no rigid body has the principal moments of inertia {:g}, {:g}, {:g}: the largest exceeds "
                                    "the sum of the other two", I[0], I[1], I[2]),
                        "check the inertia (each principal moment is at most the sum of the other two)");
        }
      }
      if (!(b.orientation.transpose() * b.orientation).isApprox(Eigen::Matrix3d::Identity(), 1e-9) || b.orientation.determinant() < 0)
        sink_.Error("param.range", b.where, b.name, "initial orientation is not a rotation matrix", "give an orthonormal matrix with det +1, or an axis and angle");
    }
    auto body_ref = [&](const std::string& n, const SourceLocation& w, const std::string& owner, bool ground_ok, bool need_rotation) {
      if (IsGround(n)) {
        if (!ground_ok) sink_.Error("mech.reference", w, owner, "the ground cannot be used here", "name a body");
        return;
      }
      const Body* b = FindBody(n);
      if (!b) {
        sink_.Error("mech.reference", w, owner, fmt::format("refers to body '{}', which does not exist", n), "define it under 'bodies'");
        return;
      }
      if (need_rotation && !b->mass.has_rotation())
        sink_.Error("mech.reference", w, owner, fmt::format("body '{}' is a point mass: it has no rotation to couple", n),
                    "give it a shape or an inertia tensor");
    };
    auto coupling = [&](const std::optional<Coupling>& c, const SourceLocation& w, const std::string& owner, const char* what) {
      if (!c) return;
      const int k = static_cast<int>(c->directions.rows());
      if (c->rigid) {
        if (k < 1 || k > 3 || c->directions.cols() != 3)
          sink_.Error("mech.coupling", w, owner, fmt::format("{} coupling needs 1 to 3 directions", what));
        else if (Eigen::FullPivLU<Eigen::MatrixXd>(c->directions).rank() < k)
          sink_.Error("mech.coupling", w, owner, fmt::format("{} directions are not independent", what));
        return;
      }
      if (k < 1 || k > 3 || c->directions.cols() != 3 || c->stiffness.size() != k || c->damping.size() != k) {
        sink_.Error("mech.coupling", w, owner, fmt::format("{} coupling needs 1 to 3 directions with one stiffness and damping each", what));
        return;
      }
      for (int i = 0; i < k; ++i) {
        if (!(c->stiffness[i] > 0))
          sink_.Error("param.range", w, owner, fmt::format("{} stiffness must be > 0 (got {:g})", what, c->stiffness[i]),
                      "a compliant coupling needs a positive stiffness; leave a direction out to make it free");
        if (!(c->damping[i] >= 0)) sink_.Error("param.range", w, owner, fmt::format("{} damping must be >= 0 (got {:g})", what, c->damping[i]));
      }
      if (Eigen::FullPivLU<Eigen::MatrixXd>(c->directions).rank() < k)
        sink_.Error("mech.coupling", w, owner, fmt::format("{} directions are not independent", what));
    };
    for (const Joint& j : m_.joints()) {
      unique(j.name, j.where);
      body_ref(j.parent, j.where, j.name, true, j.rotation.has_value() || !j.parent_point.isZero());
      body_ref(j.child, j.where, j.name, false, j.rotation.has_value() || !j.child_point.isZero());
      if (j.parent == j.child) sink_.Error("mech.reference", j.where, j.name, "a joint needs two different bodies");
      if (!j.translation && !j.rotation) sink_.Error("mech.coupling", j.where, j.name, "the joint couples nothing", "give it a translation or a rotation coupling");
      coupling(j.translation, j.where, j.name, "translational");
      coupling(j.rotation, j.where, j.name, "rotational");
    }
    if (sink_.has_errors()) return;
    for (const Joint& j : m_.joints()) WarnIfDeflected(j);
    for (const GearMesh& gm : m_.gears()) {
      unique(gm.name, gm.where);
      body_ref(gm.carrier, gm.where, gm.name, true, true);
      body_ref(gm.body_a, gm.where, gm.name, false, true);
      body_ref(gm.body_b, gm.where, gm.name, false, !gm.rack_b);
      if (gm.rack_b && gm.contact != GearMesh::Contact::kPitch)
        sink_.Error("mech.gear_geometry", gm.where, gm.name, "a rack meshes through its pitch point", "add 'contact: pitch'");
      // A tooth count is a whole number of a size gears have: a denormal or fractional count makes
      // a ratio of no meaning (and 1e-310 an infinite one).
      for (const auto& [side, teeth] : {std::pair{"a", gm.teeth_a}, std::pair{"b", gm.rack_b ? 1.0 : gm.teeth_b}})
        if (!(teeth >= 1 && teeth <= kMaxTeeth && teeth == std::floor(teeth)))
          sink_.Error("param.range", gm.where, gm.name,
                      fmt::format("gear '{}' has {:g} teeth: a tooth count is a whole number from 1 to {:g}", side, teeth, kMaxTeeth),
                      "write the number of teeth of the gear, e.g. teeth: 24");
      if (!gm.rigid && !(gm.stiffness > 0))
        sink_.Error("param.range", gm.where, gm.name, fmt::format("mesh stiffness must be > 0 (got {:g})", gm.stiffness),
                    "give the mesh a stiffness, or make it an ideal constraint with 'rigid: true'");
      if (!gm.rigid && !(gm.damping >= 0)) sink_.Error("param.range", gm.where, gm.name, "mesh damping must be >= 0");
      if (gm.axis_a.norm() < 1e-12 || gm.axis_b.norm() < 1e-12) sink_.Error("param.range", gm.where, gm.name, "gear axes must be non-zero vectors");
      // The mesh relates the two gears' spins relative to the carrier: each a different body.
      if (gm.body_a == gm.body_b)
        sink_.Error("mech.reference", gm.where, gm.name, fmt::format("a gear mesh needs two different gears ('{}' meshes with itself)", gm.body_a),
                    "give 'a' and 'b' the two bodies whose teeth mesh");
      else if (gm.carrier == gm.body_a || gm.carrier == gm.body_b)
        sink_.Error("mech.reference", gm.where, gm.name,
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
        sink_.Error("mech.reference", d.where, d.name, fmt::format("the drive turns '{}' relative to itself", d.body),
                    "'reference' is the body the drive is mounted on (default: the ground)");
      if (d.kind == Drive::Kind::kVelocity && !IsGround(d.reference))
        sink_.Error("mech.reference", d.where, d.name, "a velocity drive acts relative to the ground", "remove 'reference'");
      const bool velocity = d.kind == Drive::Kind::kAngularVelocity || d.kind == Drive::Kind::kVelocity;
      if (velocity && !d.rigid && !(d.stiffness > 0)) sink_.Error("param.range", d.where, d.name, "a velocity drive acts through a coupling: its stiffness must be > 0", "give K and R (the paper's drive: K = 1000, R = 5)");
      if (velocity && !(d.damping >= 0)) sink_.Error("param.range", d.where, d.name, "drive damping must be >= 0");
      if (d.axis.norm() < 1e-12) sink_.Error("param.range", d.where, d.name, "drive axis must be a non-zero vector");
    }
    for (const Point& p : m_.points()) {
      unique(p.name, p.where);
      body_ref(p.body, p.where, p.name, false, !p.at.isZero());
    }
  }

  /// A mesh through its pitch point: its geometry consistent with the axes and teeth (an error
  /// says which axis or radius is wrong), its angles in range, and the teeth rolling at t = 0 (a
  /// warning gives the slip speed).
  void CheckPitchMesh(const GearMesh& gm) {
    const MeshGeometry geo = m_.GeometryOf(gm);
    if (!geo.error.empty()) {
      sink_.Error("mech.gear_geometry", gm.where, gm.name, geo.error, geo.hint);
      return;
    }
    if (!(gm.pressure_angle >= 0.0 && gm.pressure_angle < 1.2))
      sink_.Error("param.range", gm.where, gm.name, fmt::format("the pressure angle must be in [0, 69) degrees (got {:g})", gm.pressure_angle * 180 / std::numbers::pi),
                  "standard gears: 20 degrees");
    if (!(std::abs(gm.helix_angle) < 1.2))
      sink_.Error("param.range", gm.where, gm.name, fmt::format("the helix angle must be within +-69 degrees (got {:g})", gm.helix_angle * 180 / std::numbers::pi),
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
      d.code = "mech.gear_slip";
      d.where = gm.where;
      d.element = gm.name;
      d.message = fmt::format("the teeth slip at {:.6g} m/s at t = 0 (pitch-line speeds {:.6g} and {:.6g} m/s): the mesh starts deflecting",
                              slip, t.dot(va), t.dot(vb));
      d.hint = "give the gears initial speeds that roll (teeth_a s_a + teeth_b s_b = 0), or start them at rest";
      sink_.Add(d);
    }
  }

  /// Position of a joint's attachment on `body` (ground: the absolute point) at t = 0.
  Eigen::Vector3d AttachmentAtStart(const std::string& body, const Eigen::Vector3d& point) const {
    if (IsGround(body)) return point;
    const Body* b = FindBody(body);
    return b->position + b->orientation * point;
  }

  void WarnIfDeflected(const Joint& j) {
    if (!j.translation) return;
    const Eigen::Vector3d gap = AttachmentAtStart(j.child, j.child_point) - AttachmentAtStart(j.parent, j.parent_point);
    if (gap.norm() <= 1e-9) return;
    Diagnostic d;
    d.severity = Diagnostic::Severity::kWarning;
    d.code = "mech.initial_gap";
    d.where = j.where;
    d.element = j.name;
    d.message = fmt::format("the attachment points are {:.3g} m apart at t = 0; the coupling takes this offset as its rest position", gap.norm());
    d.hint = "check 'at' against the bodies' positions";
    sink_.Add(d);
  }

  // --- expansion --------------------------------------------------------------------------

  void Bond(const std::string& from, const std::string& to, const std::string& name) { g_.Connect(from, to, 0, name); }

  Element Make(const std::string& name, ElementKind kind, int dim, const std::string& domain, const SourceLocation& where) {
    Element e;
    e.name = name;
    e.kind = kind;
    e.dim = dim;
    e.domain = domain;
    e.where = where;
    return e;
  }

  void AddBody(const Body& b) {
    info_[b.name] = BodyInfo{&b, {}, {}};
    Element v = Make(b.name + ".v", ElementKind::kOne, 3, "translation", b.where);
    v.components = kXyz;
    g_.Add(v);
    Element mass = Make(b.name + ".mass", ElementKind::kI, 3, "translation", b.where);
    mass.param = Param::Scalar(b.mass.mass);
    mass.state_name = b.name + ".p";
    mass.initial = b.mass.mass * b.velocity;
    mass.components = kXyz;
    g_.Add(mass);
    Bond(b.name + ".v", b.name + ".mass", b.name + ".mass");
    AuxState r;
    r.name = b.name + ".r";
    r.kind = AuxState::Kind::kIntegral;
    r.of = b.name + ".v";
    r.initial = b.position;
    r.unit = "m";
    r.components = kXyz;
    r.where = b.where;
    g_.AddAux(r);
    if (b.mass.has_rotation()) {
      Element w = Make(b.name + ".omega", ElementKind::kOne, 3, "rotation", b.where);
      w.components = kXyz;
      g_.Add(w);
      Element inertia = Make(b.name + ".inertia", ElementKind::kI, 3, "rotation", b.where);
      inertia.param = Param::Matrix(b.mass.inertia);
      inertia.rotation = b.name + ".R";
      inertia.state_name = b.name + ".h";
      inertia.initial = b.orientation * b.mass.inertia * b.orientation.transpose() * b.omega;
      inertia.components = kXyz;
      g_.Add(inertia);
      Bond(b.name + ".omega", b.name + ".inertia", b.name + ".inertia");
      AuxState rot;
      rot.name = b.name + ".R";
      rot.kind = AuxState::Kind::kOrientation;
      rot.of = b.name + ".omega";
      rot.initial = b.orientation;
      rot.stabilization = b.stabilization;
      rot.where = b.where;
      g_.AddAux(rot);
    }
    if (!m_gravity().isZero()) {
      // m g on the CoM; its work is gravity's potential energy, -m g . (r - r0), which the energy
      // account counts as stored (energy.potential), not as work (Element::potential_work).
      Element grav = Make(b.name + ".gravity", ElementKind::kSe, 3, "translation", b.where);
      for (int i = 0; i < 3; ++i) grav.source.components.push_back(TimeFunction::Constant(b.mass.mass * m_gravity()[i]));
      grav.potential_work = true;
      g_.Add(grav);
      Bond(b.name + ".gravity", b.name + ".v", b.name + ".gravity");
    }
  }

  const Eigen::Vector3d& m_gravity() const { return gravity_; }

  /// The 1-junction whose flow is w_child - w_parent (the child's omega for the ground), built
  /// once per pair and shared by every coupling of the pair.
  std::string RelativeOmega(const std::string& child, const std::string& parent) {
    if (IsGround(parent)) return child + ".omega";
    const std::string key = child + "~" + parent;
    if (relative_.count(key)) return relative_[key];
    const std::string diff = key + ".w_diff", rel = key + ".w";
    g_.AddJunction(diff, ElementKind::kZero, 3);
    Element r = Make(rel, ElementKind::kOne, 3, "rotation", {});
    r.components = kXyz;
    g_.Add(r);
    Bond(child + ".omega", diff, key + ".child");
    Bond(diff, parent + ".omega", key + ".parent");
    Bond(diff, rel, key + ".rel");
    info_[child].moment_terms.push_back({key + ".child.e", -1.0});
    info_[parent].moment_terms.push_back({key + ".parent.e", +1.0});
    relative_[key] = rel;
    return rel;
  }

  /// A TF (constant directions) or MTF (directions turning with a body) mapping 3-vectors of the
  /// inertial frame to components along `rows`, in the coupling's frame.
  void AddFrameElement(const std::string& name, Coupling::Frame frame, const std::string& parent, const std::string& child,
                       const Eigen::MatrixXd& rows, const SourceLocation& where) {
    const std::string body = frame == Coupling::Frame::kChild ? child : parent;
    if (frame == Coupling::Frame::kWorld || IsGround(body)) {
      Element tf = Make(name, ElementKind::kTF, 0, "", where);
      tf.param = Param::Matrix(rows);
      g_.Add(tf);
      return;
    }
    Modulus m;
    m.kind = Modulus::Kind::kRotation;
    m.rotation = body + ".R";
    m.transpose = true;
    // (sizes first: comparing matrices of different sizes is undefined in Eigen's release builds)
    const bool identity = rows.rows() == 3 && rows.cols() == 3 && rows == Eigen::MatrixXd::Identity(3, 3);
    if (!identity) m.left = rows;
    Element mtf = Make(name, ElementKind::kMTF, 0, "", where);
    mtf.modulus = m;
    g_.Add(mtf);
  }

  /// A 1-junction `name` of dimension k with a C (K) and an R on it, fed by `from`; or, when
  /// `rigid`, with an ideal constraint `name.rigid` (an Sf of zero flow held by its reaction).
  void AddCompliance(const std::string& from, const std::string& name, const Eigen::VectorXd& k, const Eigen::VectorXd& r,
                     const std::string& domain, const std::vector<std::string>& comps, const SourceLocation& where,
                     bool rigid = false) {
    const int n = static_cast<int>(k.size());
    Element j = Make(name, ElementKind::kOne, n, domain, where);
    j.components = comps;
    g_.Add(j);
    if (rigid) {
      Element c = Make(name + ".rigid", ElementKind::kSf, n, domain, where);
      c.source.components = {TimeFunction::Constant(0.0)};
      c.constraint = true;
      c.components = comps;
      // The stiffness it stands for, if given, shares a redundant reaction as the compliant
      // coupling would (CompiledModel::ShareRedundantEfforts).
      if (n > 0 && k.size() == n && (k.array() > 0.0).all() && k.allFinite()) c.compliance = k.cwiseInverse();
      g_.Add(c);
      Bond(from, name, name + ".in");
      Bond(name + ".rigid", name, name + ".rigid");
      return;
    }
    Element c = Make(name + ".K", ElementKind::kC, n, domain, where);
    c.param = n == 1 ? Param::Scalar(k[0]) : Param::Matrix(k.asDiagonal());
    c.components = comps;
    g_.Add(c);
    Element d = Make(name + ".R", ElementKind::kR, n, domain, where);
    d.param = n == 1 ? Param::Scalar(r[0]) : Param::Matrix(r.asDiagonal());
    d.components = comps;
    g_.Add(d);
    Bond(from, name, name + ".in");
    Bond(name, name + ".K", name + ".K");
    Bond(name, name + ".R", name + ".R");
  }

  std::vector<std::string> DirectionNames(const Coupling& c) {
    if (!c.components.empty()) return c.components;
    const int k = static_cast<int>(c.directions.rows());
    if (k == 1) return {};
    std::vector<std::string> out;
    for (int i = 0; i < k; ++i) {
      int axis = -1;
      for (int a = 0; a < 3; ++a)
        if (c.directions.row(i).isApprox(Eigen::RowVector3d::Unit(a))) axis = a;
      out.push_back(axis >= 0 ? kXyz[axis] : std::to_string(i + 1));
    }
    return out;
  }

  void AddOutput(OutputDecl o) { g_.AddOutput(std::move(o)); }

  OutputDecl SumOutput(const std::string& name, std::vector<std::pair<std::string, double>> terms, const std::string& unit,
                       const SourceLocation& where) {
    OutputDecl o;
    o.kind = OutputDecl::Kind::kSum;
    o.name = name;
    o.terms = std::move(terms);
    o.unit = unit;
    o.components = kXyz;
    o.where = where;
    return o;
  }

  void AddJoint(const Joint& j) {
    if (j.translation) {
      const Coupling& c = *j.translation;
      const std::string sum = j.name + ".t_sum";
      g_.AddJunction(sum, ElementKind::kZero, 3);
      Bond(j.child + ".v", sum, j.name + ".t_child");
      info_[j.child].force_terms.push_back({j.name + ".t_child.e", -1.0});
      if (!j.child_point.isZero()) AddLever(j.name + ".t_child_arm", j.child, j.child_point, +1.0, sum);
      if (!IsGround(j.parent)) {
        Bond(sum, j.parent + ".v", j.name + ".t_parent");
        info_[j.parent].force_terms.push_back({j.name + ".t_parent.e", +1.0});
        if (!j.parent_point.isZero()) AddLever(j.name + ".t_parent_arm", j.parent, j.parent_point, -1.0, sum);
      }
      AddFrameElement(j.name + ".t_frame", c.frame, j.parent, j.child, c.directions, j.where);
      if (Slides(j) && j.sensors) {
        // The relative velocity of the joint's points, a 1-junction the slide sensor also reads.
        const std::string rel = j.name + ".t_rel";
        Element r = Make(rel, ElementKind::kOne, 3, "translation", j.where);
        r.components = kXyz;
        g_.Add(r);
        Bond(sum, rel, rel);
        Bond(rel, j.name + ".t_frame", j.name + ".t_frame");
        AddAxialSensor(j, rel, "translation");
      } else {
        Bond(sum, j.name + ".t_frame", j.name + ".t_frame");
      }
      AddCompliance(j.name + ".t_frame", j.name + ".t", c.stiffness, c.damping, "translation", DirectionNames(c), j.where,
                    c.rigid);
      AddOutput(SumOutput(j.name + ".F", {{j.name + ".t_child.e", -1.0}}, "N", j.where));
    }
    if (j.rotation) {
      const Coupling& c = *j.rotation;
      const std::string rel = RelativeOmega(j.child, j.parent);
      AddFrameElement(j.name + ".r_frame", c.frame, j.parent, j.child, c.directions, j.where);
      Bond(rel, j.name + ".r_frame", j.name + ".r_in");
      if (IsGround(j.parent)) info_[j.child].moment_terms.push_back({j.name + ".r_in.e", -1.0});
      AddCompliance(j.name + ".r_frame", j.name + ".r", c.stiffness, c.damping, "rotation", DirectionNames(c), j.where,
                    c.rigid);
      AddOutput(SumOutput(j.name + ".M", {{j.name + ".r_in.e", -1.0}}, "N m", j.where));
    }
    if (Turns(j)) AddAxialSensor(j, RelativeOmega(j.child, j.parent), "rotation");
    if (j.sensors && (j.kind == "coupling" || j.kind == "spherical") && !HasIdealConstraints() && Spins(j.child) && (IsGround(j.parent) || Spins(j.parent)))
      AddRotationSensor(j);
    if (j.stops || j.friction) AddAxialSwitches(j);
  }

  /// The relative rotation sensor of a joint without a single free axis (docs/mechanisms.md,
  /// "Joint sensors"): the relative angular velocity in the parent's frame, R_p^T (w_c - w_p) (the
  /// 1-junction `<joint>.rel_w`, no other bond), integrated into the orientation state
  /// `<joint>.relative` = R_p^T R_c (R_p^T R_c)(0)^T, and its rotation vector as the signals
  /// `<joint>.rotvec.angle` (in [0, pi]) and `<joint>.rotvec.x|y|z`, the outputs `<joint>.rotation.*`.
  void AddRotationSensor(const Joint& j) {
    const std::string rel = RelativeOmega(j.child, j.parent), w = j.name + ".rel_w", q = j.name + ".relative";
    AddFrameElement(w + "_frame", Coupling::Frame::kParent, j.parent, j.child, Eigen::Matrix3d::Identity(), j.where);
    Bond(rel, w + "_frame", w + ".in");
    if (IsGround(j.parent)) info_[j.child].moment_terms.push_back({w + ".in.e", -1.0});
    Element junction = Make(w, ElementKind::kOne, 3, "rotation", j.where);
    junction.components = kXyz;
    g_.Add(junction);
    Bond(w + "_frame", w, w + ".out");
    AuxState a;
    a.name = q;
    a.kind = AuxState::Kind::kOrientation;
    a.of = w;
    a.where = j.where;
    g_.AddAux(a);
    // v = 2 sin(theta) u from the skew part, 2 cos(theta) = trace - 1; the vector theta u.
    const std::string vx = fmt::format("({0}.32 - {0}.23)", q), vy = fmt::format("({0}.13 - {0}.31)", q),
                      vz = fmt::format("({0}.21 - {0}.12)", q);
    const std::string norm = fmt::format("sqrt({0}*{0} + {1}*{1} + {2}*{2})", vx, vy, vz);
    const std::string angle = j.name + ".rotvec.angle";
    // The signals `<joint>.rotvec.*`, reported as the outputs `<joint>.rotation.*`.
    auto signal = [&](const std::string& component, const std::string& text) {
      Signal sg;
      sg.name = j.name + ".rotvec." + component;
      sg.value = LawOf(text, j.where);
      sg.unit = "rad";
      sg.where = j.where;
      g_.AddSignal(sg);
      OutputDecl o;
      o.name = j.name + ".rotation." + component;
      o.variable = sg.name;
      o.unit = "rad";
      o.where = j.where;
      AddOutput(o);
    };
    signal("angle", fmt::format("atan2({0}, {1}.11 + {1}.22 + {1}.33 - 1)", norm, q));
    const char* axes[] = {"x", "y", "z"};
    const std::string v[] = {vx, vy, vz};
    for (int k = 0; k < 3; ++k)  // theta v / |v|; 0 where v = 0 (no rotation)
      signal(axes[k], fmt::format("{} * {} / ({} + 1e-300)", angle, v[k], norm));
  }

  /// A body with an angular velocity (not a point mass).
  bool Spins(const std::string& body) const {
    const auto it = body_by_name_.find(body);
    return it != body_by_name_.end() && it->second->mass.has_rotation();
  }
  /// Whether a joint, mesh or drive is an ideal constraint: such models take no formulas yet, so
  /// their joints get no rotation sensor (a signal).
  bool HasIdealConstraints() const {
    for (const Joint& j : m_.joints())
      if ((j.translation && j.translation->rigid) || (j.rotation && j.rotation->rigid) || j.stops || j.friction) return true;
    for (const GearMesh& gm : m_.gears())
      if (gm.rigid) return true;
    for (const Drive& d : m_.drives())
      if (d.rigid) return true;
    return false;
  }

  /// A joint with an axis of rotation that needs its rate: a revolute joint's sensor, end stops, friction.
  static bool Turns(const Joint& j) { return ((j.kind == "revolute" && j.sensors) || j.stops || j.friction) && !j.axis.isZero(); }
  /// A prismatic joint with its axis (and a translation coupling): it gets the slide and speed sensor.
  static bool Slides(const Joint& j) { return j.kind == "prismatic" && !j.axis.isZero(); }

  /// The joint sensor on the free axis (docs/mechanisms.md, "Joint sensors"): the relative rate
  /// about (revolute) or along (prismatic) the axis in the parent's frame, the 1-junction
  /// `<joint>.axial` fed from the relative flow `rel` (no other bond: it carries no effort), and
  /// its integral from the assembled position, the state `<joint>.angle` or `<joint>.slide`;
  /// outputs `<joint>.rate` or `<joint>.speed`. Without `sensors`, end stops get the junction and
  /// the angle state (their gap), friction the junction only (its rate).
  void AddAxialSensor(const Joint& j, const std::string& rel, const std::string& domain) {
    const bool rotation = domain == "rotation";
    const std::string axial = j.name + ".axial";
    AddSpin(axial + "_proj", j.parent, j.axis, 1.0);
    Bond(rel, axial + "_proj", axial + ".in");
    if (rotation && IsGround(j.parent)) info_[j.child].moment_terms.push_back({axial + ".in.e", -1.0});
    g_.Add(Make(axial, ElementKind::kOne, 1, domain, j.where));
    Bond(axial + "_proj", axial, axial + ".out");
    if (j.sensors || j.stops) AddAngle(j.name + (rotation ? ".angle" : ".slide"), axial, j.where, rotation ? "rad" : "m");
    if (!j.sensors) return;
    OutputDecl rate;
    rate.name = j.name + (rotation ? ".rate" : ".speed");
    rate.variable = axial + ".f";
    rate.unit = rotation ? "rad/s" : "m/s";
    rate.where = j.where;
    AddOutput(rate);
  }

  /// A revolute joint's end stops and friction (docs/events.md): the rotation rate about its
  /// free axis (the 1-junction `<joint>.axial`), its angle (`<joint>.angle`, from the assembled
  /// position), contacts at the stops (`<joint>.lower`, gap angle - lower; `<joint>.upper`, gap
  /// upper - angle), a friction on the rate (`<joint>.friction`, a capacity).
  void AddAxialSwitches(const Joint& j) {
    const std::string axial = j.name + ".axial";  // made by AddAxialSensor
    if (j.stops) {
      const std::string angle = j.name + ".angle";
      for (const bool lower : {true, false}) {
        const std::string stop = j.name + (lower ? ".lower" : ".upper");
        Element c = MakeContact(stop, angle, lower ? 1.0 : -1.0, lower ? -j.stops->lower : j.stops->upper, j.stops->restitution,
                                j.stops->where);
        c.switching.limit = true;
        g_.Add(c);
        if (lower) Bond(stop, axial, stop);  // its flow is the rate: the angle leaves the lower stop as it grows
        else Bond(axial, stop, stop);
      }
    }
    if (j.friction) {
      Element f = Make(j.name + ".friction", ElementKind::kSf, 1, "rotation", j.friction->where);
      f.source.components = {TimeFunction::Constant(0.0)};
      f.constraint = true;
      f.switching.kind = Switching::Kind::kFriction;
      f.switching.capacity = true;
      f.switching.normal = j.friction->torque;
      f.switching.normal_signal = j.friction->signal;
      f.switching.where = j.friction->where;
      g_.Add(f);
      Bond(j.name + ".friction", axial, j.name + ".friction");
    }
  }

  /// An MTF carrying the lever arm of a body point: its flow is scale * (w x R point), into `sum`.
  void AddLever(const std::string& name, const std::string& body, const Eigen::Vector3d& point, double scale,
                const std::string& sum) {
    Modulus m;
    m.kind = Modulus::Kind::kLever;
    m.rotation = body + ".R";
    m.lever = point;
    m.scale = scale;
    Element e = Make(name, ElementKind::kMTF, 0, "", {});
    e.modulus = m;
    g_.Add(e);
    Bond(body + ".omega", name, name + ".w");
    Bond(name, sum, name + ".v");
    info_[body].moment_terms.push_back({name + ".w.e", -1.0});
  }

  /// A 1 x 3 map from a relative angular velocity to a spin about `axis` of `frame_body` times
  /// `scale` (TF for the ground, MTF otherwise).
  void AddSpin(const std::string& name, const std::string& frame_body, const Eigen::Vector3d& axis, double scale) {
    const Eigen::MatrixXd row = scale * axis.normalized().transpose();
    if (IsGround(frame_body)) {
      Element tf = Make(name, ElementKind::kTF, 0, "", {});
      tf.param = Param::Matrix(row);
      g_.Add(tf);
      return;
    }
    Modulus m;
    m.kind = Modulus::Kind::kRotation;
    m.rotation = frame_body + ".R";
    m.transpose = true;
    m.left = row;
    Element mtf = Make(name, ElementKind::kMTF, 0, "", {});
    mtf.modulus = m;
    g_.Add(mtf);
  }

  /// The velocity a carrier-fixed arm rho (carrier frame) gets from a gear's angular velocity,
  /// scale * (w x R_c rho), into the 0-junction `sum` (a TF for the ground carrier, else an MTF).
  void AddContactLever(const std::string& name, const std::string& body, const std::string& carrier, const Eigen::Vector3d& rho,
                       double scale, const std::string& sum) {
    Element e;
    if (IsGround(carrier)) {
      Eigen::Matrix3d skew;
      skew << 0, -rho.z(), rho.y(), rho.z(), 0, -rho.x(), -rho.y(), rho.x(), 0;
      e = Make(name, ElementKind::kTF, 0, "", {});
      e.param = Param::Matrix(-scale * skew);
    } else {
      Modulus m;
      m.kind = Modulus::Kind::kLever;
      m.rotation = carrier + ".R";
      m.lever = rho;
      m.scale = scale;
      e = Make(name, ElementKind::kMTF, 0, "", {});
      e.modulus = m;
    }
    g_.Add(e);
    Bond(body + ".omega", name, name + ".w");
    Bond(name, sum, name + ".v");
    info_[body].moment_terms.push_back({name + ".w.e", -1.0});
  }

  /// A 0-junction `sum` whose flow out is v_pitch,a - v_pitch,b (each v_C + w x R_c rho); its
  /// effort is the force on b (on a its opposite).
  void AddPitchVelocities(const std::string& sum, const GearMesh& gm, const MeshGeometry& geo, const std::string& tag) {
    g_.AddJunction(sum, ElementKind::kZero, 3);
    Bond(gm.body_a + ".v", sum, sum + ".a");
    info_[gm.body_a].force_terms.push_back({sum + ".a.e", -1.0});
    if (FindBody(gm.body_a)->mass.has_rotation()) AddContactLever(gm.name + ".a_arm" + tag, gm.body_a, gm.carrier, geo.rho_a, +1.0, sum);
    Bond(sum, gm.body_b + ".v", sum + ".b");
    info_[gm.body_b].force_terms.push_back({sum + ".b.e", +1.0});
    if (FindBody(gm.body_b)->mass.has_rotation()) AddContactLever(gm.name + ".b_arm" + tag, gm.body_b, gm.carrier, geo.rho_b, -1.0, sum);
  }

  /// A mesh through its pitch point (docs/mechanisms.md, "Tooth forces"): the coupling on
  /// n . (v_pitch,a - v_pitch,b), n the line of action, with the stiffness and damping referred
  /// to it (K / (r_a cos(helix) cos(pressure))^2); its effort is the normal force on b.
  void AddPitchGear(const GearMesh& gm) {
    const MeshGeometry& geo = geometry_.at(gm.name);
    const std::string vp = gm.name + ".vp", line = gm.name + ".line";
    AddPitchVelocities(vp, gm, geo, "");
    AddFrameElement(line, Coupling::Frame::kParent, gm.carrier, gm.carrier, geo.n.transpose(), gm.where);
    Bond(vp, line, line);
    const double tangential = std::cos(gm.helix_angle) * std::cos(gm.pressure_angle);  // F_t per unit F_n
    const double arm = geo.r_a * tangential;  // torque on a per unit normal force
    const double k = gm.stiffness / (arm * arm), r = gm.damping / (arm * arm);
    const std::string mesh = gm.name + ".mesh";
    if (gm.backlash > 0.0 && gm.rigid) {
      AddBacklashContacts(line, gm, arm, "translation");
    } else {
      AddCompliance(line, mesh, Eigen::VectorXd::Constant(1, k), Eigen::VectorXd::Constant(1, r), "translation", {}, gm.where, gm.rigid);
      if (gm.backlash > 0.0) {
        Element& spring = g_.element(g_.Find(mesh + ".K"));
        const double h = gm.backlash / 2 * arm;
        spring.law_effort = LawOf(fmt::format("{:.17g}*(q - clamp(q, {:.17g}, {:.17g}))", k, -h, h), gm.where);
      }
    }
    const std::string f = mesh + ".in.e";  // the normal force on b along n (on a its opposite): the bond into the coupling
    auto scalar = [&](const std::string& name, double c, const char* unit) {
      OutputDecl o = SumOutput(gm.name + "." + name, {{f, c}}, unit, gm.where);
      o.components.clear();
      AddOutput(o);
    };
    const Eigen::Vector3d a = gm.axis_a.normalized();
    scalar("torque", arm, "N m");
    scalar("F_t", tangential, "N");
    scalar("F_n", 1.0, "N");
    scalar("F_r", geo.radial_a.dot(geo.n), "N");  // pushes a towards its axis
    scalar("F_a", -a.dot(geo.n), "N");            // on a, along a's axis
    if (!gm.rack_b) {
      scalar("b.F_r", -geo.radial_b.dot(geo.n), "N");
      scalar("b.F_a", gm.axis_b.normalized().dot(geo.n), "N");
    }
  }

  void AddGear(const GearMesh& gm) {
    if (gm.contact == GearMesh::Contact::kPitch) {
      AddPitchGear(gm);
      return;
    }
    const std::string sum = gm.name + ".sum";
    g_.AddJunction(sum, ElementKind::kZero, 1);
    const std::pair<const std::string*, std::pair<Eigen::Vector3d, double>> sides[] = {
        {&gm.body_a, {gm.axis_a, 1.0}}, {&gm.body_b, {gm.axis_b, gm.teeth_b / gm.teeth_a}}};
    const char* tag[] = {"a", "b"};
    for (int i = 0; i < 2; ++i) {
      const std::string& body = *sides[i].first;
      const std::string rel = RelativeOmega(body, gm.carrier);
      const std::string spin = gm.name + "." + tag[i];
      AddSpin(spin, gm.carrier, sides[i].second.first, sides[i].second.second);
      Bond(rel, spin, spin + ".in");
      Bond(spin, sum, spin + ".out");
      if (IsGround(gm.carrier)) info_[body].moment_terms.push_back({spin + ".in.e", -1.0});
    }
    if (gm.backlash > 0.0 && gm.rigid) {
      AddBacklashContacts(sum, gm);
    } else {
      AddCompliance(sum, gm.name + ".mesh", Eigen::VectorXd::Constant(1, gm.stiffness), Eigen::VectorXd::Constant(1, gm.damping),
                    "rotation", {}, gm.where, gm.rigid);
      if (gm.backlash > 0.0) {
        // A dead zone in the spring: no torque while the teeth are within the play.
        Element& spring = g_.element(g_.Find(gm.name + ".mesh.K"));
        spring.law_effort = LawOf(fmt::format("{:.17g}*(q - clamp(q, {:.17g}, {:.17g}))", gm.stiffness, -gm.backlash / 2, gm.backlash / 2),
                                  gm.where);
      }
    }
    OutputDecl torque;
    torque.name = gm.name + ".torque";
    torque.variable = sum + ".e";
    torque.where = gm.where;
    AddOutput(torque);
    if (!gm.sensors) return;
    // The mesh phase (with `sensors`): gear a's rolling angle relative to the carrier, the integral
    // of s_a (the 1-junction `<mesh>.rolling`, no other bond: it carries no torque), the state
    // `<mesh>.phase`.
    const std::string rolling = gm.name + ".rolling";
    AddSpin(rolling + "_proj", gm.carrier, gm.axis_a, 1.0);
    Bond(RelativeOmega(gm.body_a, gm.carrier), rolling + "_proj", rolling + ".in");
    if (IsGround(gm.carrier)) info_[gm.body_a].moment_terms.push_back({rolling + ".in.e", -1.0});
    g_.Add(Make(rolling, ElementKind::kOne, 1, "rotation", gm.where));
    Bond(rolling + "_proj", rolling, rolling + ".out");
    AddAngle(gm.name + ".phase", rolling, gm.where);
  }

  /// A formula made by the expansion (its numbers written exactly): parsed, located at `where`.
  static Formula LawOf(const std::string& text, const SourceLocation& where) {
    expr::ParseResult parsed = expr::Parse(text);
    MB_ASSERT(parsed.root != nullptr, "a formula of the mechanism expansion does not parse: " + text);
    return Formula{text, parsed.root, where};
  }

  /// An angle [rad], the integral of the flow of the 1-junction `of` from 0; returns its name.
  std::string AddAngle(const std::string& name, const std::string& of, const SourceLocation& where, const std::string& unit = "rad") {
    AuxState a;
    a.name = name;
    a.kind = AuxState::Kind::kIntegral;
    a.of = of;
    a.unit = unit;
    a.initial = Eigen::MatrixXd::Zero(1, 1);
    a.where = where;
    g_.AddAux(a);
    return name;
  }

  /// A rotational contact (docs/events.md) whose gap is scale * gap + offset; the caller bonds it
  /// so that its flow is the separation velocity.
  Element MakeContact(const std::string& name, const std::string& gap, double scale, double offset, double restitution,
                      const SourceLocation& where) {
    Element c = Make(name, ElementKind::kSf, 1, "rotation", where);
    c.source.components = {TimeFunction::Constant(0.0)};
    c.constraint = true;
    c.switching.kind = Switching::Kind::kContact;
    c.switching.gap = gap;
    c.switching.gap_scale = scale;
    c.switching.gap_offset = offset;
    c.switching.restitution = restitution;
    c.switching.where = where;
    return c;
  }

  /// A rigid mesh with backlash: its deflection rate d (the 1-junction `<mesh>.mesh`) is free,
  /// its deflection q (`<mesh>.mesh.q`) the integral of d, and the two flanks are contacts
  /// (docs/events.md) at q = b/2 (separating at -d, gap b/2 - q) and q = -b/2 (separating at d,
  /// gap q + b/2), their forces the mesh torque.
  /// `arm` refers the play to the coupling's line (1 for a torque between spins; r_a cos(helix)
  /// for a force at the pitch point, whose deflection is a length).
  void AddBacklashContacts(const std::string& from, const GearMesh& gm, double arm = 1.0, const std::string& domain = "rotation") {
    const std::string name = gm.name + ".mesh";
    g_.Add(Make(name, ElementKind::kOne, 1, domain, gm.where));
    Bond(from, name, name + ".in");
    const std::string q = AddAngle(name + ".q", name, gm.where, arm != 1.0 ? "m" : "rad");
    const double h = gm.backlash / 2 * arm;
    for (const bool positive : {true, false}) {
      const std::string flank = name + (positive ? ".flank_pos" : ".flank_neg");
      // gap h - q (the positive flank) or q + h
      Element c = MakeContact(flank, q, positive ? -1.0 : 1.0, h, gm.restitution, gm.where);
      c.domain = domain;
      // The mesh's K, if given, shares a load with redundant constraints as the rigid mesh's would.
      if (gm.stiffness > 0.0 && std::isfinite(gm.stiffness)) c.compliance = Eigen::VectorXd::Constant(1, arm * arm / gm.stiffness);
      g_.Add(c);
      if (positive) Bond(name, flank, flank);  // its flow is -d: the flanks part as q falls
      else Bond(flank, name, flank);
    }
  }

  void AddDrive(const Drive& d) {
    switch (d.kind) {
      case Drive::Kind::kAngularVelocity:
      case Drive::Kind::kVelocity: {
        const bool angular = d.kind == Drive::Kind::kAngularVelocity;
        const std::string from = angular ? RelativeOmega(d.body, d.reference) : d.body + ".v";
        const std::string axis = d.name + ".axis", diff = d.name + ".diff";
        AddSpin(axis, angular ? d.reference : std::string(kGround), d.axis, 1.0);
        Bond(from, axis, d.name + ".in");
        if (IsGround(d.reference) || !angular) {
          auto& terms = angular ? info_[d.body].moment_terms : info_[d.body].force_terms;
          terms.push_back({d.name + ".in.e", -1.0});
        }
        Element src = Make(d.name + ".source", ElementKind::kSf, 1, angular ? "rotation" : "translation", d.where);
        src.source.components = {d.value};
        if (d.formula.given()) {
          src.source.components = {TimeFunction::Constant(0.0)};  // a placeholder: the formula is the value
          src.value = {d.formula};
        }
        if (d.rigid) {
          // An ideal drive: the source is an ideal constraint on the spin; its effort is the reaction.
          src.constraint = true;
          g_.Add(src);
          Bond(axis, d.name + ".source", d.name + ".source");
          OutputDecl o = SumOutput(d.name + (angular ? ".torque" : ".force"), {{d.name + ".source.e", -1.0}}, angular ? "N m" : "N", d.where);
          o.components.clear();
          AddOutput(o);
          break;
        }
        g_.AddJunction(diff, ElementKind::kZero, 1);
        Bond(axis, diff, d.name + ".spin");
        g_.Add(src);
        Bond(diff, d.name + ".source", d.name + ".source");
        AddCompliance(diff, d.name + ".coupling", Eigen::VectorXd::Constant(1, d.stiffness), Eigen::VectorXd::Constant(1, d.damping),
                      angular ? "rotation" : "translation", {}, d.where);
        // The coupling's effort tau acts on the body as -tau along the axis.
        OutputDecl o = SumOutput(d.name + (angular ? ".torque" : ".force"), {{diff + ".e", -1.0}}, angular ? "N m" : "N", d.where);
        o.components.clear();
        AddOutput(o);
        break;
      }
      case Drive::Kind::kTorque:
      case Drive::Kind::kForce: {
        const bool torque = d.kind == Drive::Kind::kTorque;
        Element src = Make(d.name + ".source", ElementKind::kSe, 3, torque ? "rotation" : "translation", d.where);
        const Eigen::Vector3d a = d.axis.normalized();
        for (int i = 0; i < 3; ++i) src.source.components.push_back(d.value.Scaled(a[i]));
        if (d.formula.given()) {
          // Component k is a[k] * formula; a component the axis does not reach is the constant 0.
          src.value.resize(3);
          for (int i = 0; i < 3; ++i) {
            src.source.components[i] = TimeFunction::Constant(0.0);
            if (a[i] == 0.0) continue;
            Formula& f = src.value[i];
            f = d.formula;
            if (a[i] != 1.0) f.root = expr::Binary(expr::Node::Kind::kMul, expr::Number(a[i]), d.formula.root);
          }
        }
        src.components = kXyz;
        g_.Add(src);
        if (torque) {
          Bond(d.name + ".source", d.body + ".omega", d.name + ".source");
        } else if (d.point.isZero()) {
          Bond(d.name + ".source", d.body + ".v", d.name + ".source");
        } else {
          const std::string at = d.name + ".at";
          g_.AddJunction(at, ElementKind::kZero, 3);
          Bond(d.name + ".source", at, d.name + ".source");
          Bond(at, d.body + ".v", d.name + ".v");
          AddLever(d.name + ".arm", d.body, d.point, -1.0, at);
          info_[d.body].moment_terms.pop_back();  // an applied force is no coupling
        }
        OutputDecl o;
        o.name = d.name + (torque ? ".torque" : ".force");
        o.variable = d.name + ".source.e";
        o.where = d.where;
        AddOutput(o);
        break;
      }
    }
  }

  void AddPointOutput(const Point& p) {
    OutputDecl o;
    o.kind = OutputDecl::Kind::kPoint;
    o.name = p.name;
    o.position = p.body + ".r";
    o.rotation = p.body + ".R";
    o.point = p.at;
    o.unit = std::string("m");  // assigning the literal trips GCC 12's false -Wrestrict (GCC bug 105651)
    o.where = p.where;
    if (!FindBody(p.body)->mass.has_rotation()) {  // a point mass: its CoM is the point
      o.kind = OutputDecl::Kind::kVariable;
      o.variable = p.body + ".r";
    }
    AddOutput(o);
  }

  void AddBodyOutputs(const Body& b) {
    const BodyInfo& info = info_.at(b.name);
    OutputDecl v;
    v.name = b.name + ".v";
    v.variable = b.name + ".v.f";
    v.where = b.where;
    AddOutput(v);
    // A body with no coupling still gets F (and M) columns, identically zero.
    auto terms_or_zero = [&](std::vector<std::pair<std::string, double>> t, const std::string& junction) {
      if (t.empty()) t.push_back({junction + ".f", 0.0});
      return t;
    };
    AddOutput(SumOutput(b.name + ".F", terms_or_zero(info.force_terms, b.name + ".v"), "N", b.where));
    if (b.mass.has_rotation()) {
      OutputDecl w;
      w.name = b.name + ".omega";
      w.variable = b.name + ".omega.f";
      w.where = b.where;
      AddOutput(w);
      AddOutput(SumOutput(b.name + ".M", terms_or_zero(info.moment_terms, b.name + ".omega"), "N m", b.where));
      OutputDecl orth;
      orth.kind = OutputDecl::Kind::kOrthonormality;
      orth.name = b.name + ".orthonormality";
      orth.rotation = b.name + ".R";
      orth.where = b.where;
      AddOutput(orth);
    }
  }

 public:
  Eigen::Vector3d gravity_ = Eigen::Vector3d::Zero();

 private:
  const Mechanism& m_;
  BondGraph& g_;
  DiagnosticSink& sink_;
  std::unordered_map<std::string, const Body*> body_by_name_;
  std::unordered_map<std::string, BodyInfo> info_;
  std::unordered_map<std::string, std::string> relative_;
  std::unordered_map<std::string, MeshGeometry> geometry_;
};

}  // namespace

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

std::string Mechanism::DescribePart(const std::string& element) const {
  const std::string head = element.substr(0, element.find('.'));
  if (const auto tilde = head.find('~'); tilde != std::string::npos)
    return fmt::format("the relative rotation of '{}' and '{}'", head.substr(0, tilde), head.substr(tilde + 1));
  for (const Body& b : bodies_)
    if (b.name == head) return fmt::format("body '{}'", head);
  for (const Joint& j : joints_)
    if (j.name == head) return fmt::format("joint '{}' ({} of '{}' on '{}')", head, j.kind, j.child, j.parent);
  for (const GearMesh& gm : gears_)
    if (gm.name == head) return fmt::format("gear mesh '{}'", head);
  for (const Drive& d : drives_)
    if (d.name == head) return fmt::format("drive '{}'", head);
  return {};
}

void Mechanism::ExpandInto(BondGraph& g, DiagnosticSink& sink) const {
  Expander e(*this, g, sink);
  e.gravity_ = gravity_;
  e.Run();
}

BondGraph Mechanism::Build(const std::string& name) const {
  BondGraph g(name);
  DiagnosticSink sink;
  ExpandInto(g, sink);
  sink.ThrowIfErrors();
  return g;
}

}  // namespace multibond::mech

namespace multibond::mech {

JointTree Mechanism::MakeJointTree() const {
  std::map<std::string, const Body*> body;
  for (const Body& b : bodies_) body[b.name] = &b;
  auto orientation = [&](const std::string& name) -> Eigen::Matrix3d {
    const auto it = body.find(name);
    return it == body.end() ? Eigen::Matrix3d::Identity() : it->second->orientation;
  };
  auto omega = [&](const std::string& name) -> Eigen::Vector3d {
    const auto it = body.find(name);
    return it == body.end() ? Eigen::Vector3d::Zero() : it->second->omega;
  };
  auto count = [](const std::optional<Coupling>& c) { return c ? static_cast<int>(c->directions.rows()) : 0; };
  std::set<std::string> in_tree = {kGround};
  JointTree tree;
  auto add = [&](const std::string& name, const std::string& parent, const Joint* j) {
    TreeBody tb;
    tb.name = name;
    tb.parent = parent == kGround ? "" : parent;
    Eigen::Vector3d axis_world = Eigen::Vector3d::Zero();
    if (j) {
      tb.joint = j->name;
      tb.anchor = j->child == name ? j->child_point : j->parent_point;
      if (count(j->rotation) == 2) {
        const Eigen::Vector3d n = Eigen::Vector3d(j->rotation->directions.row(0)).cross(Eigen::Vector3d(j->rotation->directions.row(1)));
        switch (j->rotation->frame) {
          case Coupling::Frame::kParent: axis_world = orientation(j->parent) * n; break;
          case Coupling::Frame::kChild: axis_world = orientation(j->child) * n; break;
          case Coupling::Frame::kWorld: axis_world = n; break;
        }
      }
    }
    if (!(axis_world.norm() > 1e-12)) axis_world = omega(name) - omega(parent);  // no bearing: how it turns at the start
    if (!(axis_world.norm() > 1e-12)) axis_world = orientation(parent).col(2);
    tb.axis = (orientation(parent).transpose() * axis_world).normalized();
    in_tree.insert(name);
    tree.push_back(tb);
  };
  for (;;) {
    const Joint* best = nullptr;
    std::tuple<int, int, bool> best_key{-1, -1, false};
    for (const Joint& j : joints_) {
      if (in_tree.count(j.parent) == in_tree.count(j.child)) continue;
      const std::string& outside = in_tree.count(j.parent) ? j.child : j.parent;
      if (!body.count(outside)) continue;
      const bool rigid = (j.rotation && j.rotation->rigid) || (j.translation && j.translation->rigid);
      const std::tuple<int, int, bool> key{count(j.rotation), count(j.translation), rigid};
      if (key > best_key) best = &j, best_key = key;
    }
    if (!best) break;
    if (in_tree.count(best->parent)) add(best->child, best->parent, best);
    else add(best->parent, best->child, best);
  }
  for (const Body& b : bodies_)
    if (!in_tree.count(b.name)) add(b.name, kGround, nullptr);
  return tree;
}

}  // namespace multibond::mech

namespace multibond::mech {

MeshGeometry Mechanism::GeometryOf(const GearMesh& gm) const {
  MeshGeometry out;
  auto find = [&](const std::string& n) -> const Body* {
    for (const Body& b : bodies_)
      if (b.name == n) return &b;
    return nullptr;
  };
  const Body* carrier = gm.carrier == kGround ? nullptr : find(gm.carrier);
  const Body* ga = find(gm.body_a);
  const Body* gb = find(gm.body_b);
  if (!ga || !gb || (gm.carrier != kGround && !carrier)) {
    out.error = "the mesh names a body that does not exist";
    return out;
  }
  // The gears' centres in the carrier's frame (its CoM the origin; the ground: absolute).
  auto local = [&](const Body* b) -> Eigen::Vector3d {
    return carrier ? Eigen::Vector3d(carrier->orientation.transpose() * (b->position - carrier->position)) : b->position;
  };
  const Eigen::Vector3d ca = local(ga), cb = local(gb);
  const Eigen::Vector3d a = gm.axis_a.normalized();
  const double scale = std::max({(cb - ca).norm(), gm.radius_a, 1e-3});
  const double tol = 1e-9 * scale;
  auto perp = [](const Eigen::Vector3d& v, const Eigen::Vector3d& axis) -> Eigen::Vector3d { return v - axis * axis.dot(v); };
  const Eigen::Vector3d b = gm.rack_b ? Eigen::Vector3d::Zero() : Eigen::Vector3d(gm.axis_b.normalized());
  const bool parallel = gm.rack_b || a.cross(b).norm() < 1e-9;
  Eigen::Vector3d line = a;  // the pitch element: along the axes, or from a bevel pair's apex
  Eigen::Vector3d p;
  if (gm.rack_b) {
    const Eigen::Vector3d u = perp(cb - ca, a);
    const double r = gm.radius_a;
    if (gm.pitch_point) {
      p = *gm.pitch_point;
    } else if (!(r > 0) || u.norm() < tol) {
      out.error = "a rack and pinion needs the pinion's pitch radius ('radius' of gear a) and the rack's centre off the pinion's axis";
      out.hint = "give a: {..., radius: r} (module x teeth / 2) or the mesh's 'pitch_point'";
      return out;
    } else {
      p = ca + r * u.normalized();
    }
  } else if (gm.pitch_point) {
    p = *gm.pitch_point;
    if (!parallel) {
      // The apex: where the axes meet (the point of a's axis closest to b's).
      const Eigen::Vector3d w = ca - cb;
      const double ab = a.dot(b), den = 1 - ab * ab;
      const double sa = (ab * b.dot(w) - a.dot(w)) / den;
      line = perp(p - (ca + sa * a), Eigen::Vector3d(a.cross(b).normalized()));
      if (line.norm() < tol) {
        out.error = "the pitch point is at the apex of the bevel pair";
        out.hint = "give a point on the pitch cones, away from where the axes meet";
        return out;
      }
      line.normalize();
    }
  } else if (parallel) {
    const Eigen::Vector3d d = perp(cb - ca, a);
    const double dist = d.norm();
    if (dist < tol) {
      out.error = "the gears' centres are on one axis: there is no pitch point between them";
      out.hint = "place the gears' centres one centre distance apart, or give the mesh's 'pitch_point'";
      return out;
    }
    const Eigen::Vector3d u = d / dist;  // from a's axis towards b's
    if (!gm.internal) {
      p = ca + dist * gm.teeth_a / (gm.teeth_a + gm.teeth_b) * u;
    } else if (gm.teeth_a == gm.teeth_b) {
      out.error = "an internal mesh needs a ring with more teeth than its pinion";
      out.hint = "check the teeth (the ring's count is the larger)";
      return out;
    } else if (gm.teeth_a > gm.teeth_b) {
      p = ca + dist * gm.teeth_a / (gm.teeth_a - gm.teeth_b) * u;  // a is the ring: beyond the pinion
    } else {
      p = cb - dist * gm.teeth_b / (gm.teeth_b - gm.teeth_a) * u;  // b is the ring
    }
  } else {
    // Bevel: the point where both gears' mid-planes meet the plane of the axes.
    const Eigen::Vector3d nrm = a.cross(b).normalized();
    const Eigen::Vector3d w = ca - cb;
    const double ab = a.dot(b), den = 1 - ab * ab;
    const double sa = (ab * b.dot(w) - a.dot(w)) / den, sb = (b.dot(w) - ab * a.dot(w)) / den;
    const Eigen::Vector3d apex_a = ca + sa * a, apex_b = cb + sb * b;
    if ((apex_a - apex_b).norm() > 1e-6 * scale) {
      out.error = fmt::format("the gears' axes do not meet (they pass {:.3g} m apart): a bevel pair's axes intersect", (apex_a - apex_b).norm());
      out.hint = "check the gears' positions and axes (crossed and worm gears are not modelled)";
      return out;
    }
    Eigen::Matrix3d m;
    m.row(0) = a.transpose();
    m.row(1) = b.transpose();
    m.row(2) = nrm.transpose();
    p = m.fullPivLu().solve(Eigen::Vector3d(a.dot(ca), b.dot(cb), nrm.dot(ca)));
    line = p - apex_a;
    if (line.norm() < tol) {
      out.error = "the gears' mid-planes meet at the apex of the bevel pair";
      out.hint = "place each bevel gear's centre at its mean pitch circle, or give the mesh's 'pitch_point'";
      return out;
    }
    line.normalize();
  }
  out.point = p;
  out.rho_a = p - ca;
  out.rho_b = p - cb;
  // A gear's pitch radius and the unit vector from its axis to P; false if P is on the axis.
  auto radial = [&](const Eigen::Vector3d& rho, const Eigen::Vector3d& axis, const char* gear, double* r, Eigen::Vector3d* unit) {
    const Eigen::Vector3d v = perp(rho, axis);
    *r = v.norm();
    if (*r < tol) {
      out.error = fmt::format("the pitch point is on gear {}'s axis", gear);
      out.hint = "check the gears' positions, or the mesh's 'pitch_point'";
      return false;
    }
    *unit = v / *r;
    return true;
  };
  if (!radial(out.rho_a, a, "a", &out.r_a, &out.radial_a)) return out;
  out.t = a.cross(out.radial_a);
  // The line of action: F_t along t, F_t tan(helix) along a's axis, F_t tan(pressure) / cos(helix)
  // along s, apart (the drive flank) or, for the coast flank, together.
  auto line_of_action = [&] {
    const double cp = std::cos(gm.pressure_angle), sp = std::sin(gm.pressure_angle);
    const double flank = gm.coast_flank ? -1.0 : 1.0;
    out.n = std::cos(gm.helix_angle) * cp * out.t + std::sin(gm.helix_angle) * cp * a + flank * sp * out.s;
  };
  if (gm.rack_b) {
    out.s = out.radial_a;  // the separating force pushes the rack away from the pinion
    line_of_action();
    return out;
  }
  if (!radial(out.rho_b, b, "b", &out.r_b, &out.radial_b)) return out;
  // Rolling: r_a w_a.a + r_b w_b.b = 0 (teeth_a s_a + teeth_b s_b = 0) means b's axis is t x radial_b.
  const Eigen::Vector3d b_expected = out.t.cross(out.radial_b);
  if (std::abs(out.t.dot(b)) > 1e-6 || b.dot(b_expected) < 1 - 1e-6) {
    auto vec = [](const Eigen::Vector3d& v) {
      auto c = [](double x) { return std::abs(x) < 5e-13 ? 0.0 : x; };
      return fmt::format("[{:.6g}, {:.6g}, {:.6g}]", c(v.x()), c(v.y()), c(v.z()));
    };
    out.error = fmt::format(
        "gear b's axis {} does not roll with gear a's: at the pitch point {} (carrier frame) the teeth roll without slip when "
        "teeth_a s_a + teeth_b s_b = 0 with b's axis {}",
        vec(b), vec(p), vec(b_expected));
    out.hint = fmt::format("write b's axis as {} (external spur: the same as a's; internal: the opposite)", vec(b_expected));
    return out;
  }
  if (std::abs(out.r_b / out.r_a - gm.teeth_b / gm.teeth_a) > 1e-6 * gm.teeth_b / gm.teeth_a) {
    out.error = fmt::format("the pitch radii {:.6g} m (a) and {:.6g} m (b) are not in the ratio of the teeth {:g}:{:g}", out.r_a, out.r_b,
                            gm.teeth_a, gm.teeth_b);
    out.hint = "place the gears so that their pitch circles touch (radius = module x teeth / 2), or check the teeth";
    return out;
  }
  if (!parallel && gm.helix_angle != 0.0) {
    out.error = "a helix angle is modelled for parallel axes (helical gears and racks), not for bevel gears";
    out.hint = "remove 'helix_angle_deg' (straight bevel gears)";
    return out;
  }
  // The separating force on b: perpendicular to t and to the pitch element, into b (out of a ring b).
  const bool b_ring = gm.internal && gm.teeth_b > gm.teeth_a;
  const Eigen::Vector3d v = perp(perp(out.rho_b, out.t), line);
  out.s = v.norm() > tol ? Eigen::Vector3d((b_ring ? 1.0 : -1.0) * v.normalized()) : Eigen::Vector3d::Zero();
  line_of_action();
  return out;
}

}  // namespace multibond::mech
