#pragma once
/// \file
/// Reading the values of the mechanism sections (docs/mechanisms.md): 3-vectors, axes, directions,
/// orientations, the couplings of joints ({K, R, directions, frame, rigid}) and mass properties.

#include <optional>
#include <string>
#include <vector>

#include "multibond/io/parameter_reader.h"
#include "multibond/mech/mechanism.h"

namespace multibond {

class MechanismValues : public ParameterReader {
 public:
  using ParameterReader::ParameterReader;

  Eigen::Vector3d Vec3(const YAML::Node& n, const std::string& element);
  /// "x", "-z" or a 3-vector (normalised).
  Eigen::Vector3d Axis(const YAML::Node& n, const std::string& element);
  /// Rows of unit vectors: "all", a list of axes, or a matrix; their names into `names` if named.
  Eigen::MatrixXd Directions(const YAML::Node& n, const std::string& element, std::vector<std::string>* names);
  /// A 3x3 rotation matrix or {axis, angle | degrees}.
  Eigen::Matrix3d Orientation(const YAML::Node& n, const std::string& element);
  /// K (required unless `rigid`) and R of a coupling, one value or one per direction.
  void Gains(const YAML::Node& n, const std::string& element, int k, Eigen::VectorXd* stiff, Eigen::VectorXd* damp,
             bool rigid = false);
  mech::Coupling::Frame Frame(const YAML::Node& n, const std::string& element, mech::Coupling::Frame dflt);
  /// A coupling section: {K, R, directions|axes, frame}. `fixed_rows` (named kinds) gives the
  /// directions; otherwise they are read (default: all three). Rigid if it says so or rigid_joint_.
  std::optional<mech::Coupling> ReadCoupling(const YAML::Node& n, const std::string& element, const char* what,
                                             const Eigen::MatrixXd* fixed_rows, mech::Coupling::Frame frame);
  /// A body's mass and inertia: from shape and density, or given.
  mech::MassProperties Mass(const YAML::Node& b, const std::string& name);

 protected:
  bool rigid_joint_ = false;  ///< the joint being read is rigid (its couplings default to rigid)
};

}  // namespace multibond
