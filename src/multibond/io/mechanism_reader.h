#pragma once
/// \file
/// Reading the mechanism sections of a model file (docs/mechanisms.md): 'rigid', 'sensors', 'gravity',
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
  /// A model-wide key that names joints and gear meshes: 'all' or a list of their names ('rigid', 'sensors').
  struct PartList {
    explicit PartList(std::string k) : key(std::move(k)) {}
    std::string key;
    bool all = false;
    std::vector<std::string> names;
    std::vector<SourceLocation> where;  ///< where each of names is written
    std::unordered_set<std::string> set;  ///< names, to look up
    /// Whether the key names the joint or gear mesh `name` (or says 'all').
    bool Has(const std::string& name) const { return all || set.count(name) > 0; }
  };
  void ReadPartList(const YAML::Node& root, PartList& list);
  /// Whether the model's 'rigid' key names the joint or gear mesh `name` (or says 'all').
  bool RigidByModel(const std::string& name) const { return rigid_.Has(name); }
  void CheckPartNames(const mech::Mechanism& m, const PartList& list);
  /// False if 'bodies' is not a mapping (said).
  bool ReadBodies(const YAML::Node& root, mech::Mechanism& m);
  /// The body read as `name`, or nullptr (the ground, or no such body).
  const mech::Body* BodyOrGround(const std::string& name) const;
  void ReadJoints(const YAML::Node& joints, mech::Mechanism& m);
  /// The joint kinds cylindrical, planar, screw and universal (docs/mechanisms.md, "Joints"): their
  /// axes (`axis`: the axis, or the planar joint's normal, as read; null if not given) and
  /// couplings into `joint`.
  void ReadJointKind(const YAML::Node& j, const std::string& name, const std::string& type, const Eigen::Vector3d* axis,
                     mech::Joint& joint);
  /// A revolute or prismatic joint's `limits: {lower, upper, restitution}` (rad or m) and
  /// `friction: TORQUE` (N m) or `friction: FORCE` (N) (docs/events.md).
  void ReadAxialSwitches(const YAML::Node& j, const std::string& name, const std::string& type, const Eigen::Vector3d& axis,
                         mech::Joint& joint);
  void ReadGears(const YAML::Node& gears, mech::Mechanism& m);
  void ReadDrives(const YAML::Node& drives, mech::Mechanism& m);
  void ReadPoints(const YAML::Node& points, mech::Mechanism& m);

  PartList rigid_{"rigid"};      ///< the model's 'rigid: all | [names]'
  PartList sensors_{"sensors"};  ///< the model's 'sensors: all | [names]' (docs/mechanisms.md, "Joint sensors")
  std::unordered_map<std::string, mech::Body> made_;  ///< the bodies read, by name
  /// The coupling section of a rigid joint that gives none.
  const YAML::Node rigid_section_ = YAML::Load("{rigid: true}");
};

}  // namespace multibond
