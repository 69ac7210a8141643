#pragma once
/// \file
/// Reading the mechanism sections of a model file (docs/mechanisms.md): 'rigid', 'gravity',
/// 'bodies', 'joints', 'gears', 'drives' and 'points', into a mech::Mechanism that is expanded into
/// the graph being built.

#include <memory>
#include <string>
#include <unordered_map>
#include <unordered_set>
#include <vector>

#include "multibond/io/mechanism_values.h"

namespace multibond {

class MechanismReader : public MechanismValues {
 public:
  explicit MechanismReader(LoadContext& cx) : MechanismValues(cx) {}

  /// The mechanism of the model `root` (which has 'bodies'), expanded into the context's graph;
  /// nullptr if anything in it is in error (each said in the sink).
  std::shared_ptr<const mech::Mechanism> ReadMechanism(const YAML::Node& root);

 private:
  void ReadRigid(const YAML::Node& root);
  /// Whether the model's 'rigid' key names the joint or gear mesh `name` (or says 'all').
  bool RigidByModel(const std::string& name) const;
  void CheckRigidNames(const mech::Mechanism& m);
  /// False if 'bodies' is not a mapping (said).
  bool ReadBodies(const YAML::Node& root, mech::Mechanism& m);
  /// The body read as `name`, or nullptr (the ground, or no such body).
  const mech::Body* BodyOrGround(const std::string& name) const;
  void ReadJoints(const YAML::Node& joints, mech::Mechanism& m);
  /// A revolute joint's `limits: {lower, upper, restitution}` and `friction: TORQUE` (docs/events.md).
  void ReadAxialSwitches(const YAML::Node& j, const std::string& name, const std::string& type, const Eigen::Vector3d& axis,
                         mech::Joint& joint);
  void ReadGears(const YAML::Node& gears, mech::Mechanism& m);
  void ReadDrives(const YAML::Node& drives, mech::Mechanism& m);
  void ReadPoints(const YAML::Node& points, mech::Mechanism& m);

  bool rigid_all_ = false;                       ///< the model's 'rigid: all'
  std::vector<std::string> rigid_names_;         ///< the model's 'rigid: [names]'
  std::vector<SourceLocation> rigid_where_;      ///< where each of rigid_names_ is written
  std::unordered_set<std::string> rigid_set_;    ///< rigid_names_, to look up
  std::unordered_map<std::string, mech::Body> made_;  ///< the bodies read, by name
  /// The coupling section of a rigid joint that gives none.
  const YAML::Node rigid_section_ = YAML::Load("{rigid: true}");
};

}  // namespace multibond
