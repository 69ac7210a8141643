#include "multibond/io/settings_reader.h"

#include <stdexcept>

#include <fmt/format.h>

#include "multibond/core/diagnostic_codes.h"
#include "multibond/sim/simulator.h"

namespace multibond {

void SettingsReader::ReadCompileSettings(const YAML::Node& root, CompileOptions& options) {
  if (root["domain"]) options.default_domain = Domain(root["domain"], "domain");
  if (root["constraints"]) {
    const std::string c = root["constraints"].IsScalar() ? root["constraints"].Scalar() : "";
    if (c == "ideal") options.ideal_constraints = true;
    else if (c != "compliant")
      sink_.Error(codes::kValueUnknown, Loc(root["constraints"]), "constraints", fmt::format("unknown constraints '{}'", c),
                  "write 'constraints: ideal' (derivative causality solved exactly) or 'constraints: compliant' (the default)");
  }
  if (root["algebraic_loops"]) {
    const std::string c = root["algebraic_loops"].IsScalar() ? root["algebraic_loops"].Scalar() : "";
    if (c == "solve") options.solve_algebraic_loops = true;
    else if (c != "error")
      sink_.Error(codes::kValueUnknown, Loc(root["algebraic_loops"]), "algebraic_loops", fmt::format("unknown algebraic_loops '{}'", c),
                  "write 'algebraic_loops: solve' (each loop solved as a linear system at every evaluation) or "
                  "'algebraic_loops: error' (the default: a loop is reported and the model refused)");
  }
}

/// `mechanism`: the model has bodies (joint coordinates need them).
void SettingsReader::ReadSimulation(const YAML::Node& n, SimulationDefaults& s, bool mechanism) {
  if (!n.IsMap()) {
    sink_.Error(codes::kYamlStructure, Loc(n), "simulation", "'simulation' is a mapping of settings", "write e.g. simulation: {t_end: 5, dt: 0.001}");
    return;
  }
  CheckKeys(n, {"t_end", "dt", "solver", "rtol", "atol", "step", "max_step", "coordinates", "event_rest_time", "max_events_per_second", "initial"},
            "simulation");
  const Env none;
  // `zero`: 0 is allowed (it means "the built-in choice").
  auto number = [&](const char* key, std::optional<double>& out, bool zero) {
    if (!n[key]) return;
    bool ok = true;
    const double v = Number(n[key], fmt::format("simulation.{}", key), none, &ok);  // the key it is wrong in
    if (!ok) return;  // said by Number
    if (!(zero ? v >= 0 : v > 0))
      sink_.Error(codes::kParamRange, Loc(n[key]), "simulation", fmt::format("{} must be {} 0 (got {:g})", key, zero ? ">=" : ">", v));
    out = v;
  };
  auto positive = [&](const char* key, std::optional<double>& out) { number(key, out, false); };
  positive("t_end", s.t_end);
  positive("dt", s.dt);
  positive("rtol", s.rtol);
  positive("atol", s.atol);
  positive("step", s.step);
  positive("max_step", s.max_step);
  number("event_rest_time", s.event_rest_time, true);
  positive("max_events_per_second", s.max_events_per_second);
  // What the run would refuse of these settings is an error of the file, here, not at 'run'.
  auto check_together = [&](const char* key, auto&& check) {
    try {
      check();
    } catch (const std::invalid_argument& e) {
      sink_.Error(codes::kParamRange, Loc(n[key]), "simulation", e.what());
    }
  };
  if (s.rtol && *s.rtol > 0) check_together("rtol", [&] { CheckRelativeTolerance(*s.rtol); });
  bool span_ok = true;
  if (s.t_end && *s.t_end > 0) {
    try {
      CheckEndTime(0.0, *s.t_end);
    } catch (const std::invalid_argument& e) {
      sink_.Error(codes::kParamRange, Loc(n["t_end"]), "simulation.t_end", e.what());
      span_ok = false;
    }
  }
  if (span_ok && s.t_end && s.dt && *s.t_end > 0 && *s.dt > 0) check_together("dt", [&] { CheckOutputGrid(0.0, *s.t_end, *s.dt); });
  if (s.step && s.dt) check_together("step", [&] { CheckFixedStep(*s.step, *s.dt); });
  if (const YAML::Node c = n["coordinates"]) {
    if (!c.IsScalar() || (c.Scalar() != "joint" && c.Scalar() != "inertial"))
      sink_.Error(codes::kValueUnknown, Loc(c), "simulation", "'coordinates' is joint or inertial",
                  "joint: the integrator advances each body relative to its tree joint; inertial: the model's own states");
    else if (c.Scalar() == "joint" && !mechanism)
      sink_.Error(codes::kKeyMissing, Loc(c), "simulation", "joint coordinates are for mechanisms: the model has no bodies", "remove 'coordinates'");
    else
      s.coordinates = c.Scalar();
  }
  if (const YAML::Node c = n["initial"]) {
    if (!c.IsScalar() || (c.Scalar() != "model" && c.Scalar() != "steady"))
      sink_.Error(codes::kValueUnknown, Loc(c), "simulation", fmt::format("'initial' is model or steady (got {})", Describe(c)),
                  "model: the initial values the elements and states give; steady: the steady state found from them at the start");
    else
      s.initial = c.Scalar();
  }
  if (n["solver"]) {
    s.solver = n["solver"].Scalar();
    try {
      const Method method = ParseMethod(*s.solver);
      if (method == Method::kRk4 && !s.step)
        sink_.Error(codes::kKeyConflict, Loc(n["solver"]), "simulation", "rk4 is a fixed-step method and needs 'step'", "add step: 1.0e-4 (or use dopri5)");
      if (UsesNewtonMatrix(method) && s.step)
        sink_.Error(codes::kKeyConflict, Loc(n["step"]), "simulation", fmt::format("{} chooses its own steps: a fixed 'step' is for {}", *s.solver, kFixedStepMethodNames),
                    "bound its steps with max_step instead");
    } catch (const std::invalid_argument& e) {
      sink_.Error(codes::kValueUnknown, Loc(n["solver"]), "simulation", e.what());
    }
  }
}

}  // namespace multibond
