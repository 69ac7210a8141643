#pragma once
/// \file
/// Reading the 'states' section (orientation and integral states) and the 'outputs' section.

#include <string>

#include "multibond/io/yaml_values.h"

namespace multibond {

class StatesOutputsReader : public ValueReader {
 public:
  using ValueReader::ValueReader;

  /// The states of the scope `prefix` (a submodel instance's, or "" for the model).
  void ReadStates(const YAML::Node& n, const std::string& prefix, const Env& env);
  /// The model's outputs.
  void ReadOutputs(const YAML::Node& n);
};

}  // namespace multibond
