#include "multibond/io/element_reader.h"

#include <cmath>

#include <fmt/format.h>

#include "multibond/core/structure.h"
#include "multibond/io/diagnostic_codes.h"
#include "multibond/io/did_you_mean.h"

namespace multibond {

namespace {

const std::vector<std::string> kCommonKeys = {"type", "dim", "domain", "components", "description"};

}  // namespace

void ElementReader::ReadElement(const std::string& name, const YAML::Node& spec, const SourceLocation& where, const std::string& prefix,
                                const Env& env) {
  if (!spec.IsMap()) {
    sink_.Error(where, name, "an element is a mapping with at least a 'type'", "write e.g. '{type: C, stiffness: 100}'");
    return;
  }
  if (!spec["type"]) {
    sink_.Error(where, name, "element has no 'type'", "add type: Se, Sf, I, C, R, TF, MTF, GY, MGY, 0, 1 or a submodel name");
    return;
  }
  const std::string type = spec["type"].Scalar();
  const auto kind = ParseKind(type);
  if (!kind) {
    std::vector<std::string> names = {"Se", "Sf", "I", "C", "R", "TF", "MTF", "GY", "MGY", "0", "1"};
    for (const auto& [sm, def] : cx_.submodels) names.push_back(sm);
    const std::string guess = DidYouMean(type, names);
    sink_.Error(Loc(spec["type"]), name, fmt::format("unknown element type '{}'", type),
                guess.empty() ? "use Se, Sf, I, C, R, TF, MTF, GY, MGY, 0, 1 or a submodel name" : fmt::format("did you mean '{}'?", guess));
    return;
  }
  Element e;
  e.name = name;
  e.kind = *kind;
  e.where = where;
  std::vector<std::string> keys = kCommonKeys;
  if (IsTwoPort(e.kind)) keys = {"type", "description"};  // dimensions come from the ratio; domains may differ per port
  auto require = [&](const char* key, const char* hint) {
    if (spec[key]) return true;
    sink_.Error(where, name, fmt::format("{} needs '{}'", KindName(e.kind), key), hint);
    return false;
  };
  switch (e.kind) {
    case ElementKind::kSe:
    case ElementKind::kSf: {
      const char* key = e.kind == ElementKind::kSe ? "effort" : "flow";
      keys.push_back(key);
      if (e.kind == ElementKind::kSf) {
        keys.insert(keys.end(), {"constraint", "compliance"});
        if (spec["constraint"]) e.constraint = Bool(spec["constraint"], name);
        if (spec["compliance"]) {
          if (!e.constraint)
            sink_.Error(Loc(spec["compliance"]), name, "'compliance' belongs to an ideal constraint",
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
        e.source = ReadSource(spec[key], name, env);
      break;
    }
    case ElementKind::kI:
      keys.insert(keys.end(), {"inertia", "p0", "rotation"});
      if (require("inertia", "e.g. inertia: 2.0 (kg, kg m^2, H, ...)")) e.param = ReadParam(spec["inertia"], name, env);
      if (spec["p0"]) e.initial = Vector(spec["p0"], name, env);
      if (spec["rotation"]) e.rotation = Qualify(prefix, Str(spec["rotation"], name));
      break;
    case ElementKind::kC:
      keys.insert(keys.end(), {"stiffness", "compliance", "q0"});
      if (spec["stiffness"] && spec["compliance"]) sink_.Error(where, name, "give either 'stiffness' or 'compliance', not both");
      if (spec["compliance"]) {
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
      break;
    case ElementKind::kR:
      keys.push_back("resistance");
      if (require("resistance", "e.g. resistance: 2.0 (N s/m, N m s/rad, ohm, ...)")) e.param = ReadParam(spec["resistance"], name, env);
      break;
    case ElementKind::kTF:
    case ElementKind::kGY:
      keys.push_back("ratio");
      if (require("ratio", "e.g. ratio: 0.25, or a matrix (rows = port 2, columns = port 1)")) {
        e.param = ReadParam(spec["ratio"], name, env);
        if (e.param.is_scalar && e.param.scalar == 0.0) sink_.Error(Loc(spec["ratio"]), name, "ratio must not be 0");
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
  if (spec["dim"]) {
    const double d = Number(spec["dim"], name, env);
    if (d < 1 || d > 64 || d != std::floor(d)) sink_.Error(Loc(spec["dim"]), name, fmt::format("dim must be a whole number from 1 to 64 (got {:g})", d));
    else e.dim = static_cast<int>(d);
  }
  if (spec["domain"]) e.domain = Domain(spec["domain"], name);
  if (spec["components"])
    e.components = Components(spec["components"], name);
  if (graph_.Find(name) >= 0 || graph_.FindAux(name) >= 0) {
    sink_.Error(where, name, "duplicate name", "give every element and state a unique name");
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
