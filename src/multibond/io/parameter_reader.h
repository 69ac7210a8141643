#pragma once
/// \file
/// Reading the parameters of elements that are more than numbers: time functions of sources and
/// drives ({step|ramp|sine|table: ...}) and the moduli of MTF and MGY.

#include <string>

#include "multibond/io/yaml_values.h"

namespace multibond {

class ParameterReader : public ValueReader {
 public:
  using ValueReader::ValueReader;

  /// A number or one of {step: ...}, {ramp: ...}, {sine: ...}, {table: ...}.
  TimeFunction ReadTimeFunction(const YAML::Node& n, const std::string& element, const Env& env);
  /// One time function per component (a list), or one.
  SourceValue ReadSource(const YAML::Node& n, const std::string& element, const Env& env);
  /// An MTF's or MGY's modulus; rotation and lever states are named under `prefix`.
  Modulus ReadModulus(const YAML::Node& n, const std::string& element, const std::string& prefix, const Env& env);

 private:
  Eigen::MatrixXd ModulusMatrix(const YAML::Node& n, const std::string& element, const std::string& prefix, const Env& env,
                                std::vector<Formula>* entries);
  /// The rows of a modulus: a list of axes.
  Eigen::MatrixXd Selection(const YAML::Node& n, const std::string& element);
};

}  // namespace multibond
