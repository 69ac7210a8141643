#pragma once
/// \file
/// The rigid-body multibond library: bodies, joints (compliant couplings), gear meshes, drives and
/// points, expanded into an ordinary BondGraph made of the engine's elements, after the paper's
/// formulation (Vaz & Hirai): per body a translational momentum p = m v at the centre of mass and
/// an angular momentum h = R Ib R^T w in the inertial frame (no Euler junction structure), with
/// the orientation R and position r as states integrated from the flows. docs/mechanisms.md shows
/// each component's expansion.
///
/// Names in the expanded graph (B a body, J a joint, G a gear mesh, D a drive):
///   B.v, B.omega (1-junctions: CoM velocity and angular velocity, inertial frame),
///   B.p, B.h (states: momenta), B.R (orientation state, R.11 ... R.33), B.r (CoM position),
///   outputs B.v, B.omega, B.F, B.M (sum of the couplings' forces and moments on B, inertial
///   frame, moments about the CoM), B.orthonormality (|R^T R - I|);
///   J.F, J.M (force and moment of the joint on its child, inertial frame), J.t.K, J.t.R, J.r.K,
///   J.r.R (the couplings' C and R; a rigid coupling has J.t.rigid / J.r.rigid instead, an ideal
///   constraint whose effort is the reaction); a screw's helix J.helix (0-junction), J.h.K, J.h.R
///   (or J.h.rigid), output J.helix_force; a universal joint's rotation J.r_lever, J.r_cross, J.r_frame;
///   G.torque, G.deflection (G.mesh.rigid when rigid);
///   meshes through the pitch point also G.F_t, G.F_r, G.F_a, G.F_n, G.b.F_r, G.b.F_a;
///   D.torque (or D.force); points P.x,y,z;
///   joint sensors (with `sensors`): revolute J.axial (1-junction, the rate about the axis), state J.angle, output
///   J.rate; prismatic J.t_rel (the points' relative velocity), J.axial, state J.slide, output J.speed;
///   cylindrical and screw both (J.axial, J.angle, J.rate; J.t_axial, J.slide, J.speed), planar
///   J.t_axial, state J.slide (components u, v), output J.speed, and J.axial, J.angle, J.rate;
///   universal J.axial_a, J.axial_b, states J.angle_a, J.angle_b, outputs J.rate_a, J.rate_b;
///   coupling and spherical J.rel_w, state J.relative, signals J.rotvec.*, outputs J.rotation.*;
///   gear meshes (spin contact) G.rolling, state G.phase.

#include <optional>
#include <string>
#include <vector>

#include <Eigen/Dense>

#include "multibond/core/graph.h"
#include "multibond/core/joint_tree.h"
#include "multibond/mech/mass_properties.h"

