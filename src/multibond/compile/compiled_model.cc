#include "multibond/compile/compiled_model.h"

#include <dlfcn.h>

#include <chrono>

#include "multibond/compile/jit.h"

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
                         signal_class_, internal_class_, options_.energy_account});  // blocks, x0, gathers, names
  energy_ = EnergyAccount({graph_, layout_, [this](int element, int state) {
                             return StoredEnergyFormula(element, state);  // formulas.cc
                           }});  // each I's and C's stored energy
  const std::vector<int> modulus_of = PlanModuli();
  const PlanDeps deps = OrderPlan(EmitInstructions(modulus_of));  // plan_, tears_, tear_closure_
  needed_moduli_ = plan::Specialize(plan_, coef_, sum_terms_, sum_signs_, moduli_);
  CheckFormulaUse();  // formulas.cc
  if (!tears_.empty() && !constraints_.empty()) {
    Diagnostic d;
    d.code = "causality.algebraic_loop";
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
  GenerateCode();
  lap("generate_code");
}

void CompiledModel::GenerateCode() {
  if (options_.generate_code && !constraints_.empty()) {
    rhs_engine_ = "interpreter (ideal constraints are solved around the plan)";
    // Every part of a constrained evaluation as generated code, in one library: the plan at zero
    // multipliers (step 1 of CalcConstrained), its tangent (step 2), B's columns and W's
    // L D L^T (step 3) and what the multipliers reach (step 4).
    const bool has_factor = constraints_.factor().factor_size() > 0;
    const JitResult jit = CompileAndLoad(GenerateSource(/*with_fast=*/false) + GenerateColumnsSource() +
                                             (has_factor ? GenerateFactorSource() : "") + GenerateTangentSource() +
                                             GenerateReactSource(),
                                         "multibond_bcols");
    void* factor = jit.symbol && has_factor ? dlsym(jit.library.get(), "multibond_ldlt_factor") : nullptr;
    void* solve = jit.symbol && has_factor ? dlsym(jit.library.get(), "multibond_ldlt_solve") : nullptr;
    void* plan = jit.symbol ? dlsym(jit.library.get(), "multibond_rhs") : nullptr;
    void* tangent = jit.symbol ? dlsym(jit.library.get(), "multibond_tangent") : nullptr;
    void* react = jit.symbol ? dlsym(jit.library.get(), "multibond_react") : nullptr;
    if (jit.symbol && plan && tangent && react && ((factor && solve) || !has_factor)) {
      ConstraintSolver::Generated g;
      g.factor = reinterpret_cast<ConstraintFactor::GeneratedFactor>(factor);
      g.solve = reinterpret_cast<ConstraintFactor::GeneratedSolve>(solve);
      g.columns = reinterpret_cast<ConstraintSolver::GeneratedColumns>(jit.symbol);
      g.tangent = reinterpret_cast<ConstraintSolver::GeneratedTangent>(tangent);
      g.react = reinterpret_cast<ConstraintSolver::GeneratedReact>(react);
      g.library = jit.library;
      constraints_.UseGenerated(std::move(g));
      generated_ = reinterpret_cast<GeneratedRhs>(plan);  // no generated_fast_: CalcStateDerivatives must solve
      rhs_engine_ = "generated code for the plan at zero multipliers, its tangent, the constraint matrix and its L D L^T, "
                    "and what the multipliers reach (" + jit.description + ")";
    } else {
      rhs_engine_ += " (code generation for the constrained evaluation failed: " + jit.description + ")";
    }
  } else if (options_.generate_code && !tears_.empty()) {
    rhs_engine_ = "interpreter (algebraic loops are solved around the plan, which the generated code does not do)";
  } else if (options_.generate_code) {
    const JitResult jit = CompileAndLoad(GenerateSource(), "multibond_rhs");
    void* fast = jit.symbol ? dlsym(jit.library.get(), "multibond_rhs_fast") : nullptr;
    if (jit.symbol && fast) {
      generated_ = reinterpret_cast<GeneratedRhs>(jit.symbol);
      generated_fast_ = reinterpret_cast<GeneratedRhs>(fast);
      generated_library_ = jit.library;
      rhs_engine_ = "generated code (" + jit.description + ")";
    } else {
      rhs_engine_ = "interpreter (code generation failed: " + jit.description + ")";
    }
  }
}

Eigen::VectorXd CompiledModel::MakeInitialState() const { return layout_.x0(); }

bool CompiledModel::has_invariants() const {
  if (!constraints_.empty()) return true;
  for (const StateBlock& b : layout_.blocks())
    if (b.kind == StateBlock::Kind::kOrientation) return true;
  return false;
}

}  // namespace multibond
