#include "multibond/io/element_reader.h"

#include <cctype>
#include <cmath>
#include <cstdlib>

#include <fmt/format.h>

#include "multibond/core/identifier.h"
#include "multibond/core/structure.h"
#include "multibond/core/diagnostic_codes.h"
#include "multibond/core/units.h"
#include "multibond/io/did_you_mean.h"

namespace multibond {

namespace {

const std::vector<std::string> kCommonKeys = {"type", "dim", "domain", "components", "description"};

/// The hint of a value that must be constant, per kind: where its law goes instead.
std::string LawKeysHint(ElementKind k) {
  switch (k) {
    case ElementKind::kSe: return "a value that changes in time is a formula: effort: \"F0*sin(2*pi*f0*t)\" (docs/model-format.md, 'Expressions')";
    case ElementKind::kSf: return "a value that changes in time is a formula: flow: \"v0*sin(2*pi*f0*t)\" (docs/model-format.md, 'Expressions')";
    case ElementKind::kI: return "an inertia that is not constant is a law: 'flow:' (a formula of p) or 'energy:', instead of 'inertia:'";
    case ElementKind::kC: return "a stiffness that is not constant is a law: 'effort:' (a formula of q) or 'energy:', instead of 'stiffness:'";
    case ElementKind::kR: return "a resistance that is not constant is a law: 'effort:' (a formula of f) or 'flow:' (a formula of e), instead of 'resistance:'";
    case ElementKind::kTF:
    case ElementKind::kGY: return "a ratio that changes is a scalar formula: ratio: \"...\" (a matrix ratio is constant)";
    case ElementKind::kMTF:
    case ElementKind::kMGY: return "a modulus that changes is a matrix of formulas: modulus: {matrix: [[\"cos(a)\", ...]]}, or follows an orientation state (rotation:, lever:)";
    default: return "";
  }
}

}  // namespace

/// A law or a value written as a formula. A formula of parameters only is folded into `*constant`
/// (when given) and the formula is not kept; returns false after a reported problem.
bool ElementReader::ReadLaw(const YAML::Node& n, const std::string& name, const FormulaScope& scope, Formula* law, double* constant) {
  std::optional<Formula> f = ReadFormula(n, name, scope);
  if (!f) return false;
  if (constant) {
    if (const std::optional<double> v = ConstantValue(*f)) {
      if (!std::isfinite(*v)) {
        sink_.Error(codes::kParamRange, f->where, name, fmt::format("the formula '{}' gives {:g}: not a finite number", PrintableExcerpt(f->text), *v),
                    "check the formula and the parameters it uses");
        return false;
      }
      *constant = *v;
      return true;
    }
  }
  *law = std::move(*f);
  return true;
}

/// An Se's or Sf's value: time functions (a number, {step: ...}, ...), formulas (text that is not
/// a number), or a list with one of either per component. A formula of parameters only is a
/// constant time function. Formulas go to `value`, one per component, with the component's
/// `source` entry a placeholder constant 0; a time function's `value` entry is not given.
void ElementReader::ReadSourceValue(const YAML::Node& n, Element& e, const FormulaScope& scope, const Env& env) {
  const std::vector<YAML::Node> items = n.IsSequence() ? std::vector<YAML::Node>(n.begin(), n.end()) : std::vector<YAML::Node>{n};
  std::vector<Formula> formulas(items.size());
  bool any = false;
  for (std::size_t i = 0; i < items.size(); ++i) {
    const YAML::Node& item = items[i];
    if (IsPlainValue(item)) {
      e.source.components.push_back(ReadTimeFunction(item, e.name, env));
      continue;
    }
    double constant = 0.0;
    Formula law;
    if (ReadLaw(item, e.name, scope, &law, &constant) && !law.given()) {
      e.source.components.push_back(TimeFunction::Constant(constant));
      continue;
    }
    e.source.components.push_back(TimeFunction::Constant(0.0));
    any = any || law.given();
    formulas[i] = std::move(law);
  }
  if (any) e.value = std::move(formulas);
}

void ElementReader::ReadSwitching(const YAML::Node& spec, Element& e, const FormulaScope& scope, const Env& env) {
  Switching& sw = e.switching;
  const std::string& name = e.name;
  if (spec["contact"] && spec["friction"]) {
    sink_.Error(codes::kKeyConflict, Loc(spec["friction"]), name, "an Sf is a contact or a friction, not both", "use two elements, each on its own relative flow");
    return;
  }
  if (spec["constraint"] && !Bool(spec["constraint"], name)) {
    sink_.Error(codes::kKeyConflict, Loc(spec["constraint"]), name, "a contact or friction is an ideal constraint", "remove 'constraint: false'");
    return;
  }
  e.constraint = true;
  const bool contact = static_cast<bool>(spec["contact"]);
  const YAML::Node n = contact ? spec["contact"] : spec["friction"];
  sw.where = Loc(n);
  if (!n.IsMap()) {
    sink_.Error(codes::kYamlStructure, Loc(n), name, fmt::format("'{}' is a mapping", contact ? "contact" : "friction"),
                contact ? "e.g. contact: {gap: height, restitution: 0.8}" : "e.g. friction: {normal: 19.62, static: 0.5, kinetic: 0.4} or friction: {capacity: 50}");
    return;
  }
  if (contact) {
    sw.kind = Switching::Kind::kContact;
    CheckKeys(n, {"gap", "restitution"}, name);
    if (!n["gap"]) sink_.Error(codes::kKeyMissing, Loc(n), name, "a contact needs 'gap': the variable that measures it (> 0 while open)", "e.g. gap: height");
    else sw.gap = Qualify(scope.prefix, Str(n["gap"], name));
    if (n["restitution"]) {
      sw.restitution = Number(n["restitution"], name, env);
      if (!(sw.restitution >= 0.0 && sw.restitution <= 1.0))
        sink_.Error(codes::kParamRange, Loc(n["restitution"]), name, fmt::format("restitution must be in [0, 1] (got {:g})", sw.restitution),
                    "0: a plastic impact, 1: an elastic one");
    }
    return;
  }
  sw.kind = Switching::Kind::kFriction;
  CheckKeys(n, {"normal", "static", "kinetic", "capacity"}, name);
  if (n["capacity"]) {
    if (n["normal"] || n["static"] || n["kinetic"])
      sink_.Error(codes::kKeyConflict, Loc(n["capacity"]), name, "a clutch or brake gives 'capacity' alone", "or a friction: 'normal', 'static' and 'kinetic'");
    sw.capacity = true;
    sw.mu_s = sw.mu_k = 1.0;
    ReadNormal(n["capacity"], e, scope, env);
    return;
  }
  if (!n["normal"] || !n["static"] || !n["kinetic"]) {
    sink_.Error(codes::kKeyMissing, Loc(n), name, "a friction needs 'normal', 'static' and 'kinetic' (or a clutch's 'capacity')",
                "e.g. friction: {normal: 19.62, static: 0.5, kinetic: 0.4}");
    return;
  }
  ReadNormal(n["normal"], e, scope, env);
  bool ok_s = true, ok_k = true;
  sw.mu_s = Number(n["static"], name, env, &ok_s);
  sw.mu_k = Number(n["kinetic"], name, env, &ok_k);
  if (ok_k && !(sw.mu_k >= 0.0))
    sink_.Error(codes::kParamRange, Loc(n["kinetic"]), name, fmt::format("the kinetic coefficient must be >= 0 (got {:g})", sw.mu_k));
  if (ok_s && ok_k && !(sw.mu_s >= sw.mu_k))
    sink_.Error(codes::kParamRange, Loc(n["static"]), name,
                fmt::format("the static coefficient ({:g}) is below the kinetic one ({:g})", sw.mu_s, sw.mu_k),
                "static friction is at least kinetic friction: mu_s >= mu_k");
}

void ElementReader::ReadNormal(const YAML::Node& n, Element& e, const FormulaScope& scope, const Env& env) {
  Switching& sw = e.switching;
  if (IsPlainValue(n) || n.IsMap()) {
    sw.normal = ReadTimeFunction(n, e.name, env);
  } else if (const auto f = ReadFormula(n, e.name, scope)) {
    if (const auto v = ConstantValue(*f)) {
      sw.normal = TimeFunction::Constant(*v);
    } else if (f->root->kind == expr::Node::Kind::kName) {
      sw.normal_signal = f->root->name;
    } else {
      sink_.Error(codes::kYamlStructure, Loc(n), e.name, "a normal force or capacity is a number, a time function or a signal's name",
                  "declare the formula as a signal under 'signals:' and name it here");
      return;
    }
  }
  if (sw.normal.is_constant() && sw.normal_signal.empty() && !(sw.normal.value >= 0.0))
    sink_.Error(codes::kParamRange, Loc(n), e.name, fmt::format("a normal force or capacity must be >= 0 (got {:g})", sw.normal.value));
}

void ElementReader::ReadElement(const std::string& name, const YAML::Node& spec, const SourceLocation& where, const std::string& prefix,
                                const Env& env) {
  if (!spec.IsMap()) {
    sink_.Error(codes::kYamlStructure, where, name, "an element is a mapping with at least a 'type'", "write e.g. '{type: C, stiffness: 100}'");
    return;
  }
  if (!spec["type"]) {
    sink_.Error(codes::kKeyMissing, where, name, "element has no 'type'", "add type: Se, Sf, I, C, R, TF, MTF, GY, MGY, 0, 1 or a submodel name");
    return;
  }
  const std::string type = spec["type"].Scalar();
  const auto kind = ParseKind(type);
  if (!kind) {
    std::vector<std::string> names = {"Se", "Sf", "I", "C", "R", "TF", "MTF", "GY", "MGY", "0", "1"};
    for (const auto& [sm, def] : cx_.submodels) names.push_back(sm);
    const std::string guess = DidYouMean(type, names);
    sink_.Error(codes::kElementType, Loc(spec["type"]), name, fmt::format("unknown element type '{}'", type),
                guess.empty() ? "use Se, Sf, I, C, R, TF, MTF, GY, MGY, 0, 1 or a submodel name" : fmt::format("did you mean '{}'?", guess));
    return;
  }
  Element e;
  e.name = name;
  e.kind = *kind;
  e.where = where;
  law_keys_hint_ = LawKeysHint(e.kind);
  auto scope = [&](std::vector<std::string> own, const char* what) { return FormulaScope{&env, prefix, std::move(own), what}; };
  const char* law_key = nullptr;  // the first key of the element that gives a law (a formula of its own variables)
  std::vector<std::string> keys = kCommonKeys;
  if (IsTwoPort(e.kind)) keys = {"type", "description"};  // dimensions come from the ratio; domains may differ per port
  auto require = [&](const char* key, const char* hint) {
    if (spec[key]) return true;
    sink_.Error(codes::kKeyMissing, where, name, fmt::format("{} needs '{}'", KindName(e.kind), key), hint);
    e.param = Param::Scalar(1.0);  // a placeholder that no later check reports again
    return false;
  };
  // The dimension first: a multiport's energy names its own variables by it (q1 ... qn).
  if (spec["dim"]) {
    const double d = Number(spec["dim"], name, env);
    if (d < 1 || d > 64 || d != std::floor(d)) sink_.Error(codes::kParamRange, Loc(spec["dim"]), name, fmt::format("dim must be a whole number from 1 to 64 (got {:g})", d));
    else e.dim = static_cast<int>(d);
  }
  switch (e.kind) {
    case ElementKind::kSe:
    case ElementKind::kSf: {
      const char* key = e.kind == ElementKind::kSe ? "effort" : "flow";
      keys.push_back(key);
      if (e.kind == ElementKind::kSf) {
        keys.insert(keys.end(), {"constraint", "compliance", "contact", "friction"});
        if (spec["constraint"]) e.constraint = Bool(spec["constraint"], name);
        if (spec["contact"] || spec["friction"]) ReadSwitching(spec, e, scope({}, "friction's normal force"), env);
        if (spec["compliance"]) {
          if (!e.constraint)
            sink_.Error(codes::kKeyConflict, Loc(spec["compliance"]), name, "'compliance' belongs to an ideal constraint",
                        "add 'constraint: true', or model the coupling as a C");
          e.compliance = Vector(spec["compliance"], name, env);
          for (Eigen::Index k = 0; k < e.compliance.size(); ++k)
            if (!(e.compliance[k] > 0) || !std::isfinite(e.compliance[k]))
              sink_.Error(codes::kParamRange, Loc(spec["compliance"]), name,
                          fmt::format("compliance must be > 0 and finite (got {:g})", e.compliance[k]),
                          "the compliance 1/K of the coupling the constraint stands for shares a redundant reaction");
        }
      }
      if (require(key, e.kind == ElementKind::kSe ? "e.g. effort: 1.0 or effort: {step: 1.0}" : "e.g. flow: 0 or flow: {sine: {amplitude: 1, frequency: 2}}"))
        ReadSourceValue(spec[key], e, scope({}, e.kind == ElementKind::kSe ? "Se's effort" : "Sf's flow"), env);
      break;
    }
    case ElementKind::kI: {
      keys.insert(keys.end(), {"inertia", "p0", "rotation", "flow", "energy"});
      const int given = (spec["inertia"] ? 1 : 0) + (spec["flow"] ? 1 : 0) + (spec["energy"] ? 1 : 0);
      if (given > 1) sink_.Error(codes::kKeyConflict, where, name, "give one of 'inertia', 'flow' and 'energy'", "'flow' and 'energy' are laws: a formula of p instead of a constant inertia");
      if (spec["flow"] || spec["energy"]) {
        law_key = spec["flow"] ? "flow" : "energy";
        e.param = Param::Scalar(1.0);  // not used: the law is
        if (spec["flow"]) ReadLaw(spec["flow"], name, scope({"p"}, "I's flow law (a formula of its momentum p)"), &e.law_effort, nullptr);
        else {
          ReadLaw(spec["energy"], name,
                  scope(OwnVariables(e.kind, e.dim), e.dim > 1 ? "multiport I's energy (a formula of its momenta p1 ... pn)" : "I's energy (a formula of its momentum p)"),
                  &e.energy, nullptr);
        }
      } else if (require("inertia", "e.g. inertia: 2.0 (kg, kg m^2, H, ...)")) {
        e.param = ReadParam(spec["inertia"], name, env);
      }
      if (spec["p0"]) e.initial = Vector(spec["p0"], name, env);
      if (spec["rotation"]) e.rotation = Qualify(prefix, Str(spec["rotation"], name));
      keys.push_back("units");
      break;
    }
    case ElementKind::kC:
      keys.insert(keys.end(), {"stiffness", "compliance", "q0", "effort", "energy"});
      if (spec["stiffness"] && spec["compliance"]) sink_.Error(codes::kKeyConflict, where, name, "give either 'stiffness' or 'compliance', not both");
      if ((spec["effort"] || spec["energy"]) &&
          (spec["stiffness"] ? 1 : 0) + (spec["compliance"] ? 1 : 0) + (spec["effort"] ? 1 : 0) + (spec["energy"] ? 1 : 0) > 1)
        sink_.Error(codes::kKeyConflict, where, name, "give one of 'stiffness', 'compliance', 'effort' and 'energy'",
                    "'effort' and 'energy' are laws: a formula of q instead of a constant stiffness");
      if (spec["effort"] || spec["energy"]) {
        law_key = spec["effort"] ? "effort" : "energy";
        e.param = Param::Scalar(1.0);  // not used: the law is
        if (spec["effort"]) ReadLaw(spec["effort"], name, scope({"q"}, "C's effort law (a formula of its displacement q)"), &e.law_effort, nullptr);
        else {
          ReadLaw(spec["energy"], name,
                  scope(OwnVariables(e.kind, e.dim), e.dim > 1 ? "multiport C's energy (a formula of its displacements q1 ... qn)" : "C's energy (a formula of its displacement q)"),
                  &e.energy, nullptr);
        }
      } else if (spec["compliance"]) {
        Param c = ReadParam(spec["compliance"], name, env);
        // The stiffness is its inverse; a bad compliance is said once, here, and leaves a stiffness of 1.
        if (c.is_scalar) {
          const bool ok = c.scalar > 0;
          if (!ok)
            sink_.Error(codes::kParamRange, Loc(spec["compliance"]), name, fmt::format("compliance must be > 0 (got {:g})", c.scalar),
                        "a compliance stores energy only when positive");
          e.param = Param::Scalar(ok ? 1.0 / c.scalar : 1.0);
        } else {
          const bool ok = c.matrix.allFinite() && IsPositiveDefinite(c.matrix);
          if (!ok && c.matrix.size() > 0)
            sink_.Error(codes::kParamRange, Loc(spec["compliance"]), name, "compliance matrix must be symmetric positive definite",
                        "a compliance stores energy in every direction only when positive definite (a singular one "
                        "has no stiffness: an ideal constraint is an Sf with constraint: true)");
          const bool square = c.matrix.rows() == c.matrix.cols();
          e.param = ok ? Param::Matrix(c.matrix.inverse())
                       : square ? Param::Matrix(Eigen::MatrixXd::Identity(c.matrix.rows(), c.matrix.cols())) : c;
        }
      } else if (require("stiffness", "e.g. stiffness: 100 (N/m, N m/rad, 1/F, ...)")) {
        e.param = ReadParam(spec["stiffness"], name, env);
      }
      if (spec["q0"]) e.initial = Vector(spec["q0"], name, env);
      keys.push_back("units");
      break;
    case ElementKind::kR:
      keys.insert(keys.end(), {"resistance", "effort", "flow", "active"});
      if (spec["active"]) e.active = Bool(spec["active"], name);
      if (spec["resistance"] && (spec["effort"] || spec["flow"]))
        sink_.Error(codes::kKeyConflict, where, name, "give either 'resistance' or a law ('effort' and/or 'flow'), not both",
                    "'effort' is a formula of f, 'flow' a formula of e: a resistor that is not linear");
      if (spec["effort"] || spec["flow"]) {
        law_key = spec["effort"] ? "effort" : "flow";
        e.param = Param::Scalar(1.0);  // not used: the law is
        if (spec["effort"]) ReadLaw(spec["effort"], name, scope({"f"}, "R's effort law (a formula of its flow f)"), &e.law_effort, nullptr);
        if (spec["flow"]) ReadLaw(spec["flow"], name, scope({"e"}, "R's flow law (a formula of its effort e)"), &e.law_flow, nullptr);
      } else if (require("resistance", "e.g. resistance: 2.0 (N s/m, N m s/rad, ohm, ...)")) {
        e.param = ReadParam(spec["resistance"], name, env);
      }
      break;
    case ElementKind::kTF:
    case ElementKind::kGY:
      keys.push_back("ratio");
      if (require("ratio", "e.g. ratio: 0.25, or a matrix (rows = port 2, columns = port 1)")) {
        const YAML::Node r = spec["ratio"];
        if (!IsPlainValue(r)) {
          // A formula: of parameters only, a number as any ratio; else the ratio as it changes.
          double ratio = 1.0;
          Formula law;
          e.param = Param::Scalar(1.0);
          if (ReadLaw(r, name, scope({}, "ratio"), &law, &ratio)) {
            if (law.given()) e.value = {std::move(law)};
            else e.param = Param::Scalar(ratio);
          }
        } else {
          e.param = ReadParam(r, name, env);
        }
        if (e.param.is_scalar && e.param.scalar == 0.0) sink_.Error(codes::kParamRange, Loc(r), name, "ratio must not be 0");
      }
      break;
    case ElementKind::kMTF:
    case ElementKind::kMGY:
      keys.push_back("modulus");
      if (require("modulus", "e.g. modulus: {rotation: A.R, transpose: true}")) e.modulus = ReadModulus(spec["modulus"], name, prefix, env);
      break;
    case ElementKind::kZero:
    case ElementKind::kOne:
      break;
  }
  CheckKeys(spec, keys, name);
  if (spec["domain"]) e.domain = Domain(spec["domain"], name);
  if (spec["components"])
    e.components = Components(spec["components"], name);
  if ((e.kind == ElementKind::kI || e.kind == ElementKind::kC) && spec["units"]) {
    // One unit per component (they label columns and reach gnuplot and HTML: the grammar only).
    const YAML::Node& list = spec["units"];
    const std::vector<std::string> units = Words(list, name, "units");
    bool good = list.IsSequence();
    for (size_t k = 0; good && k < units.size() && k < list.size(); ++k)
      if (const std::string problem = UnitProblem(units[k]); !problem.empty()) {
        sink_.Error(codes::kUnitInvalid, Loc(list[k]), name, fmt::format("the unit '{}' is refused: {}", PrintableExcerpt(units[k]), problem),
                    "a unit such as m, N s, rad/s or C (docs/model-format.md, \"Names and units\")");
        good = false;
      }
    if (good && e.dim > 0 && static_cast<int>(units.size()) != e.dim)
      sink_.Error(codes::kParamShape, Loc(list), name, fmt::format("'units' has {} entries for {} components", units.size(), e.dim),
                  "give one unit per component, in the order of 'components'");
    else if (good && e.dim <= 0)
      sink_.Error(codes::kParamShape, Loc(list), name, "'units' needs 'dim': one unit per component", "add dim: n");
    else if (good)
      e.state_units = units;
  }
  // A law relates one effort and one flow: its bond is scalar (what fixes another dimension here is
  // said here; one inferred through a junction is said when the model is compiled).
  if (law_key && std::string(law_key) == "energy" && e.dim > 1) {
    // A multiport: one energy of the vector state, its gradient the efforts (flows); the sizes of
    // its initial value and component names are checked with every element's (core/structure.cc).
    if (!e.rotation.empty())
      sink_.Error(codes::kStructureDimension, where, name, "a multiport energy does not turn with an orientation",
                  "a rigid body's inertia is a constant 3 x 3 'inertia' with 'rotation'");
  } else if (law_key) {
    std::string what;
    if (e.dim > 1) what = fmt::format("'dim' is {}", e.dim);
    else if (e.initial.size() > 1) what = fmt::format("its initial value has {} entries", e.initial.size());
    else if (e.components.size() > 1) what = fmt::format("it names {} components", e.components.size());
    else if (!e.rotation.empty()) what = "it turns with an orientation (a 3-dimensional bond)";
    const bool storage = IsStorage(e.kind);
    if (!what.empty())
      sink_.Error(codes::kStructureDimension, where, name, fmt::format("a law ('{}') is for a scalar bond, but {}", law_key, what),
                  storage ? "a formula law relates one effort and one flow: give a multiport's stored energy instead (energy: of q1 ... qn, "
                            "or p1 ... pn, with dim), use one element per component, or a constant parameter for a vector bond"
                          : "a formula law relates one effort and one flow: use one element per component, or a constant parameter for a vector bond");
  }
  if (graph_.Find(name) >= 0 || graph_.FindAux(name) >= 0) {
    sink_.Error(codes::kNameDuplicate, where, name, "duplicate name", "give every element and state a unique name");
    return;
  }
  graph_.Add(std::move(e));
}

/// Redundant reactions are shared by compliances only when every constraint has one
/// (CompiledModel::ShareRedundantEfforts); a partial set is ignored, and the user is told.
void ElementReader::WarnIfSomeCompliancesAreIgnored() {
  const Element* with = nullptr;
  const Element* without = nullptr;
  for (int i = 0; i < graph_.num_elements(); ++i) {
    const Element& e = graph_.element(i);
    if (e.kind != ElementKind::kSf || !e.constraint) continue;
    if (e.compliance.size() > 0 && !with) with = &e;
    if (e.compliance.size() == 0 && !without) without = &e;
  }
  if (!with || !without) return;
  Diagnostic d;
  d.severity = Diagnostic::Severity::kWarning;
  d.where = with->where;
  d.element = with->name;
  d.code = codes::kConstraintComplianceIgnored;
  d.message = fmt::format("the compliance is not used: constraint '{}' has none, and redundant reactions are "
                          "shared by compliances only when every constraint has one (else by the constraints' mobilities)",
                          without->name);
  d.hint = fmt::format("give '{}' (and every other constraint) a compliance (a rigid joint or mesh: its K), or remove them all",
                       without->name);
  sink_.Add(d);
}

}  // namespace multibond
