#pragma once
/// \file
/// Reading the values of a model file's YAML nodes (names, words, numbers, vectors, matrices,
/// parameters, true/false, formulas), each problem reported at its place in the file. The base of
/// every section reader of the loader.
///
/// A number may be written as a formula of the model's parameters (docs/model-format.md,
/// "Expressions"): `1/12`, "2*pi*f0". It is evaluated where it is read; a problem in it is
/// reported at the character of the formula where it is. Formulas that may change in time (laws,
/// signals, a state's rate) are read as trees by ReadFormula (formula_values.cc).

#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <yaml-cpp/yaml.h>

#include "multibond/io/load_context.h"

namespace multibond {

/// What the names of a formula that may change in time lead to, besides the parameters: the
/// parameters of the submodel being expanded, its instance's prefix (names of elements and states
/// in the formula are local to it), and the names of the element's own variables in its law.
struct FormulaScope {
  const Env* env = nullptr;      ///< the submodel's parameters (shadowing the model's)
  std::string prefix;            ///< the instance ("" at the top level)
  std::vector<std::string> own;  ///< e.g. {"q"} in a C's effort law; empty outside laws
  std::string what;              ///< what the formula is, for messages: "C effort law", "signal"
};

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
  /// A finite, normal number, a $parameter of `env`, or a formula of parameters (those of `env` and
  /// the model's); 0 and *ok = false after a reported problem.
  double Number(const YAML::Node& n, const std::string& element, const Env& env, bool* ok = nullptr);
  /// A formula that may name time and model variables (a law, a source's value, a signal, a
  /// state's rate or input): parsed, every parameter replaced by its value, and names of elements
  /// and states qualified by the scope's prefix. nullopt after a reported problem.
  std::optional<Formula> ReadFormula(const YAML::Node& n, const std::string& element, const FormulaScope& scope);
  /// The value of a formula that names nothing but `pi` (its parameters replaced), else nullopt.
  static std::optional<double> ConstantValue(const Formula& f);
  /// A plain number (YAML's .nan and .inf included: refused as numbers), a submodel's $parameter
  /// or no scalar at all: not a formula.
  static bool IsPlainValue(const YAML::Node& n);
  /// file:line:column of the character at `offset` of a scalar's text (past an opening quote).
  SourceLocation At(const YAML::Node& n, int offset) const;
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
  /// The hint of a formula that names time or a variable where a constant is needed: the keys
  /// of the element being read that take a law ("" = the general hint).
  std::string law_keys_hint_;
  /// What a constant being read is, where a formula that names time or a variable is more
  /// helpfully said so than in general: the message then starts with it (e.g. "an initial value
  /// is a constant: a number or a formula of parameters"); "" = the general message.
  std::string constant_rule_;

  /// Parses `text`, the scalar `n`; reports a syntax error at its character. `number`: a number
  /// was expected there (the message says so). Null after a reported problem.
  expr::NodePtr Parse(const YAML::Node& n, const std::string& text, const std::string& element, bool number);
  /// Reports the name `id` of a formula that is neither a parameter nor a variable there.
  void UnknownName(const YAML::Node& n, const expr::Node& name, const std::string& element, const std::vector<std::string>& more,
                   const std::string& own_hint);

 private:
  /// The formula of a number (not a plain number): parsed and evaluated with the parameters.
  double Constant(const YAML::Node& n, const std::string& text, const std::string& element, const Env& env, bool* ok);
};

}  // namespace multibond
