#include "multibond/io/states_outputs_reader.h"

#include <cmath>
#include <utility>

#include <fmt/format.h>

#include "multibond/core/identifier.h"
#include "multibond/core/units.h"
#include "multibond/core/diagnostic_codes.h"
#include "multibond/io/did_you_mean.h"
#include "multibond/io/model_parameters.h"

namespace multibond {

namespace {

const char* kUnitHint =
    "write SI symbols with an optional prefix, separated by spaces or '*', one '/', whole exponents: "
    "e.g. m, rad, N m, kg m^2, rad/s, m s^-2; '-' for none";

}  // namespace

/// A name that formulas read bare (a state, a signal) must not be a parameter's, nor, for a
/// signal, an element's or a state's.
bool StatesOutputsReader::NameIsFree(const std::string& name, const SourceLocation& where, const char* what) {
  const char* taken = nullptr;
  if (cx_.FindParameter(name)) taken = "a parameter";
  else if (std::string(what) == "a signal" && (graph_.Find(name) >= 0 || graph_.FindAux(name) >= 0))
    taken = graph_.Find(name) >= 0 ? "an element" : "a state";
  else if (std::string(what) == "a state" && cx_.signal_names.count(name)) taken = "a signal";
  if (!taken) return true;
  sink_.Error(codes::kNameDuplicate, where, name, fmt::format("{} may not be named like {} ('{}')", what, taken, name),
              "a formula names both by their bare name: give one of them another name");
  return false;
}

void StatesOutputsReader::ReadStates(const YAML::Node& n, const std::string& prefix, const Env& env) {
  if (!n.IsMap()) {
    sink_.Error(codes::kYamlStructure, Loc(n), "states", "'states' must be a mapping of names to {kind: orientation|integral|lag|pid, ...}");
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
      sink_.Error(codes::kYamlStructure, a.where, name, "a state is a mapping {kind: ..., of: ...}");
      continue;
    }
    const std::string kind = s["kind"] ? s["kind"].Scalar() : "";
    std::vector<std::string> keys;
    if (kind == "orientation" || kind == "integral") {
      a.kind = kind == "orientation" ? AuxState::Kind::kOrientation : AuxState::Kind::kIntegral;
      keys = {"kind", "of", "initial", "components", "unit", "description"};
      if (kind == "integral") keys.push_back("rate");
    } else if (kind == "lag") {
      a.kind = AuxState::Kind::kLag;
      keys = {"kind", "input", "time_constant", "initial", "unit", "description"};
    } else if (kind == "pid") {
      a.kind = AuxState::Kind::kPid;
      keys = {"kind", "input", "kp", "ki", "kd", "tf", "tt", "min", "max", "initial", "unit", "description"};
    } else {
      const std::string guess = DidYouMean(kind, {"orientation", "integral", "lag", "pid"});
      sink_.Error(codes::kValueUnknown, s["kind"] ? Loc(s["kind"]) : a.where, name, fmt::format("unknown state kind '{}'", kind),
                  guess.empty() ? "use kind: orientation, integral, lag or pid" : fmt::format("did you mean '{}'?", guess));
      continue;
    }
    CheckKeys(s, keys, name);
    law_keys_hint_ = "this value is a constant; what changes in time is the state's 'rate' (integral) or 'input' (lag, pid)";
    const FormulaScope scope{&env, prefix, {}, "state's formula"};
    bool good = true;
    auto formula = [&](const char* key, Formula& out) {
      if (const std::optional<Formula> f = ReadFormula(s[key], name, scope)) out = *f;
      else good = false;
    };
    auto number = [&](const char* key, double dflt) {
      if (!s[key]) return dflt;
      bool ok = true;
      const double v = Number(s[key], name, env, &ok);
      good = good && ok;
      return ok ? v : dflt;
    };
    auto range = [&](const char* key, const std::string& message, const char* hint) {
      sink_.Error(codes::kParamRange, s[key] ? Loc(s[key]) : a.where, name, message, hint);
      good = false;
    };
    if (a.kind == AuxState::Kind::kIntegral && s["rate"]) {
      // A signal state: dx/dt = rate, a formula.
      if (s["of"]) sink_.Error(codes::kKeyConflict, Loc(s["of"]), name, "give 'of' (a flow to integrate) or 'rate' (a formula), not both");
      formula("rate", a.rate);
      if (s["components"]) sink_.Error(codes::kKeyConflict, Loc(s["components"]), name, "a state with a 'rate' is scalar: it has no components");
    } else if (a.kind == AuxState::Kind::kIntegral || a.kind == AuxState::Kind::kOrientation) {
      if (!s["of"]) {
        sink_.Error(codes::kStateOf, a.where, name,
                    a.kind == AuxState::Kind::kIntegral
                        ? "state needs 'of': the 1-junction or one-port whose flow it integrates (or 'rate': a formula)"
                        : "state needs 'of': the 1-junction or one-port whose flow it integrates");
        continue;
      }
      a.of = Qualify(prefix, s["of"].Scalar());
    } else {
      if (!s["input"]) {
        sink_.Error(codes::kKeyMissing, a.where, name, fmt::format("a {} state needs 'input': the formula of the signal it {}", kind,
                                               a.kind == AuxState::Kind::kLag ? "follows" : "controls (the error)"),
                    "e.g. input: \"setpoint - shaft.f\"");
        continue;
      }
      formula("input", a.input);
    }
    if (a.kind == AuxState::Kind::kLag) {
      if (!s["time_constant"]) {
        sink_.Error(codes::kKeyMissing, a.where, name, "a lag needs 'time_constant' [s]", "e.g. time_constant: 0.1");
        good = false;
      }
      a.time_constant = number("time_constant", 0.0);
      if (s["time_constant"] && good && !(a.time_constant > 0))
        range("time_constant", fmt::format("time_constant must be > 0 (got {:g})", a.time_constant), "the lag's time constant is in seconds");
    }
    if (a.kind == AuxState::Kind::kPid) {
      AuxState::Pid& c = a.pid;
      c.kp = number("kp", 0.0);
      c.ki = number("ki", 0.0);
      c.kd = number("kd", 0.0);
      c.tf = number("tf", 0.0);
      c.tt = number("tt", 0.0);
      c.u_min = number("min", -HUGE_VAL);
      c.u_max = number("max", HUGE_VAL);
      for (const auto& [key, v] : {std::pair{"kp", c.kp}, std::pair{"ki", c.ki}, std::pair{"kd", c.kd}})
        if (v < 0)
          range(key, fmt::format("{} must be >= 0 (got {:g})", key, v), "for a controller that acts the other way, negate its input");
      if (c.kp == 0 && c.ki == 0 && c.kd == 0 && good)
        range("kp", "a PID needs a gain: kp, ki or kd > 0", "e.g. kp: 2.0, ki: 0.5");
      for (const auto& [key, v] : {std::pair{"tf", c.tf}, std::pair{"tt", c.tt}})
        if (v < 0) range(key, fmt::format("{} must be >= 0 (got {:g})", key, v), "a time constant is in seconds (tt: 0 chooses one)");
      if (c.kd > 0 && !(c.tf > 0))
        range(s["tf"] ? "tf" : "kd", "a derivative part (kd > 0) needs its filter time constant tf > 0",
              "e.g. tf: 0.01 (a few times shorter than the time scale the derivative should see)");
      if (s["min"] && s["max"] && !(c.u_min < c.u_max))
        range("max", fmt::format("max must be > min (got min {:g}, max {:g})", c.u_min, c.u_max), "the output is clamped to [min, max]");
    }
    if (s["initial"]) {
      // A constant, like the gains: a number or a formula of parameters (which --set changes).
      constant_rule_ = "an initial value is a constant: a number or a formula of parameters";
      if (a.kind == AuxState::Kind::kOrientation) {
        a.initial = Matrix(s["initial"], name, env);
        if (a.initial.rows() != 3 || a.initial.cols() != 3) sink_.Error(codes::kYamlStructure, Loc(s["initial"]), name, "an orientation's initial value is a 3x3 matrix");
        else if (!(a.initial.transpose() * a.initial).isApprox(Eigen::Matrix3d::Identity(), 1e-9) || a.initial.determinant() < 0)
          sink_.Error(codes::kParamRange, Loc(s["initial"]), name, "the initial orientation is not a rotation matrix (R^T R = I, det R = +1)");
      } else {
        a.initial = Vector(s["initial"], name, env);
        if (a.kind == AuxState::Kind::kPid && a.initial.size() > 1)
          sink_.Error(codes::kParamRange, Loc(s["initial"]), name,
                      fmt::format("a PID's initial value is that of its integral state '{}.i': one number (got {})", name, a.initial.size()),
                      "to start at a steady output u0 with zero error, initial: u0/ki");
        else if ((a.rate.given() || a.kind == AuxState::Kind::kLag) && a.initial.size() > 1)
          sink_.Error(codes::kParamRange, Loc(s["initial"]), name, fmt::format("the state is scalar: its initial value is one number (got {})", a.initial.size()));
        else if (a.kind == AuxState::Kind::kPid && a.pid.ki == 0.0 && a.initial.size() == 1 && a.initial(0, 0) != 0.0)
          sink_.Error(codes::kParamRange, Loc(s["initial"]), name,
                      fmt::format("a PID without ki has no integral action: its integral state '{}.i' has no effect, so its initial value "
                                  "must be 0 (got {:g})",
                                  name, a.initial(0, 0)),
                      "give ki > 0, or leave out 'initial'");
      }
      constant_rule_.clear();
    }
    if (s["components"] && !a.rate.given())
      a.components = Components(s["components"], name);
    if (s["unit"]) {
      // A unit labels columns and reaches gnuplot scripts and HTML: only the unit grammar passes.
      a.unit = Str(s["unit"], name);
      if (const std::string problem = UnitProblem(a.unit); !problem.empty()) {
        sink_.Error(codes::kUnitInvalid, Loc(s["unit"]), name, fmt::format("the unit '{}' is refused: {}", PrintableExcerpt(a.unit), problem), kUnitHint);
        a.unit.clear();
      }
    }
    if (!good) continue;
    if (graph_.Find(name) >= 0 || graph_.FindAux(name) >= 0) {
      sink_.Error(codes::kNameDuplicate, a.where, name, "duplicate name", "give every element and state a unique name");
      continue;
    }
    if (!NameIsFree(name, a.where, "a state")) continue;
    graph_.AddAux(std::move(a));
  }
}

