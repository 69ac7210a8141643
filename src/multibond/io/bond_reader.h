#pragma once
/// \file
/// Reading one bond of a 'bonds' section ('from -> to', [from, to] or {from, to, name, dim}) into
/// the graph, its ends resolved in the scope it is written in.

#include <string>

#include "multibond/io/yaml_values.h"

namespace multibond {

class BondReader : public ValueReader {
 public:
  using ValueReader::ValueReader;

  /// Connects the bond `b` of the scope `prefix` (a submodel instance's, or "" for the model).
  void ReadBond(const YAML::Node& b, const std::string& prefix, const Env& env);

 private:
  /// Resolves a bond end: a local name in this scope, or "instance.port" of a submodel instance.
  std::string Endpoint(const std::string& local, const std::string& prefix, const YAML::Node& at);
};

}  // namespace multibond
