#pragma once
/// \file
/// Reading one element of an 'elements' section (Se, Sf, I, C, R, TF, MTF, GY, MGY, 0, 1) with its
/// parameters into the graph; a submodel instance is read by SubmodelReader instead.

#include <string>

#include "multibond/io/parameter_reader.h"

namespace multibond {

class ElementReader : public ParameterReader {
 public:
  using ParameterReader::ParameterReader;

  /// Adds the element `name` (qualified), written at `where` as `spec`, to the graph; state names
  /// in its parameters are qualified by `prefix`, $parameters read from `env`.
  void ReadElement(const std::string& name, const YAML::Node& spec, const SourceLocation& where, const std::string& prefix,
                   const Env& env);
  /// Warns (constraint.compliance_ignored) when some ideal constraints have a compliance and others none.
  void WarnIfSomeCompliancesAreIgnored();

 private:
  bool ReadLaw(const YAML::Node& n, const std::string& name, const FormulaScope& scope, Formula* law, double* constant);
  void ReadSourceValue(const YAML::Node& n, Element& e, const FormulaScope& scope, const Env& env);
  /// An Sf's `contact:` or `friction:` (docs/events.md): makes it a switching constraint.
  void ReadSwitching(const YAML::Node& spec, Element& e, const FormulaScope& scope, const Env& env);
  /// A friction's normal force or capacity: a number, a time function or a signal's name.
  void ReadNormal(const YAML::Node& n, Element& e, const FormulaScope& scope, const Env& env);
};

}  // namespace multibond
