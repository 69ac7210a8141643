/// \file
/// Switching elements: the end stops and friction of revolute and prismatic joints, gear backlash contacts.

#include "multibond/mech/expander.h"

#include <cmath>

#include <fmt/format.h>

#include "multibond/core/expression.h"

namespace multibond::mech::detail {

void Expander::AddAxialSwitches(const Joint& j) {
  // A revolute joint's turn (rad, N m) or a prismatic joint's slide (m, N) along its free axis.
  const bool slide = Slides(j);
  const std::string domain = slide ? "translation" : "rotation";
  const std::string axial = j.name + ".axial";  // made by AddAxialSensor
  if (j.stops) {
    const std::string q = j.name + (slide ? ".slide" : ".angle");
    for (const bool lower : {true, false}) {
      const std::string stop = j.name + (lower ? ".lower" : ".upper");
      Element c = MakeContact(stop, domain, q, lower ? 1.0 : -1.0, lower ? -j.stops->lower : j.stops->upper, j.stops->restitution,
                              j.stops->where);
      c.switching.limit = true;
      g_.Add(c);
      if (lower) Bond(stop, axial, stop);  // its flow is the rate: q leaves the lower stop as it grows
      else Bond(axial, stop, stop);
    }
  }
  if (j.friction) {
    Element f = Make(j.name + ".friction", ElementKind::kSf, 1, domain, j.friction->where);
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

Formula Expander::LawOf(const std::string& text, const SourceLocation& where) {
  expr::ParseResult parsed = expr::Parse(text);
  MB_ASSERT(parsed.root != nullptr, "a formula of the mechanism expansion does not parse: " + text);
  return Formula{text, parsed.root, where};
}

std::string Expander::AddAngle(const std::string& name, const std::string& of, const SourceLocation& where, const std::string& unit) {
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

Element Expander::MakeContact(const std::string& name, const std::string& domain, const std::string& gap, double scale, double offset,
                              double restitution, const SourceLocation& where) {
  Element c = Make(name, ElementKind::kSf, 1, domain, where);
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

void Expander::AddBacklashContacts(const std::string& from, const GearMesh& gm, double arm, const std::string& domain) {
  const std::string name = gm.name + ".mesh";
  g_.Add(Make(name, ElementKind::kOne, 1, domain, gm.where));
  Bond(from, name, name + ".in");
  const std::string q = AddAngle(name + ".q", name, gm.where, arm != 1.0 ? "m" : "rad");
  const double h = gm.backlash / 2 * arm;
  for (const bool positive : {true, false}) {
    const std::string flank = name + (positive ? ".flank_pos" : ".flank_neg");
    // gap h - q (the positive flank) or q + h
    Element c = MakeContact(flank, domain, q, positive ? -1.0 : 1.0, h, gm.restitution, gm.where);
    // The mesh's K, if given, shares a load with redundant constraints as the rigid mesh's would.
    if (gm.stiffness > 0.0 && std::isfinite(gm.stiffness)) c.compliance = Eigen::VectorXd::Constant(1, arm * arm / gm.stiffness);
    g_.Add(c);
    if (positive) Bond(name, flank, flank);  // its flow is -d: the flanks part as q falls
    else Bond(flank, name, flank);
  }
}

}  // namespace multibond::mech::detail
