#pragma once
/// \file
/// A model's generated right-hand side, outside the model: the compiled model stays immutable
/// and shareable between threads, and whoever runs it decides whether generated code evaluates.
///
///   CompiledModel (immutable)  --GeneratedRhs::Start(model, options)-->  GeneratedRhs
///   model.MakeWorkspace(code.get())  -->  a Workspace whose evaluations run the generated code
///                                         once it is loaded, the interpreter before (same bits)
///
/// A GeneratedRhs owns what compiling needs at run time: the texts, the background compile's
/// thread, its cancel flag, the loaded libraries and the numbers the code reads. A Workspace
/// without one (MakeWorkspace()) evaluates on the interpreter. The run's system object
/// (sim::ModelSystem) takes it from RunOptions::code.

#include <atomic>
#include <condition_variable>
#include <cstddef>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "multibond/compile/constraint_solver.h"

namespace multibond {

class CompiledModel;

/// The functions of a loaded right-hand side: one unit's (multibond_rhs and multibond_rhs_fast),
/// the parts of a split one, or with ideal constraints the plan at zero multipliers (rhs) and the
/// constraint solver's steps 2-4 and factor (constrained). Published once, never changed after.
struct GeneratedCode {
  using Fn = void (*)();  ///< cast to its real signature at the call (see codegen.cc)
  Fn rhs = nullptr, fast = nullptr;
  std::vector<Fn> parts;
  bool has_constrained = false;
  ConstraintSolver::Generated constrained;
  const double* values = nullptr;  ///< the numbers the code reads (src->values; GenerateUnits)
  std::vector<std::shared_ptr<void>> libraries;  ///< keep the shared objects loaded
};

struct GenerateOptions {
  /// Start returns at once and the code is compiled in the background while the interpreter
  /// evaluates; evaluations switch to the generated code when it is loaded (both give the same
  /// bits); a compile that fails says so on stderr. Off: Start compiles and loads before it
  /// returns (a compile that fails leaves the interpreter, with the reason in engine()).
  bool background = false;
  /// The generated code reads the model's numbers (coefficients, sources' values, formulas'
  /// constants) from a table at run time instead of having them as literals, so that its text
  /// depends on the model's structure only and models that differ in parameter values share one
  /// compiled library (a sweep's runs: compiled once). Off, the default for one model: literals,
  /// which the compiler folds into the code (the differential's right-hand side 124 ns against
  /// 146 ns with the table; docs/design.md, "Generated code at scale"). A model large enough to
  /// be split into units reads the table either way.
  bool value_table = false;
  /// With background: compilers still running after this many seconds are ended and the
  /// interpreter goes on (what was built stays cached for the next run); 0: no limit.
  double budget_seconds = 60;
  /// A generated right-hand side longer than CompiledModel::kOneFunctionChars (or than this) is
  /// split into units of about this many characters, each its own shared object, compiled in
  /// parallel (docs/design.md, "Generated code at scale"). 0: the default (kDefaultUnitChars).
  std::size_t unit_chars = 0;
  static constexpr std::size_t kDefaultUnitChars = 128 * 1024;
};

class GeneratedRhs {
 public:
  /// Generates the model's code and compiles it (compile/jit.h: cached by the source's hash),
  /// now or in the background. A model that generated code does not cover (algebraic loops
  /// solved around the plan, a law used backwards that reaches ideal constraints) gets an object
  /// that evaluates on the interpreter and says why in engine(). Keeps the model alive.
  static std::shared_ptr<const GeneratedRhs> Start(std::shared_ptr<const CompiledModel> model, const GenerateOptions& options = {});
  ~GeneratedRhs();
  GeneratedRhs(const GeneratedRhs&) = delete;
  GeneratedRhs& operator=(const GeneratedRhs&) = delete;

  /// The loaded code, null while it compiles or when there is none: read once per evaluation
  /// (the background compile may publish between two).
  const GeneratedCode* code() const { return ready_.load(std::memory_order_acquire); }
  /// How the right-hand side is evaluated: "generated code (<library>)" or "interpreter (<why>)";
  /// while compiling in the background, says so.
  const std::string& engine() const {
    return state_.load(std::memory_order_acquire) == State::kCompiling ? pending_engine_ : engine_;
  }
  /// True when the generated code evaluates, or is being compiled in the background to do so.
  bool uses_generated_code() const { return code() != nullptr || state_.load(std::memory_order_acquire) == State::kCompiling; }
  /// True when the generated code evaluates now (not still compiling in the background).
  bool ready() const { return code() != nullptr; }
  /// Waits for a background compile to end; then true when the generated code evaluates.
  bool Wait() const;
  /// At the end of a run that a background compile did not catch up with: hands the units not
  /// yet built over to `program jit-finish` (compile/jit.h, HandOverUnits), which fills the cache
  /// for the next run of this model, and ends this process's compile. Returns what was done (also
  /// in engine() from then on), "" when no compile was running.
  std::string HandOver(const std::string& program) const;
  /// The model whose code this is.
  const CompiledModel& model() const { return *model_; }
  /// The wall time Start took [s] (the compile itself when not in the background).
  double start_seconds() const { return start_seconds_; }

 private:
  GeneratedRhs() = default;
  /// Compiles and loads `units`, then publishes the code and engine_ (the compile thread's work,
  /// or Start's own).
  void Load(const std::vector<std::string>& units);

  std::shared_ptr<const CompiledModel> model_;
  GenerateOptions options_;
  std::vector<double> values_;      ///< the numbers the generated code reads (GenerateUnits)
  std::vector<std::string> units_;  ///< the texts compiled (kept for HandOver)
  bool light_ = false;              ///< they are compiled at -O1 (JitControl::light)
  std::unique_ptr<GeneratedCode> loaded_;
  std::atomic<const GeneratedCode*> ready_{nullptr};  ///< null: the interpreter evaluates
  enum class State { kNone, kCompiling, kDone };
  std::atomic<State> state_{State::kNone};
  std::string engine_ = "interpreter";
  std::string pending_engine_;            ///< engine() while compiling in the background
  mutable std::atomic<bool> cancel_{false};
  mutable std::string handed_over_;       ///< HandOver's note, written before the cancel
  double start_seconds_ = 0.0;
  std::thread thread_;
  mutable std::mutex mutex_;
  mutable std::condition_variable done_;
};

/// engine() of `code`, or "interpreter" without one.
inline std::string RhsEngine(const GeneratedRhs* code) { return code ? code->engine() : "interpreter"; }

}  // namespace multibond
