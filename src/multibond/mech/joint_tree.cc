/// \file
/// The spanning tree of a mechanism's bodies for joint coordinates.

#include <cmath>
#include <map>
#include <set>
#include <tuple>

#include "multibond/mech/mechanism.h"

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
      } else if (j->kind == "universal") {
        // Two free turns, about the yokes (the relative rotation is Rot(a1, theta_a) Rot(a2,
        // theta_b)): the body's axis is the yoke it starts turning about, the other's angle is
        // the rotation off it; at rest, the parent's yoke. Not the initial spin's direction: off
        // both yokes it is no direction the joint lets the body keep turning about.
        const Eigen::Vector3d a1 = (orientation(j->parent) * j->axis).normalized();
        const Eigen::Vector3d a2 = (orientation(j->child) * j->child_axis).normalized();
        const Eigen::Vector3d spin = omega(name) - omega(parent);
        axis_world = std::abs(spin.dot(a2)) > std::abs(spin.dot(a1)) ? a2 : a1;
      }
    }
    tb.bearing = axis_world.norm() > 1e-12;
    if (!tb.bearing) axis_world = omega(name) - omega(parent);  // no bearing: how it turns at the start
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
