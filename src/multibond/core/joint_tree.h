#pragma once
/// \file
/// A spanning tree of a mechanism's bodies, for integrating their motion in joint (relative)
/// coordinates: each body's orientation and position measured relative to its tree parent, so
/// that a body turning steadily about a bearing has states that grow linearly or stay constant
/// (an angle, its rate), not the sines and cosines of its inertial-frame orientation matrix and
/// momenta. The mechanism library builds the tree from its joints (mech::Mechanism::MakeJointTree);
/// the simulator changes variables with it (sim/joint_coordinates.h). docs/design.md, "Joint
/// coordinates".

#include <string>
#include <vector>

#include <Eigen/Dense>

namespace multibond {

struct TreeBody {
  /// The body: its states are <name>.R (orientation, absent for a point mass), <name>.r (centre
  /// of mass), <name>.p (translational momentum), <name>.h (angular momentum).
  std::string name;
  std::string parent;  ///< a body before it in the tree, or "" for the ground
  /// The point of the body (body frame, from its centre of mass) whose position relative to the
  /// parent is a state: the tree joint's point, which a bearing keeps fixed in the parent.
  Eigen::Vector3d anchor = Eigen::Vector3d::Zero();
  /// The expected axis of the body's rotation relative to its parent, in the parent's frame at
  /// t = 0 (unit): the angle about it is one state, the small rotation off it two others.
  Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();
  /// The axis is a joint's free turn (a bearing: the joint couples the rotation about the two
  /// directions across it; or a universal joint's yoke), which the body keeps whatever its
  /// inertia: it is not moved to a nearby principal axis, as a free body's initial spin is.
  bool bearing = false;
  /// Which joint made the edge (for reports), "" when none does (the body hangs from the ground).
  std::string joint;
};

/// Parents before children.
using JointTree = std::vector<TreeBody>;

}  // namespace multibond
