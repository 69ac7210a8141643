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
  layout_ = StateLayout({graph_, structure_, slots_.effort_class, slots_.flow_class, slots_.class_offset, slots_.class_size, slots_.class_units,
                         slots_.signal_class, slots_.internal_class, slots_.signal_state_units, options_.energy_account});  // blocks, x0, gathers, names
  AnalyzeModulatedStorage();  // modulated_storage.cc: storage laws that read t, signals, other states
  energy_ = EnergyAccount({graph_, layout_, [this](int element, int state) {
                             return StoredEnergyFormula(element, state);  // formulas.cc
                           }});  // each I's and C's stored energy
  const std::vector<int> modulus_of = PlanModuli();
  const PlanDeps deps = OrderPlan(EmitInstructions(modulus_of));  // plan_.instrs, loops_.tears, loops_.closure
  for (int at : loops_.closure) loops_.nonlinear = loops_.nonlinear || plan_.instrs[at].op == Op::kExpr || plan_.instrs[at].op == Op::kSolve;
  RefuseUnbookedModulation();  // modulated_storage.cc: after the order, so that a loop is reported as one
  plan_.needed_moduli = plan::Specialize(plan_.instrs, plan_.coef, plan_.sum_terms, plan_.sum_signs, plan_.moduli);
  if (!loops_.tears.empty() && !constraints_.empty()) {
    Diagnostic d;
    d.code = codes::kCausalityAlgebraicLoop;
    d.where = graph_.element(loops_.loops.front().element).where;
    d.element = graph_.element(loops_.loops.front().element).name;
    d.message = "algebraic loops are not solved in a model with ideal constraints (yet)";
    for (const AlgebraicLoop& loop : loops_.loops) d.details.push_back("loop: " + loop.path);
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
  if (!loops_.tears.empty()) return "algebraic loops are solved around the plan, which the generated code does not do";
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
