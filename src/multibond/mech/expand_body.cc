/// \file
/// A body's expansion (momenta, orientation and position states, gravity) and its outputs.

#include "multibond/mech/expander.h"

#include <cmath>

#include <fmt/format.h>

namespace multibond::mech::detail {

Element Expander::Make(const std::string& name, ElementKind kind, int dim, const std::string& domain, const SourceLocation& where) {
  Element e;
  e.name = name;
  e.kind = kind;
  e.dim = dim;
  e.domain = domain;
  e.where = where;
  return e;
}

void Expander::AddBody(const Body& b) {
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
  r.unit = std::string("m");  // the literal trips GCC 12's false -Wrestrict (GCC bug 105651)
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

OutputDecl Expander::SumOutput(const std::string& name, std::vector<std::pair<std::string, double>> terms, const std::string& unit,
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

void Expander::AddPointOutput(const Point& p) {
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

void Expander::AddBodyOutputs(const Body& b) {
  const BodyInfo& info = info_.at(b.name);
  AddVariableOutput(b.name + ".v", b.name + ".v.f", "", b.where);
  // A body with no coupling still gets F (and M) columns, identically zero.
  auto terms_or_zero = [&](std::vector<std::pair<std::string, double>> t, const std::string& junction) {
    if (t.empty()) t.push_back({junction + ".f", 0.0});
    return t;
  };
  AddOutput(SumOutput(b.name + ".F", terms_or_zero(info.force_terms, b.name + ".v"), "N", b.where));
  if (b.mass.has_rotation()) {
    AddVariableOutput(b.name + ".omega", b.name + ".omega.f", "", b.where);
    AddOutput(SumOutput(b.name + ".M", terms_or_zero(info.moment_terms, b.name + ".omega"), "N m", b.where));
    OutputDecl orth;
    orth.kind = OutputDecl::Kind::kOrthonormality;
    orth.name = b.name + ".orthonormality";
    orth.rotation = b.name + ".R";
    orth.where = b.where;
    AddOutput(orth);
  }
}

}  // namespace multibond::mech::detail