namespace multibond::mech {

/// The name that stands for the inertial frame (a fixed, massless "body").
inline constexpr const char* kGround = "ground";

struct Body {
  std::string name;
  MassProperties mass;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();     ///< CoM at t = 0 [m]
  Eigen::Matrix3d orientation = Eigen::Matrix3d::Identity();  ///< R(0): body frame -> inertial
  Eigen::Vector3d velocity = Eigen::Vector3d::Zero();     ///< CoM velocity at t = 0 [m/s]
  Eigen::Vector3d omega = Eigen::Vector3d::Zero();        ///< angular velocity at t = 0, inertial [rad/s]
  double stabilization = 0.0;  ///< orientation drift control gain (see AuxState::stabilization)
  SourceLocation where;
};

/// A set of compliant directions: one C (stiffness) and one R (damping) per direction.
struct Coupling {
  enum class Frame { kParent, kWorld, kChild };
  /// Rows are the directions (unit vectors) in `frame`; k x 3 with k = 1, 2 or 3.
  Eigen::MatrixXd directions = Eigen::Matrix3d::Identity();
  Eigen::VectorXd stiffness;  ///< per direction (N/m or N m/rad)
  Eigen::VectorXd damping;    ///< per direction (N s/m or N m s/rad)
  Frame frame = Frame::kWorld;
  std::vector<std::string> components;  ///< names of the directions ("x", "y", ...)
  /// An ideal constraint instead of the C and R: zero relative velocity in `directions`, held
  /// exactly by a reaction (stiffness and damping are ignored). See docs/design.md.
  bool rigid = false;
};

/// A joint: compliant couplings between a point of the parent (or of the ground) and a point of
/// the child. Translation acts on v_child_point - v_parent_point, rotation on chosen components of
/// w_child - w_parent expressed in the chosen frame. Free directions carry nothing.
struct Joint {
  std::string name;
  std::string kind = "coupling";  ///< coupling, revolute, fixed, spherical, prismatic, held, cylindrical, planar, screw, universal
  std::string parent = kGround;
  std::string child;
  Eigen::Vector3d parent_point = Eigen::Vector3d::Zero();  ///< parent frame from its CoM; ground: absolute
  Eigen::Vector3d child_point = Eigen::Vector3d::Zero();   ///< child frame, from its CoM
  std::optional<Coupling> translation, rotation;
  /// Revolute and prismatic joints: the free axis (parent frame), along which the joint sensor
  /// measures (docs/mechanisms.md, "Joint sensors"). Revolute and prismatic joints: the switching
  /// elements on the rotation about it or the slide along it (docs/events.md): end stops at
  /// relative positions `lower` < `upper` [rad or m, from the assembled position] with impacts of
  /// `restitution`, and a friction torque or force (Coulomb: sticks while the torque or force
  /// needed is within it), a number, a time function or a signal's name.
  Eigen::Vector3d axis = Eigen::Vector3d::Zero();
  /// Universal joints: the child's yoke axis (child frame), perpendicular to the parent's `axis`
  /// at t = 0. The rotation coupling (one direction) then acts about n = (R_p axis) x (R_c
  /// child_axis), the spider's third axis, instead of its `directions` (docs/mechanisms.md, "Joints").
  Eigen::Vector3d child_axis = Eigen::Vector3d::Zero();
  /// Screw joints: the lead [m per turn] and the coupling (one direction, N/m) on the helix,
  /// s' - lead / (2 pi) theta', s the slide along `axis` and theta the turn about it.
  double lead = 0.0;
  std::optional<Coupling> helix;
  struct Stops {
    double lower = 0.0, upper = 0.0, restitution = 0.0;
    SourceLocation where;
  };
  std::optional<Stops> stops;
  struct Friction {
    TimeFunction torque = TimeFunction::Constant(0.0);  ///< N m (revolute) or N (prismatic)
    std::string signal;
    SourceLocation where;
  };
  std::optional<Friction> friction;
  /// The joint sensor (docs/mechanisms.md, "Joint sensors"), off by default: each is a state the
  /// integrator carries. End stops keep their angle state either way.
  bool sensors = false;
  SourceLocation where;
};

/// Named joint kinds. `axis` is in the parent's frame; k_t, r_t (translation) and k_r, r_r
/// (rotation) apply to every coupled direction.
Joint MakeRevolute(std::string name, std::string parent, std::string child, const Eigen::Vector3d& at,
                   const Eigen::Vector3d& axis, double k_t, double r_t, double k_r, double r_r);
Joint MakeFixed(std::string name, std::string parent, std::string child, const Eigen::Vector3d& at, double k_t,
                double r_t, double k_r, double r_r);
Joint MakeSpherical(std::string name, std::string parent, std::string child, const Eigen::Vector3d& at, double k_t,
                    double r_t);
Joint MakePrismatic(std::string name, std::string parent, std::string child, const Eigen::Vector3d& at,
                    const Eigen::Vector3d& axis, double k_t, double r_t, double k_r, double r_r);

/// Cylindrical: translation and rotation perpendicular to `axis` coupled (slides along and turns
/// about it). Planar: translation along `normal` and rotation about the two in-plane axes coupled
/// (slides in the plane, turns about the normal). Screw: a cylindrical joint whose slide follows
/// the turn, s = lead / (2 pi) theta, through a coupling of k_h, r_h on the helix. Universal
/// (Cardan): translation coupled, rotation coupled about the spider's third axis only
/// (`axis` on the parent, `child_axis` on the child, perpendicular at t = 0).
Joint MakeCylindrical(std::string name, std::string parent, std::string child, const Eigen::Vector3d& at,
                      const Eigen::Vector3d& axis, double k_t, double r_t, double k_r, double r_r);
Joint MakePlanar(std::string name, std::string parent, std::string child, const Eigen::Vector3d& at,
                 const Eigen::Vector3d& normal, double k_t, double r_t, double k_r, double r_r);
Joint MakeScrew(std::string name, std::string parent, std::string child, const Eigen::Vector3d& at, const Eigen::Vector3d& axis,
                double lead, double k_t, double r_t, double k_r, double r_r, double k_h, double r_h);
Joint MakeUniversal(std::string name, std::string parent, std::string child, const Eigen::Vector3d& at,
                    const Eigen::Vector3d& axis, const Eigen::Vector3d& child_axis, double k_t, double r_t, double k_r,
                    double r_r);
/// Makes every coupling of a joint an ideal constraint (rigid), the named kinds' `rigid: true`.
void MakeRigid(Joint& j);

/// Two unit vectors orthogonal to `axis` and to each other (rows of a 2 x 3 matrix).
Eigen::Matrix<double, 2, 3> Perpendicular(const Eigen::Vector3d& axis);

/// A gear mesh: a transformer between the spins of two bodies relative to a carrier, in the
/// carrier's frame: s_i = axis_i . (R_c^T (w_i - w_c)). The mesh deflection rate
/// d = s_a + (teeth_b / teeth_a) s_b is zero when the gears roll without slip, so the axes are
/// oriented such that rolling means teeth_a s_a + teeth_b s_b = 0. A C (stiffness) and an R
/// (damping) act on d; the mesh torque acts on both gears and its reaction on the carrier.
struct GearMesh {
  std::string name;
  std::string carrier = kGround;
  std::string body_a, body_b;
  Eigen::Vector3d axis_a = Eigen::Vector3d::UnitZ(), axis_b = Eigen::Vector3d::UnitZ();  ///< carrier frame
  double teeth_a = 1.0, teeth_b = 1.0;
  double stiffness = 0.0, damping = 0.0;  ///< N m/rad, N m s/rad (referred to gear a)
  bool rigid = false;  ///< an ideal mesh: zero deflection rate, held by the mesh torque
  bool sensors = false;  ///< the mesh phase G.phase, a state (docs/mechanisms.md, "Joint sensors"); off by default
  /// Backlash (docs/events.md): the total free play of the teeth [rad, referred to gear a]; the
  /// deflection q moves freely in [-b/2, b/2]. Compliant: a dead zone in the coupling's spring,
  /// K (q - clamp(q, -b/2, b/2)). Rigid: the flanks are two contacts at q = +-b/2 with impacts of
  /// `restitution` (0: plastic, the flanks stay together until the torque reverses).
  double backlash = 0.0;
  double restitution = 0.0;
  /// Where the mesh acts (docs/mechanisms.md, "Tooth forces"). kSpin: a torque between the spins
  /// (the paper's model; the bearings carry no tooth force). kPitch: a force through the contact,
  /// the coupling acting on n . (v_pitch,a - v_pitch,b) with v_pitch = v_C + w x (R_c rho), rho the
  /// carrier-fixed arm from the gear's centre to the pitch point, n the line of action
  /// cos(helix) cos(pressure) t + sin(helix) cos(pressure) axis_a +- sin(pressure) s (t: where a's
  /// pitch point moves as a turns about its axis; s: apart, on b); both gears' bearings carry the
  /// normal force, the carrier the reaction.
  enum class Contact { kSpin, kPitch };
  Contact contact = Contact::kSpin;
  double pressure_angle = 0.0;  ///< normal pressure angle [rad] (kPitch)
  double helix_angle = 0.0;     ///< helix angle [rad] of parallel-axis gears, signed (kPitch)
  bool coast_flank = false;     ///< the line of action of the flank loaded by F_t < 0 (kPitch)
  bool internal = false;        ///< parallel axes: the gear with more teeth is a ring (internal teeth)
  bool rack_b = false;          ///< b is a rack: it translates; no axis or teeth (kPitch)
  double radius_a = 0.0;        ///< pitch radius of a [m], needed with a rack (0: from the geometry)
  std::optional<Eigen::Vector3d> pitch_point;  ///< carrier frame from its CoM (ground: absolute); default from the geometry
  SourceLocation where;
};

/// The contact geometry of a mesh at t = 0, in the carrier's frame (ground: absolute): the pitch
/// point, the arms from each gear's centre to it, the unit directions (t: where a's pitch point
/// moves as a turns positively; n: the line of the coupling; s: the separating force on b) and the
/// pitch radii. `error` is empty when the geometry is consistent (axes, radii and teeth), else it
/// says what is wrong and `hint` how to fix it.
struct MeshGeometry {
  Eigen::Vector3d point = Eigen::Vector3d::Zero(), rho_a = Eigen::Vector3d::Zero(), rho_b = Eigen::Vector3d::Zero();
  Eigen::Vector3d t = Eigen::Vector3d::Zero(), n = Eigen::Vector3d::Zero(), s = Eigen::Vector3d::Zero();
  Eigen::Vector3d radial_a = Eigen::Vector3d::Zero(), radial_b = Eigen::Vector3d::Zero();  ///< unit, from the axis to the point
  double r_a = 0.0, r_b = 0.0;
  std::string error, hint;
};

/// A drive. Velocity drives impose a flow source on a compliant coupling (the paper's drive);
/// effort drives apply a torque or force directly.
struct Drive {
  enum class Kind { kAngularVelocity, kVelocity, kTorque, kForce };
  std::string name;
  Kind kind = Kind::kAngularVelocity;
  std::string body;
  std::string reference = kGround;  ///< velocity drives: the body the velocity is relative to
  Eigen::Vector3d axis = Eigen::Vector3d::UnitX();  ///< in the reference's frame (torque/force: inertial)
  TimeFunction value;               ///< rad/s, m/s, N m or N along the axis
  /// The value as a formula of `t` and model variables (e.g. "-c*L.omega.f.z"), used instead of
  /// `value` when given. The expansion puts it into the source's `value`: a velocity drive's as
  /// it is, a torque's or force's as axis[k] * formula per component k.
  Formula formula;
  double stiffness = 0.0, damping = 0.0;  ///< velocity drives' coupling
  /// Velocity drives: an ideal drive, the source itself an ideal constraint (its flow imposed
  /// exactly, its effort the drive's reaction) instead of the coupling; `value` must be continuous
  /// and agree with the body's speed at t = 0.
  bool rigid = false;
  Eigen::Vector3d point = Eigen::Vector3d::Zero();  ///< force drives: application point (body frame)
  SourceLocation where;
};

/// A body-fixed point whose inertial position is reported: r_B + R_B at.
struct Point {
  std::string name;
  std::string body;
  Eigen::Vector3d at = Eigen::Vector3d::Zero();
  SourceLocation where;
};

class Mechanism {
 public:
  void AddBody(Body b) { bodies_.push_back(std::move(b)); }
  void AddJoint(Joint j) { joints_.push_back(std::move(j)); }
  void AddGear(GearMesh g) { gears_.push_back(std::move(g)); }
  void AddDrive(Drive d) { drives_.push_back(std::move(d)); }
  void AddPoint(Point p) { points_.push_back(std::move(p)); }
  void SetGravity(const Eigen::Vector3d& g) { gravity_ = g; }

