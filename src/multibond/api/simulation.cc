// The public Simulation: an integrator advanced by the caller, over the compiled model. It calls
// the integrator as Simulate does (the same Reset, then AdvanceTo the times asked for, the state
// projected at each), so stepping to the output times of a run gives that run's numbers.

#include <cmath>
#include <optional>
#include <stdexcept>

#include <fmt/format.h>

#include "multibond/api/lookup.h"
#include "multibond/api/simulation_impl.h"

namespace multibond {

void Simulation::Impl::Start(std::shared_ptr<const CompiledModel> compiled, std::shared_ptr<const GeneratedRhs> generated) {
  model = std::move(compiled);
  code = std::move(generated);
  CheckIntegratorOptions(model->num_states(), UsesNewtonMatrix(options.integrator.method) ? model->jacobian_pattern() : nullptr,
                         options.integrator);
  system = std::make_unique<ModelSystem>(*model, nullptr, code.get());
  t = options.t_start;
  x = model->MakeInitialState();
  xdot.resize(x.size());
  // Ideal constraints start satisfied: initial momenta are projected onto them (as Simulate does).
  if (model->has_constraints()) model->Project(t, x.data(), system->workspace());
  Restart();
}

void Simulation::Impl::Restart() {
  integrator = MakeIntegrator(*system, options.integrator);
  integrator->Reset(t, x.data());
  evaluated = false;
}

Workspace& Simulation::Impl::Evaluate() {
  Workspace& ws = system->workspace();
  if (!evaluated) {
    model->CalcDerivatives(t, x.data(), xdot.data(), ws);
    evaluated = true;
  }
  return ws;
}

Simulation::Simulation(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
Simulation::Simulation(Simulation&&) noexcept = default;
Simulation& Simulation::operator=(Simulation&&) noexcept = default;
Simulation::~Simulation() = default;

double Simulation::time() const { return impl_->t; }

void Simulation::Reset() {
  Impl& s = *impl_;
  s.graph = s.initial_graph;
  s.Start(s.initial_model, s.initial_code);
}

void Simulation::AdvanceTo(double t) {
  Impl& s = *impl_;
  if (!(t >= s.t) || !std::isfinite(t))
    throw std::invalid_argument(fmt::format("AdvanceTo({}) from t = {}: a simulation advances to a later finite time", t, s.t));
  if (t == s.t) return;
  s.evaluated = false;
  try {
    s.integrator->AdvanceTo(t, s.x.data());
  } catch (const SolverError&) {
    s.t = s.integrator->time();
    throw;
  }
  s.t = t;
  // Between steps the integrator reports an interpolant; its orientations are projected onto
  // rotations (and momenta onto ideal constraints) as a run's output rows are.
  if (s.options.integrator.project && s.model->has_invariants()) s.model->Project(t, s.x.data(), s.system->workspace());
}

const std::vector<std::string>& Simulation::state_names() const { return impl_->model->state_names(); }

std::vector<double> Simulation::state() const { return {impl_->x.data(), impl_->x.data() + impl_->x.size()}; }

void Simulation::SetState(std::span<const double> x) {
  Impl& s = *impl_;
  if (x.size() != static_cast<size_t>(s.x.size()))
    throw std::invalid_argument(fmt::format("the model has {} states (got {} values)", s.x.size(), x.size()));
  s.x = Eigen::Map<const Eigen::VectorXd>(x.data(), s.x.size());
  s.Restart();
}

namespace {

/// The variable called `name` and the component asked for (-1: all): a variable or state of the
/// model, a declared output that names one, or either with ".<component>".
std::optional<std::pair<VariableRef, int>> TryFindValue(const CompiledModel& m, const std::string& name) {
  for (const OutputDecl& o : m.graph().outputs())
    if (o.kind == OutputDecl::Kind::kVariable && o.name == name) return TryFindValue(m, o.variable);
  if (auto v = m.FindVariable(name)) return std::pair{*v, -1};
  const size_t dot = name.rfind('.');
  if (dot == std::string::npos) return std::nullopt;
  const auto whole = TryFindValue(m, name.substr(0, dot));
  if (!whole || whole->second >= 0) return std::nullopt;
  const std::vector<std::string>& components = whole->first.components;
  for (size_t c = 0; c < components.size(); ++c)
    if (components[c] == name.substr(dot + 1)) return std::pair{whole->first, static_cast<int>(c)};
  return std::nullopt;
}

std::pair<VariableRef, int> FindValue(const CompiledModel& m, std::string_view name) {
  if (auto found = TryFindValue(m, std::string(name))) return *found;
  std::vector<std::string> known = m.state_names();
  for (int c = 0; c < m.num_slot_classes(); ++c) known.push_back(m.slot_class_name(c));
  for (const OutputDecl& o : m.graph().outputs())
    if (o.kind == OutputDecl::Kind::kVariable) known.push_back(o.name);
  ThrowUnknownName("variable", name, known);
}

}  // namespace

std::vector<double> Simulation::Values(std::string_view name) const {
  Impl& s = *impl_;
  const auto [v, component] = FindValue(*s.model, name);
  std::vector<double> out(v.size);
  s.model->Read(v, s.x.data(), s.Evaluate(), out.data());
  if (component >= 0) return {out[component]};
  return out;
}

double Simulation::Value(std::string_view name) const {
  const std::vector<double> v = Values(name);
  if (v.size() != 1)
    throw std::invalid_argument(fmt::format("'{}' has {} components: ask for one ('{}.<component>') or use Values", name, v.size(), name));
  return v[0];
}

std::vector<std::string> Simulation::input_names() const {
  std::vector<std::string> names;
  for (const Element& e : impl_->graph.elements())
    if (IsSource(e.kind)) names.push_back(e.name);
  return names;
}

void Simulation::SetInput(std::string_view source, double value) { SetInput(source, std::span<const double>(&value, 1)); }

void Simulation::SetInput(std::string_view source, std::span<const double> values) {
  Impl& s = *impl_;
  const int i = s.graph.Find(std::string(source));
  if (i < 0 || !IsSource(s.graph.element(i).kind)) ThrowUnknownName("source", source, input_names());
  if (values.empty()) throw std::invalid_argument(fmt::format("SetInput('{}') needs a value", source));
  Element& e = s.graph.element(i);
  e.source.components.clear();
  for (const double v : values) e.source.components.push_back(TimeFunction::Constant(v));
  auto rebuilt = CompiledModel::Compile(s.graph, s.compile);  // checks the number of components (param.range)
  // A source's value changes no state: the state carries over to the rebuilt model.
  MB_ASSERT(rebuilt->state_names() == s.model->state_names(), "a source's value changed the state layout");
  // Generated code as before, its numbers from a table: every later input reuses the library.
  std::shared_ptr<const GeneratedRhs> code;
  if (s.code) {
    GenerateOptions go;
    go.value_table = true;
    code = GeneratedRhs::Start(rebuilt, go);
  }
  s.system.reset();  // it refers to the model it replaces
  s.model = std::move(rebuilt);
  s.code = std::move(code);
  s.system = std::make_unique<ModelSystem>(*s.model, nullptr, s.code.get());
  s.Restart();
}

}  // namespace multibond
