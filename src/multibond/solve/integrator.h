#pragma once
/// \file
/// The integrator interface. Every SUNDIALS header is included by the .cc files of this folder
/// only; callers see this interface and SolverError.

#include <memory>
#include <string>
#include <vector>

#include "multibond/core/error.h"
#include "multibond/core/ode_system.h"

namespace multibond {

enum class Method {
  kBdf,            ///< CVODE, variable-order BDF, Newton with dense finite-difference Jacobian
  kAdams,          ///< CVODE, Adams-Moulton, Newton with dense finite-difference Jacobian (see adams note in cvode_integrator.cc)
  kDormandPrince,  ///< ARKODE ERKStep, Dormand-Prince 5(4), adaptive
  kRk4,            ///< ARKODE ERKStep, classical RK4 Butcher table, fixed step
  /// ARKODE ERKStep, Bogacki-Shampine 3(2), adaptive: 3 evaluations per step (first same as
  /// last) for a real stability interval of 2.51, against 3.3 for Dormand-Prince's 6. At the
  /// stability limit of stiff explicit runs (the differential) it needs the fewest evaluations;
  /// its steps are bounded by 95% of that limit, from an estimate of the Jacobian's spectral
  /// radius (see arkode_integrator.cc).
  kBogackiShampine,
  /// ARKODE ERKStep with multibond's own table: a stabilised explicit Runge-Kutta 3(2), 4
  /// evaluations per step (first same as last) for a real stability interval of 5.84, 1.46 per
  /// evaluation against Bogacki-Shampine's 0.84. Made for stiff explicit runs held by the
  /// stability of fast real modes (the compliant differential: 73,000 steps instead of
  /// 160,000). Its steps are bounded by 95% of that limit as Bogacki-Shampine's are (see
  /// arkode_integrator.cc, MakeStabilizedRk3Table).
  kStabilizedRk3,
};

/// How BDF and Adams form and factorise their Newton matrix I - gamma J.
enum class JacobianKind {
  /// kSparse when the system gives a Jacobian pattern (OdeSystem::jacobian_pattern) with at
  /// least kSparseMinStates states and at most kSparseMaxDensity of the entries; else kDense.
  kAuto,
  /// Difference quotients one column at a time (CVODE's), Eigen's dense LU.
  kDense,
  /// Difference quotients one group of columns that share no row at a time (Curtis, Powell and
  /// Reid), on the system's pattern; SUNDIALS' KLU sparse LU. Needs a pattern.
  kSparse,
};
constexpr int kSparseMinStates = 50;
constexpr double kSparseMaxDensity = 0.25;
JacobianKind ParseJacobianKind(const std::string& name);  ///< "auto", "dense", "sparse"
const char* JacobianKindName(JacobianKind k);

/// The methods that take a fixed step (IntegratorOptions::fixed_step, --step), for messages.
constexpr const char* kFixedStepMethodNames = "rk4, dopri5, bs3 and srk3";

/// Parses "bdf", "adams", "dopri5"/"dormand-prince", "bs3"/"bogacki-shampine",
/// "srk3"/"stabilized-rk3", "rk4"; throws
/// std::invalid_argument.
Method ParseMethod(const std::string& name);
const char* MethodName(Method m);

struct IntegratorOptions {
  Method method = Method::kBdf;
  double rtol = 1e-8;
  double atol = 1e-10;
  /// Per-state absolute tolerances (empty = use atol for every state).
  std::vector<double> atol_per_state;
  /// Step size for fixed-step methods (required for kRk4; if > 0 with kDormandPrince,
  /// kBogackiShampine or kStabilizedRk3, fixed step).
  double fixed_step = 0.0;
  double max_step = 0.0;        ///< 0 = no limit
  double initial_step = 0.0;    ///< 0 = solver's choice
  long max_steps_per_output = 1000000;  ///< between two AdvanceTo calls
  /// Keep the state on the system's invariant manifold (if it has one): CVODE's BDF projects
  /// after every step; the adaptive ERKStep methods project when the drift reaches a thousandth
  /// of the error tolerance (checked every 16 steps); fixed-step ERKStep after every step.
  /// Adams cannot (CVODE projects with BDF only): its drift is the integration error's.
  bool project = true;
  JacobianKind jacobian = JacobianKind::kAuto;  ///< BDF and Adams only
};

struct IntegratorStats {
  long steps = 0;
  long rhs_evals = 0;           ///< including those used for finite-difference Jacobians
  long jac_evals = 0;
  long linear_setups = 0;
  long error_test_failures = 0;
  long nonlinear_failures = 0;
  long projections = 0;         ///< adaptive ERKStep: restarts from a projected state
  /// BDF and Adams: the evaluations of f per Jacobian (the number of column groups for a sparse
  /// Jacobian, the number of states for a dense one), and whether it was sparse.
  long evals_per_jacobian = 0;
  bool sparse_jacobian = false;
  double last_step = 0.0;
  /// Adds the counters of `o` (those of a run before a restart, which zeroes them).
  void AddCounts(const IntegratorStats& o) {
    steps += o.steps;
    rhs_evals += o.rhs_evals;
    jac_evals += o.jac_evals;
    linear_setups += o.linear_setups;
    error_test_failures += o.error_test_failures;
    nonlinear_failures += o.nonlinear_failures;
    projections += o.projections;
  }
};

class Integrator {
 public:
  virtual ~Integrator() = default;
  /// (Re)starts the integration at t0 from x0 (num_states() entries).
  virtual void Reset(double t0, const double* x0) = 0;
  /// Integrates to tout and writes x(tout) into x. Throws SolverError (with the time reached and
  /// the solver's flag) on failure; any exception thrown by the system's CalcDerivatives is
  /// rethrown here after the solver has returned.
  virtual void AdvanceTo(double tout, double* x) = 0;
  /// Integrates towards tout and stops early where an event function of the system crosses zero
  /// (OdeSystem::CalcRoots and RootDirections; SUNDIALS' root finding on the step's interpolant,
  /// to its time tolerance). `stop_time` (>= tout): the solver never steps past it: tout itself
  /// when tout is a discontinuity (a time event), the next time event beyond tout (a step past
  /// it would integrate across the jump and the next call could not go back), or infinity; below
  /// it the solver may step past tout and interpolate back, as AdvanceTo does. Writes x at the
  /// time reached and returns that time; `roots` (num_roots() entries, or null without event
  /// functions) gets 1 for each function that crossed there, 0 for the others. The caller
  /// restarts the integration (Reset) after handling an event. A tout within a few roundings of
  /// the current time is no interval to integrate: the clock moves there, the state stays.
  virtual double AdvanceUntil(double tout, double stop_time, double* x, int* roots) = 0;
  virtual double time() const = 0;
  virtual IntegratorStats stats() const = 0;
  virtual const IntegratorOptions& options() const = 0;
};

/// BDF and Adams (CVODE): they choose their own steps and solve a Newton system with a Jacobian
/// (IntegratorOptions::jacobian); the others are explicit Runge-Kutta methods.
inline bool UsesNewtonMatrix(Method m) { return m == Method::kBdf || m == Method::kAdams; }

/// Throws std::invalid_argument, saying what is wrong, for options the integrator would refuse
/// (MakeIntegrator checks them too): so that a front end can check them before it writes anything.
/// `pattern`: the system's Jacobian pattern (OdeSystem::jacobian_pattern), or null.
/// Throws std::invalid_argument unless 0 <= rtol < 1 (a relative tolerance): for front ends that
/// report it where it was given.
void CheckRelativeTolerance(double rtol);
void CheckIntegratorOptions(int num_states, const JacobianPattern* pattern, const IntegratorOptions& options);

/// Makes the integrator the options ask for. The system must outlive the integrator.
/// Throws std::invalid_argument for inconsistent options (e.g. rk4 without a step).
std::unique_ptr<Integrator> MakeIntegrator(OdeSystem& system, const IntegratorOptions& options);

}  // namespace multibond
