#include "multibond/compile/compiled_model.h"

#include <chrono>

#include "multibond/core/diagnostic_codes.h"

namespace multibond {

std::shared_ptr<const CompiledModel> CompiledModel::Compile(BondGraph graph, const CompileOptions& options) {
  std::shared_ptr<CompiledModel> m(new CompiledModel());
  m->graph_ = std::move(graph);
  m->options_ = options;
  m->Build();
  return m;
}

void CompiledModel::Build() {
  // Each pass reads what the ones before it made (docs/design.md, "The compiled model's parts
  // and passes").
  // Each pass's time (compile_seconds): causality, the plan, the ideal constraints, the code.
  using Clock = std::chrono::steady_clock;
  Clock::time_point mark = Clock::now();
  auto lap = [&](const char* phase) {
    const Clock::time_point now = Clock::now();
    compile_seconds_.emplace_back(phase, std::chrono::duration<double>(now - mark).count());
    mark = now;
  };
  PrepareConstraintGraph();  // structure, causality; ideal constraints become effort sources
  lap("causality");
  AssignSlots();             // slot classes, their names; the multipliers' offsets
  layout_ = StateLayout({graph_, structure_, effort_class_, flow_class_, class_offset_, class_size_, class_units_,
                         signal_class_, internal_class_, signal_state_units_, options_.energy_account});  // blocks, x0, gathers, names
  AnalyzeModulatedStorage();  // modulated_storage.cc: storage laws that read t, signals, other states
  energy_ = EnergyAccount({graph_, layout_, [this](int element, int state) {
                             return StoredEnergyFormula(element, state);  // formulas.cc
                           }});  // each I's and C's stored energy
  const std::vector<int> modulus_of = PlanModuli();
  const PlanDeps deps = OrderPlan(EmitInstructions(modulus_of));  // plan_, tears_, tear_closure_
  for (int at : tear_closure_) tear_nonlinear_ = tear_nonlinear_ || plan_[at].op == Op::kExpr || plan_[at].op == Op::kSolve;
  RefuseUnbookedModulation();  // modulated_storage.cc: after the order, so that a loop is reported as one
  needed_moduli_ = plan::Specialize(plan_, coef_, sum_terms_, sum_signs_, moduli_);
  if (!tears_.empty() && !constraints_.empty()) {
    Diagnostic d;
    d.code = codes::kCausalityAlgebraicLoop;
    d.where = graph_.element(algebraic_loops_.front().element).where;
    d.element = graph_.element(algebraic_loops_.front().element).name;
    d.message = "algebraic loops are not solved in a model with ideal constraints (yet)";
    for (const AlgebraicLoop& loop : algebraic_loops_) d.details.push_back("loop: " + loop.path);
    d.hint = "add a storage element in the loop, or use compliant joints";
    throw ModelError(d);
  }
  lap("compile_plan");
  BuildConstraints(deps.reads, deps.writes);  // constraints.cc
  BuildSwitches();                            // switching.cc
  FindIndependentConstraints();
  lap("constraints");
}

std::string CompiledModel::GeneratedCodeRefusal() const {
  if (!constraints_.empty() && !constraints_.formulas_emittable())
    return "a resistor's law used backwards reaches the ideal constraints, which the generated code does not differentiate";
  if (!tears_.empty()) return "algebraic loops are solved around the plan, which the generated code does not do";
  return "";
}

Eigen::VectorXd CompiledModel::MakeInitialState() const { return layout_.x0(); }

bool CompiledModel::has_invariants() const {
  if (!constraints_.empty()) return true;
  for (const StateBlock& b : layout_.blocks())
    if (b.kind == StateBlock::Kind::kOrientation) return true;
  return false;
}

}  // namespace multibond
