#include "multibond/solve/arkode_integrator.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include <arkode/arkode.h>
#include <arkode/arkode_butcher.h>
#include <arkode/arkode_erkstep.h>
#include <nvector/nvector_serial.h>
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

/// multibond's stabilised Runge-Kutta 3(2) (Method::kStabilizedRk3): third order, four
/// evaluations per step, real stability interval 5.8379 (Bogacki-Shampine: 2.5127 for three).
///
/// Why: on a model whose explicit step is held by the stability of fast real modes (the
/// compliant differential: planet-bearing dampers at -7.5e4 /s), what counts is the real
/// stability interval per evaluation. ARKODE 6.4's tables reach at most 0.97 (ARK4(3)7L, which
/// 6.4.1 cannot use without a post-step hook), third-order SSP tables at most 1.6 but with
/// |R| ~ 0.99 all along it (the stiff modes are not damped: noisy reactions), and LSRKStep's
/// Chebyshev methods came with SUNDIALS 7.2 (Debian bookworm ships 6.4.1); RKC's second order
/// left the energy account 1e-8 off at rtol 1e-10 (measured).
///
/// Design (docs/design.md, "A stabilised third-order table"):
/// - Stability polynomial R(z) = 1 + z + z^2/2 + z^3/6 + g4 z^4, g4 = 49/2592 = 0.018904,
///   between the values that give the longest real interval with |R| <= 0.9 inside it (0.01874:
///   5.87) and with |R| <= 0.8 (0.01906: 5.70); without damping 0.01846 gives 6.02. Measured on
///   [-5.55, -0.3], 95% of the interval: |R| <= 0.846; at -5.55 itself R = 0.29.
/// - Stages as a chain, Y_i = y + h a_i f(Y_i-1), with c = (0, 1/8, 7/20, 11/16): every stage
///   value stays within |y| for z on the interval (no internal amplification of rounding). The
///   weights b solve the four third-order conditions (sum b = 1, b.c = 1/2, b.c^2 = 1/3,
///   b.Ac = 1/6) exactly; c was chosen so that they also give g4 and stay below 0.63 in size.
/// - A fifth stage at y_n+1 (c = 1, its row = b), which ERKStep reuses as the next step's first:
///   four evaluations per step. SUNDIALS 6.4.1 reuses a last stage at c = 1 whatever its row
///   (see Create), so the row must be b, as it is.
/// - Embedding d (second order: sum d = 1, d.c = 1/2) over the five stages: the estimate
///   E(z) = R(z) - Rhat(z) = -z^3/48 + O(z^4) for small z (Bogacki-Shampine's: -0.0206 z^3), and
///   |E| <= 0.07 on the whole interval, so that stiff modes at the stability limit do not
///   inflate the error estimate (a least-squares choice among the three free weights).
ButcherTablePtr MakeStabilizedRk3Table() {
  constexpr double b1 = 107.0 / 231.0, b2 = -4.0 / 9.0, b3 = 200.0 / 567.0, b4 = 560.0 / 891.0;
  sunrealtype c[5] = {0.0, 1.0 / 8.0, 7.0 / 20.0, 11.0 / 16.0, 1.0};
  sunrealtype a[25] = {0.0,       0.0,        0.0,         0.0, 0.0,   //
                       1.0 / 8.0, 0.0,        0.0,         0.0, 0.0,   //
                       0.0,       7.0 / 20.0, 0.0,         0.0, 0.0,   //
                       0.0,       0.0,        11.0 / 16.0, 0.0, 0.0,   //
                       b1,        b2,         b3,          b4,  0.0};  // row-major 5 x 5
  sunrealtype b[5] = {b1, b2, b3, b4, 0.0};
  sunrealtype d[5] = {9781.0 / 18480.0, -107.0 / 288.0, 2593.0 / 18144.0, 9257.0 / 14256.0, 1.0 / 20.0};
  return ButcherTablePtr(sun::NonNull(ARKodeButcherTable_Create(5, 3, 2, c, a, b, d)));
}

