#include "multibond/solve/arkode_integrator.h"

#include <array>

#include <algorithm>
#include <cmath>
#include <string>

#include <arkode/arkode.h>
#include <arkode/arkode_butcher.h>
#include <arkode/arkode_erkstep.h>
#include <fmt/format.h>

#include "multibond/solve/sundials_support.h"

namespace multibond {
namespace {

struct ErkMemDeleter {
  void operator()(void* mem) const noexcept { ERKStepFree(&mem); }
};
using ErkMemPtr = std::unique_ptr<void, ErkMemDeleter>;

struct ButcherTableDeleter {
  void operator()(ARKodeButcherTable b) const noexcept { ARKodeButcherTable_Free(b); }
};
using ButcherTablePtr =
    std::unique_ptr<std::remove_pointer_t<ARKodeButcherTable>, ButcherTableDeleter>;

/// Our flag for a fixed-step run whose state stopped being finite (no SUNDIALS flag covers it).
constexpr const char* kNonFiniteFlag = "NONFINITE_STATE";

/// Classical 4-stage, 4th-order Runge-Kutta, without an embedded error estimate (fixed step).
ButcherTablePtr MakeRk4Table() {
  sunrealtype c[4] = {0.0, 0.5, 0.5, 1.0};
  sunrealtype a[16] = {0.0, 0.0, 0.0, 0.0,   //
                       0.5, 0.0, 0.0, 0.0,   //
                       0.0, 0.5, 0.0, 0.0,   //
                       0.0, 0.0, 1.0, 0.0};  // row-major s x s
  sunrealtype b[4] = {1.0 / 6.0, 1.0 / 3.0, 1.0 / 3.0, 1.0 / 6.0};
  // Create copies the arrays; p = 0 and d = NULL: no embedding.
  return ButcherTablePtr(sun::NonNull(ARKodeButcherTable_Create(4, 4, 0, c, a, b, nullptr)));
}

std::string Explain(int flag, const IntegratorOptions& options) {
  switch (flag) {
    case ARK_TOO_MUCH_WORK:
      return fmt::format(
          "the solver took max_steps_per_output = {} steps without reaching the next output time",
          options.max_steps_per_output);
    case ARK_TOO_MUCH_ACC:
      return "the requested accuracy is beyond machine precision (tolerances too small)";
    case ARK_ERR_FAILURE:
      return "error test failed repeatedly or with |h| = hmin (is the solution blowing up?)";
    case ARK_RHSFUNC_FAIL:
    case ARK_FIRST_RHSFUNC_ERR:
    case ARK_REPTD_RHSFUNC_ERR:
    case ARK_UNREC_RHSFUNC_ERR:
      return "the right-hand side failed";
    case ARK_MEM_FAIL:
      return "out of memory";
    case ARK_ILL_INPUT:
      return "the solver rejected an input (option, tolerance or time)";
    case ARK_TOO_CLOSE:
      return "the output time is too close to the start time";
    case ARK_INVALID_TABLE:
      return "the Butcher table is invalid for this use (adaptive stepping needs an embedding)";
    default:
      return "the solver failed";
  }
}

/// CallbackState plus what the post-step hook reports. The Rhs sees it through its base.
struct ErkCallbackState : sun::CallbackState {
  using CallbackState::CallbackState;
  bool nonfinite = false;
  double nonfinite_t = 0.0;
  std::array<int, 5> nonfinite_states{};  ///< the first entries found non-finite
  int num_nonfinite = 0;
};

/// Post-step hook of fixed-step runs; returning nonzero stops ERKStepEvolve. A fixed step has
/// no error test, so an unstable step size or a finite-time blow-up would otherwise march on
/// with inf/NaN states and return them as results.
int CheckStateFinite(sunrealtype t, N_Vector y, void* user_data) noexcept {
  // Restore the system's invariants first (orthonormal orientations), as CVODE's projection does.
  auto* common = static_cast<sun::CallbackState*>(user_data);
  if (common->project) common->system->Project(N_VGetArrayPointer(y));
  const sunrealtype* v = N_VGetArrayPointer(y);
  const sunindextype n = N_VGetLength(y);
  // One pass: any infinity or NaN makes a sum non-finite (inf - inf is NaN). Four partial sums,
  // so the additions pipeline (strict IEEE order forbids the compiler to split one chain).
  sunrealtype s[4] = {0.0, 0.0, 0.0, 0.0};
  sunindextype i = 0;
  for (; i + 4 <= n; i += 4)
    for (int k = 0; k < 4; ++k) s[k] += v[i + k];
  for (; i < n; ++i) s[0] += v[i];
  if (!std::isfinite((s[0] + s[1]) + (s[2] + s[3]))) {
    auto* state = static_cast<ErkCallbackState*>(static_cast<sun::CallbackState*>(user_data));
    state->nonfinite = true;
    state->nonfinite_t = t;
    state->num_nonfinite = 0;
    for (sunindextype j = 0; j < n && state->num_nonfinite < 5; ++j)
      if (!std::isfinite(v[j])) state->nonfinite_states[state->num_nonfinite++] = static_cast<int>(j);
    return -1;
  }
  return 0;
}

class ArkodeIntegrator final : public sun::SundialsIntegrator<ErkCallbackState> {
 public:
  ArkodeIntegrator(OdeSystem& system, const IntegratorOptions& options) : SundialsIntegrator(system, options) {}

