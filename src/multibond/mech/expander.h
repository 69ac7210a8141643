#pragma once
/// \file
/// The expansion of a Mechanism into bond-graph elements, shared by the files that each expand one
/// kind of part (expand_body.cc, expand_coupling.cc, expand_joint.cc, expand_switches.cc,
/// expand_gear.cc, expand_drive.cc) and check the mechanism first (validate.cc). Internal to the
/// mech layer: users call Mechanism::ExpandInto or Mechanism::Build.

#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include <Eigen/Dense>

#include "multibond/mech/mechanism.h"

namespace multibond::mech::detail {

/// The most teeth a gear may have (a sane bound: real gears have a few to a few thousand).
inline constexpr double kMaxTeeth = 100000;

inline const std::vector<std::string> kXyz = {"x", "y", "z"};

/// Expands a Mechanism into bond-graph elements. Each body contributes its two 1-junctions
/// (v, omega), their inertias and its R, r states; each coupling a small junction structure
/// (0-junction for relative flows, TF/MTF for frames and lever arms, a 1-junction with C and R).
class Expander {
 public:
  Expander(const Mechanism& m, BondGraph& g, DiagnosticSink& sink) : m_(m), g_(g), sink_(sink) {
    for (const Body& b : m_.bodies()) body_by_name_.emplace(b.name, &b);  // the first of a name, as a search would find
  }

  void Run();

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

  void Validate();

  /// A mesh through its pitch point: its geometry consistent with the axes and teeth (an error
  /// says which axis or radius is wrong), its angles in range, and the teeth rolling at t = 0 (a
  /// warning gives the slip speed).
  void CheckPitchMesh(const GearMesh& gm);

  /// Position of a joint's attachment on `body` (ground: the absolute point) at t = 0.
  Eigen::Vector3d AttachmentAtStart(const std::string& body, const Eigen::Vector3d& point) const;

  void WarnIfDeflected(const Joint& j);

  // --- expansion --------------------------------------------------------------------------

  void Bond(const std::string& from, const std::string& to, const std::string& name) { g_.Connect(from, to, 0, name); }

  Element Make(const std::string& name, ElementKind kind, int dim, const std::string& domain, const SourceLocation& where);

  void AddBody(const Body& b);

  const Eigen::Vector3d& m_gravity() const { return gravity_; }

  /// The 1-junction whose flow is w_child - w_parent (the child's omega for the ground), built
  /// once per pair and shared by every coupling of the pair.
  std::string RelativeOmega(const std::string& child, const std::string& parent);

  /// A TF (constant directions) or MTF (directions turning with a body) mapping 3-vectors of the
  /// inertial frame to components along `rows`, in the coupling's frame.
  void AddFrameElement(const std::string& name, Coupling::Frame frame, const std::string& parent, const std::string& child,
                       const Eigen::MatrixXd& rows, const SourceLocation& where);

  /// A 1-junction `name` of dimension k with a C (K) and an R on it, fed by `from`; or, when
  /// `rigid`, with an ideal constraint `name.rigid` (an Sf of zero flow held by its reaction).
  void AddCompliance(const std::string& from, const std::string& name, const Eigen::VectorXd& k, const Eigen::VectorXd& r,
                     const std::string& domain, const std::vector<std::string>& comps, const SourceLocation& where,
                     bool rigid = false);

  std::vector<std::string> DirectionNames(const Coupling& c);

  void AddOutput(OutputDecl o) { g_.AddOutput(std::move(o)); }
  /// An output that reads one variable; `unit` "" takes the variable's own.
  void AddVariableOutput(const std::string& name, const std::string& variable, const std::string& unit, const SourceLocation& where) {
    OutputDecl o;
    o.name = name;
    o.variable = variable;
    o.unit = unit;
    o.where = where;
    AddOutput(std::move(o));
  }

  OutputDecl SumOutput(const std::string& name, std::vector<std::pair<std::string, double>> terms, const std::string& unit,
                       const SourceLocation& where);

  void AddJoint(const Joint& j);

  /// The relative rotation sensor of a joint without a single free axis (docs/mechanisms.md,
  /// "Joint sensors"): the relative angular velocity in the parent's frame, R_p^T (w_c - w_p) (the
  /// 1-junction `<joint>.rel_w`, no other bond), integrated into the orientation state
  /// `<joint>.relative` = R_p^T R_c (R_p^T R_c)(0)^T, and its rotation vector as the signals
  /// `<joint>.rotvec.angle` (in [0, pi]) and `<joint>.rotvec.x|y|z`, the outputs `<joint>.rotation.*`.
  void AddRotationSensor(const Joint& j);