/// The tables of ours (classical RK4, srk3), given to ERKStep; null for the ones SUNDIALS has.
ButcherTablePtr OwnTable(Method m) {
  if (m == Method::kRk4) return MakeRk4Table();
  if (m == Method::kStabilizedRk3) return MakeStabilizedRk3Table();
  return nullptr;
}

/// Real stability interval of each adaptive explicit method that bounds its steps (0: none).
double StabilityInterval(Method m) {
  switch (m) {
    case Method::kBogackiShampine:
      return 2.5127;  // of 1 + z + z^2/2 + z^3/6
    case Method::kStabilizedRk3:
      return 5.8378;  // of 1 + z + z^2/2 + z^3/6 + 49 z^4/2592 (5.83788)
    default:
      return 0.0;
  }
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

/// The explicit stability limit of Bogacki-Shampine and srk3, h <= interval / rho(J), from an
/// estimate of the spectral radius rho of the Jacobian by power iteration on finite differences
/// of f (as RKC codes do), renewed every kRenewEvery steps; given to ERKStep as its stability
/// function.
///
/// Why: an explicit method on a stiff model runs at its stability limit, where the error
/// controller finds the limit only by overstepping it. Without this bound Bogacki-Shampine
/// hunts on the differential (300-500 rejected steps) and the stiff modes (-7.5e4 /s), barely
/// damped at the limit, leave noise of 1e-4 in the reaction forces: two runs that differ only
/// by rounding (generated code and interpreter) drifted 1.6e-4 apart in 0.5 s. With steps at
/// kMargin of the limit, |R(h lambda)| <= 0.8: no step is rejected, and such runs agree to
/// 2e-12 over 5 s. The error controller still takes smaller steps wherever accuracy needs them.
/// The estimates cost about 500 evaluations of f over the differential's 0-5 s (of 486,000).
struct StabilityLimit {
  static constexpr long kRenewEvery = 1000;  ///< steps (calls) between estimates
  static constexpr int kMaxIterations = 20;
  static constexpr double kMargin = 0.95;  ///< of the real stability interval (ERKStep's "CFL fraction")
  double interval = 0.0;  ///< real stability interval of the method: h |lambda| <= interval
  long calls = 0;         ///< since the last estimate
  double hstab = 0.0;     ///< interval / rho (0: no limit)
  long evaluations = 0;   ///< of f, for the statistics
  bool have_direction = false;  ///< v holds the last estimate's direction
  std::vector<double> fy, v, yp, fp;
};

/// CallbackState plus the tolerances (for ErrorWeights), the stability limit and what the
/// post-step hook reports. The Rhs sees it through its base.
struct ErkCallbackState : sun::CallbackState {
  using CallbackState::CallbackState;
  double rtol = 0.0, atol = 0.0;
  const double* atol_per_state = nullptr;  ///< n entries, or null: atol for every state
  bool some_atol_zero = false;             ///< then a weight can be infinite (y_i = 0)
  StabilityLimit stability;
  bool nonfinite = false;
  double nonfinite_t = 0.0;
  std::array<int, 5> nonfinite_states{};  ///< the first entries found non-finite
  int num_nonfinite = 0;
};

/// rho(J(t, y)) by power iteration: v_k+1 = f(y + v_k) - f(y), with v_k scaled to a small
/// perturbation, and rho ~ |v_k+1| / |v_k|, until two estimates agree to 1% (the largest seen
/// if they never do: a complex dominant pair). Starts from the previous estimate's direction;
/// the first time from f(y) plus a fixed pseudo-random vector, so that every mode is present
/// (f(y0) alone may miss the stiffest: at the differential's start it found -1.9e4, not
/// -7.5e4). 0 if f does not respond.
double SpectralRadius(OdeSystem& system, double t, const double* y, sunindextype n, StabilityLimit& s) {
  double* fy = s.fy.data();
  double* v = s.v.data();
  double* yp = s.yp.data();
  double* fp = s.fp.data();
  auto norm = [n](const double* a) {
    double sum = 0.0;
    for (sunindextype i = 0; i < n; ++i) sum += a[i] * a[i];
    return std::sqrt(sum);
  };
  auto usable = [](double x) { return x > 0.0 && std::isfinite(x); };
  system.CalcDerivatives(t, y, fy);
  ++s.evaluations;
  double vn = s.have_direction ? norm(v) : 0.0;
  if (!usable(vn)) {
    const double fn = norm(fy);
    const double mix = usable(fn) ? 0.1 * fn / std::sqrt(static_cast<double>(n)) : 1.0;
    for (sunindextype i = 0; i < n; ++i) {
      const double r = static_cast<double>((static_cast<unsigned long long>(i) * 2654435761ULL) % 2001ULL) / 1000.0 - 1.0;
      v[i] = (usable(fn) ? fy[i] : 0.0) + mix * r;
    }
    vn = norm(v);
    if (!usable(vn)) return 0.0;
  }
  s.have_direction = true;
  const double root_eps = std::sqrt(std::numeric_limits<double>::epsilon());
  const double yn = norm(y);
  const double dy = usable(yn) ? root_eps * yn : root_eps;  // size of the perturbation
  double rho = 0.0, largest = 0.0;
  for (int k = 0; k < StabilityLimit::kMaxIterations; ++k) {
    const double scale = dy / vn;
    for (sunindextype i = 0; i < n; ++i) yp[i] = y[i] + scale * v[i];
    system.CalcDerivatives(t, yp, fp);
    ++s.evaluations;
    for (sunindextype i = 0; i < n; ++i) v[i] = fp[i] - fy[i];
    vn = norm(v);
    if (!usable(vn)) {
      s.have_direction = false;
      return largest;
    }
    const double next = vn / dy;
    largest = std::max(largest, next);
    if (k > 0 && std::abs(next - rho) <= 0.01 * next) return std::max(next, rho);
    rho = next;
  }
  return largest;
}

/// ARKODE's explicit stability function (ERKStepSetStabilityFn): hstab = interval / rho, with
/// rho renewed every kRenewEvery calls (ARKODE calls it once per step attempt).
int StabilityStep(N_Vector y, sunrealtype t, sunrealtype* hstab, void* user_data) noexcept {
  auto* state = static_cast<ErkCallbackState*>(static_cast<sun::CallbackState*>(user_data));
  StabilityLimit& s = state->stability;
  if (s.calls++ % StabilityLimit::kRenewEvery == 0) {
    try {
      const double rho = SpectralRadius(*state->system, t, N_VGetArrayPointer(y), N_VGetLength(y), s);
      // Rounded up to a grid of 64 values per octave (at most 1.1% more): the finite differences
      // carry the rounding of f (~1e-7 relative), which would otherwise change the step, and so
      // the whole trajectory, between runs whose right-hand sides differ only by rounding (the
      // generated code and the interpreter).
      s.hstab = rho > 0.0 && std::isfinite(rho) ? s.interval / std::exp2(std::ceil(std::log2(rho) * 64.0) / 64.0) : 0.0;
    } catch (...) {
      state->pending = std::current_exception();
      return -1;
    }
  }
  *hstab = s.hstab;  // <= 0: ARKODE applies no stability limit
  return 0;
}

/// Post-step hook of fixed-step runs; returning nonzero stops ERKStepEvolve. A fixed step has
/// no error test, so an unstable step size or a finite-time blow-up would otherwise march on
/// with inf/NaN states and return them as results.
int CheckStateFinite(sunrealtype t, N_Vector y, void* user_data) noexcept {
  // Restore the system's invariants first (orthonormal orientations), as CVODE's projection does.
  auto* common = static_cast<sun::CallbackState*>(user_data);
  if (common->project) common->system->Project(t, N_VGetArrayPointer(y));
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

/// The error weights ewt_i = 1 / (rtol |y_i| + atol_i), ARKODE's own formula, in one pass (two
/// when some absolute tolerance is zero) where ARKODE's built-in function makes five vector
/// operations (abs, scale, add, min, inverse) every step. Like it, fails (-1) when a weight
/// would be infinite, which only a zero absolute tolerance allows. (One pass instead of two:
/// 592 -> 388 instructions per call on the differential, callgrind.) (A reciprocal estimate refined by Newton steps instead of the
/// divisions was 2.6 times faster alone, but no faster in a run: the divisions overlap with
/// what follows.)
int ErrorWeights(N_Vector y, N_Vector ewt, void* user_data) noexcept {
  const auto* state = static_cast<const ErkCallbackState*>(static_cast<sun::CallbackState*>(user_data));
  const sunrealtype* yd = NV_DATA_S(y);
  sunrealtype* w = NV_DATA_S(ewt);
  const sunindextype n = NV_LENGTH_S(y);
  const double rtol = state->rtol;
  if (!state->some_atol_zero) {  // every weight finite: one pass
    if (const double* atol_i = state->atol_per_state) {
      for (sunindextype i = 0; i < n; ++i) w[i] = 1.0 / (rtol * std::abs(yd[i]) + atol_i[i]);
    } else {
      const double atol = state->atol;
      for (sunindextype i = 0; i < n; ++i) w[i] = 1.0 / (rtol * std::abs(yd[i]) + atol);
    }
    return 0;
  }
  if (const double* atol_i = state->atol_per_state) {
    for (sunindextype i = 0; i < n; ++i) w[i] = rtol * std::abs(yd[i]) + atol_i[i];
  } else {
    const double atol = state->atol;
    for (sunindextype i = 0; i < n; ++i) w[i] = rtol * std::abs(yd[i]) + atol;
  }
  int zero = 0;
  for (sunindextype i = 0; i < n; ++i) zero |= !(w[i] > 0.0);
  if (zero) return -1;
  for (sunindextype i = 0; i < n; ++i) w[i] = 1.0 / w[i];
  return 0;
}

class ArkodeIntegrator final : public sun::SundialsIntegrator<ErkCallbackState> {
  std::vector<int> roots_found_;  ///< ERKStepGetRootInfo's answer, per event function
  double root_time_ = 0.0;        ///< the event's time when AdvanceUntil stopped at one, else -inf
  /// An event a step found beyond the tout it was asked for (-inf: none), and its roots.
  double pending_root_ = -std::numeric_limits<double>::infinity();
  std::vector<int> pending_roots_;

 public:
  ArkodeIntegrator(OdeSystem& system, const IntegratorOptions& options) : SundialsIntegrator(system, options) {}

  void Reset(double t0, const double* x0) override {
    LoadInitialState(x0);
    pending_root_ = -std::numeric_limits<double>::infinity();
    callbacks_.nonfinite = false;
    t_step_ = t0;
    steps_since_check_ = 0;
    restart_pending_ = false;
    callbacks_.stability.calls = 0;
    callbacks_.stability.evaluations = 0;
    callbacks_.stability.have_direction = false;
    if (mem_) {
      Check(ERKStepReInit(mem_.get(), sun::Rhs, t0, y_.get()), t0);  // keeps options and table
    } else {
      Create(t0);
    }
    time_ = t0;
    projections_ = 0;
  }

  void AdvanceTo(double tout, double* x) override { AdvanceUntil(tout, sun::kNoStopTime, x, nullptr); }

  double AdvanceUntil(double tout, double stop_time, double* x, int* roots) override {
    MB_ASSERT(mem_ != nullptr, "AdvanceTo called before Reset");
    MB_ASSERT(tout >= time_, fmt::format("AdvanceTo({}) is before the current time {}", tout, time_));
    MB_ASSERT(stop_time >= tout, "a stop time before tout");
    if (roots) std::fill(roots, roots + roots_found_.size(), 0);
    if (sun::TooCloseToStep(time_, tout)) {
      time_ = tout;  // nothing to integrate (sundials_support.h)
    } else {
      callbacks_.ClearMessages();
      root_time_ = -std::numeric_limits<double>::infinity();
      if (fixed_step()) {
        AdvanceFixed(tout);
      } else {
        AdvanceAdaptive(tout, stop_time);
      }
      if (root_time_ > -std::numeric_limits<double>::infinity()) {  // stopped at an event: y_ holds the state there
        if (roots) sun::CopyRoots(roots_found_, roots);
        time_ = root_time_;
      } else {
        time_ = tout;
      }
    }
    std::copy_n(N_VGetArrayPointer(y_.get()), n_, x);
    return time_;
  }

  IntegratorStats stats() const override {
    IntegratorStats s;
    if (!mem_) return s;
    ERKStepGetNumSteps(mem_.get(), &s.steps);
    ERKStepGetNumRhsEvals(mem_.get(), &s.rhs_evals);
    s.rhs_evals += callbacks_.stability.evaluations;  // the stability limit's estimates
    ERKStepGetNumErrTestFails(mem_.get(), &s.error_test_failures);
    ERKStepGetLastStep(mem_.get(), &s.last_step);
    s.projections = projections_;
    return s;
  }


 private:
  bool fixed_step() const { return options_.fixed_step > 0; }

  /// Fixed step: ERKStep's normal mode with a stop time at tout (only the last step before it is
  /// shortened) and the post-step hook (projection, and the finiteness check a fixed step needs).
  void AdvanceFixed(double tout) {
    Check(ERKStepSetStopTime(mem_.get(), tout), time_);
    // A fixed step takes (tout - t) / step steps, however many: the cap is for step-choosing methods that stall.
    const long needed = static_cast<long>(std::ceil((tout - time_) / options_.fixed_step)) + 16;
    Check(ERKStepSetMaxNumSteps(mem_.get(), std::max(options_.max_steps_per_output, needed)), time_);
    sunrealtype reached = time_;
    const int flag = ERKStepEvolve(mem_.get(), tout, y_.get(), &reached, ARK_NORMAL);
    sun::RethrowPending(callbacks_);
    if (flag == ARK_ROOT_RETURN) {
      root_time_ = reached;
      Check(ERKStepGetRootInfo(mem_.get(), roots_found_.data()), reached);
    }
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
  }

  /// Adaptive: one ERKStep step at a time (ARK_ONE_STEP) until the step passes tout, then the
  /// solution at tout from ERKStep's interpolant (as accurate as the steps, and cheaper than
  /// cutting a step at every output). Stepping ourselves lets the invariants be restored without
  /// a post-step hook: with one, SUNDIALS 6.4 evaluates f(t_n+1, y_n+1) anew after every step,
  /// which costs the first-same-as-last methods their reuse of the last stage (Dormand-Prince:
  /// 7 evaluations per step instead of 6; Bogacki-Shampine: 4 instead of 3). Instead the drift
  /// is measured every kDriftCheckInterval steps, and only when it matters (CheckDrift) is the
  /// state projected and ERKStep restarted from it: ERKStepReset keeps the step size and the
  /// controller's history, and costs one evaluation.
  void AdvanceAdaptive(double tout, double stop_time) {
    void* mem = mem_.get();
    const double hmin = sun::MinUsefulStep(time_);  // see there
    if (options_.max_step == 0 || hmin < options_.max_step) Check(ERKStepSetMinStep(mem, hmin), time_);
    Check(ERKStepSetStopTime(mem, std::min(stop_time, sun::kNoStopTime)), time_);
    // An event found by a step that went past an earlier tout: the interpolant of that step
    // still gives the state there, and the one at tout before it.
    if (pending_root_ > -std::numeric_limits<double>::infinity()) {
      if (pending_root_ <= tout) {
        root_time_ = pending_root_;
        roots_found_ = pending_roots_;
        pending_root_ = -std::numeric_limits<double>::infinity();
        Check(ERKStepGetDky(mem, root_time_, 0, y_.get()), root_time_);
        return;
      }
      Check(ERKStepGetDky(mem, tout, 0, y_.get()), t_step_);
      return;
    }
    long steps = 0;
    while (t_step_ < tout) {
      if (steps == options_.max_steps_per_output) Check(ARK_TOO_MUCH_WORK, t_step_);
      if (restart_pending_) {
        restart_pending_ = false;
        Check(ERKStepReset(mem, t_step_, projected_.get()), t_step_);
        ++projections_;
      }
      sunrealtype reached = t_step_;
      const int flag = ERKStepEvolve(mem, tout, step_.get(), &reached, ARK_ONE_STEP);
      sun::RethrowPending(callbacks_);
      if (flag < 0) {
        ERKStepGetCurrentTime(mem, &reached);
        Check(flag, reached);
      }
      if (flag == ARK_ROOT_RETURN) {  // step_ holds the interpolated state at the event
        sunrealtype tcur = reached;
        ERKStepGetCurrentTime(mem, &tcur);  // the step's end, past the event
        if (reached > tout) {  // after tout: reported by the next call, tout's state first
          pending_root_ = reached;
          Check(ERKStepGetRootInfo(mem, pending_roots_.data()), reached);
          t_step_ = tcur;
          break;
        }
        root_time_ = reached;
        Check(ERKStepGetRootInfo(mem, roots_found_.data()), reached);
        std::copy_n(N_VGetArrayPointer(step_.get()), n_, N_VGetArrayPointer(y_.get()));
        return;
      }
      t_step_ = reached;
      ++steps;
      if (callbacks_.project && ++steps_since_check_ >= kDriftCheckInterval) {
        steps_since_check_ = 0;
        CheckDrift();
      }
    }
    Check(ERKStepGetDky(mem, tout, 0, y_.get()), t_step_);
  }

  /// Right after a step (step_ holds y_n at t_n, written by ARK_ONE_STEP): projects a copy
  /// of y_n and, if the projection moves some component by more than kDriftFraction of its
  /// error tolerance rtol |y_i| + atol_i, restarts ERKStep from it before the next step. Not at
  /// once: outputs inside the step just taken are still interpolated from ERKStep's data.
  void CheckDrift() {
    const sunrealtype* y = N_VGetArrayPointer(step_.get());
    sunrealtype* p = N_VGetArrayPointer(projected_.get());
    std::copy_n(y, n_, p);
    callbacks_.system->Project(t_step_, p);
    const double rtol = options_.rtol;
    const double* atol = callbacks_.atol_per_state;
    bool drifted = false;
    for (sunindextype i = 0; i < n_; ++i)
      drifted |= std::abs(p[i] - y[i]) > kDriftFraction * (rtol * std::abs(y[i]) + (atol ? atol[i] : options_.atol));
    restart_pending_ = drifted;
  }

  void Create(double t0) {
    // Kept local until fully configured, so a failure leaves no half-built solver behind.
    ErkMemPtr owner(sun::NonNull(ERKStepCreate(sun::Rhs, t0, y_.get(), ctx_.get())));
    void* mem = owner.get();
    Check(ERKStepSetErrHandlerFn(mem, sun::RecordMessage, &callbacks_), t0);
    Check(ERKStepSetUserData(mem, static_cast<sun::CallbackState*>(&callbacks_)), t0);
    callbacks_.rtol = options_.rtol;
    callbacks_.atol = options_.atol;
    callbacks_.atol_per_state = options_.atol_per_state.empty() ? nullptr : options_.atol_per_state.data();
    callbacks_.some_atol_zero = callbacks_.atol_per_state
                                    ? *std::min_element(options_.atol_per_state.begin(), options_.atol_per_state.end()) <= 0.0
                                    : options_.atol <= 0.0;
    Check(ERKStepWFtolerances(mem, ErrorWeights), t0);  // receives the user data (set above)
    if (const int nr = callbacks_.system->num_roots(); nr > 0) {
      roots_found_.assign(nr, 0);
      pending_roots_.assign(nr, 0);
      std::vector<int> directions(nr, -1);  // which crossings are events (OdeSystem::RootDirections)
      callbacks_.system->RootDirections(directions.data());
      Check(ERKStepRootInit(mem, nr, sun::Roots), t0);
      Check(ERKStepSetRootDirection(mem, directions.data()), t0);
      Check(ERKStepSetNoInactiveRootWarn(mem), t0);
    }
    if (const ButcherTablePtr table = OwnTable(options_.method)) {
      Check(ERKStepSetTable(mem, table.get()), t0);  // ERKStep keeps a copy
    } else {
      // Both tables (and srk3's above) are truly "first same as last" (last row of A = b), which
      // matters: without a post-step hook SUNDIALS 6.4.1 reuses the last stage of any table
      // whose last node is c = 1 (see the fixed-step note below), and the adaptive path has no
      // hook.
      Check(ERKStepSetTableNum(mem, options_.method == Method::kBogackiShampine ? ARKODE_BOGACKI_SHAMPINE_4_2_3
                                                                                 : ARKODE_DORMAND_PRINCE_7_4_5),
            t0);
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
      if (options_.max_step > 0) Check(ERKStepSetMaxStep(mem, options_.max_step), t0);
      if (options_.initial_step > 0) Check(ERKStepSetInitStep(mem, options_.initial_step), t0);
      if (StabilityInterval(options_.method) > 0) {
        // Steps at most kMargin of the stability limit (see StabilityLimit). Not for
        // Dormand-Prince: with ERKStep's defaults its step settles at 87% of its limit on the differential (and stays there,
        // see the window below); with this bound and no window it took 120,129 steps instead
        // of 129,889, but its reaction forces were noisier: runs differing by rounding drifted
        // 1.8e-7 apart over 5 s, against 6e-9.
        StabilityLimit& s = callbacks_.stability;
        s.interval = StabilityInterval(options_.method);
        for (auto* scratch : {&s.fy, &s.v, &s.yp, &s.fp}) scratch->assign(n_, 0.0);
        Check(ERKStepSetStabilityFn(mem, StabilityStep, static_cast<sun::CallbackState*>(&callbacks_)), t0);
        Check(ERKStepSetCFLFraction(mem, StabilityLimit::kMargin), t0);
        // ERKStep keeps the step unchanged while the controller proposes between 1 and 1.5
        // times it. Below the stability limit that froze the differential at 2.1e-5 s, 1.49
        // times short of the limit; without the window the step sits at the limit (or wherever
        // accuracy puts it).
        Check(ERKStepSetFixedStepBounds(mem, 1.0, 1.0), t0);
      }
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
    // A step that met infinities leaves ERKStep's own time NaN: the failure is after the last good time.
    SolverError error(std::isfinite(t) ? t : time_, name ? name.get() : fmt::format("ARKODE flag {}", flag), std::move(text));
    if (mem_ && flag != ARK_TOO_MUCH_WORK) {  // too many steps: no state failed a test
      sun::VectorPtr ele = sun::MakeVector(n_, ctx_.get()), ewt = sun::MakeVector(n_, ctx_.get());
      if (ERKStepGetEstLocalErrors(mem_.get(), ele.get()) == ARK_SUCCESS && ERKStepGetErrWeights(mem_.get(), ewt.get()) == ARK_SUCCESS)
        error.set_states(sun::WorstComponents(ele.get(), ewt.get()));
    }
    throw error;
  }

  /// How often (in steps) the adaptive path measures the drift off the invariant manifold, and
  /// the largest correction it lets pass, as a fraction of each component's error tolerance.
  /// On the differential (rtol 1e-8, atol 1e-10) Dormand-Prince never reaches it over 0-5 s;
  /// Bogacki-Shampine projects 5,125 times in 160,185 steps, and |R^T R - I| of the states it
  /// reports (interpolated, before the simulator projects them) stays below 2e-10 (1e-16 with
  /// a projection after every step; 1.1e-13 for Dormand-Prince, which never projects here).
  static constexpr long kDriftCheckInterval = 16;
  static constexpr double kDriftFraction = 1e-3;


  double t_step_ = 0.0;         ///< time of ERKStep's internal state (adaptive path)
  long steps_since_check_ = 0;  ///< steps since the last drift check
  bool restart_pending_ = false;  ///< restart from projected_ before the next step
  long projections_ = 0;
  sun::VectorPtr step_ = sun::MakeVector(n_, ctx_.get());       ///< y_n, written by ARK_ONE_STEP
  sun::VectorPtr projected_ = sun::MakeVector(n_, ctx_.get());  ///< scratch for the drift check
  // Destroyed before the base's context and vectors, which the solver memory refers to.
  ErkMemPtr mem_;
};

}  // namespace

std::unique_ptr<Integrator> MakeArkodeIntegrator(OdeSystem& system, const IntegratorOptions& options) {
  return std::make_unique<ArkodeIntegrator>(system, options);
}

}  // namespace multibond
