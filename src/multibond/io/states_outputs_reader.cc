#include "multibond/io/states_outputs_reader.h"

#include <fmt/format.h>

#include "multibond/core/identifier.h"
#include "multibond/core/units.h"
#include "multibond/io/diagnostic_codes.h"
#include "multibond/io/did_you_mean.h"

namespace multibond {

void StatesOutputsReader::ReadStates(const YAML::Node& n, const std::string& prefix, const Env& env) {
  if (!n.IsMap()) {
    sink_.Error(Loc(n), "states", "'states' must be a mapping of names to {kind: orientation|integral, of: ...}");
    return;
  }
  for (const auto& kv : n) {
    const std::string name = Qualify(prefix, kv.first.Scalar());
    const YAML::Node s = kv.second;
    if (!CheckName(kv.first.Scalar(), Loc(kv.first), "a state's")) continue;
    AuxState a;
    a.name = name;
    a.where = Loc(kv.first);
    if (!s.IsMap()) {
      sink_.Error(a.where, name, "a state is a mapping {kind: ..., of: ...}");
      continue;
    }
    CheckKeys(s, {"kind", "of", "initial", "components", "unit", "description"}, name);
    const std::string kind = s["kind"] ? s["kind"].Scalar() : "";
    if (kind == "orientation") a.kind = AuxState::Kind::kOrientation;
    else if (kind == "integral") a.kind = AuxState::Kind::kIntegral;
    else {
      const std::string guess = DidYouMean(kind, {"orientation", "integral"});
      sink_.Error(s["kind"] ? Loc(s["kind"]) : a.where, name, fmt::format("unknown state kind '{}'", kind),
                  guess.empty() ? "use kind: orientation or kind: integral" : fmt::format("did you mean '{}'?", guess));
      continue;
    }
    if (!s["of"]) {
      sink_.Error(a.where, name, "state needs 'of': the 1-junction or one-port whose flow it integrates");
      continue;
    }
    a.of = Qualify(prefix, s["of"].Scalar());
    if (s["initial"]) {
      if (a.kind == AuxState::Kind::kOrientation) {
        a.initial = Matrix(s["initial"], name, env);
        if (a.initial.rows() != 3 || a.initial.cols() != 3) sink_.Error(Loc(s["initial"]), name, "an orientation's initial value is a 3x3 matrix");
        else if (!(a.initial.transpose() * a.initial).isApprox(Eigen::Matrix3d::Identity(), 1e-9) || a.initial.determinant() < 0)
          sink_.Error(Loc(s["initial"]), name, "the initial orientation is not a rotation matrix (R^T R = I, det R = +1)");
      } else {
        a.initial = Vector(s["initial"], name, env);
      }
    }
    if (s["components"])
      a.components = Components(s["components"], name);
    if (s["unit"]) {
      // A unit labels columns and reaches gnuplot scripts and HTML: only the unit grammar passes.
      a.unit = Str(s["unit"], name);
      if (const std::string problem = UnitProblem(a.unit); !problem.empty()) {
        sink_.Error(codes::kUnitInvalid, Loc(s["unit"]), name, fmt::format("the unit '{}' is refused: {}", PrintableExcerpt(a.unit), problem),
                    "write SI symbols with an optional prefix, separated by spaces or '*', one '/', whole exponents: "
                    "e.g. m, rad, N m, kg m^2, rad/s, m s^-2; '-' for none");
        a.unit.clear();
      }
    }
    if (graph_.Find(name) >= 0 || graph_.FindAux(name) >= 0) {
      sink_.Error(a.where, name, "duplicate name", "give every element and state a unique name");
      continue;
    }
    graph_.AddAux(std::move(a));
  }
}

void StatesOutputsReader::ReadOutputs(const YAML::Node& n) {
  if (!n.IsSequence()) {
    sink_.Error(Loc(n), "outputs", "'outputs' must be a list", "e.g. '- spring.e' or '- {name: position, variable: spring.q}'");
    return;
  }
  for (const auto& o : n) {
    OutputDecl d;
    d.where = Loc(o);
    if (o.IsScalar()) {
      d.name = d.variable = o.Scalar();
    } else if (o.IsMap()) {
      CheckKeys(o, {"name", "variable"}, "output");
      if (!o["variable"]) {
        sink_.Error(d.where, "output", "an output needs 'variable'");
        continue;
      }
      d.variable = o["variable"].Scalar();
      d.name = o["name"] ? o["name"].Scalar() : d.variable;
      if (o["name"] && !CheckName(d.name, Loc(o["name"]), "an output's")) continue;
    } else {
      sink_.Error(d.where, "output", "an output is a variable name or {name: ..., variable: ...}");
      continue;
    }
    graph_.AddOutput(d);
  }
}

}  // namespace multibond
