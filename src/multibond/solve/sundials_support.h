#pragma once
/// \file
/// Private to solve/: RAII ownership of SUNDIALS objects and the C callbacks shared by the CVODE
/// and ARKODE integrators. Not installed API; include only from this folder's .cc files.

#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
#include <vector>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <limits>
#include <memory>
#include <new>
#include <string>
#include <type_traits>
#include <utility>

#include <nvector/nvector_serial.h>
#include <sundials/sundials_context.h>
#include <sundials/sundials_linearsolver.h>
#include <sundials/sundials_matrix.h>
#include <sundials/sundials_nvector.h>
#include <sunmatrix/sunmatrix_dense.h>

#include "multibond/solve/integrator.h"

namespace multibond::sun {

struct ContextDeleter {
  void operator()(SUNContext ctx) const noexcept { SUNContext_Free(&ctx); }
};
struct VectorDeleter {
  void operator()(N_Vector v) const noexcept { N_VDestroy(v); }
};
struct MatrixDeleter {
  void operator()(SUNMatrix m) const noexcept { SUNMatDestroy(m); }
};
struct LinearSolverDeleter {
  void operator()(SUNLinearSolver ls) const noexcept { SUNLinSolFree(ls); }
};
/// For the malloc'd strings of CVodeGetReturnFlagName / ERKStepGetReturnFlagName.
struct CFreeDeleter {
  void operator()(char* p) const noexcept { std::free(p); }
};

using ContextPtr = std::unique_ptr<std::remove_pointer_t<SUNContext>, ContextDeleter>;
using VectorPtr = std::unique_ptr<std::remove_pointer_t<N_Vector>, VectorDeleter>;
using MatrixPtr = std::unique_ptr<std::remove_pointer_t<SUNMatrix>, MatrixDeleter>;
using LinearSolverPtr = std::unique_ptr<std::remove_pointer_t<SUNLinearSolver>, LinearSolverDeleter>;
using CString = std::unique_ptr<char, CFreeDeleter>;

/// SUNDIALS constructors report failure by returning NULL; the only cause is memory.
template <typename T>
T NonNull(T p) {
  if (p == nullptr) throw std::bad_alloc();
  return p;
}

inline ContextPtr MakeContext() {
  SUNContext ctx = nullptr;
  if (SUNContext_Create(nullptr, &ctx) != 0) throw std::bad_alloc();
  return ContextPtr(NonNull(ctx));
}

/// Tight loops for the vector operations the integrators call every step. Debian's serial
/// N_Vector spends ~74 instructions per element in a linear combination (measured with callgrind
/// on the differential: 4 calls per RK4 step cost 5x the four right-hand sides). SUNDIALS lets an
/// application replace any entry of a vector's operations table; clones inherit the table.
namespace fast {
// Every vector here is serial (MakeVector and its clones): read its content directly rather than
// through the operations table.
inline sunrealtype* Data(N_Vector v) { return NV_DATA_S(v); }
inline sunindextype Len(N_Vector v) { return NV_LENGTH_S(v); }
inline void LinearSum(sunrealtype a, N_Vector x, sunrealtype b, N_Vector y, N_Vector z) {
  const sunrealtype *xd = Data(x), *yd = Data(y);
  sunrealtype* zd = Data(z);
  for (sunindextype i = 0, n = Len(z); i < n; ++i) zd[i] = a * xd[i] + b * yd[i];
}
inline void Scale(sunrealtype c, N_Vector x, N_Vector z) {
  const sunrealtype* xd = Data(x);
  sunrealtype* zd = Data(z);
  if (c == 1.0) {  // the integrators copy vectors this way: 1 * x is x
    if (zd != xd) std::copy_n(xd, Len(z), zd);
    return;
  }
  for (sunindextype i = 0, n = Len(z); i < n; ++i) zd[i] = c * xd[i];
}
inline void Const(sunrealtype c, N_Vector z) {
  sunrealtype* zd = Data(z);
  for (sunindextype i = 0, n = Len(z); i < n; ++i) zd[i] = c;
}
/// z = sum_j c_j x_j in one pass over the elements (z written once, each x_j read once), with
/// the number of vectors a compile-time constant so the inner sum unrolls and the loop vectorises.
/// The coefficients and the data pointers are copied into locals first: read through `c` and `x`
/// inside the loop, GCC reloads them at every element (a store to z might change them), which
/// made the 4-vector combination of the differential 1.45 times slower (103 against 71 ns for 196
/// elements, alone in a loop). The sum runs in the same order as before: bit-identical results.
template <size_t... J>
inline void CombineTerms(std::index_sequence<J...>, const sunrealtype* c, N_Vector* x, sunrealtype* z, sunindextype n) {
  // J runs over 0..N-2: the terms after the first.
  const sunrealtype cc[] = {c[0], c[J + 1]...};
  const sunrealtype* const xs[] = {Data(x[0]), Data(x[J + 1])...};
  // z is either one of the x_j (same elements) or disjoint from all: element i of z depends on
  // element i of the x_j only, so there is no loop-carried dependence. Said explicitly: with more
  // than ~8 vectors GCC stops checking the pointers for overlap at run time and would otherwise
  // not vectorise the loop (SSPRK(9,3)'s 10-vector combinations ran 4 times slower).
#pragma GCC ivdep
  for (sunindextype i = 0; i < n; ++i) {
    sunrealtype s = cc[0] * xs[0][i];
    ((s += cc[J + 1] * xs[J + 1][i]), ...);
    z[i] = s;  // z may be x[0] (SUNDIALS allows it): x[0][i] has been read already
  }
}
template <int N>
inline void Combine(const sunrealtype* c, N_Vector* x, sunrealtype* z, sunindextype n) {
  CombineTerms(std::make_index_sequence<N - 1>{}, c, x, z, n);
}
/// Terms with a zero coefficient are left out (Butcher tables have many: Bogacki-Shampine's
/// solution weights end in 0, Dormand-Prince's have two), which saves reading a whole vector
/// each; 0 * x_j adds nothing unless x_j holds an infinity or a NaN.
/// Up to kMaxFused vectors in one pass (the 9-stage SSPRK(9,3) combines 10); more in passes.
constexpr int kMaxFused = 16;
template <int... N>
constexpr std::array<void (*)(const sunrealtype*, N_Vector*, sunrealtype*, sunindextype), sizeof...(N)> CombineTable(
    std::integer_sequence<int, N...>) {
  return {&Combine<N + 1>...};
}
inline int LinearCombination(int nvec, sunrealtype* c, N_Vector* x, N_Vector z) {
  sunrealtype* zd = Data(z);
  const sunindextype n = Len(z);
  sunrealtype cs[kMaxFused];
  N_Vector xs[kMaxFused];
  if (nvec <= kMaxFused) {
    int kept = 0;
    for (int j = 0; j < nvec; ++j)
      if (c[j] != 0.0) {
        cs[kept] = c[j];
        xs[kept++] = x[j];
      }
    if (kept == 0) {
      std::fill_n(zd, n, 0.0);
      return 0;
    }
    static constexpr auto kCombine = CombineTable(std::make_integer_sequence<int, kMaxFused>{});
    kCombine[kept - 1](cs, xs, zd, n);
    return 0;
  }
  // More vectors (high-order tables): accumulate in passes.
  const sunrealtype* x0 = Data(x[0]);
  for (sunindextype i = 0; i < n; ++i) zd[i] = c[0] * x0[i];
  for (int j = 1; j < nvec; ++j) {
    const sunrealtype* xj = Data(x[j]);
    for (sunindextype i = 0; i < n; ++i) zd[i] += c[j] * xj[i];
  }
  return 0;
}
inline void Inv(N_Vector x, N_Vector z) {
  const sunrealtype* xd = Data(x);
  sunrealtype* zd = Data(z);
  for (sunindextype i = 0, n = Len(z); i < n; ++i) zd[i] = 1.0 / xd[i];
}
inline int ScaleAddMulti(int nvec, sunrealtype* a, N_Vector x, N_Vector* y, N_Vector* z) {
  const sunrealtype* xd = Data(x);
  const sunindextype n = Len(x);
  for (int j = 0; j < nvec; ++j) {
    const sunrealtype* yd = Data(y[j]);
    sunrealtype* zd = Data(z[j]);
    for (sunindextype i = 0; i < n; ++i) zd[i] = a[j] * xd[i] + yd[i];
  }
  return 0;
}
/// Four doubles (GCC/clang vector extension): the compiler keeps these in AVX registers.
typedef double Double4 __attribute__((vector_size(32)));
/// p = x[0..4) * w[0..4), elementwise, from unaligned loads. (Written through a reference: a
/// Double4 returned by value is an AVX register in the ABI only with AVX on, and GCC warns.)
inline void Product4(const sunrealtype* x, const sunrealtype* w, Double4& p) {
  Double4 a, b;
  std::memcpy(&a, x, sizeof a);
  std::memcpy(&b, w, sizeof b);
  p = a * b;
}
/// sum_i (x_i w_i)^2 with sixteen partial sums in four vector registers. One running sum is a
/// chain of dependent additions (4 cycles each; 196 on the differential, twice per step),
/// which strict IEEE order forbids the compiler to split. 160 ns per call that way, 34 ns
/// this way (the error norm's latency is on the step's critical path). The rounding differs
/// from a single running sum in the last bits, always in the same way.
inline sunrealtype WSqrSumLocal(N_Vector x, N_Vector w) {
  const sunrealtype *xd = Data(x), *wd = Data(w);
  const sunindextype n = Len(x);
  Double4 a0 = {0.0, 0.0, 0.0, 0.0}, a1 = a0, a2 = a0, a3 = a0;
  sunindextype i = 0;
  for (; i + 16 <= n; i += 16) {
    Double4 p0, p1, p2, p3;
    Product4(xd + i, wd + i, p0);
    Product4(xd + i + 4, wd + i + 4, p1);
    Product4(xd + i + 8, wd + i + 8, p2);
    Product4(xd + i + 12, wd + i + 12, p3);
    a0 += p0 * p0;
    a1 += p1 * p1;
    a2 += p2 * p2;
    a3 += p3 * p3;
  }
  for (; i + 4 <= n; i += 4) {
    Double4 p;
    Product4(xd + i, wd + i, p);
    a0 += p * p;
  }
  sunrealtype tail = 0.0;
  for (; i < n; ++i) {
    const sunrealtype p = xd[i] * wd[i];
    tail += p * p;
  }
  const Double4 s = (a0 + a1) + (a2 + a3);
  return ((s[0] + s[1]) + (s[2] + s[3])) + tail;
}
inline sunrealtype WrmsNorm(N_Vector x, N_Vector w) { return std::sqrt(WSqrSumLocal(x, w) / static_cast<sunrealtype>(Len(x))); }
inline void Prod(N_Vector x, N_Vector y, N_Vector z) {
  const sunrealtype *xd = Data(x), *yd = Data(y);
  sunrealtype* zd = Data(z);
  for (sunindextype i = 0, n = Len(z); i < n; ++i) zd[i] = xd[i] * yd[i];
}
inline void Abs(N_Vector x, N_Vector z) {
  const sunrealtype* xd = Data(x);
  sunrealtype* zd = Data(z);
  for (sunindextype i = 0, n = Len(z); i < n; ++i) zd[i] = std::abs(xd[i]);
}
inline void AddConst(N_Vector x, sunrealtype b, N_Vector z) {
  const sunrealtype* xd = Data(x);
  sunrealtype* zd = Data(z);
  for (sunindextype i = 0, n = Len(z); i < n; ++i) zd[i] = xd[i] + b;
}
}  // namespace fast

inline VectorPtr MakeVector(sunindextype n, SUNContext ctx) {
  VectorPtr v(NonNull(N_VNew_Serial(n, ctx)));
  N_VEnableFusedOps_Serial(v.get(), SUNTRUE);
  N_Vector_Ops ops = v->ops;
  ops->nvlinearsum = fast::LinearSum;
  ops->nvscale = fast::Scale;
  ops->nvconst = fast::Const;
  ops->nvlinearcombination = fast::LinearCombination;
  ops->nvscaleaddmulti = fast::ScaleAddMulti;
  ops->nvwsqrsumlocal = fast::WSqrSumLocal;
  ops->nvwrmsnorm = fast::WrmsNorm;
  ops->nvprod = fast::Prod;
  ops->nvabs = fast::Abs;
  ops->nvaddconst = fast::AddConst;
  ops->nvinv = fast::Inv;
  return v;
}

namespace fast {
// CVODE's linear solver interface keeps the Jacobian J and, at every update of the Newton
// matrix, copies it and forms I - gamma J in place (SUNMatCopy, SUNMatScaleAddI). SUNDIALS 6.4's
// dense versions walk the columns element by element through the column pointers: about 17% of
// a BDF run of the ideal differential in joint coordinates (108 states). Both matrices are one
// contiguous column-major block, so a copy and a scale are one loop each.
inline int MatCopy(SUNMatrix a, SUNMatrix b) {
  if (SM_ROWS_D(a) != SM_ROWS_D(b) || SM_COLUMNS_D(a) != SM_COLUMNS_D(b)) return SUNMAT_ILL_INPUT;
  std::memcpy(SM_DATA_D(b), SM_DATA_D(a), sizeof(sunrealtype) * static_cast<size_t>(SM_LDATA_D(a)));
  return SUNMAT_SUCCESS;
}
inline int MatScaleAddI(sunrealtype c, SUNMatrix a) {
  sunrealtype* d = SM_DATA_D(a);
  for (sunindextype i = 0, n = SM_LDATA_D(a); i < n; ++i) d[i] *= c;
  const sunindextype rows = SM_ROWS_D(a), diag = std::min(rows, SM_COLUMNS_D(a));
  for (sunindextype j = 0; j < diag; ++j) d[j * rows + j] += 1.0;
  return SUNMAT_SUCCESS;
}
SUNMatrix MatClone(SUNMatrix a);
inline void InstallMatrixOps(SUNMatrix m) {
  m->ops->copy = MatCopy;
  m->ops->scaleaddi = MatScaleAddI;
  m->ops->clone = MatClone;  // CVODE's saved copy of J is a clone: it gets these too
}
inline SUNMatrix MatClone(SUNMatrix a) {
  SUNMatrix m = SUNDenseMatrix(SM_ROWS_D(a), SM_COLUMNS_D(a), a->sunctx);
  if (m) InstallMatrixOps(m);
  return m;
}
}  // namespace fast

/// A dense matrix whose copy, I + c A and clones use the loops above.
inline MatrixPtr MakeDenseMatrix(sunindextype rows, sunindextype cols, SUNContext ctx) {
  MatrixPtr m(NonNull(SUNDenseMatrix(rows, cols, ctx)));
  fast::InstallMatrixOps(m.get());
  return m;
}

/// SUNDIALS 6.4 cannot clear a stop time: one beyond any run stands for none.
inline constexpr double kNoStopTime = std::numeric_limits<double>::max();

/// True when tout lies within a few roundings of t: no solver can step there (CVODE and ARKODE
/// refuse an output time within two roundings of the start, CV_TOO_CLOSE), and the state does
/// not change over such a time. An event one rounding from an output time (a step at 0.3 s and
/// the output time 3 * 0.1 s) leaves such a gap; the integrators then just move their clock.
inline bool TooCloseToStep(double t, double tout) {
  return tout - t <= 16.0 * std::numeric_limits<double>::epsilon() * std::max(std::abs(t), std::abs(tout));
}

/// The smallest step worth taking from time t on: a few units in the last place of t; below
/// it t + h rounds to (almost) t. Near a finite-time singularity the adaptive controllers
/// shrink h to ~1e-170 and keep "accepting" steps that no longer move t until
/// max_steps_per_output is exhausted (1e6 steps, seconds); with this hmin they fail at once
/// ("error test failed with |h| = hmin"). Based on the start of the output interval, not its
/// end: a stiff initial layer at t ~ 0 legitimately needs steps far below ulp(tout). So the
/// guard is off (0) on an interval that starts at t = 0. Set anew for every output interval.
inline double MinUsefulStep(double t) {
  constexpr double kUlps = 4.0;
  return kUlps * std::numeric_limits<double>::epsilon() * std::abs(t);
}

/// What the C callbacks share with the integrator (passed as user_data / eh_data). It must not
/// move while the solver memory exists, hence the integrators are neither copyable nor movable.
struct CallbackState {
  explicit CallbackState(OdeSystem& s, bool project_invariants = false)
      : system(&s), project(project_invariants && s.has_invariants()) {}
  OdeSystem* system;
  bool project;  ///< restore the system's invariants after every step
  std::exception_ptr pending;  ///< thrown by CalcDerivatives; rethrown after the solver returns
  std::string last_error;      ///< last error message SUNDIALS wanted to print
  std::string last_warning;    ///< last warning (e.g. "t + h = t on the next step")

