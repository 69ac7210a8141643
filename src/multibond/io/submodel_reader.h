#pragma once
/// \file
/// Submodels: the 'submodels' definitions, and reading a scope (the model's top level, or one
/// instance of a definition under its name): its elements, states and bonds, each instance
/// expanded in place with its parameters.

#include <string>

#include "multibond/io/yaml_values.h"

namespace multibond {

class SubmodelReader : public ValueReader {
 public:
  using ValueReader::ValueReader;

  /// The 'submodels' section, into the context's definitions.
  void ReadSubmodelDefs(const YAML::Node& n);
  /// Reads the elements, bonds and states of a model or of a submodel instance under `prefix`;
  /// `depth`: how many instances this scope is nested in.
  void ReadScope(const YAML::Node& scope, const std::string& prefix, const Env& env, int depth);

 private:
  /// The instance `name` of the submodel `type`, its parameters given in `spec` (else their defaults).
  void Instantiate(const std::string& name, const std::string& type, const YAML::Node& spec, const SourceLocation& where,
                   const Env& outer, int depth);
  void InstantiateBody(const std::string& name, const std::string& type, const YAML::Node& spec, const SourceLocation& where,
                       const Env& outer, int depth);
};

}  // namespace multibond
