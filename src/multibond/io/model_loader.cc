// The model loader: runs the section readers over a model file in the order of the format
// (docs/model-format.md), all sharing one LoadContext, and throws every problem found together.
//   yaml_document      the file's bytes within their limits -> one YAML mapping
//   settings_reader    domain, constraints, algebraic_loops; later 'simulation'
//   model_parameters_reader  'parameters' (with the values set from outside), evaluated first:
//                      every number of the file may be a formula of them (formula_values.cc)
//   submodel_reader    'submodels'; the scope of the model and of each instance
//     element_reader   each element with its parameters (parameter_reader: time functions, moduli)
//     bond_reader      each bond
//     states_outputs_reader  'states' and 'outputs'
//   mechanism_reader   'rigid', 'gravity', 'bodies', 'joints', 'gears', 'drives', 'points'
//   size_limits        the expansion and the expanded graph within InputLimits

#include "multibond/io/model_loader.h"

#include <fmt/format.h>

#include "multibond/core/structure.h"
#include "multibond/core/diagnostic_codes.h"
#include "multibond/io/element_reader.h"
#include "multibond/io/load_context.h"
#include "multibond/io/mechanism_reader.h"
#include "multibond/io/model_parameters_reader.h"
#include "multibond/io/settings_reader.h"
#include "multibond/io/size_limits.h"
#include "multibond/io/states_outputs_reader.h"
#include "multibond/io/submodel_reader.h"
#include "multibond/io/yaml_document.h"

namespace multibond {

namespace {

const std::vector<std::string> kTopKeys = {"model", "description", "domain", "elements", "bonds", "states", "outputs",
                                           "simulation", "submodels", "gravity", "bodies", "joints", "gears", "drives", "points",
                                           "constraints", "rigid", "sensors", "algebraic_loops", "parameters", "signals", "assembly"};

LoadedModel Load(LoadContext& cx, const YAML::Node& root, const std::vector<ParameterOverride>& overrides) {
  LoadedModel out{BondGraph("model"), {}, {}, cx.file, cx.text, {}, nullptr, {}};
  DiagnosticSink& sink = cx.sink;
  ValueReader values(cx);
  values.CheckKeys(root, kTopKeys, "");
  std::string name = "model";
  if (root["model"]) name = values.Str(root["model"], "model");
  if (root["model"] && !values.CheckName(name, values.Loc(root["model"]), "the model's", false)) name = "model";
  cx.graph = BondGraph(name);
  cx.graph.set_source_file(cx.file);
  SettingsReader settings(cx);
  settings.ReadCompileSettings(root, out.compile);
  // Formulas name signals before they are read (a parameter may not depend on one): their names first.
  if (root["signals"] && root["signals"].IsMap())
    for (const auto& kv : root["signals"]) cx.signal_names.insert(kv.first.Scalar());
  ModelParametersReader(cx).Read(root["parameters"], overrides);
  SubmodelReader scopes(cx);
  if (root["submodels"]) scopes.ReadSubmodelDefs(root["submodels"]);
  const bool mechanism = root["bodies"].IsDefined();
  std::shared_ptr<const mech::Mechanism> parts;
  if (mechanism) parts = MechanismReader(cx).ReadMechanism(root);
  if (!root["elements"] && !mechanism)
    sink.Error(codes::kKeyMissing, {cx.file, 1, 1}, "", "the model has no 'elements' section (nor 'bodies')", "list the elements under 'elements:'");
  if (!root["bonds"] && !mechanism)
    sink.Error(codes::kKeyMissing, {cx.file, 1, 1}, "", "the model has no 'bonds' section", "list the bonds under 'bonds:', e.g. '- force -> mass'");
  for (const char* key : {"joints", "gears", "drives", "points", "gravity", "assembly"})
    if (root[key] && !mechanism) sink.Error(codes::kKeyMissing, values.Loc(root[key]), key, fmt::format("'{}' needs a 'bodies' section", key), "declare the bodies first");
  // Submodel instances, their depth and the elements and bonds they expand to are counted
  // before anything is expanded: an exponential nest is refused in microseconds.
  SizeLimits sizes(cx);
  if (!sizes.CheckExpansion(root)) sink.ThrowIfErrors();
  scopes.ReadScope(root, "", Env{}, 0);
  sizes.CheckGraphSize(root);
  ElementReader(cx).WarnIfSomeCompliancesAreIgnored();
  if (root["signals"]) StatesOutputsReader(cx).ReadSignals(root["signals"]);
  if (root["outputs"]) StatesOutputsReader(cx).ReadOutputs(root["outputs"]);
  if (root["simulation"]) settings.ReadSimulation(root["simulation"], out.simulation, mechanism);
  if (sink.has_errors()) {
    // Report the parameter problems of what could be read too, so that one pass shows them all.
    // (Structural problems of a partly read graph would mostly be echoes of the errors above.)
    // An element with a number that could not be read (said) is not said again to be out of range.
    DiagnosticSink structural;
    AnalyzeStructure(cx.graph, out.compile.default_domain, structural);
    for (const auto& d : structural.diagnostics())
      if (d.code == codes::kParamRange && !cx.unread_numbers.count(d.element)) sink.Add(d);
  }
  sink.ThrowIfErrors();
  for (const auto& d : sink.diagnostics())
    if (d.severity == Diagnostic::Severity::kWarning) out.warnings.push_back(d);
  out.graph = std::move(cx.graph);
  out.mechanism = std::move(parts);
  out.parameters = std::move(cx.parameters);
  return out;
}

/// Runs `f`, turning a YAML exception (a node of a shape the loader did not expect somewhere it
/// did not check) into a model error with the place yaml-cpp knows.
template <typename F>
auto Explained(const std::string& file, F&& f) {
  try {
    return f();
  } catch (const YAML::Exception& e) {
    Diagnostic d;
    d.where = {file, e.mark.line >= 0 ? e.mark.line + 1 : 0, e.mark.line >= 0 ? e.mark.column + 1 : 0};
    d.code = codes::kYamlStructure;
    d.message = "unexpected structure in the model file (" + e.msg + ")";
    d.hint = "compare this part of the file with docs/model-format.md";
    throw ModelError(d);
  }
}

}  // namespace

LoadedModel LoadModelString(const std::string& yaml, const std::string& file, const InputLimits& limits,
                            const std::vector<ParameterOverride>& parameters) {
  return Explained(file, [&] {
    LoadContext cx(file, yaml, limits);
    const YAML::Node root = YamlDocument(cx).Parse();
    return Load(cx, root, parameters);
  });
}

ParsedModel::ParsedModel(std::string text, std::string file, const InputLimits& limits)
    : file_(std::move(file)), text_(std::move(text)), limits_(limits) {
  root_ = Explained(file_, [&] {
    LoadContext cx(file_, text_, limits_);
    return std::make_unique<YAML::Node>(YamlDocument(cx).Parse());
  });
}

ParsedModel::~ParsedModel() = default;

LoadedModel ParsedModel::Load(const std::vector<ParameterOverride>& parameters) const {
  return Explained(file_, [&] {
    LoadContext cx(file_, text_, limits_);
    return multibond::Load(cx, *root_, parameters);
  });
}

LoadedModel LoadModelFile(const std::string& path, const InputLimits& limits, const std::vector<ParameterOverride>& parameters) {
  return LoadModelString(ReadModelText(path, limits), path, limits, parameters);
}

}  // namespace multibond