void StatesOutputsReader::ReadSignals(const YAML::Node& n) {
  if (!n.IsMap()) {
    sink_.Error(codes::kYamlStructure, Loc(n), "signals", "'signals' maps each name to its formula",
                "write e.g. signals: {error: \"setpoint - shaft.f\", torque: {value: \"k*error\", unit: N m}}");
    return;
  }
  law_keys_hint_ = "";
  for (const auto& kv : n) {
    const std::string name = kv.first.Scalar();
    const SourceLocation where = Loc(kv.first);
    if (!CheckName(name, where, "a signal's")) continue;
    if (IsReservedInFormulas(name)) {
      sink_.Error(codes::kNameInvalid, where, name,
                  fmt::format("a signal may not be named '{}': in formulas {}", name,
                              name == "t" ? "'t' is time" : name == "pi" ? "'pi' is 3.14159..." : "it names an element's own variable in its law"),
                  "choose another name");
      continue;
    }
    Signal sig;
    sig.name = name;
    sig.where = where;
    YAML::Node v = kv.second;
    if (v.IsMap()) {
      CheckKeys(v, {"value", "unit", "description"}, name);
      if (v["unit"]) {
        sig.unit = Str(v["unit"], name);
        if (const std::string problem = UnitProblem(sig.unit); !problem.empty()) {
          sink_.Error(codes::kUnitInvalid, Loc(v["unit"]), name, fmt::format("the unit '{}' is refused: {}", PrintableExcerpt(sig.unit), problem), kUnitHint);
          sig.unit.clear();
        }
      }
      if (!v["value"]) {
        sink_.Error(codes::kKeyMissing, where, name, "a signal given as a mapping needs 'value': its formula", "write e.g. {value: \"k*error\", unit: N m}");
        continue;
      }
      v = v["value"];
    }
    const std::optional<Formula> f = ReadFormula(v, name, FormulaScope{nullptr, "", {}, "signal"});
    if (!f || !NameIsFree(name, where, "a signal")) continue;
    sig.value = *f;
    graph_.AddSignal(std::move(sig));  // a name given twice is a YAML error (yaml.duplicate_key)
  }
}

void StatesOutputsReader::ReadOutputs(const YAML::Node& n) {
  if (!n.IsSequence()) {
    sink_.Error(codes::kYamlStructure, Loc(n), "outputs", "'outputs' must be a list", "e.g. '- spring.e' or '- {name: position, variable: spring.q}'");
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
        sink_.Error(codes::kKeyMissing, d.where, "output", "an output needs 'variable'");
        continue;
      }
      d.variable = o["variable"].Scalar();
      d.name = o["name"] ? o["name"].Scalar() : d.variable;
      if (o["name"] && !CheckName(d.name, Loc(o["name"]), "an output's")) continue;
    } else {
      sink_.Error(codes::kYamlStructure, d.where, "output", "an output is a variable name or {name: ..., variable: ...}");
      continue;
    }
    graph_.AddOutput(d);
  }
}

}  // namespace multibond
