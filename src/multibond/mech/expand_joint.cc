/// \file
/// A joint's expansion: its translation and rotation couplings and its sensors.

#include "multibond/core/diagnostic_codes.h"
#include "multibond/mech/expander.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include <fmt/format.h>

namespace multibond::mech::detail {

void Expander::AddJoint(const Joint& j) {
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
    if (SlideSensed(j) || SlidesAndTurns(j) || SlidesInPlane(j)) {
      // The relative velocity of the joint's points, a 1-junction the slide sensor also reads.
      const std::string rel = j.name + ".t_rel";
      Element r = Make(rel, ElementKind::kOne, 3, "translation", j.where);
      r.components = kXyz;
      g_.Add(r);
      Bond(sum, rel, rel);
      Bond(rel, j.name + ".t_frame", j.name + ".t_frame");
      if (SlidesInPlane(j)) AddPlaneSensor(j, rel);
      else AddAxialSensor(j, rel, "translation", Slides(j) ? std::string() : j.name + ".t_axial");
    } else {
      Bond(sum, j.name + ".t_frame", j.name + ".t_frame");
    }
    AddCompliance(j.name + ".t_frame", j.name + ".t", c.stiffness, c.damping, "translation", DirectionNames(c), j.where,
                  c.rigid);
    AddOutput(SumOutput(j.name + ".F", {{j.name + ".t_child.e", -1.0}}, "N", j.where));
  }
  if (j.rotation && j.kind == "universal") {
    AddUniversalRotation(j);
  } else if (j.rotation) {
    const Coupling& c = *j.rotation;
    const std::string rel = RelativeOmega(j.child, j.parent);
    AddFrameElement(j.name + ".r_frame", c.frame, j.parent, j.child, c.directions, j.where);
    Bond(rel, j.name + ".r_frame", j.name + ".r_in");
    if (IsGround(j.parent)) info_[j.child].moment_terms.push_back({j.name + ".r_in.e", -1.0});
    AddCompliance(j.name + ".r_frame", j.name + ".r", c.stiffness, c.damping, "rotation", DirectionNames(c), j.where,
                  c.rigid);
    std::vector<std::pair<std::string, double>> moment = {{j.name + ".r_in.e", -1.0}};
    // The helix's torque on the child, or the stops' and the friction's couple about the free
    // axis: the joint's moment is all it exerts, not its coupling's alone.
    if (j.helix || (Turns(j) && (j.stops || j.friction))) moment.push_back({j.name + ".axial.in.e", -1.0});
    AddOutput(SumOutput(j.name + ".M", std::move(moment), "N m", j.where));
  }
  if (Turns(j)) AddAxialSensor(j, RelativeOmega(j.child, j.parent), "rotation");
  if (j.helix) AddHelix(j);
  if (j.kind == "universal" && j.sensors) AddUniversalSensors(j);
  if (j.sensors && (j.kind == "coupling" || j.kind == "spherical") && Spins(j.child) && (IsGround(j.parent) || Spins(j.parent)))
    AddRotationSensor(j);
  if (j.stops || j.friction) AddAxialSwitches(j);
}

void Expander::AddRotationSensor(const Joint& j) {
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
    AddVariableOutput(j.name + ".rotation." + component, sg.name, "rad", j.where);
  };
  signal("angle", fmt::format("atan2({0}, {1}.11 + {1}.22 + {1}.33 - 1)", norm, q));
  const char* axes[] = {"x", "y", "z"};
  const std::string v[] = {vx, vy, vz};
  for (int k = 0; k < 3; ++k)  // theta v / |v|; 0 where v = 0 (no rotation)
    signal(axes[k], fmt::format("{} * {} / ({} + 1e-300)", angle, v[k], norm));
}

bool Expander::Spins(const std::string& body) const {
  const auto it = body_by_name_.find(body);
  return it != body_by_name_.end() && it->second->mass.has_rotation();
}

bool Expander::HasIdealConstraints() const {
  for (const Joint& j : m_.joints())
    if ((j.translation && j.translation->rigid) || (j.rotation && j.rotation->rigid) || (j.helix && j.helix->rigid) || j.stops ||
        j.friction)
      return true;
  for (const GearMesh& gm : m_.gears())
    if (gm.rigid) return true;
  for (const Drive& d : m_.drives())
    if (d.rigid) return true;
  return false;
}

