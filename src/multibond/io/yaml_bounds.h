#pragma once
/// \file
/// A pass over a YAML text's parser events that bounds what the text can make the loader do
/// (InputLimits::yaml_nodes, ::depth) and refuses an alias to a node that contains it (yaml-cpp
/// would build a cyclic tree, which every walk follows without end). LoadYamlBounded builds the
/// tree from the same events as they are checked (one parse of the text); CheckYamlBounds only
/// checks them.

#include <optional>
#include <string>
#include <vector>

#include <yaml-cpp/node/node.h>

#include "multibond/core/error.h"
#include "multibond/io/limits.h"

namespace multibond {

/// Reports in `sink`, each as a located diagnostic, the first of:
///  - "limit.yaml-nodes": more nodes than limits.yaml_nodes, every alias counted as the nodes of
///    the node it stands for (so "billion laughs" is refused after limits.yaml_nodes nodes);
///  - "limit.depth": collections nested deeper than limits.depth;
///  - "yaml.self_alias": an alias to an anchor whose node is still open (`a: &x [*x]`).
/// Returns true when the text is within bounds. A syntax error is thrown as YAML::Exception, as
/// yaml-cpp's loader would throw it.
bool CheckYamlBounds(const std::string& text, const std::string& file, const InputLimits& limits, DiagnosticSink& sink);

/// The documents of `text`, as YAML::LoadAll builds them (the same nodes, marks, tags, styles and
/// shared aliased nodes), from one parse whose events are bounded as CheckYamlBounds bounds them:
/// nullopt, with the diagnostic in `sink`, at the first event out of bounds; no node beyond it is
/// built. A syntax error is thrown as YAML::Exception, as YAML::LoadAll throws it.
std::optional<std::vector<YAML::Node>> LoadYamlBounded(const std::string& text, const std::string& file, const InputLimits& limits,
                                                       DiagnosticSink& sink);

}  // namespace multibond
