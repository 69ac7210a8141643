#pragma once
/// \file
/// Reading the values of a model file's YAML nodes (names, words, numbers, vectors, matrices,
/// parameters, true/false), each problem reported at its place in the file. The base of every
/// section reader of the loader.

#include <string>
#include <vector>

#include <Eigen/Core>
#include <yaml-cpp/yaml.h>

#include "multibond/io/load_context.h"

namespace multibond {

class ValueReader {
 public:
  explicit ValueReader(LoadContext& cx) : cx_(cx), sink_(cx.sink), graph_(cx.graph) {}

  SourceLocation Loc(const YAML::Mark& m) const { return cx_.Loc(m); }
  SourceLocation Loc(const YAML::Node& n) const { return cx_.Loc(n); }

  /// A name of the identifier grammar (core/identifier.h); else reports it (name.invalid) and
  /// returns false. `names_columns`: the name heads result columns, so 'time' and 'energy' are taken.
  bool CheckName(const std::string& name, const SourceLocation& where, const char* what, bool names_columns = true);
  /// A list of component names (identifiers, a leading digit allowed).
  std::vector<std::string> Components(const YAML::Node& n, const std::string& element);
  /// Reports every key of the mapping `map` that is not `allowed`, with a did-you-mean.
  void CheckKeys(const YAML::Node& map, const std::vector<std::string>& allowed, const std::string& element);
  /// What a node is, for messages: "a list", "nothing", "'word'"...
  static std::string Describe(const YAML::Node& n);
  /// A list of words (component names, ports); anything else is reported.
  std::vector<std::string> Words(const YAML::Node& n, const std::string& element, const char* what);
  std::string Str(const YAML::Node& n, const std::string& element);
  /// A known domain ("" for generic).
  std::string Domain(const YAML::Node& n, const std::string& element);
  /// A finite, normal number, or a $parameter of `env`; 0 and *ok = false after a reported problem.
  double Number(const YAML::Node& n, const std::string& element, const Env& env, bool* ok = nullptr);
  Eigen::VectorXd Vector(const YAML::Node& n, const std::string& element, const Env& env);
  Eigen::MatrixXd Matrix(const YAML::Node& n, const std::string& element, const Env& env);
  /// A scalar, a diagonal given as a list, or a full matrix.
  Param ReadParam(const YAML::Node& n, const std::string& element, const Env& env);
  bool Bool(const YAML::Node& n, const std::string& element);
  /// "prefix.local" ("local" without a prefix).
  static std::string Qualify(const std::string& prefix, const std::string& local);

 protected:
  LoadContext& cx_;
  DiagnosticSink& sink_;
  BondGraph& graph_;
};

}  // namespace multibond
