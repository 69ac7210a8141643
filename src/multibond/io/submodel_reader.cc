#include "multibond/io/submodel_reader.h"

#include <algorithm>

#include <fmt/format.h>

#include "multibond/io/bond_reader.h"
#include "multibond/core/diagnostic_codes.h"
#include "multibond/io/did_you_mean.h"
#include "multibond/io/element_reader.h"
#include "multibond/io/states_outputs_reader.h"

namespace multibond {

void SubmodelReader::ReadSubmodelDefs(const YAML::Node& n) {
  if (!n.IsMap()) {
    sink_.Error(codes::kYamlStructure, Loc(n), "submodels", "expected a mapping of submodel names to definitions");
    return;
  }
  for (const auto& kv : n) {
    const std::string name = kv.first.Scalar();
    const YAML::Node def = kv.second;
    if (!CheckName(name, Loc(kv.first), "a submodel's")) continue;
    if (!def.IsMap()) {
      sink_.Error(codes::kYamlStructure, Loc(def), name, "a submodel definition is a mapping with parameters, ports, elements and bonds");
      continue;
    }
    CheckKeys(def, {"description", "parameters", "ports", "elements", "bonds", "states"}, name);
    if (ParseKind(name)) sink_.Error(codes::kKeyConflict, Loc(kv.first), name, "a submodel cannot be named like an element kind");
    SubmodelDef sd{def, {}, {}};
    if (def["parameters"]) {
      if (!def["parameters"].IsMap())
        sink_.Error(codes::kYamlStructure, Loc(def["parameters"]), name, "'parameters' maps each name to its default value", "write e.g. parameters: {m: 1.0}");
      else
        for (const auto& p : def["parameters"])
          if (CheckName(p.first.Scalar(), Loc(p.first), "a parameter's", false)) sd.defaults[p.first.Scalar()] = Number(p.second, name, Env{});
    }
    if (def["ports"])
      for (const auto& p : Words(def["ports"], name, "ports")) sd.ports.insert(p);
    // A port names one of the definition's elements: said here, once, not at every use.
    if (def["ports"] && def["ports"].IsSequence() && def["elements"] && def["elements"].IsMap()) {
      std::vector<std::string> locals;
      for (const auto& e : def["elements"]) locals.push_back(e.first.Scalar());
      for (const auto& p : def["ports"]) {
        if (!p.IsScalar() || std::find(locals.begin(), locals.end(), p.Scalar()) != locals.end()) continue;
        sd.ports_in_error = true;
        const std::string guess = DidYouMean(p.Scalar(), locals);
        sink_.Error(codes::kBondUnknownEnd, Loc(p), name, fmt::format("port '{}' is not one of the submodel's elements", p.Scalar()),
                    guess.empty() ? "a port names an element under the submodel's 'elements'" : fmt::format("did you mean '{}'?", guess));
      }
    }
    cx_.submodels[name] = sd;
  }
}

/// Reads the elements, bonds and states of a model or of a submodel instance under `prefix`.
void SubmodelReader::ReadScope(const YAML::Node& scope, const std::string& prefix, const Env& env, int depth) {
  if (static_cast<std::uint64_t>(depth) > cx_.limits.depth) return;  // said by CheckExpansion before expanding
  // The scope's states are named by the formulas of its elements (a bare name of a state is local).
  if (const YAML::Node states = scope["states"]; states && states.IsMap())
    for (const auto& kv : states) cx_.state_names.insert(Qualify(prefix, kv.first.Scalar()));
  const YAML::Node elements = scope["elements"];
  if (elements && !elements.IsMap()) {
    sink_.Error(codes::kYamlStructure, Loc(elements), "elements", "'elements' must be a mapping of names to element specifications",
                "write e.g. 'mass: {type: I, inertia: 1.0}'");
  } else if (elements) {
    NameIndex seen;  // the names of this scope
    for (const auto& kv : elements) {
      // A list or a mapping as a name ([a, b]: ...) has no text: said as what it is, not as empty.
      if (!kv.first.IsScalar()) {
        sink_.Error(codes::kNameInvalid, Loc(kv.first), "", fmt::format("an element's name is {}, not a word", Describe(kv.first)),
                    "a name is a letter or '_', then letters, digits and '_' (at most 64 characters)");
        continue;
      }
      const std::string local = kv.first.Scalar();
      if (const SourceLocation* first = seen.Add(local, Loc(kv.first))) {
        Diagnostic d;
        d.where = Loc(kv.first);
        d.element = local;
        d.message = "duplicate element name";
        d.code = codes::kNameDuplicate;
        d.details.push_back("first defined at " + first->ToString());
        d.hint = "give every element a unique name";
        sink_.Add(d);
        continue;
      }
      // An element refused here has had its error: the bonds that name it do not add another.
      const std::string qualified = Qualify(prefix, local);
      if (!CheckName(local, Loc(kv.first), "an element's")) {
        cx_.refused_elements.insert(qualified);
        continue;
      }
      const YAML::Node& spec = kv.second;
      if (spec.IsMap() && spec["type"] && cx_.submodels.count(spec["type"].Scalar()))
        Instantiate(qualified, spec["type"].Scalar(), spec, Loc(kv.first), env, depth);
      else
        ElementReader(cx_).ReadElement(qualified, spec, Loc(kv.first), prefix, env);
      if (graph_.Find(qualified) < 0 && !cx_.instances.contains(qualified)) cx_.refused_elements.insert(qualified);
    }
  }
  if (scope["states"]) StatesOutputsReader(cx_).ReadStates(scope["states"], prefix, env);
  const YAML::Node bonds = scope["bonds"];
  if (bonds && !bonds.IsSequence()) {
    sink_.Error(codes::kYamlStructure, Loc(bonds), "bonds", "'bonds' must be a list", "write e.g. '- force -> mass'");
  } else if (bonds) {
    BondReader reader(cx_);
    for (const auto& b : bonds) reader.ReadBond(b, prefix, env);
  }
}

void SubmodelReader::Instantiate(const std::string& name, const std::string& type, const YAML::Node& spec, const SourceLocation& where,
                                 const Env& outer, int depth) {
  // A submodel that contains itself (directly or through others) would expand without end.
  if (std::find(cx_.instantiating.begin(), cx_.instantiating.end(), type) != cx_.instantiating.end()) {
    std::string chain;
    for (const auto& t : cx_.instantiating) chain += t + " -> ";
    sink_.Error(codes::kSubmodelRecursive, where, name, fmt::format("submodel '{}' contains itself: {}{}", type, chain, type),
                "a submodel may use other submodels, but not itself");
    return;
  }
  cx_.instantiating.push_back(type);
  InstantiateBody(name, type, spec, where, outer, depth);
  cx_.instantiating.pop_back();
}

void SubmodelReader::InstantiateBody(const std::string& name, const std::string& type, const YAML::Node& spec,
                                     const SourceLocation& where, const Env& outer, int depth) {
  const SubmodelDef& def = cx_.submodels.at(type);
  if (++cx_.instances_expanded > cx_.limits.instances) return;  // said by CheckExpansion before expanding
  Env env = def.defaults;
  std::vector<std::string> keys = {"type", "description"};
  for (const auto& [p, v] : def.defaults) keys.push_back(p);
  CheckKeys(spec, keys, name);
  law_keys_hint_ = "a submodel's parameter is a constant: a number or a formula of parameters";
  for (const auto& kv : spec) {
    const std::string key = kv.first.Scalar();
    if (key != "type" && key != "description" && def.defaults.count(key)) env[key] = Number(kv.second, name, outer);
  }
  law_keys_hint_.clear();
  if (!def.ports_in_error) cx_.instance_ports[name] = def.ports;
  cx_.instances.Add(name, where);
  ReadScope(def.node, name, env, depth + 1);
}

}  // namespace multibond