  void Reset(double t0, const double* x0) override {
    LoadInitialState(x0);
    callbacks_.nonfinite = false;
    if (mem_) {
      Check(ERKStepReInit(mem_.get(), sun::Rhs, t0, y_.get()), t0);  // keeps options and table
    } else {
      Create(t0);
    }
    time_ = t0;
  }

  void AdvanceTo(double tout, double* x) override {
    MB_ASSERT(mem_ != nullptr, "AdvanceTo called before Reset");
    MB_ASSERT(tout >= time_, fmt::format("AdvanceTo({}) is before the current time {}", tout, time_));
    if (tout > time_) {
      callbacks_.ClearMessages();
      if (fixed_step()) {
        // Stop exactly on tout (only the last step before it is shortened) rather than step
        // past it and interpolate.
        Check(ERKStepSetStopTime(mem_.get(), tout), time_);
      } else {
        // Adaptive: interpolating at tout is as accurate as the steps, and cheaper than
        // cutting a step at every output. hmin: see sun::MinUsefulStep.
        const double hmin = sun::MinUsefulStep(time_);
        if (options_.max_step == 0 || hmin < options_.max_step)
          Check(ERKStepSetMinStep(mem_.get(), hmin), time_);
      }
      sunrealtype reached = time_;
      const int flag = ERKStepEvolve(mem_.get(), tout, y_.get(), &reached, ARK_NORMAL);
      sun::RethrowPending(callbacks_);
      if (callbacks_.nonfinite) {
        SolverError error(callbacks_.nonfinite_t, kNonFiniteFlag,
                          "the state became infinite or NaN (step too large for the model, or "
                          "the solution blows up)");
        error.set_states({callbacks_.nonfinite_states.begin(), callbacks_.nonfinite_states.begin() + callbacks_.num_nonfinite});
        throw error;
      }
      if (flag < 0) {
        // ERKStepEvolve leaves *tret untouched on failure; ask where it stopped.
        ERKStepGetCurrentTime(mem_.get(), &reached);
        Check(flag, reached);
      }
      time_ = tout;
    }
    std::copy_n(N_VGetArrayPointer(y_.get()), n_, x);
  }


  IntegratorStats stats() const override {
    IntegratorStats s;
    if (!mem_) return s;
    ERKStepGetNumSteps(mem_.get(), &s.steps);
    ERKStepGetNumRhsEvals(mem_.get(), &s.rhs_evals);
    ERKStepGetNumErrTestFails(mem_.get(), &s.error_test_failures);
    ERKStepGetLastStep(mem_.get(), &s.last_step);
    return s;
  }