  /// A body with an angular velocity (not a point mass).
  bool Spins(const std::string& body) const;
  /// Whether a joint, mesh or drive is an ideal constraint: such models take no formulas yet, so
  /// their joints get no rotation sensor (a signal).
  bool HasIdealConstraints() const;

  /// A joint with an axis of rotation that needs its rate: a revolute, cylindrical, planar or
  /// screw joint's sensor, a revolute joint's end stops or friction, a screw's helix.
  static bool Turns(const Joint& j) {
    const bool turning_kind = j.kind == "revolute" || j.kind == "cylindrical" || j.kind == "planar" || j.kind == "screw";
    return ((turning_kind && j.sensors) || ((j.stops || j.friction) && j.kind != "prismatic") || j.helix) && !j.axis.isZero();
  }
  /// A prismatic joint with its axis (and a translation coupling): it gets the slide and speed
  /// sensor, and its end stops and friction act along the axis.
  static bool Slides(const Joint& j) { return j.kind == "prismatic" && !j.axis.isZero(); }
  /// A prismatic joint that needs its slide rate `<joint>.axial`: its sensor, end stops, friction.
  static bool SlideSensed(const Joint& j) { return Slides(j) && (j.sensors || j.stops || j.friction); }
  /// A cylindrical or screw joint: the slide along its axis (junction `<joint>.t_axial`, besides
  /// the turn's `<joint>.axial`), for the sensor or the screw's helix.
  static bool SlidesAndTurns(const Joint& j) {
    return (j.kind == "cylindrical" || j.kind == "screw") && !j.axis.isZero() && (j.sensors || j.helix);
  }
  /// A planar joint with its sensor: the in-plane slide, 2 components (junction `<joint>.t_axial`).
  static bool SlidesInPlane(const Joint& j) { return j.kind == "planar" && !j.axis.isZero() && j.sensors; }

  /// The checks of the joint kinds with axes of their own (validate.cc calls it per joint): a
  /// universal joint's axes non-zero and perpendicular at t = 0; a screw's lead and helix coupling.
  void CheckJointKind(const Joint& j);

  /// A universal joint's rotation coupling (docs/mechanisms.md, "Joints"): its flow is
  /// n . (w_c - w_p) with n = (R_p axis) x (R_c child_axis), built as a lever MTF on the child's
  /// orientation (w x R_c child_axis) followed by a projection on R_p axis: each modulus linear in
  /// one orientation, so the coupling may be an ideal constraint. Its deflection is
  /// -(R_p axis) . (R_c child_axis), the yokes' departure from perpendicular.
  void AddUniversalRotation(const Joint& j);
  /// A universal joint's sensors: the yoke angles `<joint>.angle_a` (about `axis`, parent frame)
  /// and `<joint>.angle_b` (about `child_axis`, child frame) with their rates.
  void AddUniversalSensors(const Joint& j);
  /// A screw's helix: the coupling `<joint>.h` on s' - lead / (2 pi) theta' (a 0-junction
  /// `<joint>.helix` fed by the axial junctions, the turn through the TF `<joint>.helix_lead`).
  void AddHelix(const Joint& j);
  /// A planar joint's in-plane slide sensor from the relative velocity `rel` of its points.
  void AddPlaneSensor(const Joint& j, const std::string& rel);

  /// The joint sensor on the free axis (docs/mechanisms.md, "Joint sensors"): the relative rate
  /// about (revolute) or along (prismatic) the axis in the parent's frame, the 1-junction
  /// `<joint>.axial` fed from the relative flow `rel` (no other bond: it carries no effort), and
  /// its integral from the assembled position, the state `<joint>.angle` or `<joint>.slide`;
  /// outputs `<joint>.rate` or `<joint>.speed`. Without `sensors`, end stops get the junction and
  /// the angle state (their gap), friction the junction only (its rate).
  /// `junction` names the 1-junction (default `<joint>.axial`; a cylindrical or screw joint's
  /// slide: `<joint>.t_axial`).
  void AddAxialSensor(const Joint& j, const std::string& rel, const std::string& domain, const std::string& junction = {});

