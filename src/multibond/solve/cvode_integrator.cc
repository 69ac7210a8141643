#include "multibond/solve/cvode_integrator.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include <cvode/cvode.h>
#include <cvode/cvode_proj.h>
#include <cvode/cvode_ls.h>
#include <fmt/format.h>
#include <sunlinsol/sunlinsol_klu.h>
#include <sunmatrix/sunmatrix_dense.h>
#include <sunmatrix/sunmatrix_sparse.h>

#include "multibond/solve/column_groups.h"
#include "multibond/solve/eigen_linear_solver.h"
#include "multibond/solve/sundials_support.h"

namespace multibond {
namespace {

/// KLU's ordering codes (sunlinsol_klu.h names only its default, 1 = COLAMD): 0 is AMD.
constexpr int kKluOrderingAmd = 0;

struct CvodeMemDeleter {
  void operator()(void* mem) const noexcept { CVodeFree(&mem); }
};
using CvodeMemPtr = std::unique_ptr<void, CvodeMemDeleter>;

std::string Explain(int flag, const IntegratorOptions& options) {
  switch (flag) {
    case CV_TOO_MUCH_WORK:
      return fmt::format(
          "the solver took max_steps_per_output = {} steps without reaching the next output time",
          options.max_steps_per_output);
    case CV_TOO_MUCH_ACC:
      return "the requested accuracy is beyond machine precision (tolerances too small)";
    case CV_ERR_FAILURE:
      return "error test failed repeatedly or with |h| = hmin (is the solution blowing up?)";
    case CV_CONV_FAILURE:
      return "the nonlinear solver failed to converge repeatedly or with |h| = hmin";
    case CV_LINIT_FAIL:
    case CV_LSETUP_FAIL:
    case CV_LSOLVE_FAIL:
      return "the linear solver failed (singular Newton matrix?)";
    case CV_RHSFUNC_FAIL:
    case CV_FIRST_RHSFUNC_ERR:
    case CV_REPTD_RHSFUNC_ERR:
    case CV_UNREC_RHSFUNC_ERR:
      return "the right-hand side failed";
    case CV_NLS_INIT_FAIL:
    case CV_NLS_SETUP_FAIL:
    case CV_NLS_FAIL:
      return "the nonlinear solver failed";
    case CV_MEM_FAIL:
      return "out of memory";
    case CV_ILL_INPUT:
      return "the solver rejected an input (option, tolerance or time)";
    case CV_TOO_CLOSE:
      return "the output time is too close to the start time";
    default:
      return "the solver failed";
  }
}

/// CallbackState plus what the difference-quotient Jacobian needs.
struct CvodeCallbackState : sun::CallbackState {
  using CallbackState::CallbackState;
  void* mem = nullptr;  ///< CVODE's, for the step and the error weights
  const JacobianPattern* pattern = nullptr;  ///< null: dense (every column its own group, every row)
  /// Dense matrix, but the system's pattern known: its column groups (a state that nothing depends
  /// on shares a group with the others like it) and only its rows are evaluated.
  const JacobianPattern* dense_pattern = nullptr;
  ColumnGroups groups;
  std::vector<double> increment;  ///< per state, for the group being evaluated
  std::vector<char> unresolved;   ///< per state: its column has a quotient lost in rounding
  std::vector<int> columns;       ///< the columns of the pass being evaluated (no two share a row)
  long evaluations = 0;           ///< of f, by DifferenceQuotientJacobian
};

/// J = df/dy by difference quotients: dense (one evaluation of f per column) or on the system's
/// pattern (one per group of columns that share no row, into a CSC matrix for KLU).
///
/// Each increment is first CVODE's own (cvLsDenseDQJac): max(sqrt(u) |y_j|, minInc / w_j),
/// minInc = 1000 |h| u n |f|_wrms, w the error weights. That increment shrinks with h, and a
/// quotient whose difference f_i(y + d e_j) - f_i(y) is a few roundings of f_i is noise of size
/// u |f_i| / d: starting from rest with a large force (1e5 N on a 10 kg mass and a 100 N/m
/// spring, atol 1e-10), the first step is 2e-15 s, d ~ 1e-21, and CVODE's own dense Jacobian held
/// +1.9e10 where -100 belongs. CVODE keeps a Jacobian for up to 51 steps: as h grew a
/// thousandfold, that entry dominated the Newton matrix, each correction came out tiny, the
/// iteration "converged" at the predictor and BDF went on with the spring ignored (spring.q 2e4
/// instead of 0.86 at 2 s, status ok); the noise there was CVODE's f(y) at the first step, off
/// by one rounding from what f returns (h f / h). So a nonzero difference below 64 roundings
/// of f_i is not taken: the column is evaluated again with its increment times 1000 (up to three
/// times, while the increment stays below sqrt(u) max(|y_j|, 1)), and the entry takes the first
/// resolved quotient, else 0: a zero entry only slows Newton's convergence (CVODE then renews
/// the Jacobian at the step it has reached), a noise entry of any size can stop it from
/// converging to the right answer. A difference of exactly zero is a zero entry.
int DifferenceQuotientJacobian(sunrealtype t, N_Vector y, N_Vector fy, SUNMatrix jac, void* user_data, N_Vector tmp1,
                               N_Vector tmp2, N_Vector tmp3) noexcept {
  auto* state = static_cast<CvodeCallbackState*>(user_data);
  try {
    const JacobianPattern* p = state->pattern;
    const JacobianPattern* dp = state->dense_pattern;
    const sunindextype n = N_VGetLength(y);
    if (p) {
      std::copy(p->col_start.begin(), p->col_start.end(), SUNSparseMatrix_IndexPointers(jac));  // CVODE zeroes the matrix first
      std::copy(p->row_index.begin(), p->row_index.end(), SUNSparseMatrix_IndexValues(jac));
    }
    sunrealtype* data = p ? SUNSparseMatrix_Data(jac) : SUNDenseMatrix_Data(jac);
    // Column j's entries: data[first + k] for the rows row(k), k in [0, count).
    auto entries = [&](int j, auto&& visit) {
      if (p) {
        for (int e = p->col_start[j]; e < p->col_start[j + 1]; ++e) visit(p->row_index[e], data + e);
      } else if (dp) {  // CVODE zeroes the matrix first
        for (int e = dp->col_start[j]; e < dp->col_start[j + 1]; ++e)
          visit(dp->row_index[e], data + static_cast<size_t>(j) * n + dp->row_index[e]);
      } else {
        for (sunindextype i = 0; i < n; ++i) visit(static_cast<int>(i), data + static_cast<size_t>(j) * n + i);
      }
    };

    N_Vector ewt = tmp3;
    sunrealtype h = 0.0;
    if (CVodeGetErrWeights(state->mem, ewt) != CV_SUCCESS || CVodeGetCurrentStep(state->mem, &h) != CV_SUCCESS)
      return -1;
    const double uround = std::numeric_limits<double>::epsilon();
    const double srur = std::sqrt(uround);
    const double fnorm = N_VWrmsNorm(fy, ewt);
    const double min_inc = fnorm != 0.0 ? 1000.0 * std::abs(h) * uround * static_cast<double>(n) * fnorm : 1.0;
    constexpr double kResolved = 64.0;  // roundings of f_i a difference must exceed (a few: noise)
    constexpr int kRetries = 3;
    const sunrealtype* yv = N_VGetArrayPointer(y);
    const sunrealtype* f0 = N_VGetArrayPointer(fy);
    const sunrealtype* w = N_VGetArrayPointer(ewt);
    sunrealtype* yp = N_VGetArrayPointer(tmp1);
    sunrealtype* f1 = N_VGetArrayPointer(tmp2);
    std::copy_n(yv, n, yp);
    std::vector<char>& unresolved = state->unresolved;
    unresolved.assign(n, 0);
    std::vector<int>& columns = state->columns;
    const int groups = p || dp ? state->groups.count() : static_cast<int>(n);
    for (int g = 0; g < groups; ++g) {
      columns.clear();
      if (p || dp) columns.assign(state->groups.column.begin() + state->groups.start[g], state->groups.column.begin() + state->groups.start[g + 1]);
      else columns.push_back(g);
      for (int pass = 0; pass <= kRetries && !columns.empty(); ++pass) {
        for (const int j : columns) {
          const double d = pass == 0 ? std::max(srur * std::abs(yv[j]), min_inc / w[j]) : state->increment[j] * 1000.0;
          yp[j] = yv[j] + d;
          state->increment[j] = yp[j] - yv[j];  // the step as represented
        }
        state->system->CalcDerivatives(t, yp, f1);
        ++state->evaluations;
        for (const int j : columns) {
          const double inv = 1.0 / state->increment[j];
          const bool last = pass == kRetries || state->increment[j] * 1000.0 > srur * std::max(std::abs(yv[j]), 1.0);
          bool noisy = false;
          entries(j, [&](int i, double* out) {
            if (pass > 0 && !(std::isnan(*out))) return;  // resolved at an earlier pass
            const double diff = f1[i] - f0[i];
            const bool lost = diff != 0.0 && std::abs(diff) <= kResolved * uround * std::max(std::abs(f0[i]), std::abs(f1[i]));
            // NaN: to be done again; at the last increment, noise is no information: 0.
            *out = !lost ? diff * inv : last ? 0.0 : std::numeric_limits<double>::quiet_NaN();
            noisy = noisy || (lost && !last);
          });
          unresolved[j] = noisy;
          yp[j] = yv[j];
        }
        columns.erase(std::remove_if(columns.begin(), columns.end(), [&](int j) { return !unresolved[j]; }), columns.end());
      }
    }
    return 0;
  } catch (...) {
    state->pending = std::current_exception();
    return -1;
  }
}

class CvodeIntegrator final : public sun::SundialsIntegrator<CvodeCallbackState> {
 public:
  CvodeIntegrator(OdeSystem& system, const IntegratorOptions& options) : SundialsIntegrator(system, options) {}

