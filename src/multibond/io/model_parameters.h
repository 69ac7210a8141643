#pragma once
/// \file
/// The top-level parameters of a model file (docs/model-format.md, "Parameters"): named constants,
/// each a number or a formula of other parameters, with a unit and a description; and the values
/// that the command line (--set NAME=VALUE) or the C++ API give them instead of the file's.

#include <string>
#include <vector>

#include "multibond/core/error.h"

namespace multibond {

/// One parameter as the model uses it: its final value and where it came from.
struct ModelParameter {
  std::string name;
  double value = 0.0;
  std::string text;         ///< the value as written (in the file, or as set): "2.5" or "L0/2"
  std::string unit;         ///< "" = none given
  std::string description;  ///< "" = none given
  SourceLocation where;     ///< its name in the file
  bool set = false;         ///< its value was given from outside the file (--set, the API)
  bool ok = true;           ///< false: it could not be computed (the reason was reported once)
  /// True when `text` is a formula, not a plain number.
  bool is_formula() const;
};

/// A value for a parameter from outside the file: `value` is a number or a formula of the
/// model's other parameters (as in the file).
struct ParameterOverride {
  std::string name;
  std::string value;
};

/// "NAME=VALUE" as --set takes it. Throws std::invalid_argument saying what is wrong.
ParameterOverride ParseParameterAssignment(const std::string& assignment);

/// Names that no parameter or signal may take: `t` (time) and `pi`, and the names an element's own
/// variables have in its law (`q`, `p`, `e`, `f`).
bool IsReservedInFormulas(const std::string& name);

}  // namespace multibond
