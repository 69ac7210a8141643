#include "multibond/api/run_options.h"

#include <stdexcept>

namespace multibond {

RunOptions ResolveRunOptions(const LoadedModel& lm, const SimulationOptions& given, const InputLimits& limits) {
  const SimulationDefaults& file = lm.simulation;
  RunOptions o;
  o.t_start = given.t_start;
  o.t_end = given.t_end.value_or(file.t_end.value_or(kDefaultEndTime));
  o.dt = given.dt.value_or(file.dt.value_or(kDefaultOutputInterval));
  IntegratorOptions& i = o.integrator;
  i.method = ParseMethod(given.solver.value_or(file.solver.value_or(kDefaultSolver)));
  i.rtol = given.rtol.value_or(file.rtol.value_or(kDefaultRtol));
  i.atol = given.atol.value_or(file.atol.value_or(kDefaultAtol));
  i.fixed_step = given.step.value_or(file.step.value_or(0.0));
  // The file's fixed step belongs to the file's solver: a step-choosing solver given explicitly
  // leaves it (a step given with it is refused by the run).
  if (!given.step && given.solver && UsesNewtonMatrix(i.method)) i.fixed_step = 0.0;
  i.max_step = given.max_step.value_or(file.max_step.value_or(0.0));
  i.project = given.project;
  i.jacobian = ParseJacobianKind(given.jacobian);
  const std::string coordinates = given.coordinates.value_or(file.coordinates.value_or("inertial"));
  if (coordinates == "joint") {
    if (!lm.mechanism || lm.mechanism->empty())
      throw std::invalid_argument("joint coordinates are for mechanisms: the model has no bodies");
    o.joint_coordinates = lm.mechanism->MakeJointTree();
  } else if (coordinates != "inertial") {
    throw std::invalid_argument("coordinates must be 'inertial' or 'joint' (got '" + coordinates + "')");
  }
  o.all_variables = given.all_variables;
  // Events (docs/events.md): the options over the file's `simulation:` keys over the defaults.
  o.event_rest_time = given.event_rest_time.value_or(file.event_rest_time.value_or(0.0));
  o.max_events_per_second = given.max_events_per_second.value_or(file.max_events_per_second.value_or(o.max_events_per_second));
  o.stop = given.stop;
  o.max_forced_steps = static_cast<double>(limits.steps);
  return o;
}

}  // namespace multibond