  void Reset(double t0, const double* x0) override {
    LoadInitialState(x0);
    callbacks_.evaluations = 0;  // CVodeReInit zeroes CVODE's counters too
    if (mem_) {
      Check(CVodeReInit(mem_.get(), t0, y_.get()), t0);  // keeps every option, zeroes counters
    } else {
      Create(t0);
    }
    time_ = t0;
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
      const double hmin = sun::MinUsefulStep(time_);  // see there
      if (options_.max_step == 0 || hmin < options_.max_step)
        Check(CVodeSetMinStep(mem_.get(), hmin), time_);
      Check(CVodeSetStopTime(mem_.get(), std::min(stop_time, sun::kNoStopTime)), time_);
      sunrealtype reached = time_;
      // CV_NORMAL may step past tout and interpolate back; harmless for smooth models.
      const int flag = CVode(mem_.get(), tout, y_.get(), &reached, CV_NORMAL);
      sun::RethrowPending(callbacks_);
      Check(flag, reached);
      if (flag == CV_ROOT_RETURN) {
        Check(CVodeGetRootInfo(mem_.get(), roots_found_.data()), reached);
        if (roots) sun::CopyRoots(roots_found_, roots);
        time_ = reached;
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
    void* mem = mem_.get();
    long nfe = 0;
    long nfe_ls = 0;
    CVodeGetNumSteps(mem, &s.steps);
    CVodeGetNumRhsEvals(mem, &nfe);
    CVodeGetNumLinSolvSetups(mem, &s.linear_setups);
    CVodeGetNumErrTestFails(mem, &s.error_test_failures);
    CVodeGetNumNonlinSolvConvFails(mem, &s.nonlinear_failures);
    CVodeGetLastStep(mem, &s.last_step);
    CVodeGetNumLinRhsEvals(mem, &nfe_ls);  // the difference-quotient Jacobian's evaluations
    CVodeGetNumJacEvals(mem, &s.jac_evals);
    s.rhs_evals = nfe + nfe_ls + callbacks_.evaluations;
    s.sparse_jacobian = callbacks_.pattern != nullptr;
    // Without the rounding check's repeats (they are in rhs_evals).
    s.evals_per_jacobian = s.sparse_jacobian || callbacks_.dense_pattern ? callbacks_.groups.count() : n_;
    return s;
  }

 private:
  std::vector<int> roots_found_;  ///< CVodeGetRootInfo's answer, per event function

  void Create(double t0) {
    const bool bdf = options_.method == Method::kBdf;
    // Kept local until fully configured, so a failure leaves no half-built solver behind.
    CvodeMemPtr owner(sun::NonNull(CVodeCreate(bdf ? CV_BDF : CV_ADAMS, ctx_.get())));
    void* mem = owner.get();
    Check(CVodeSetErrHandlerFn(mem, sun::RecordMessage, &callbacks_), t0);
    Check(CVodeInit(mem, sun::Rhs, t0, y_.get()), t0);
    Check(CVodeSetUserData(mem, &callbacks_), t0);
    if (options_.atol_per_state.empty()) {
      Check(CVodeSStolerances(mem, options_.rtol, options_.atol), t0);
    } else {
      sun::VectorPtr atol = sun::MakeVector(n_, ctx_.get());
      std::copy_n(options_.atol_per_state.data(), n_, N_VGetArrayPointer(atol.get()));
      Check(CVodeSVtolerances(mem, options_.rtol, atol.get()), t0);  // CVODE keeps a copy
    }
    // Both methods use CVODE's default Newton iteration with a difference-quotient Jacobian:
    // CVODE's own, dense, or (JacobianKind) ours on the system's pattern, sparse, with KLU.
    // Adams would classically use fixed-point iteration, but SUNDIALS 6.4's
    // SUNNonlinSol_FixedPoint turns an unrecoverable RHS failure (our -1 after an exception)
    // into a recoverable convergence failure: CVODE then shrinks h and creeps towards the
    // failing time until max_steps_per_output is exhausted (1e6 steps, seconds). Newton aborts
    // at once, tolerates mild stiffness and took ~25% fewer steps on a damped oscillator; the
    // price, a dense LU per Jacobian update, is small at the size of our models, with Eigen's
    // LU (eigen_linear_solver.h).
    callbacks_.mem = mem;
    const JacobianPattern* pattern = callbacks_.system->jacobian_pattern();
    const bool sparse = pattern != nullptr && pattern->n == n_ &&
                        (options_.jacobian == JacobianKind::kSparse ||
                         (options_.jacobian == JacobianKind::kAuto && n_ >= kSparseMinStates &&
                          pattern->nonzeros() <= kSparseMaxDensity * static_cast<double>(n_) * static_cast<double>(n_)));
    if (sparse) {
      callbacks_.pattern = pattern;
      callbacks_.groups = GroupColumns(*pattern);
      callbacks_.increment.assign(n_, 0.0);
      jacobian_.reset(sun::NonNull(SUNSparseMatrix(n_, n_, pattern->nonzeros(), CSC_MAT, ctx_.get())));
      linear_solver_.reset(sun::NonNull(SUNLinSol_KLU(y_.get(), jacobian_.get(), ctx_.get())));
      // KLU orders by AMD on A + A^T, not its default COLAMD: our Jacobians are structurally
      // almost symmetric (a coupling ties two bodies both ways), where AMD's fill is smaller.
      // BDF, measured (release): the compliant differential 0.45 -> 0.34 s, its pitch-point
      // variant 1.20 -> 0.72 s, the four-bar 0.29 -> 0.20 s, the planetary set 0.28 -> 0.21 s,
      // the 10,000-body chain 179 -> 170 ms; the compliant differential in joint coordinates
      // 0.88 -> 0.52 s (dense: 0.60 s).
      Check(SUNLinSol_KLUSetOrdering(linear_solver_.get(), kKluOrderingAmd), t0);
      Check(CVodeSetLinearSolver(mem, linear_solver_.get(), jacobian_.get()), t0);
    } else {
      callbacks_.pattern = nullptr;
      // With a pattern the dense Jacobian is still evaluated by groups of columns: fewer
      // evaluations whenever some states share no row (quadratures: one group for all of them).
      // (--jacobian dense asks for one evaluation per state, as CVODE's own.)
      callbacks_.dense_pattern = options_.jacobian == JacobianKind::kAuto && pattern != nullptr && pattern->n == n_ ? pattern : nullptr;
      if (callbacks_.dense_pattern) callbacks_.groups = GroupColumns(*pattern);
      callbacks_.increment.assign(n_, 0.0);
      jacobian_ = sun::MakeDenseMatrix(n_, n_, ctx_.get());
      linear_solver_.reset(sun::NonNull(sun::MakeEigenDenseSolver(n_, ctx_.get())));
      Check(CVodeSetLinearSolver(mem, linear_solver_.get(), jacobian_.get()), t0);
    }
    Check(CVodeSetJacFn(mem, DifferenceQuotientJacobian), t0);
    if (options_.max_step > 0) Check(CVodeSetMaxStep(mem, options_.max_step), t0);
    if (options_.initial_step > 0) Check(CVodeSetInitStep(mem, options_.initial_step), t0);
    if (const int nr = callbacks_.system->num_roots(); nr > 0) {
      roots_found_.assign(nr, 0);
      std::vector<int> directions(nr, -1);  // which crossings are events (OdeSystem::RootDirections)
      callbacks_.system->RootDirections(directions.data());
      Check(CVodeRootInit(mem, nr, sun::Roots), t0);
      Check(CVodeSetRootDirection(mem, directions.data()), t0);
      Check(CVodeSetNoInactiveRootWarn(mem), t0);
    }
    Check(CVodeSetMaxNumSteps(mem, options_.max_steps_per_output), t0);
    // Invariants (orthonormal orientation matrices) are restored after every step by CVODE's
    // projection: without it BDF's local errors pile up normal to the manifold (|R^T R - I|
    // ~1e-5 after 10 s of tumbling at rtol 1e-8), and a stabilising term cannot remove them.
    // CVODE projects with BDF only (with Adams, CVodeSetProjFn is accepted and the first step
    // fails: "Projection is only supported with BDF methods"). Adams integrates without it: the
    // drift off the manifold is then the integration error's (the simulator projects each state
    // it reports; over the ideal differential's 5 s at rtol 1e-8 the final speeds land within
    // 5e-9). Restarting Adams from projected states was tried: each restart drops it to order 1,
    // whose steps drift as fast again (2,700 restarts, 13 times slower).
    if (options_.project && bdf && callbacks_.system->has_invariants()) {
      Check(CVodeSetProjFn(mem, sun::ProjectCorrection), t0);
      Check(CVodeSetProjErrEst(mem, SUNFALSE), t0);
    }
    mem_ = std::move(owner);
  }

  /// Turns a negative CVODE flag into a SolverError.
  void Check(int flag, double t) const {
    if (flag >= 0) return;
    const sun::CString name(CVodeGetReturnFlagName(flag));
    std::string text = Explain(flag, options_);
    if (!callbacks_.message().empty()) text += "; CVODE: " + callbacks_.message();
    SolverError error(t, name ? name.get() : fmt::format("CVODE flag {}", flag), std::move(text));
    if (mem_ && flag != CV_TOO_MUCH_WORK) {  // too many steps: no state failed a test
      // Which states failed the error test: the weighted local error estimates of the last step.
      sun::VectorPtr ele = sun::MakeVector(n_, ctx_.get()), ewt = sun::MakeVector(n_, ctx_.get());
      if (CVodeGetEstLocalErrors(mem_.get(), ele.get()) == CV_SUCCESS && CVodeGetErrWeights(mem_.get(), ewt.get()) == CV_SUCCESS)
        error.set_states(sun::WorstComponents(ele.get(), ewt.get()));
    }
    throw error;
  }

  // Destroyed before the base's context and vectors, which the solver memory refers to.
  sun::MatrixPtr jacobian_;
  sun::LinearSolverPtr linear_solver_;
  CvodeMemPtr mem_;
};

}  // namespace

std::unique_ptr<Integrator> MakeCvodeIntegrator(OdeSystem& system, const IntegratorOptions& options) {
  return std::make_unique<CvodeIntegrator>(system, options);
}

}  // namespace multibond
