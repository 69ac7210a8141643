#include "multibond/compile/generated_rhs.h"

#include <dlfcn.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>

#include <fmt/format.h>

#include "multibond/compile/compiled_model.h"
#include "multibond/compile/jit.h"
#include "multibond/core/interrupt.h"

namespace multibond {

std::shared_ptr<const GeneratedRhs> GeneratedRhs::Start(std::shared_ptr<const CompiledModel> model, const GenerateOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  std::shared_ptr<GeneratedRhs> g(new GeneratedRhs());
  g->model_ = std::move(model);
  g->options_ = options;
  const CompiledModel& m = *g->model_;
  if (const std::string refusal = m.GeneratedCodeRefusal(); !refusal.empty()) {
    g->engine_ = "interpreter (" + refusal + ")";
    return g;
  }
  std::vector<std::string> units;
  if (m.has_constraints()) {
    // Every part of a constrained evaluation as generated code, in one library: the plan at zero
    // multipliers (step 1 of CalcConstrained), its tangent (step 2), B's columns and W's
    // L D L^T (step 3) and what the multipliers reach (step 4).
    units = {m.GenerateSource(/*with_fast=*/false) + m.GenerateColumnsSource() +
             (m.has_constraint_factor() ? m.GenerateFactorSource() : "") + m.GenerateTangentSource() + m.GenerateReactSource()};
  } else {
    CompiledModel::GeneratedUnits u =
        m.GenerateUnits(options.unit_chars > 0 ? options.unit_chars : GenerateOptions::kDefaultUnitChars, options.value_table);
    g->values_ = std::move(u.values);
    units = std::move(u.units);
    // One function in one unit (multibond_rhs and multibond_rhs_fast) at -O2, else parts at -O1.
    g->light_ = !(units.size() == 1 && units.front().find("multibond_rhs_fast(") != std::string::npos);
  }
  g->units_ = units;
  if (!options.background) {
    g->Load(units);
  } else {
    // The run starts on the interpreter and switches when the code is loaded (the same bits).
    g->pending_engine_ = fmt::format("interpreter while the generated code ({} unit{}) compiles in the background", units.size(),
                                     units.size() == 1 ? "" : "s");
    g->state_ = State::kCompiling;
    GeneratedRhs* self = g.get();  // the thread ends before *self does (the destructor joins it)
    g->thread_ = std::thread([self, units = std::move(units)] { self->Load(units); });
  }
  g->start_seconds_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return g;
}

void GeneratedRhs::Load(const std::vector<std::string>& units) {
  // One function in one unit (GenerateUnits: multibond_rhs and multibond_rhs_fast), else parts;
  // with ideal constraints one unit of the constrained evaluation's functions (Start).
  const bool constrained = model_->has_constraints();
  const bool whole = !light_;
  JitControl control;
  // The budget is the background's: a compile asked for before the run (--jit on) runs to its end.
  const bool background = state_ == State::kCompiling;
  if (background) control.budget_seconds = options_.budget_seconds;
  control.cancel = &cancel_;
  control.light = light_;
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
    if (!background) throw;     // Start's own: the stop goes on up
    jit.description = e.what();  // in the background: the run sees the stop itself
  }
  if (shown) std::fputc('\n', stderr);
  auto code = std::make_unique<GeneratedCode>();
  code->values = values_.data();
  std::string engine = "generated code (" + jit.description + ")";
  if (jit.ok() && constrained) {
    void* library = jit.libraries.front().get();
    const bool has_factor = model_->has_constraint_factor();
    ConstraintSolver::Generated& c = code->constrained;
    c.columns = reinterpret_cast<ConstraintSolver::GeneratedColumns>(jit.symbols.front());
    c.tangent = reinterpret_cast<ConstraintSolver::GeneratedTangent>(dlsym(library, "multibond_tangent"));
    c.react = reinterpret_cast<ConstraintSolver::GeneratedReact>(dlsym(library, "multibond_react"));
    c.factor = has_factor ? reinterpret_cast<ConstraintFactor::GeneratedFactor>(dlsym(library, "multibond_ldlt_factor")) : nullptr;
    c.solve = has_factor ? reinterpret_cast<ConstraintFactor::GeneratedSolve>(dlsym(library, "multibond_ldlt_solve")) : nullptr;
    code->rhs = reinterpret_cast<GeneratedCode::Fn>(dlsym(library, "multibond_rhs"));
    code->has_constrained = code->rhs && c.tangent && c.react && (!has_factor || (c.factor && c.solve));
    if (!code->has_constrained) jit.description = "a function of the constrained evaluation is missing from " + jit.description;
    engine = "generated code for the plan at zero multipliers, its tangent, the constraint matrix and its L D L^T, and what the "
             "multipliers reach (" + jit.description + ")";
  } else if (jit.ok() && whole) {
    code->rhs = reinterpret_cast<GeneratedCode::Fn>(jit.symbols.front());
    code->fast = reinterpret_cast<GeneratedCode::Fn>(dlsym(jit.libraries.front().get(), "multibond_rhs_fast"));
  } else if (jit.ok()) {
    for (void* part : jit.symbols) code->parts.push_back(reinterpret_cast<GeneratedCode::Fn>(part));
  }
  if (jit.ok() && (code->fast || !code->parts.empty() || code->has_constrained)) {
    code->libraries = std::move(jit.libraries);
    loaded_ = std::move(code);
    engine_ = engine;
    ready_.store(loaded_.get(), std::memory_order_release);
  } else if (cancel_ && !handed_over_.empty()) {
    engine_ = "interpreter (the run ended before the generated code was compiled: " + handed_over_ + ")";
  } else {
    engine_ = "interpreter (code generation failed: " + jit.description + ")";
    // In the background nobody looks at the engine before the run's end: said here (not for a
    // compile that the end of the run or a stop cancelled).
    if (background && !cancel_ && !StopRequested()) std::fprintf(stderr, "warning: running on the interpreter: %s\n", engine_.c_str());
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    state_.store(State::kDone, std::memory_order_release);
  }
  done_.notify_all();
}

bool GeneratedRhs::Wait() const {
  std::unique_lock<std::mutex> lock(mutex_);
  done_.wait(lock, [this] { return state_.load() != State::kCompiling; });
  return uses_generated_code();
}

std::string GeneratedRhs::HandOver(const std::string& program) const {
  if (state_.load(std::memory_order_acquire) != State::kCompiling || StopRequested()) return "";
  std::string note = HandOverUnits(units_, light_, program);
  if (note.empty()) note = "every unit was already built";
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (state_.load() != State::kCompiling) return "";  // it finished meanwhile
    handed_over_ = note;
  }
  cancel_ = true;
  Wait();  // the compile thread ends its compilers and publishes engine_
  return note;
}

GeneratedRhs::~GeneratedRhs() {
  cancel_ = true;  // a compile still running is ended: its finished units stay cached
  if (thread_.joinable()) thread_.join();
}

}  // namespace multibond
