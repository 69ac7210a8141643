#include "multibond/compile/compiled_model.h"

#include <dlfcn.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>

#include <fmt/format.h>

#include <chrono>

#include "multibond/compile/jit.h"
#include "multibond/core/diagnostic_codes.h"
#include "multibond/core/interrupt.h"

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
  GenerateCode();
  lap("generate_code");
}

void CompiledModel::GenerateCode() {
  if (!options_.generate_code) return;
  if (!constraints_.empty() && !constraints_.formulas_emittable()) {
    rhs_engine_ = "interpreter (a resistor's law used backwards reaches the ideal constraints, which the generated code does not "
                  "differentiate)";
    return;
  }
  if (!constraints_.empty() && !tears_.empty()) return;  // refused at compile time (Compile)
  if (!tears_.empty()) {
    rhs_engine_ = "interpreter (algebraic loops are solved around the plan, which the generated code does not do)";
    return;
  }
  std::vector<std::string> units;
  if (!constraints_.empty()) {
    // Every part of a constrained evaluation as generated code, in one library: the plan at zero
    // multipliers (step 1 of CalcConstrained), its tangent (step 2), B's columns and W's
    // L D L^T (step 3) and what the multipliers reach (step 4).
    const bool has_factor = constraints_.factor().factor_size() > 0;
    units = {GenerateSource(/*with_fast=*/false) + GenerateColumnsSource() + (has_factor ? GenerateFactorSource() : "") +
             GenerateTangentSource() + GenerateReactSource()};
    jit_light_ = false;
  } else {
    // The text is made here (it needs the plan only); the compilers may run in the background.
    GeneratedUnits g = GenerateUnits(options_.jit_unit_chars > 0 ? options_.jit_unit_chars : CompileOptions::kDefaultUnitChars);
    jit_values_ = std::move(g.values);
    units = std::move(g.units);
    // One function in one unit (multibond_rhs and multibond_rhs_fast) at -O2, else parts at -O1.
    jit_light_ = !(units.size() == 1 && units.front().find("multibond_rhs_fast(") != std::string::npos);
  }
  if (!options_.jit_background) {
    LoadGeneratedRhs(units);
    return;
  }
  // The run starts on the interpreter and switches when the code is loaded (the same bits).
  pending_engine_ = fmt::format("interpreter while the generated code ({} unit{}) compiles in the background", units.size(),
                                units.size() == 1 ? "" : "s");
  jit_state_ = JitState::kCompiling;
  jit_units_ = units;
  jit_thread_ = std::thread([this, units = std::move(units)] { LoadGeneratedRhs(units); });
}

