/// \file
/// A joint's expansion: its translation and rotation couplings and its sensors.

#include "multibond/mech/expander.h"

#include <cmath>

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

bool Expander::Spins(const std::string& body) const {
  const auto it = body_by_name_.find(body);
  return it != body_by_name_.end() && it->second->mass.has_rotation();
}

bool Expander::HasIdealConstraints() const {
  for (const Joint& j : m_.joints())
    if ((j.translation && j.translation->rigid) || (j.rotation && j.rotation->rigid) || j.stops || j.friction) return true;
  for (const GearMesh& gm : m_.gears())
    if (gm.rigid) return true;
  for (const Drive& d : m_.drives())
    if (d.rigid) return true;
  return false;
}

void Expander::AddAxialSensor(const Joint& j, const std::string& rel, const std::string& domain) {
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

}  // namespace multibond::mech::detail
