// The public Model's linear analysis: the operating point (a run to it, a steady state), the
// linear model in std types, and its modes (analysis layer: linearize.h, modes.h).

#include <stdexcept>

#include <fmt/format.h>

#include "multibond/analysis/linearize.h"
#include "multibond/analysis/modes.h"
#include "multibond/api/model_impl.h"
#include "multibond/api/run_options.h"

namespace multibond {

namespace {

Matrix ToMatrix(const Eigen::MatrixXd& m) {
  Matrix out{static_cast<int>(m.rows()), static_cast<int>(m.cols()), {}};
  out.data.reserve(static_cast<std::size_t>(m.size()));
  for (Eigen::Index r = 0; r < m.rows(); ++r)
    for (Eigen::Index c = 0; c < m.cols(); ++c) out.data.push_back(m(r, c));
  return out;
}

/// The engine's linear model about `point`: the state at its time (a run there from the start,
/// with `options`), then the steady state near it when asked.
linear::LinearModel LinearizeAt(const CompiledModel& model, const RunOptions& options, const OperatingPoint& point) {
  std::string why;
  if (!model.can_linearize(&why)) throw std::invalid_argument(fmt::format("cannot linearise a model with {}", why));
  double t = options.t_start;
  Eigen::VectorXd x = model.MakeInitialState();
  if (point.at && *point.at != options.t_start) {
    const RunOptions to = linear::RunToOperatingPoint(options, *point.at, "OperatingPoint::at");
    linear::FinalState last;
    const RunSummary s = Simulate(model, to, last);
    if (s.status != RunStatus::kOk)
      throw SolverError(s.t_reached, "operating point", fmt::format("the run to the operating point at t = {:g} s stopped: {}", *point.at, s.message));
    t = *point.at;
    x = last.State(model.num_states());
  }
  if (point.steady) x = linear::FindSteadyState(model, t, x);
  linear::LinearModel lm = linear::Linearize(model, t, x);
  lm.steady = point.steady;
  return lm;
}

}  // namespace

LinearModel Model::Linearize(const OperatingPoint& point, const SimulationOptions& options) {
  if (!built()) Build(impl_->build);
  const linear::LinearModel lm = LinearizeAt(*impl_->compiled, ResolveRunOptions(impl_->lm, options, impl_->limits), point);
  return LinearModel{lm.at,           lm.steady,      lm.states,      lm.state_units, lm.inputs,      lm.input_units,
                     lm.outputs,      lm.output_units, ToMatrix(lm.A), ToMatrix(lm.B), ToMatrix(lm.C), ToMatrix(lm.D),
                     lm.notes};
}

std::vector<Mode> Model::Modes(const OperatingPoint& point, const SimulationOptions& options) {
  if (!built()) Build(impl_->build);
  const linear::LinearModel lm = LinearizeAt(*impl_->compiled, ResolveRunOptions(impl_->lm, options, impl_->limits), point);
  std::vector<Mode> out;
  for (const linear::Mode& m : linear::ComputeModes(lm))
    out.push_back(Mode{m.eigenvalue, m.frequency_hz, m.damped_frequency_hz, m.damping_ratio, m.time_constant_s, m.participation,
                       m.conjugate_pair});
  return out;
}

}  // namespace multibond