  const std::vector<Body>& bodies() const { return bodies_; }
  const std::vector<Joint>& joints() const { return joints_; }
  const std::vector<GearMesh>& gears() const { return gears_; }
  const std::vector<Drive>& drives() const { return drives_; }
  const std::vector<Point>& points() const { return points_; }
  bool empty() const { return bodies_.empty(); }

  /// The part an expanded element belongs to, e.g. "body 'G'" for "G.inertia", "joint 'G_bearing'"
  /// for "G_bearing.r.K", "the relative rotation of 'P1' and 'A'" for "P1~A.w"; "" if none.
  std::string DescribePart(const std::string& element) const;

  /// A spanning tree of the bodies for joint coordinates: from the ground outwards, each body hangs
  /// from the joint that couples the most rotation directions, then translation directions, to a
  /// body already in the tree (the first declared among equals); its axis is that joint's free
  /// rotation axis when it couples two. Bodies that no joint reaches hang from the ground.
  JointTree MakeJointTree() const;

  /// Checks the mechanism (unknown bodies, bad parameters, couplings deflected at t = 0) into
  /// `sink`, then adds its expansion to `g`. Nothing is added if there are errors.
  void ExpandInto(BondGraph& g, DiagnosticSink& sink) const;
  /// A new graph with the expansion; throws ModelError.
  BondGraph Build(const std::string& name = "mechanism") const;
  /// The contact geometry of a mesh (kPitch) from the bodies' positions at t = 0.
  MeshGeometry GeometryOf(const GearMesh& gm) const;

  /// The bodies, to change their state at t = 0 (assembly, mech/assembly.h).
  std::vector<Body>& bodies_mutable() { return bodies_; }
  /// The joints, to put a joint's parent point onto its child's along the free directions (assembly).
  std::vector<Joint>& joints_mutable() { return joints_; }

 private:
  std::vector<Body> bodies_;
  std::vector<Joint> joints_;
  std::vector<GearMesh> gears_;
  std::vector<Drive> drives_;
  std::vector<Point> points_;
  Eigen::Vector3d gravity_ = Eigen::Vector3d::Zero();
};

}  // namespace multibond::mech
