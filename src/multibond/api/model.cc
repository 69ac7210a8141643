// The public Model: a facade over the loader (io), the compiler (compile) and the simulator (sim).

#include <stdexcept>

#include <fmt/format.h>

#include "multibond/api/lookup.h"
#include "multibond/api/model_impl.h"
#include "multibond/api/run_options.h"
#include "multibond/api/simulation_impl.h"
#include "multibond/compile/compiled_model.h"
#include "multibond/io/model_loader.h"
#include "multibond/multibond.h"
#include "multibond/sim/simulator.h"

namespace multibond {


namespace {

std::vector<ParameterOverride> Overrides(const ParameterValues& values) {
  std::vector<ParameterOverride> out;
  for (const auto& [name, value] : values) out.push_back({name, value});
  return out;
}

}  // namespace

Model::Model(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
Model::Model(Model&&) noexcept = default;
Model& Model::operator=(Model&&) noexcept = default;
Model::~Model() = default;

Model Model::FromFile(const std::string& path, const InputLimits& limits, const ParameterValues& parameters) {
  auto impl = std::make_unique<Impl>();
  impl->lm = LoadModelFile(path, limits, Overrides(parameters));
  impl->limits = limits;
  return Model(std::move(impl));
}

Model Model::FromString(const std::string& yaml, const std::string& file, const InputLimits& limits, const ParameterValues& parameters) {
  auto impl = std::make_unique<Impl>();
  impl->lm = LoadModelString(yaml, file, limits, Overrides(parameters));
  impl->limits = limits;
  return Model(std::move(impl));
}

const std::string& Model::name() const { return impl_->lm.graph.name(); }
const std::vector<Diagnostic>& Model::warnings() const { return impl_->lm.warnings; }

std::vector<std::string> Model::parameter_names() const {
  std::vector<std::string> names;
  for (const ModelParameter& p : impl_->lm.parameters) names.push_back(p.name);
  return names;
}

double Model::parameter(std::string_view name) const {
  for (const ModelParameter& p : impl_->lm.parameters)
    if (p.name == name) return p.value;
  ThrowUnknownName("parameter", name, parameter_names());
}

std::vector<std::string> Model::element_names() const {
  std::vector<std::string> names;
  for (const Element& e : impl_->lm.graph.elements()) names.push_back(e.name);
  return names;
}

namespace {

void SetSource(Element& e, std::span<const double> values) {
  e.source.components.clear();
  for (const double v : values) e.source.components.push_back(TimeFunction::Constant(v));
}

}  // namespace

void Model::SetParameter(std::string_view element, double value) { SetParameter(element, std::span<const double>(&value, 1), 0, 0); }

void Model::SetParameter(std::string_view element, std::span<const double> row_major, int rows, int cols) {
  Element& e = impl_->FindElement(element);
  const bool scalar = rows == 0 && cols == 0 && row_major.size() == 1;
  if (!scalar && (rows <= 0 || cols <= 0 || row_major.size() != static_cast<size_t>(rows) * static_cast<size_t>(cols)))
    throw std::invalid_argument(fmt::format("a {} x {} matrix needs {} values (got {})", rows, cols, rows * cols, row_major.size()));
  if (IsSource(e.kind)) {
    if (!scalar && rows != 1 && cols != 1) throw std::invalid_argument(fmt::format("source '{}' takes a value per component, not a matrix", e.name));
    SetSource(e, row_major);
    return;
  }
  switch (e.kind) {
    case ElementKind::kI:
    case ElementKind::kC:
    case ElementKind::kR:
    case ElementKind::kTF:
    case ElementKind::kGY: break;
    default:
      throw std::invalid_argument(fmt::format("element '{}' ({}) has no parameter to set (I, C, R, TF, GY and sources have)", e.name,
                                              KindName(e.kind)));
  }
  if (scalar) {
    e.param = Param::Scalar(row_major[0]);
  } else {
    Eigen::MatrixXd m(rows, cols);
    for (int r = 0; r < rows; ++r)
      for (int c = 0; c < cols; ++c) m(r, c) = row_major[static_cast<size_t>(r) * cols + c];
    e.param = Param::Matrix(std::move(m));
  }
}

void Model::SetInitial(std::string_view element, std::span<const double> values) {
  Element& e = impl_->FindElement(element);
  if (!IsStorage(e.kind))
    throw std::invalid_argument(fmt::format("element '{}' ({}) has no initial value (I and C have)", e.name, KindName(e.kind)));
  e.initial = Eigen::Map<const Eigen::VectorXd>(values.data(), static_cast<Eigen::Index>(values.size()));
}

void Model::Build(const BuildOptions& options) {
  if (options.jit != "auto" && options.jit != "on" && options.jit != "off")
    throw std::invalid_argument("jit must be 'auto', 'on' or 'off' (got '" + options.jit + "')");
  Impl& m = *impl_;
  m.build = options;
  CompileOptions co = m.lm.compile;
  if (options.ideal_constraints) co.ideal_constraints = *options.ideal_constraints;
  if (options.solve_algebraic_loops) co.solve_algebraic_loops = *options.solve_algebraic_loops;
  std::shared_ptr<const CompiledModel> compiled = CompiledModel::Compile(m.lm.graph, co);
  std::shared_ptr<const GeneratedRhs> code = options.jit != "off" ? GeneratedRhs::Start(compiled) : nullptr;
  if (options.jit == "on" && !code->uses_generated_code()) throw std::runtime_error("jit 'on', but " + code->engine());
  m.lm.compile = co;
  m.compiled = std::move(compiled);
  m.code = std::move(code);
}

bool Model::built() const { return impl_->compiled != nullptr; }
const std::string& Model::rhs_engine() const { return impl_->Engine(); }
const std::vector<std::string>& Model::state_names() const { return impl_->Built().state_names(); }

std::vector<std::string> Model::column_names(bool all_variables) const {
  std::vector<std::string> names;
  for (const Column& c : MakeColumns(impl_->Built(), all_variables)) names.push_back(c.name);
  return names;
}

namespace {

/// Keeps a run's rows column by column.
class ColumnRecorder : public Observer {
 public:
  void OnStart(const std::vector<Column>& columns) override {
    for (const Column& c : columns) {
      names.push_back(c.name);
      units.push_back(c.unit);
    }
    data.resize(columns.size());
  }
  void OnSample(const std::vector<double>& row) override {
    for (size_t c = 0; c < row.size(); ++c) data[c].push_back(row[c]);
  }
  void OnEvent(const EventRecord& e) override { events.push_back({e.time, e.kind, e.element, e.description}); }
  void OnFinish(const RunSummary&) override {}
  std::vector<std::string> names, units;
  std::vector<std::vector<double>> data;
  std::vector<Event> events;
};

Results::Status PublicStatus(RunStatus s) {
  switch (s) {
    case RunStatus::kOk: return Results::Status::kOk;
    case RunStatus::kFailed: return Results::Status::kFailed;
    case RunStatus::kInterrupted: return Results::Status::kInterrupted;
  }
  return Results::Status::kFailed;
}

}  // namespace

Results Model::Simulate(const SimulationOptions& options) {
  if (!built()) Build(impl_->build);
  RunOptions run = ResolveRunOptions(impl_->lm, options, impl_->limits);
  run.code = impl_->code;
  ColumnRecorder recorder;
  const RunSummary s = multibond::Simulate(*impl_->compiled, run, recorder);
  Results::Summary summary{PublicStatus(s.status), s.message, s.t_reached, s.stats.steps, s.stats.rhs_evals, s.wall_seconds,
                           s.energy_residual, s.warnings, std::move(recorder.events)};
  return Results(std::move(recorder.names), std::move(recorder.units), std::move(recorder.data), std::move(summary));
}

Simulation Model::Start(const SimulationOptions& options) {
  if (!built()) Build(impl_->build);
  auto sim = std::make_unique<Simulation::Impl>();
  sim->options = ResolveRunOptions(impl_->lm, options, impl_->limits);
  if (!sim->options.joint_coordinates.empty())
    throw std::invalid_argument("a Simulation advances in inertial coordinates; joint coordinates are for Simulate");
  sim->graph = impl_->lm.graph;
  sim->initial_graph = impl_->lm.graph;
  sim->compile = impl_->lm.compile;
  sim->initial_model = impl_->compiled;
  sim->initial_code = impl_->code;
  sim->Start(impl_->compiled, impl_->code);
  return Simulation(std::move(sim));
}

}  // namespace multibond
