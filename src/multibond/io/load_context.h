#pragma once
/// \file
/// What the section readers of the model loader share while one model file is read: the file and
/// its text, the limits, the diagnostics found so far, the bond graph being built and the names
/// defined so far (each found in O(1)). One LoadContext per file; every reader takes it by reference.

#include <algorithm>
#include <cstdint>
#include <map>
#include <set>
#include <string>
#include <unordered_map>
#include <unordered_set>
#include <vector>

#include <yaml-cpp/yaml.h>

#include "multibond/core/error.h"
#include "multibond/core/graph.h"
#include "multibond/io/limits.h"
#include "multibond/io/model_parameters.h"
#include "multibond/io/name_index.h"

namespace multibond {

/// A submodel's parameters in scope, by name (ordered: messages list them in this order).
using Env = std::map<std::string, double>;

/// A submodel definition of the 'submodels' section.
struct SubmodelDef {
  YAML::Node node;
  Env defaults;
  std::set<std::string> ports;
  bool ports_in_error = false;  ///< a port names no element (said at the definition, not at every use)
};

struct LoadContext {
  LoadContext(std::string file_name, std::string file_text, const InputLimits& input_limits)
      : file(std::move(file_name)), text(std::move(file_text)), limits(input_limits) {}

  std::string file;  ///< the name diagnostics give the file
  std::string text;  ///< its content
  const InputLimits& limits;
  DiagnosticSink sink;
  BondGraph graph{"model"};

  /// The 'submodels' definitions by name (ordered: did-you-mean lists them in this order).
  std::map<std::string, SubmodelDef> submodels;
  /// Submodel instances (qualified names) and where each is written.
  NameIndex instances;
  /// The ports of each instance whose definition's ports are all elements of it.
  std::unordered_map<std::string, std::set<std::string>> instance_ports;
  /// Elements the file defines but the loader refused (qualified names), with their error given.
  std::unordered_set<std::string> refused_elements;
  NameIndex bond_names;                   ///< the bonds named in the file, where
  std::vector<std::string> instantiating;  ///< the submodel types being expanded, outermost first
  std::uint64_t instances_expanded = 0;   ///< submodel instances expanded so far

  /// The top-level parameters, in the order of the file, and their index by name.
  std::vector<ModelParameter> parameters;
  std::unordered_map<std::string, std::size_t> parameter_index;
  /// The names of the top-level signals (known before anything else is read: formulas name them).
  std::unordered_set<std::string> signal_names;
  /// Every auxiliary state declared so far and in the scope being read (qualified names): a bare
  /// name in a formula is one of these, or a parameter, a signal or an element's own variable.
  std::unordered_set<std::string> state_names;
  /// The elements with a number that could not be read (said where it is; its value is 0).
  std::unordered_set<std::string> unread_numbers;

  /// The parameter called `name`, or nullptr.
  const ModelParameter* FindParameter(const std::string& name) const {
    const auto it = parameter_index.find(name);
    return it == parameter_index.end() ? nullptr : &parameters[it->second];
  }

  SourceLocation Loc(const YAML::Mark& m) const {
    if (m.line < 0) return {file, 0, 0};
    return {file, m.line + 1, m.column + 1};
  }
  SourceLocation Loc(const YAML::Node& n) const { return Loc(n.Mark()); }

  /// file:line:column of the byte at `pos` of the text (the column counts bytes).
  SourceLocation Location(size_t pos) const {
    pos = std::min(pos, text.size());
    const size_t line_start = pos == 0 ? 0 : text.rfind('\n', pos - 1) + 1;
    const int line = static_cast<int>(std::count(text.begin(), text.begin() + static_cast<long>(pos), '\n')) + 1;
    return SourceLocation{file, line, static_cast<int>(pos - line_start) + 1};
  }
};

}  // namespace multibond
