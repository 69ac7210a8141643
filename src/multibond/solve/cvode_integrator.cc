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

/// CallbackState plus what the sparse difference-quotient Jacobian needs.
struct CvodeCallbackState : sun::CallbackState {
  using CallbackState::CallbackState;
  void* mem = nullptr;  ///< CVODE's, for the step and the error weights
  const JacobianPattern* pattern = nullptr;
  ColumnGroups groups;
  std::vector<double> increment;  ///< per state, for the group being evaluated
  long evaluations = 0;           ///< of f, by SparseJacobian
};

/// J = df/dy on the system's pattern by difference quotients, one evaluation of f per group of
/// columns that share no row. Each increment is CVODE's own (cvLsDenseDQJac): max(sqrt(u) |y_j|,
/// minInc / w_j), minInc = 1000 |h| u n |f|_wrms, w the error weights; so a sparse Jacobian holds
/// the same quotients as CVODE's dense one, column by column.
int SparseJacobian(sunrealtype t, N_Vector y, N_Vector fy, SUNMatrix jac, void* user_data, N_Vector tmp1,
                   N_Vector tmp2, N_Vector tmp3) noexcept {
  auto* state = static_cast<CvodeCallbackState*>(user_data);
  try {
    const JacobianPattern& p = *state->pattern;
    const sunindextype n = N_VGetLength(y);
    sunindextype* col_start = SUNSparseMatrix_IndexPointers(jac);
    sunindextype* row = SUNSparseMatrix_IndexValues(jac);
    sunrealtype* data = SUNSparseMatrix_Data(jac);
    std::copy(p.col_start.begin(), p.col_start.end(), col_start);  // CVODE zeroes the matrix first
    std::copy(p.row_index.begin(), p.row_index.end(), row);

    N_Vector ewt = tmp3;
    sunrealtype h = 0.0;
    if (CVodeGetErrWeights(state->mem, ewt) != CV_SUCCESS || CVodeGetCurrentStep(state->mem, &h) != CV_SUCCESS)
      return -1;
    const double uround = std::numeric_limits<double>::epsilon();
    const double srur = std::sqrt(uround);
    const double fnorm = N_VWrmsNorm(fy, ewt);
    const double min_inc = fnorm != 0.0 ? 1000.0 * std::abs(h) * uround * static_cast<double>(n) * fnorm : 1.0;
    const sunrealtype* yv = N_VGetArrayPointer(y);
    const sunrealtype* f0 = N_VGetArrayPointer(fy);
    const sunrealtype* w = N_VGetArrayPointer(ewt);
    sunrealtype* yp = N_VGetArrayPointer(tmp1);
    sunrealtype* f1 = N_VGetArrayPointer(tmp2);
    std::copy_n(yv, n, yp);
    const ColumnGroups& groups = state->groups;
    for (int g = 0; g < groups.count(); ++g) {
      for (int k = groups.start[g]; k < groups.start[g + 1]; ++k) {
        const int j = groups.column[k];
        yp[j] = yv[j] + std::max(srur * std::abs(yv[j]), min_inc / w[j]);
        state->increment[j] = yp[j] - yv[j];  // the step as represented
      }
      state->system->CalcDerivatives(t, yp, f1);
      ++state->evaluations;
      for (int k = groups.start[g]; k < groups.start[g + 1]; ++k) {
        const int j = groups.column[k];
        const double inv = 1.0 / state->increment[j];
        for (int e = p.col_start[j]; e < p.col_start[j + 1]; ++e) data[e] = (f1[p.row_index[e]] - f0[p.row_index[e]]) * inv;
        yp[j] = yv[j];
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

  void AdvanceTo(double tout, double* x) override {
    MB_ASSERT(mem_ != nullptr, "AdvanceTo called before Reset");
    MB_ASSERT(tout >= time_, fmt::format("AdvanceTo({}) is before the current time {}", tout, time_));
    if (tout > time_) {
      callbacks_.ClearMessages();
      const double hmin = sun::MinUsefulStep(time_);  // see there
      if (options_.max_step == 0 || hmin < options_.max_step)
        Check(CVodeSetMinStep(mem_.get(), hmin), time_);
      sunrealtype reached = time_;
      // CV_NORMAL may step past tout and interpolate back; harmless for smooth models.
      const int flag = CVode(mem_.get(), tout, y_.get(), &reached, CV_NORMAL);
      sun::RethrowPending(callbacks_);
      Check(flag, reached);
      time_ = tout;
    }
    std::copy_n(N_VGetArrayPointer(y_.get()), n_, x);
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
    s.evals_per_jacobian = s.sparse_jacobian ? callbacks_.groups.count() : n_;
    return s;
  }

 private:
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
      Check(CVodeSetLinearSolver(mem, linear_solver_.get(), jacobian_.get()), t0);
      Check(CVodeSetJacFn(mem, SparseJacobian), t0);
    } else {
      jacobian_.reset(sun::NonNull(SUNDenseMatrix(n_, n_, ctx_.get())));
      linear_solver_.reset(sun::NonNull(sun::MakeEigenDenseSolver(n_, ctx_.get())));
      Check(CVodeSetLinearSolver(mem, linear_solver_.get(), jacobian_.get()), t0);
    }
    if (options_.max_step > 0) Check(CVodeSetMaxStep(mem, options_.max_step), t0);
    if (options_.initial_step > 0) Check(CVodeSetInitStep(mem, options_.initial_step), t0);
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
    if (mem_) {
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
