#pragma once
/// \file
/// The top-level 'parameters' section: each parameter a number or a formula of the others (in any
/// order in the file), given a unit and a description if wanted; values from outside the file
/// (--set, the API) replace the file's; all are evaluated in the order of their dependencies.

#include <vector>

#include "multibond/io/yaml_values.h"

namespace multibond {

class ModelParametersReader : public ValueReader {
 public:
  using ValueReader::ValueReader;

  /// Reads `n` (the section; may be undefined) into the context's parameters, with `overrides`
  /// over the file's values. A problem of the file is reported; a problem of an override (a name
  /// the file does not have, a value that does not read, a cycle through it) is thrown as
  /// std::invalid_argument: it is the caller's input, not the file's.
  void Read(const YAML::Node& n, const std::vector<ParameterOverride>& overrides);
};

}  // namespace multibond