void Expander::AddAxialSensor(const Joint& j, const std::string& rel, const std::string& domain, const std::string& junction) {
  const bool rotation = domain == "rotation";
  const std::string axial = junction.empty() ? j.name + ".axial" : junction;
  AddSpin(axial + "_proj", j.parent, j.axis, 1.0);
  Bond(rel, axial + "_proj", axial + ".in");
  if (rotation && IsGround(j.parent)) info_[j.child].moment_terms.push_back({axial + ".in.e", -1.0});
  g_.Add(Make(axial, ElementKind::kOne, 1, domain, j.where));
  Bond(axial + "_proj", axial, axial + ".out");
  if (j.sensors || j.stops) AddAngle(j.name + (rotation ? ".angle" : ".slide"), axial, j.where, rotation ? "rad" : "m");
  if (!j.sensors) return;
  AddVariableOutput(j.name + (rotation ? ".rate" : ".speed"), axial + ".f", rotation ? "rad/s" : "m/s", j.where);
}

void Expander::AddPlaneSensor(const Joint& j, const std::string& rel) {
  const std::string axial = j.name + ".t_axial";
  AddFrameElement(axial + "_proj", Coupling::Frame::kParent, j.parent, j.child, Perpendicular(j.axis), j.where);
  Bond(rel, axial + "_proj", axial + ".in");
  Element junction = Make(axial, ElementKind::kOne, 2, "translation", j.where);
  junction.components = {"u", "v"};
  g_.Add(junction);
  Bond(axial + "_proj", axial, axial + ".out");
  AuxState a;
  a.name = j.name + ".slide";
  a.kind = AuxState::Kind::kIntegral;
  a.of = axial;
  a.unit = std::string("m");  // the literal trips GCC 12's false -Wrestrict (GCC bug 105651)
  a.initial = Eigen::MatrixXd::Zero(2, 1);
  a.components = {"u", "v"};
  a.where = j.where;
  g_.AddAux(a);
  AddVariableOutput(j.name + ".speed", axial + ".f", "m/s", j.where);
}

void Expander::AddUniversalRotation(const Joint& j) {
  const Coupling& c = *j.rotation;
  const std::string rel = RelativeOmega(j.child, j.parent);
  // (R_p a1) . (w x R_c a2) = -n . w: the lever's scale -1 makes the flow n . w.
  Modulus lever;
  lever.kind = Modulus::Kind::kLever;
  lever.rotation = j.child + ".R";
  lever.lever = j.child_axis.normalized();
  lever.scale = -1.0;
  Element arm = Make(j.name + ".r_lever", ElementKind::kMTF, 0, "", j.where);
  arm.modulus = lever;
  g_.Add(arm);
  Element cross = Make(j.name + ".r_cross", ElementKind::kOne, 3, "rotation", j.where);
  cross.components = kXyz;
  g_.Add(cross);
  AddSpin(j.name + ".r_frame", j.parent, j.axis, 1.0);
  Bond(rel, j.name + ".r_lever", j.name + ".r_in");
  Bond(j.name + ".r_lever", j.name + ".r_cross", j.name + ".r_cross");
  Bond(j.name + ".r_cross", j.name + ".r_frame", j.name + ".r_proj");
  if (IsGround(j.parent)) info_[j.child].moment_terms.push_back({j.name + ".r_in.e", -1.0});
  AddCompliance(j.name + ".r_frame", j.name + ".r", c.stiffness, c.damping, "rotation", {}, j.where, c.rigid);
  AddOutput(SumOutput(j.name + ".M", {{j.name + ".r_in.e", -1.0}}, "N m", j.where));
}

void Expander::AddUniversalSensors(const Joint& j) {
  const std::string rel = RelativeOmega(j.child, j.parent);
  // theta_a' = a1 . R_p^T (w_c - w_p) and theta_b' = a2 . R_c^T (w_c - w_p): the relative rotation
  // is Rot(a1, theta_a) Rot(a2, theta_b) and a1 stays perpendicular to R_c a2.
  const std::pair<const char*, const std::string*> sides[] = {{"a", &j.parent}, {"b", &j.child}};
  for (const auto& [side, body] : sides) {
    const std::string axial = fmt::format("{}.axial_{}", j.name, side);
    AddSpin(axial + "_proj", *body, *body == j.parent ? j.axis : j.child_axis, 1.0);
    Bond(rel, axial + "_proj", axial + ".in");
    if (IsGround(j.parent)) info_[j.child].moment_terms.push_back({axial + ".in.e", -1.0});
    g_.Add(Make(axial, ElementKind::kOne, 1, "rotation", j.where));
    Bond(axial + "_proj", axial, axial + ".out");
    AddAngle(fmt::format("{}.angle_{}", j.name, side), axial, j.where);
    AddVariableOutput(fmt::format("{}.rate_{}", j.name, side), axial + ".f", "rad/s", j.where);
  }
}

