#include "multibond/io/plot_model.h"

#include <map>
#include <stdexcept>

#include <yaml-cpp/yaml.h>

#include "multibond/causality/causality.h"
#include "multibond/core/error.h"
#include "multibond/core/structure.h"

namespace multibond {

namespace {

/// `key` -> `value` of every "name: {field: value}" entry of a mechanism section (e.g. each joint's
/// child); `sub` reads value from a nested map ("a: {body: P1}").
void NestFromSection(const YAML::Node& root, const char* section, const char* field, const char* sub,
                     std::map<std::string, std::string>& nest) {
  const YAML::Node s = root[section];
  if (!s || !s.IsMap()) return;
  for (const auto& entry : s) {
    const YAML::Node v = entry.second;
    if (!v.IsMap() || !v[field]) continue;
    const YAML::Node target = sub ? v[field][sub] : v[field];
    if (target && target.IsScalar()) nest[entry.first.as<std::string>()] = target.as<std::string>();
  }
}

}  // namespace

DotOptions LinkGrouping(const LoadedModel& model) {
  DotOptions o;
  try {
    const YAML::Node root = YAML::Load(model.text);
    if (!root.IsMap() || !root["bodies"]) return o;
    NestFromSection(root, "joints", "child", nullptr, o.nest);
    NestFromSection(root, "drives", "body", nullptr, o.nest);
    NestFromSection(root, "gears", "a", "body", o.nest);
  } catch (const std::exception&) {
    return o;
  }
  // Relative velocities "child~parent" (and anything else named "X~Y") go with X.
  for (const Element& e : model.graph.elements()) {
    const std::string prefix = e.name.substr(0, e.name.find('.'));
    const size_t tilde = prefix.find('~');
    if (tilde != std::string::npos && tilde > 0) o.nest[prefix] = prefix.substr(0, tilde);
  }
  o.bond_names = false;
  return o;
}

PlotModel PlotModel::Read(const std::string& path, const InputLimits& limits) {
  PlotModel m;
  m.path = path;
  if (path.empty()) return m;
  try {
    m.loaded = LoadModelFile(path, limits);
    const LoadedModel& lm = *m.loaded;
    DiagnosticSink sink;
    const Structure s = AnalyzeStructure(lm.graph, lm.compile.default_domain, sink);
    if (sink.has_errors()) return m;
    const CausalAssignment c = AssignCausality(lm.graph, s);
    m.dot = MakeDot(lm.graph, &s, &c, LinkGrouping(lm));
  } catch (const ModelError&) {
    // The callers say that it does not load, without its text: the page may be shared, and the
    // diagnostics quote the file.
    m.loaded.reset();
    m.dot.clear();
  }
  return m;
}

}  // namespace multibond
