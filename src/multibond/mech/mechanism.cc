#include "multibond/mech/mechanism.h"

#include <fmt/format.h>

#include "multibond/mech/expander.h"

namespace multibond::mech {

namespace detail {

void Expander::Run() {
  Validate();
  if (sink_.has_errors()) return;
  for (const Body& b : m_.bodies()) AddBody(b);
  for (const Joint& j : m_.joints()) AddJoint(j);
  for (const GearMesh& gm : m_.gears()) AddGear(gm);
  for (const Drive& d : m_.drives()) AddDrive(d);
  for (const Point& p : m_.points()) AddPointOutput(p);
  for (const Body& b : m_.bodies()) AddBodyOutputs(b);
}

}  // namespace detail

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
  // Room for what the parts usually add (a body 5 elements, a revolute joint 13: a chain of
  // bodies on joints 18 per body), so that the lists do not grow step by step.
  const auto n = [](const auto& parts, int per) { return static_cast<int>(parts.size()) * per; };
  g.Reserve(g.num_elements() + n(bodies_, 6) + n(joints_, 14) + n(gears_, 20) + n(drives_, 6) + n(points_, 2),
            g.num_bonds() + n(bodies_, 7) + n(joints_, 16) + n(gears_, 22) + n(drives_, 6) + n(points_, 2));
  detail::Expander e(*this, g, sink);
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