void Expander::AddHelix(const Joint& j) {
  const Coupling& c = *j.helix;
  const std::string sum = j.name + ".helix", lead = j.name + ".helix_lead";
  g_.AddJunction(sum, ElementKind::kZero, 1);
  Element tf = Make(lead, ElementKind::kTF, 0, "", j.where);
  tf.param = Param::Scalar(-j.lead / (2.0 * std::numbers::pi));
  g_.Add(tf);
  Bond(j.name + ".t_axial", sum, sum + ".slide");
  Bond(j.name + ".axial", lead, lead + ".in");
  Bond(lead, sum, lead + ".out");
  AddCompliance(sum, j.name + ".h", c.stiffness, c.damping, "translation", {}, j.where, c.rigid);
  AddVariableOutput(j.name + ".helix_force", sum + ".e", "N", j.where);
}

void Expander::CheckJointKind(const Joint& j) {
  if (j.kind == "universal") {
    if (j.axis.norm() < 1e-12 || j.child_axis.norm() < 1e-12) {
      sink_.Error(codes::kMechJointAxis, j.where, j.name, "a universal joint needs two non-zero yoke axes",
                  "give 'axis' (on the parent, its frame) and 'child_axis' (on the child, its frame)");
      return;
    }
    if (j.rotation && j.rotation->directions.rows() != 1)
      sink_.Error(codes::kMechCoupling, j.where, j.name, "a universal joint's rotation coupling has one direction, the spider's third axis",
                  "give one stiffness and damping (MakeUniversal)");
    auto orientation = [&](const std::string& n) -> Eigen::Matrix3d {
      const Body* b = IsGround(n) ? nullptr : FindBody(n);
      return b ? b->orientation : Eigen::Matrix3d::Identity();
    };
    const Eigen::Vector3d a1 = orientation(j.parent) * j.axis.normalized(), a2 = orientation(j.child) * j.child_axis.normalized();
    if (std::abs(a1.dot(a2)) > 1e-6)
      sink_.Error(codes::kMechJointAxis, j.where, j.name,
                  fmt::format("the yoke axes of a universal joint are perpendicular, but 'axis' and 'child_axis' are {:.6g} degrees "
                              "apart at t = 0",
                              std::acos(std::clamp(a1.dot(a2), -1.0, 1.0)) * 180.0 / std::numbers::pi),
                  "give 'child_axis' in the child's frame, perpendicular to the parent's 'axis' as the bodies start");
  }
  if ((j.kind == "screw" || j.helix) && (!j.translation || !j.rotation || j.axis.isZero()))
    sink_.Error(codes::kMechCoupling, j.where, j.name, "a screw joint is a cylindrical joint with a helix: it needs its axis, translation and rotation",
                "use MakeScrew, or type: screw with 'axis'");
  if (j.kind == "screw" || j.helix) {
    if (!(std::isfinite(j.lead) && j.lead != 0.0))
      sink_.Error(codes::kParamRange, j.where, j.name, fmt::format("a screw's lead must be a non-zero length per turn (got {:g})", j.lead),
                  "give 'pitch' (or 'lead'), the advance per turn [m]; negative for a left-hand thread");
    if (!j.helix) {
      sink_.Error(codes::kMechCoupling, j.where, j.name, "a screw joint needs its helix coupling", "give 'helix: {K: ..., R: ...}' or 'rigid: true'");
    } else if (!j.helix->rigid && (j.helix->stiffness.size() != 1 || !(j.helix->stiffness[0] > 0) || j.helix->damping.size() != 1 ||
                                   !(j.helix->damping[0] >= 0))) {
      sink_.Error(codes::kParamRange, j.where, j.name, "the helix coupling needs a stiffness > 0 and a damping >= 0",
                  "give 'helix: {K: ..., R: ...}' (N/m and N s/m along the axis), or 'rigid: true'");
    }
  }
}

}  // namespace multibond::mech::detail