void CompiledModel::LoadGeneratedRhs(const std::vector<std::string>& units) {
  // One function in one unit (GenerateUnits: multibond_rhs and multibond_rhs_fast), else parts;
  // with ideal constraints one unit of the constrained evaluation's functions (GenerateCode).
  const bool constrained = !constraints_.empty();
  const bool whole = !jit_light_;
  JitControl control;
  // The budget is the background's: a compile asked for before the run (--jit on) runs to its end.
  const bool background = jit_state_ == JitState::kCompiling;
  if (background) control.budget_seconds = options_.jit_budget_seconds;
  control.cancel = &jit_cancel_;
  control.light = jit_light_;
  // In the background the run goes on meanwhile: the compilers take what CPU it leaves.
  if (background) control.nice = 10;
  // Progress on a terminal, for a compile that takes more than a second.
  const bool tty = isatty(STDERR_FILENO) == 1;
  bool shown = false;
  if (tty)
    control.progress = [&shown, &units](int done, int total, double seconds) {
      if (seconds < 1.0) return;
      std::fprintf(stderr, "\rcompiling the generated code: %d of %d unit%s (%.1f s)", done, total, units.size() == 1 ? "" : "s",
                   seconds);
      shown = true;
    };
  JitBatch jit;
  try {
    jit = CompileAndLoadUnits(units, constrained ? "multibond_bcols" : whole ? "multibond_rhs" : "multibond_part", control);
  } catch (const Interrupted& e) {
    if (jit_state_ != JitState::kCompiling) throw;  // Compile's own: the stop goes on up
    jit.description = e.what();                      // in the background: the run sees the stop itself
  }
  if (shown) std::fputc('\n', stderr);
  auto code = std::make_unique<JitCode>();
  std::string engine = "generated code (" + jit.description + ")";
  if (jit.ok() && constrained) {
    void* library = jit.libraries.front().get();
    const bool has_factor = constraints_.factor().factor_size() > 0;
    ConstraintSolver::Generated& g = code->constrained;
    g.columns = reinterpret_cast<ConstraintSolver::GeneratedColumns>(jit.symbols.front());
    g.tangent = reinterpret_cast<ConstraintSolver::GeneratedTangent>(dlsym(library, "multibond_tangent"));
    g.react = reinterpret_cast<ConstraintSolver::GeneratedReact>(dlsym(library, "multibond_react"));
    g.factor = has_factor ? reinterpret_cast<ConstraintFactor::GeneratedFactor>(dlsym(library, "multibond_ldlt_factor")) : nullptr;
    g.solve = has_factor ? reinterpret_cast<ConstraintFactor::GeneratedSolve>(dlsym(library, "multibond_ldlt_solve")) : nullptr;
    code->rhs = reinterpret_cast<GeneratedRhs>(dlsym(library, "multibond_rhs"));
    code->has_constrained = code->rhs && g.tangent && g.react && (!has_factor || (g.factor && g.solve));
    if (!code->has_constrained) jit.description = "a function of the constrained evaluation is missing from " + jit.description;
    engine = "generated code for the plan at zero multipliers, its tangent, the constraint matrix and its L D L^T, and what the "
             "multipliers reach (" + jit.description + ")";
  } else if (jit.ok() && whole) {
    code->rhs = reinterpret_cast<GeneratedRhs>(jit.symbols.front());
    code->fast = reinterpret_cast<GeneratedRhs>(dlsym(jit.libraries.front().get(), "multibond_rhs_fast"));
  } else if (jit.ok()) {
    for (void* part : jit.symbols) code->parts.push_back(reinterpret_cast<GeneratedRhs>(part));
  }
  if (jit.ok() && (code->fast || !code->parts.empty() || code->has_constrained)) {
    code->libraries = std::move(jit.libraries);
    jit_code_ = std::move(code);
    rhs_engine_ = engine;
    jit_ready_.store(jit_code_.get(), std::memory_order_release);
  } else if (jit_cancel_ && !jit_handed_over_.empty()) {
    rhs_engine_ = "interpreter (the run ended before the generated code was compiled: " + jit_handed_over_ + ")";
  } else {
    rhs_engine_ = "interpreter (code generation failed: " + jit.description + ")";
    // In the background nobody looks at the engine before the run's end: said here (not for a
    // compile that the end of the run or a stop cancelled).
    if (jit_state_ == JitState::kCompiling && !jit_cancel_ && !StopRequested())
      std::fprintf(stderr, "warning: running on the interpreter: %s\n", rhs_engine_.c_str());
  }
  {
    std::lock_guard<std::mutex> lock(jit_mutex_);
    jit_state_.store(JitState::kDone, std::memory_order_release);
  }
  jit_done_.notify_all();
}

bool CompiledModel::WaitForGeneratedCode() const {
  std::unique_lock<std::mutex> lock(jit_mutex_);
  jit_done_.wait(lock, [this] { return jit_state_.load() != JitState::kCompiling; });
  return uses_generated_code();
}

std::string CompiledModel::HandOverCompile(const std::string& program) const {
  if (jit_state_.load(std::memory_order_acquire) != JitState::kCompiling || StopRequested()) return "";
  std::string note = HandOverUnits(jit_units_, jit_light_, program);
  if (note.empty()) note = "every unit was already built";
  {
    std::lock_guard<std::mutex> lock(jit_mutex_);
    if (jit_state_.load() != JitState::kCompiling) return "";  // it finished meanwhile
    jit_handed_over_ = note;
  }
  jit_cancel_ = true;
  WaitForGeneratedCode();  // the compile thread ends its compilers and publishes rhs_engine_
  return note;
}

CompiledModel::~CompiledModel() {
  jit_cancel_ = true;  // a compile still running is ended: its finished units stay cached
  if (jit_thread_.joinable()) jit_thread_.join();
}

Eigen::VectorXd CompiledModel::MakeInitialState() const { return layout_.x0(); }

bool CompiledModel::has_invariants() const {
  if (!constraints_.empty()) return true;
  for (const StateBlock& b : layout_.blocks())
    if (b.kind == StateBlock::Kind::kOrientation) return true;
  return false;
}

}  // namespace multibond
