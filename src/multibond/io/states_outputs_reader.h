#pragma once
/// \file
/// Reading the 'states' section (orientation, integral, lag and PID states), the 'outputs' section
/// and the 'signals' section.

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
  /// The model's signals (top level only), after its elements and states.
  void ReadSignals(const YAML::Node& n);

 private:
  /// False, after saying so, when a state's or signal's `name` is a parameter's (or, for a
  /// signal, an element's or state's; for a state, a signal's): formulas name them bare.
  bool NameIsFree(const std::string& name, const SourceLocation& where, const char* what);
};

}  // namespace multibond