  void ClearMessages() noexcept {
    last_error.clear();
    last_warning.clear();
  }
  /// The most useful recorded message: the error if any, else the last warning.
  const std::string& message() const { return last_error.empty() ? last_warning : last_error; }
};

/// The RHS for CVODE and ERKStep. No C++ exception may unwind through SUNDIALS' C frames, so an
/// exception is parked and -1 (unrecoverable) returned; the integrator rethrows it.
inline int Rhs(sunrealtype t, N_Vector x, N_Vector xdot, void* user_data) noexcept {
  auto* state = static_cast<CallbackState*>(user_data);
  try {
    state->system->CalcDerivatives(t, N_VGetArrayPointer(x), N_VGetArrayPointer(xdot));
    return 0;
  } catch (...) {
    state->pending = std::current_exception();
    return -1;
  }
}

/// The event functions for CVODE's and ERKStep's root finding (OdeSystem::CalcRoots); an
/// exception is parked like the RHS's.
inline int Roots(sunrealtype t, N_Vector x, sunrealtype* g, void* user_data) noexcept {
  auto* state = static_cast<CallbackState*>(user_data);
  try {
    state->system->CalcRoots(t, N_VGetArrayPointer(x), g);
    return 0;
  } catch (...) {
    state->pending = std::current_exception();
    return -1;
  }
}

/// The roots SUNDIALS found (+1 or -1 per function that crossed, 0 else) as 1 or 0.
inline void CopyRoots(const std::vector<int>& found, int* roots) {
  for (size_t i = 0; i < found.size(); ++i) roots[i] = found[i] != 0 ? 1 : 0;
}

/// CVODE's projection callback: corr = P(y) - y, with P the system's projection onto its
/// invariant manifold. The error estimate is not projected (CVodeSetProjErrEst off).
inline int ProjectCorrection(sunrealtype t, N_Vector y, N_Vector corr, sunrealtype /*eps*/, N_Vector /*err*/,
                             void* user_data) noexcept {
  auto* state = static_cast<CallbackState*>(user_data);
  const sunindextype n = N_VGetLength(y);
  const sunrealtype* yv = N_VGetArrayPointer(y);
  sunrealtype* c = N_VGetArrayPointer(corr);
  std::copy_n(yv, n, c);
  state->system->Project(t, c);
  for (sunindextype i = 0; i < n; ++i) c[i] -= yv[i];
  return 0;
}

/// Replaces SUNDIALS' default handler (which prints to stderr): records the message instead.
/// Signature matches both CVErrHandlerFn and ARKErrHandlerFn.
inline void RecordMessage(int error_code, const char* /*module*/, const char* /*function*/,
                          char* msg, void* eh_data) noexcept {
  auto* state = static_cast<CallbackState*>(eh_data);
  try {
    (error_code < 0 ? state->last_error : state->last_warning) = msg != nullptr ? msg : "";
  } catch (...) {
    // Out of memory while copying a diagnostic: dropping the text is the only safe option.
  }
}

/// The indices of the `count` largest |ele_i * ewt_i|: the components of the last step's local
/// error estimate that weigh most in the error test (those that made the solver fail).
inline std::vector<int> WorstComponents(N_Vector ele, N_Vector ewt, int count = 5) {
  const sunindextype n = N_VGetLength(ele);
  const sunrealtype *e = N_VGetArrayPointer(ele), *w = N_VGetArrayPointer(ewt);
  std::vector<std::pair<double, int>> weighted;
  for (sunindextype i = 0; i < n; ++i) {
    const double v = std::abs(e[i] * w[i]);
    weighted.push_back({std::isfinite(v) ? v : std::numeric_limits<double>::infinity(), static_cast<int>(i)});
  }
  const int k = std::min<int>(count, static_cast<int>(weighted.size()));
  std::partial_sort(weighted.begin(), weighted.begin() + k, weighted.end(), std::greater<>());
  std::vector<int> out;
  for (int i = 0; i < k && weighted[i].first > 0.0; ++i) out.push_back(weighted[i].second);
  return out;
}

/// What every SUNDIALS-backed integrator holds: the options, the callbacks' shared state, the
/// context and the state vector. Derived classes add their solver memory, which (as a member of
/// the derived class) is destroyed before these, the context last.
template <typename Callbacks>
class SundialsIntegrator : public Integrator {
 public:
  // The solver holds a pointer to callbacks_: pin the object.
  SundialsIntegrator(const SundialsIntegrator&) = delete;
  SundialsIntegrator& operator=(const SundialsIntegrator&) = delete;
  double time() const override { return time_; }
  const IntegratorOptions& options() const override { return options_; }

 protected:
  SundialsIntegrator(OdeSystem& system, const IntegratorOptions& options)
      : options_(options),
        n_(system.num_states()),
        callbacks_(system, options.project),
        ctx_(MakeContext()),
        y_(MakeVector(n_, ctx_.get())) {}

  /// Copies x0 into the state vector and forgets what an earlier run left in the callbacks.
  void LoadInitialState(const double* x0) {
    std::copy_n(x0, n_, N_VGetArrayPointer(y_.get()));
    callbacks_.ClearMessages();
    callbacks_.pending = nullptr;
  }

  IntegratorOptions options_;
  sunindextype n_;
  Callbacks callbacks_;
  ContextPtr ctx_;
  VectorPtr y_;  ///< initial condition, then the solution at time_
  double time_ = 0.0;
};

/// Rethrows an exception parked by Rhs, if any.
inline void RethrowPending(CallbackState& state) {
  if (state.pending) {
    std::exception_ptr e = std::exchange(state.pending, nullptr);
    std::rethrow_exception(e);
  }
}

}  // namespace multibond::sun