  /// A revolute or prismatic joint's end stops and friction (docs/events.md): the rate about or
  /// along its free axis (the 1-junction `<joint>.axial`), its angle or slide (`<joint>.angle`
  /// [rad] or `<joint>.slide` [m], from the assembled position), contacts at the stops
  /// (`<joint>.lower`, gap q - lower; `<joint>.upper`, gap upper - q), a friction on the rate
  /// (`<joint>.friction`, a capacity: a torque or a force), all in the joint's domain.
  void AddAxialSwitches(const Joint& j);

  /// An MTF carrying the lever arm of a body point: its flow is scale * (w x R point), into `sum`.
  void AddLever(const std::string& name, const std::string& body, const Eigen::Vector3d& point, double scale,
                const std::string& sum);

  /// A 1 x 3 map from a relative angular velocity to a spin about `axis` of `frame_body` times
  /// `scale` (TF for the ground, MTF otherwise).
  void AddSpin(const std::string& name, const std::string& frame_body, const Eigen::Vector3d& axis, double scale);

  /// The velocity a carrier-fixed arm rho (carrier frame) gets from a gear's angular velocity,
  /// scale * (w x R_c rho), into the 0-junction `sum` (a TF for the ground carrier, else an MTF).
  void AddContactLever(const std::string& name, const std::string& body, const std::string& carrier, const Eigen::Vector3d& rho,
                       double scale, const std::string& sum);

  /// A 0-junction `sum` whose flow out is v_pitch,a - v_pitch,b (each v_C + w x R_c rho); its
  /// effort is the force on b (on a its opposite).
  void AddPitchVelocities(const std::string& sum, const GearMesh& gm, const MeshGeometry& geo, const std::string& tag);

  /// The carrier's share of the pitch-point velocity that the arms fixed in it miss: w_c x D with
  /// D how far the gears' actual centres are from their places in the carrier (docs/design.md,
  /// "Gear meshes through the contact"), an MTF from the carrier's angular velocity into `sum`.
  void AddPitchTransport(const std::string& sum, const GearMesh& gm, const MeshGeometry& geo);

  /// For each gear whose arm c = rho x n has a part off its axis (bevel and helical gears): its
  /// spin about its own axis a' relative to the carrier times -(R_c c_off . a'), into the scalar
  /// 0-junction `rate`: the rate the fixed arm reads from a gear spinning about a tilted axis,
  /// taken out (docs/design.md, "Gear meshes through the contact").
  void AddPitchTilt(const std::string& rate, const GearMesh& gm, const MeshGeometry& geo);

  /// A mesh through its pitch point (docs/mechanisms.md, "Tooth forces"): the coupling on
  /// n . (v_pitch,a - v_pitch,b), n the line of action, with the stiffness and damping referred
  /// to it (K / (r_a cos(helix) cos(pressure))^2); its effort is the normal force on b.
  void AddPitchGear(const GearMesh& gm);

  void AddGear(const GearMesh& gm);

  /// A formula made by the expansion (its numbers written exactly): parsed, located at `where`.
  static Formula LawOf(const std::string& text, const SourceLocation& where);

  /// An angle [rad], the integral of the flow of the 1-junction `of` from 0; returns its name.
  std::string AddAngle(const std::string& name, const std::string& of, const SourceLocation& where, const std::string& unit = "rad");

  /// A contact (docs/events.md) in `domain` ("rotation" or "translation") whose gap is
  /// scale * gap + offset; the caller bonds it so that its flow is the separation velocity.
  Element MakeContact(const std::string& name, const std::string& domain, const std::string& gap, double scale, double offset,
                      double restitution, const SourceLocation& where);

  /// A rigid mesh with backlash: its deflection rate d (the 1-junction `<mesh>.mesh`) is free,
  /// its deflection q (`<mesh>.mesh.q`) the integral of d, and the two flanks are contacts
  /// (docs/events.md) at q = b/2 (separating at -d, gap b/2 - q) and q = -b/2 (separating at d,
  /// gap q + b/2), their forces the mesh torque.
  /// `arm` refers the play to the coupling's line (1 for a torque between spins; r_a cos(helix)
  /// for a force at the pitch point, whose deflection is a length).
  void AddBacklashContacts(const std::string& from, const GearMesh& gm, double arm = 1.0, const std::string& domain = "rotation");

  void AddDrive(const Drive& d);

  void AddPointOutput(const Point& p);

  void AddBodyOutputs(const Body& b);

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

}  // namespace multibond::mech::detail