 private:
  bool fixed_step() const { return options_.fixed_step > 0; }

  void Create(double t0) {
    // Kept local until fully configured, so a failure leaves no half-built solver behind.
    ErkMemPtr owner(sun::NonNull(ERKStepCreate(sun::Rhs, t0, y_.get(), ctx_.get())));
    void* mem = owner.get();
    Check(ERKStepSetErrHandlerFn(mem, sun::RecordMessage, &callbacks_), t0);
    Check(ERKStepSetUserData(mem, static_cast<sun::CallbackState*>(&callbacks_)), t0);
    if (options_.atol_per_state.empty()) {
      Check(ERKStepSStolerances(mem, options_.rtol, options_.atol), t0);
    } else {
      sun::VectorPtr atol = sun::MakeVector(n_, ctx_.get());
      std::copy_n(options_.atol_per_state.data(), n_, N_VGetArrayPointer(atol.get()));
      Check(ERKStepSVtolerances(mem, options_.rtol, atol.get()), t0);  // ERKStep keeps a copy
    }
    if (options_.method == Method::kRk4) {
      const ButcherTablePtr table = MakeRk4Table();
      Check(ERKStepSetTable(mem, table.get()), t0);  // ERKStep keeps a copy
    } else {
      Check(ERKStepSetTableNum(mem, ARKODE_DORMAND_PRINCE_7_4_5), t0);
    }
    if (fixed_step()) {
      Check(ERKStepSetFixedStep(mem, options_.fixed_step), t0);
      // Besides catching inf/NaN, a post-step hook makes ERKStep evaluate f(t_n+1, y_n+1) anew
      // after each step. Without one, SUNDIALS 6.4.1 treats RK4 as "first same as last" and
      // reuses its last stage f(t_n + h, y_n + h k3) as the next first stage: 3 evaluations per
      // step and third-order results (seen in the Rk4 tests, which guard this). It costs DP5,
      // whose reuse is valid, one extra evaluation per fixed step.
      Check(ERKStepSetPostprocessStepFn(mem, CheckStateFinite), t0);
    } else {
      if (callbacks_.project) Check(ERKStepSetPostprocessStepFn(mem, CheckStateFinite), t0);
      if (options_.max_step > 0) Check(ERKStepSetMaxStep(mem, options_.max_step), t0);
      if (options_.initial_step > 0) Check(ERKStepSetInitStep(mem, options_.initial_step), t0);
    }
    Check(ERKStepSetMaxNumSteps(mem, options_.max_steps_per_output), t0);
    mem_ = std::move(owner);
  }

  /// Turns a negative ARKODE flag into a SolverError.
  void Check(int flag, double t) const {
    if (flag >= 0) return;
    const sun::CString name(ERKStepGetReturnFlagName(flag));
    std::string text = Explain(flag, options_);
    if (!callbacks_.message().empty()) text += "; ARKODE: " + callbacks_.message();
    SolverError error(t, name ? name.get() : fmt::format("ARKODE flag {}", flag), std::move(text));
    if (mem_) {
      sun::VectorPtr ele = sun::MakeVector(n_, ctx_.get()), ewt = sun::MakeVector(n_, ctx_.get());
      if (ERKStepGetEstLocalErrors(mem_.get(), ele.get()) == ARK_SUCCESS && ERKStepGetErrWeights(mem_.get(), ewt.get()) == ARK_SUCCESS)
        error.set_states(sun::WorstComponents(ele.get(), ewt.get()));
    }
    throw error;
  }

  // Destroyed before the base's context and vectors, which the solver memory refers to.
  ErkMemPtr mem_;
};

}  // namespace

std::unique_ptr<Integrator> MakeArkodeIntegrator(OdeSystem& system, const IntegratorOptions& options) {
  return std::make_unique<ArkodeIntegrator>(system, options);
}

}  // namespace multibond
