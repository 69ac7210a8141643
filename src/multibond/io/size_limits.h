#pragma once
/// \file
/// The size of the model against InputLimits (instances, depth, elements, bonds): once before any
/// submodel is expanded (counted from the definitions: an exponential nest is refused in
/// microseconds), once of the expanded graph. Each exceeded limit is a "limit.<name>" diagnostic.

#include <cstdint>
#include <string>

#include "multibond/io/yaml_values.h"

namespace multibond {

class SizeLimits : public ValueReader {
 public:
  using ValueReader::ValueReader;

  /// Counts what the model's submodels expand to, before any is expanded. False if a limit is exceeded.
  bool CheckExpansion(const YAML::Node& root);
  /// The expanded graph (mechanism parts included) within the element and bond limits.
  void CheckGraphSize(const YAML::Node& root);

 private:
  void LimitError(const char* name, const SourceLocation& where, std::uint64_t found, std::uint64_t limit, const std::string& what);
};

}  // namespace multibond
