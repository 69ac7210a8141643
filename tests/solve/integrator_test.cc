// Integrator tests against closed-form solutions and published reference values.
#include "multibond/solve/integrator.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace multibond {
namespace {

/// An OdeSystem from a callable f(t, x, xdot).
template <typename F>
class FnSystem final : public OdeSystem {
 public:
  FnSystem(int n, F f) : n_(n), f_(std::move(f)) {}
  int num_states() const override { return n_; }
  void CalcDerivatives(double t, const double* x, double* xdot) override { f_(t, x, xdot); }

 private:
  int n_;
  F f_;
};

template <typename F>
FnSystem<F> MakeSystem(int n, F f) {
  return FnSystem<F>(n, std::move(f));
}

constexpr double kOmega = 3.0;

auto Oscillator() {
  return MakeSystem(2, [](double, const double* x, double* xdot) {
    xdot[0] = x[1];
    xdot[1] = -kOmega * kOmega * x[0];
  });
}

auto Decay() {
  return MakeSystem(1, [](double, const double* x, double* xdot) { xdot[0] = -50.0 * x[0]; });
}

/// The tight settings of the accuracy tests: rtol 1e-10, atol 1e-12; rk4 with h = 1e-3.
IntegratorOptions AccurateOptions(Method m) {
  IntegratorOptions o;
  o.method = m;
  o.rtol = 1e-10;
  o.atol = 1e-12;
  if (m == Method::kRk4) o.fixed_step = 1e-3;
  return o;
}

bool IsAdaptive(Method m) { return m != Method::kRk4; }

/// Max global error on the oscillator x'' = -w^2 x over 0..10 s.
///
/// Adaptive methods (rtol 1e-10, atol 1e-12): the local error per step is held near 1e-10
/// relative; over 10 s (about 5 periods) the global error of BDF/Adams/DP5 stays within ~100x
/// the local tolerance, so 1e-7 is an honest bound with margin (measured: BDF 1.2e-8, Adams
/// 2e-9, DP5 8e-11).
///
/// RK4, h = 1e-3: with theta = w h = 3e-3, one step multiplies by R(i theta) =
/// e^{i theta} - i theta^5/120 + O(theta^6), a phase lag of theta^5/120 = 2.0e-15 per step and
/// |R| = 1 - theta^6/144. Over N = 1e4 steps the phase error is 2.0e-11 (the amplitude error
/// only 5e-14). Bound: 2.0e-11 plus 2e-11 for rounding over 1e4 steps (measured 2.4e-11).
double OscillatorBound(Method m) { return IsAdaptive(m) ? 1e-7 : 4e-11; }

/// Max |E/E0 - 1|. Energy error is about twice the relative amplitude error. Adaptive: twice the
/// state bound. RK4 conserves the amplitude far better than the phase: 2 N theta^6/144 = 1e-13,
/// plus rounding (measured 1.1e-13).
double EnergyBound(Method m) { return IsAdaptive(m) ? 2e-7 : 1e-12; }

/// Max absolute error on x' = -50 x, x(0) = 1, over 0..1 s.
///
/// Adaptive: local error ~ rtol |x| + atol per step with |x| <= 1; 1e-8 is ~10x the largest
/// measured error (BDF, 1.6e-9).
/// RK4, h = 1e-3, z = -0.05: per step R(z) = e^z (1 - e^{-z} (z^5/120 + z^6/720) + ...), a
/// relative error of 2.7e-9 per step, so 2.7e-6 t relative after t seconds; the absolute error
/// 2.7e-6 t e^{-50 t} peaks at t = 0.02 with 2.0e-8. Bound 2.5e-8.
double DecayBound(Method m) { return IsAdaptive(m) ? 1e-8 : 2.5e-8; }

class IntegratorMethodTest : public ::testing::TestWithParam<Method> {};

TEST_P(IntegratorMethodTest, LinearOscillatorMatchesCosSinAndConservesEnergy) {
  auto system = Oscillator();
  auto integrator = MakeIntegrator(system, AccurateOptions(GetParam()));
  double x[2] = {1.0, 0.0};
  integrator->Reset(0.0, x);
  const double e0 = 0.5 * x[1] * x[1] + 0.5 * kOmega * kOmega * x[0] * x[0];

  double max_err = 0.0;
  double max_energy_err = 0.0;
  for (int k = 1; k <= 100; ++k) {
    const double t = 0.1 * k;
    integrator->AdvanceTo(t, x);
    ASSERT_EQ(integrator->time(), t);
    // Compare v / w so that both components are O(1).
    max_err = std::max({max_err, std::abs(x[0] - std::cos(kOmega * t)),
                        std::abs(x[1] / kOmega + std::sin(kOmega * t))});
    const double e = 0.5 * x[1] * x[1] + 0.5 * kOmega * kOmega * x[0] * x[0];
    max_energy_err = std::max(max_energy_err, std::abs(e / e0 - 1.0));
  }
  EXPECT_LT(max_err, OscillatorBound(GetParam())) << MethodName(GetParam());
  EXPECT_LT(max_energy_err, EnergyBound(GetParam())) << MethodName(GetParam());

  const IntegratorStats s = integrator->stats();
  EXPECT_GT(s.steps, 0);
  EXPECT_GE(s.rhs_evals, s.steps);
  EXPECT_GT(s.last_step, 0.0);
  if (GetParam() == Method::kRk4) {
    // Fixed step: 1e4 steps of exactly 1e-3 (outputs are multiples of h).
    EXPECT_EQ(s.steps, 10000);
    EXPECT_NEAR(s.last_step, 1e-3, 1e-15);
  }
}

TEST_P(IntegratorMethodTest, ExponentialDecayMatchesExp) {
  auto system = Decay();
  auto integrator = MakeIntegrator(system, AccurateOptions(GetParam()));
  double x = 1.0;
  integrator->Reset(0.0, &x);
  double max_err = 0.0;
  for (int k = 1; k <= 100; ++k) {
    const double t = 0.01 * k;
    integrator->AdvanceTo(t, &x);
    max_err = std::max(max_err, std::abs(x - std::exp(-50.0 * t)));
  }
  EXPECT_LT(max_err, DecayBound(GetParam())) << MethodName(GetParam());
}

TEST_P(IntegratorMethodTest, ExceptionFromRhsIsRethrownUnchanged) {
  auto system = MakeSystem(1, [](double t, const double* x, double* xdot) {
    if (t > 0.5) throw std::runtime_error("model broke at t > 0.5");
    xdot[0] = -x[0];
  });
  auto integrator = MakeIntegrator(system, AccurateOptions(GetParam()));
  double x = 1.0;
  integrator->Reset(0.0, &x);
  try {
    integrator->AdvanceTo(1.0, &x);
    FAIL() << "no exception";
  } catch (const SolverError& e) {
    FAIL() << "got a SolverError instead of the model's exception: " << e.what();
  } catch (const std::runtime_error& e) {
    EXPECT_STREQ(e.what(), "model broke at t > 0.5");
  }
  // The process survived and the integrator is still usable after a Reset.
  x = 1.0;
  integrator->Reset(0.0, &x);
  integrator->AdvanceTo(0.25, &x);
  EXPECT_NEAR(x, std::exp(-0.25), 1e-7);
}

TEST_P(IntegratorMethodTest, ExceptionFromTheFirstRhsCallIsRethrown) {
  auto system = MakeSystem(1, [](double, const double*, double*) {
    throw std::domain_error("cannot evaluate at all");
  });
  auto integrator = MakeIntegrator(system, AccurateOptions(GetParam()));
  double x = 1.0;
  integrator->Reset(0.0, &x);
  EXPECT_THROW(integrator->AdvanceTo(1.0, &x), std::domain_error);
}

TEST_P(IntegratorMethodTest, PerStateAbsoluteTolerancesAreUsed) {
  auto system = Oscillator();
  IntegratorOptions o = AccurateOptions(GetParam());
  o.atol = 1.0;  // would ruin the adaptive runs if it were used instead of the vector
  o.atol_per_state = {1e-12, 1e-12};
  auto integrator = MakeIntegrator(system, o);
  double x[2] = {1.0, 0.0};
  integrator->Reset(0.0, x);
  integrator->AdvanceTo(10.0, x);
  EXPECT_NEAR(x[0], std::cos(kOmega * 10.0), OscillatorBound(GetParam()));
  EXPECT_NEAR(x[1] / kOmega, -std::sin(kOmega * 10.0), OscillatorBound(GetParam()));
}

TEST_P(IntegratorMethodTest, ResetRestartsFromScratch) {
  auto system = Decay();
  auto integrator = MakeIntegrator(system, AccurateOptions(GetParam()));
  double x = 1.0;
  integrator->Reset(0.0, &x);
  integrator->AdvanceTo(0.1, &x);
  const double first = x;
  const IntegratorStats first_stats = integrator->stats();

  x = 1.0;
  integrator->Reset(0.0, &x);
  EXPECT_EQ(integrator->time(), 0.0);
  integrator->AdvanceTo(0.0, &x);  // no-op: returns the current state
  EXPECT_EQ(x, 1.0);
  integrator->AdvanceTo(0.1, &x);
  EXPECT_EQ(x, first);
  EXPECT_EQ(integrator->stats().steps, first_stats.steps);
  EXPECT_EQ(integrator->stats().rhs_evals, first_stats.rhs_evals);
}

std::string ParamName(const ::testing::TestParamInfo<Method>& info) {
  return MethodName(info.param);
}

INSTANTIATE_TEST_SUITE_P(AllMethods, IntegratorMethodTest,
                         ::testing::Values(Method::kBdf, Method::kAdams, Method::kDormandPrince,
                                           Method::kBogackiShampine, Method::kStabilizedRk3, Method::kRk4),
                         ParamName);

// x' = x^2, x(0) = 1 has x = 1 / (1 - t): singular at t = 1.
auto BlowUp() {
  return MakeSystem(1, [](double, const double* x, double* xdot) { xdot[0] = x[0] * x[0]; });
}

class AdaptiveBlowUpTest : public ::testing::TestWithParam<Method> {};

TEST_P(AdaptiveBlowUpTest, FiniteTimeBlowUpIsASolverErrorNearTheSingularity) {
  auto system = BlowUp();
  auto integrator = MakeIntegrator(system, AccurateOptions(GetParam()));
  double x = 1.0;
  integrator->Reset(0.0, &x);
  // A third-order method lags the exact solution a little more: Bogacki-Shampine's numerical
  // singularity comes 1.7e-10 after t = 1 (x(1) = 5.7e9 still finite), so it also reports
  // the output at t = 1 and fails just past it; so does srk3.
  const bool lags = GetParam() == Method::kBogackiShampine || GetParam() == Method::kStabilizedRk3;
  // Outputs every 0.1 s, as a simulation would: from the second interval on, steps shorter than
  // a few ulps of t are refused (sun::MinUsefulStep), so the solvers fail within a few thousand
  // steps instead of spinning through max_steps_per_output steps that no longer move t.
  try {
    for (int k = 1; k <= 20; ++k) integrator->AdvanceTo(0.1 * k, &x);
    FAIL() << "integrated through a singularity";
  } catch (const SolverError& e) {
    EXPECT_GE(e.t(), 0.9) << e.what();
    EXPECT_LE(e.t(), lags ? 1.0 + 1e-6 : 1.0) << e.what();
    EXPECT_FALSE(e.flag().empty());
    EXPECT_FALSE(e.text().empty());
    EXPECT_LT(integrator->stats().steps, 100000) << e.what();
  }
  // The last output reached.
  EXPECT_NEAR(integrator->time(), lags ? 1.0 : 0.9, 1e-12);
}

INSTANTIATE_TEST_SUITE_P(AdaptiveMethods, AdaptiveBlowUpTest,
                         ::testing::Values(Method::kBdf, Method::kAdams, Method::kDormandPrince,
                                           Method::kBogackiShampine, Method::kStabilizedRk3),
                         ParamName);

TEST(Rk4, BlowUpIsCaughtWhenTheStateStopsBeingFinite) {
  // Fixed step has no error test: RK4 steps over the singularity and the state overflows a few
  // steps later. The integrator must report that rather than return inf/NaN.
  auto system = BlowUp();
  auto integrator = MakeIntegrator(system, AccurateOptions(Method::kRk4));
  double x = 1.0;
  integrator->Reset(0.0, &x);
  try {
    for (int k = 1; k <= 20; ++k) integrator->AdvanceTo(0.1 * k, &x);
    FAIL() << "returned a non-finite state without error";
  } catch (const SolverError& e) {
    EXPECT_GE(e.t(), 0.999) << e.what();
    EXPECT_LE(e.t(), 1.1) << e.what();
    EXPECT_EQ(e.flag(), "NONFINITE_STATE");
  }
}

TEST(Bdf, RobertsonStiffKineticsMatchesReference) {
  auto system = MakeSystem(3, [](double, const double* y, double* ydot) {
    ydot[0] = -0.04 * y[0] + 1e4 * y[1] * y[2];
    ydot[2] = 3e7 * y[1] * y[1];
    ydot[1] = -ydot[0] - ydot[2];
  });
  IntegratorOptions o;
  o.method = Method::kBdf;
  o.rtol = 1e-8;
  o.atol_per_state = {1e-10, 1e-14, 1e-10};
  auto integrator = MakeIntegrator(system, o);
  double y[3] = {1.0, 0.0, 0.0};
  integrator->Reset(0.0, y);
  integrator->AdvanceTo(40.0, y);
  EXPECT_NEAR(y[0], 0.7158270687, 1e-5 * 0.7158270687);
  EXPECT_NEAR(y[1], 9.185534764e-06, 1e-5 * 9.185534764e-06);
  EXPECT_NEAR(y[2], 0.2841637457, 1e-5 * 0.2841637457);

  const IntegratorStats s = integrator->stats();
  EXPECT_GT(s.steps, 0);
  EXPECT_GT(s.jac_evals, 0);
  EXPECT_GT(s.linear_setups, 0);
  // rhs_evals includes the difference-quotient Jacobian's n = 3 evaluations per Jacobian.
  EXPECT_GE(s.rhs_evals, s.steps + 3 * s.jac_evals);
}

/// |x(1) - exact| after fixed steps h of `method` on `system` from x(0) = x0.
template <typename System>
double FixedStepErrorAt1(System& system, Method method, double h, double x0, double exact) {
  IntegratorOptions o;
  o.method = method;
  o.fixed_step = h;
  auto integrator = MakeIntegrator(system, o);
  double x = x0;
  integrator->Reset(0.0, &x);
  integrator->AdvanceTo(1.0, &x);
  return std::abs(x - exact);
}

TEST(Rk4, HalvingTheStepDividesTheErrorBySixteen) {
  // Non-autonomous on purpose, so the stage times (the c column of the table) matter.
  auto system = MakeSystem(1, [](double t, const double* x, double* xdot) {
    xdot[0] = x[0] * std::cos(t);  // x = exp(sin t)
  });
  const double coarse = FixedStepErrorAt1(system, Method::kRk4, 0.1, 1.0, std::exp(std::sin(1.0)));
  const double fine = FixedStepErrorAt1(system, Method::kRk4, 0.05, 1.0, std::exp(std::sin(1.0)));
  ASSERT_GT(fine, 0.0);
  EXPECT_GT(coarse / fine, 12.0) << coarse << " / " << fine;
  EXPECT_LT(coarse / fine, 20.0) << coarse << " / " << fine;
}

TEST(Rk4, StatsCountFixedStepsAndStages) {
  auto system = Decay();
  auto integrator = MakeIntegrator(system, AccurateOptions(Method::kRk4));
  double x = 1.0;
  integrator->Reset(0.0, &x);
  integrator->AdvanceTo(1.0, &x);
  const IntegratorStats s = integrator->stats();
  EXPECT_EQ(s.steps, 1000);
  // ERKStep evaluates f(t0, x0) once before the first step, then per step stages 2-4 plus
  // f(t_n+1, x_n+1), which serves as stage 1 of the next step: 4 per step, plus 1. (3 per step
  // would mean the SUNDIALS 6.4.1 last-stage reuse bug is back: see arkode_integrator.cc.)
  EXPECT_EQ(s.rhs_evals, 4000 + 1);
  EXPECT_EQ(s.error_test_failures, 0);
  EXPECT_EQ(s.jac_evals, 0);
}

TEST(Rk4, OutputTimesThatAreNotMultiplesOfTheStepAreHitExactly) {
  auto system = Decay();
  IntegratorOptions o;
  o.method = Method::kRk4;
  o.fixed_step = 0.003;
  auto integrator = MakeIntegrator(system, o);
  double x = 1.0;
  integrator->Reset(0.0, &x);
  for (int k = 1; k <= 10; ++k) {
    const double t = 0.01 * k;
    integrator->AdvanceTo(t, &x);
    EXPECT_EQ(integrator->time(), t);
    // Per 0.01 s: three steps with z = -0.15, each off by e^{-z} |z^5/120 + z^6/720| = 7.2e-7
    // relative (the short step adds 1e-10): 2.2e-4 t relative in all.
    const double exact = std::exp(-50.0 * t);
    EXPECT_NEAR(x, exact, 2.5e-4 * t * exact);
  }
  // 0.01 needs 3 full steps and one shortened step of 0.001: 4 steps per output.
  EXPECT_EQ(integrator->stats().steps, 40);
}

/// A point turning on the unit circle at kOmega: (x, y)' = kOmega (-y, x). Its invariant is
/// x^2 + y^2 = 1; Project() moves the point radially back onto the circle and counts the calls.
class CircleSystem final : public OdeSystem {
 public:
  int num_states() const override { return 2; }
  void CalcDerivatives(double, const double* x, double* xdot) override {
    ++evaluations;
    xdot[0] = -kOmega * x[1];
    xdot[1] = kOmega * x[0];
  }
  bool has_invariants() const override { return true; }
  void Project(double /*t*/, double* x) override {
    ++projections;
    const double r = std::hypot(x[0], x[1]);
    x[0] /= r;
    x[1] /= r;
  }
  long evaluations = 0, projections = 0;
};

/// Largest |radius - 1| of the states the integrator reports at 100 outputs over 0..10 s.
double WorstRadiusError(Method m, bool project, IntegratorStats* stats = nullptr, double r0 = 1.0) {
  CircleSystem system;
  IntegratorOptions o = AccurateOptions(m);
  o.project = project;
  auto integrator = MakeIntegrator(system, o);
  double x[2] = {r0, 0.0};
  integrator->Reset(0.0, x);
  double worst = 0.0;
  for (int k = 1; k <= 100; ++k) {
    integrator->AdvanceTo(0.1 * k, x);
    worst = std::max(worst, std::abs(std::hypot(x[0], x[1]) - 1.0));
  }
  if (stats) *stats = integrator->stats();
  return worst;
}

class AdaptiveErkProjectionTest : public ::testing::TestWithParam<Method> {};

TEST_P(AdaptiveErkProjectionTest, ProjectionKeepsTheReuseOfTheLastStage) {
  // A post-step hook would cost every step one more evaluation (SUNDIALS 6.4 evaluates f anew
  // after it): Dormand-Prince would make 7 per step, Bogacki-Shampine 4. The adaptive path
  // projects only when the drift matters, so the first-same-as-last reuse survives.
  IntegratorStats with, without;
  WorstRadiusError(GetParam(), true, &with);
  WorstRadiusError(GetParam(), false, &without);
  // Every attempt (accepted or rejected) costs the stages after the first; each projection
  // restarts ERKStep from the projected state at the cost of one evaluation; the first step
  // adds f(t0, y0) and ARKODE's estimate of the initial step (a few evaluations);
  // Dormand-Prince's interpolant (Hermite, degree 4) evaluates f once for each of the 100
  // outputs; the stability limit's estimate of the spectral radius costs at most 21
  // evaluations every 1000 steps.
  const bool dp5 = GetParam() == Method::kDormandPrince;
  const long per_step = dp5 ? 6 : GetParam() == Method::kStabilizedRk3 ? 4 : 3;
  auto extra = [&](const IntegratorStats& s) { return 10 + (dp5 ? 100 : 0) + 21 * (s.steps / 1000 + 1); };
  EXPECT_GT(with.projections, 0);
  EXPECT_LE(with.rhs_evals, per_step * (with.steps + with.error_test_failures) + with.projections + extra(with));
  EXPECT_LE(without.rhs_evals, per_step * (without.steps + without.error_test_failures) + extra(without));
}

TEST_P(AdaptiveErkProjectionTest, ProjectionHoldsTheInvariantFarBelowTheTolerance) {
  // Without projection the radius drifts with the integration error (measured: 9.6e-11 for
  // Dormand-Prince, 1.0e-9 for Bogacki-Shampine over 10 s); with it, the drift is restored
  // whenever it reaches 1e-3 of the error tolerance (rtol 1e-10, atol 1e-12 here), and what is
  // left is the interpolant's error at the outputs (measured 1.2e-12 and 3.6e-13).
  IntegratorStats stats;
  const double with = WorstRadiusError(GetParam(), true, &stats);
  const double without = WorstRadiusError(GetParam(), false);
  EXPECT_LT(with, 1e-11) << "projections: " << stats.projections;
  EXPECT_GT(without, 30 * with);
}

TEST_P(AdaptiveErkProjectionTest, AStateOffTheManifoldIsProjectedAtTheFirstCheck) {
  // Started 1e-3 off the circle: the first drift check (16 steps in) projects it back.
  IntegratorStats stats;
  const double worst = WorstRadiusError(GetParam(), true, &stats, 1.001);
  EXPECT_GE(stats.projections, 1);
  CircleSystem system;
  IntegratorOptions o = AccurateOptions(GetParam());
  auto integrator = MakeIntegrator(system, o);
  double x[2] = {1.001, 0.0};
  integrator->Reset(0.0, x);
  integrator->AdvanceTo(0.1, x);
  EXPECT_LT(std::abs(std::hypot(x[0], x[1]) - 1.0), 1e-12);
  EXPECT_LT(worst, 1.1e-3);
}

INSTANTIATE_TEST_SUITE_P(AdaptiveErk, AdaptiveErkProjectionTest,
                         ::testing::Values(Method::kDormandPrince, Method::kBogackiShampine, Method::kStabilizedRk3),
                         ParamName);

TEST(AdaptiveErk, ErrorWeightsWithAZeroAbsoluteToleranceFailOnAZeroState) {
  // ewt_i = 1 / (rtol |y_i| + atol_i) is infinite for y_i = 0 and atol_i = 0: an input error, as
  // with ARKODE's own weight function, not a division by zero.
  auto system = Decay();
  IntegratorOptions o = AccurateOptions(Method::kDormandPrince);
  o.atol_per_state = {0.0};
  auto integrator = MakeIntegrator(system, o);
  double x = 0.0;
  integrator->Reset(0.0, &x);
  EXPECT_THROW(integrator->AdvanceTo(1.0, &x), SolverError);
  // With a state away from zero the same tolerances are fine.
  x = 1.0;
  integrator->Reset(0.0, &x);
  integrator->AdvanceTo(0.1, &x);
  EXPECT_NEAR(x, std::exp(-5.0), 1e-9);
}

TEST(AdaptiveErk, MaxStepsPerOutputIsEnforced) {
  auto system = Oscillator();
  IntegratorOptions o = AccurateOptions(Method::kDormandPrince);
  o.max_steps_per_output = 10;
  auto integrator = MakeIntegrator(system, o);
  double x[2] = {1.0, 0.0};
  integrator->Reset(0.0, x);
  try {
    integrator->AdvanceTo(10.0, x);
    FAIL() << "took more than 10 steps without complaint";
  } catch (const SolverError& e) {
    EXPECT_EQ(e.flag(), "ARK_TOO_MUCH_WORK");
    EXPECT_EQ(integrator->stats().steps, 10);
  }
}

/// x' = -1e4 (x - sin t): stiff, so an explicit method is limited by stability, not accuracy
/// (rtol 1e-6). The steps of `method` must sit at 95% of its limit interval / 1e4 (the spectral
/// radius estimated by power iteration) instead of hunting for it by rejected steps
/// (Dormand-Prince, which has no such bound, is rejected 105 times here).
void ExpectStepsJustInsideTheStabilityLimit(Method method, double interval) {
  auto system = MakeSystem(1, [](double t, const double* x, double* xdot) { xdot[0] = -1e4 * (x[0] - std::sin(t)); });
  IntegratorOptions o;
  o.method = method;
  o.rtol = 1e-6;
  o.atol = 1e-9;
  auto integrator = MakeIntegrator(system, o);
  double x = 0.0;
  integrator->Reset(0.0, &x);
  for (int k = 1; k <= 100; ++k) integrator->AdvanceTo(0.01 * k, &x);
  const IntegratorStats s = integrator->stats();
  const double at_the_limit = 1e4 / (0.95 * interval);  // steps over 0..1 s
  EXPECT_GT(s.steps, 0.97 * at_the_limit);
  EXPECT_LT(s.steps, 1.05 * at_the_limit);
  EXPECT_LE(s.error_test_failures, 5);
  // x = sin t - 1e-4 cos t + O(1e-8) once the initial layer has died out.
  EXPECT_NEAR(x, std::sin(1.0) - 1e-4 * std::cos(1.0), 1e-6);
}

TEST(AdaptiveErk, BogackiShampineStepsJustInsideItsStabilityLimit) {
  ExpectStepsJustInsideTheStabilityLimit(Method::kBogackiShampine, 2.5127);
}

TEST(AdaptiveErk, StabilizedRk3StepsJustInsideItsStabilityLimit) {
  // 2.3 times longer steps than Bogacki-Shampine's, for 4 evaluations each instead of 3.
  ExpectStepsJustInsideTheStabilityLimit(Method::kStabilizedRk3, 5.8378);
}

TEST(StabilizedRk3, HalvingTheStepDividesTheErrorByEight) {
  // Third order on a nonlinear, non-autonomous problem: the four order conditions, not just the
  // stability polynomial (which a linear test would see), and the stage times c. Fixed steps of
  // 0.1, 0.05 and 0.025 give errors 1.48e-5, 1.95e-6 and 2.50e-7 at t = 1: ratios 7.6 and 7.8,
  // tending to 8 (a second-order slip would give 4).
  auto system = MakeSystem(1, [](double t, const double* x, double* xdot) {
    xdot[0] = x[0] * x[0] * std::cos(t);  // x = 1 / (2 - sin t), from x(0) = 1/2
  });
  auto error_at_1 = [&](double h) {
    return FixedStepErrorAt1(system, Method::kStabilizedRk3, h, 0.5, 1.0 / (2.0 - std::sin(1.0)));
  };
  const double coarse = error_at_1(0.1), fine = error_at_1(0.05), finer = error_at_1(0.025);
  ASSERT_GT(finer, 0.0);
  EXPECT_GT(coarse / fine, 6.0) << coarse << " / " << fine;
  EXPECT_LT(coarse / fine, 10.0) << coarse << " / " << fine;
  EXPECT_GT(fine / finer, 7.0) << fine << " / " << finer;
  EXPECT_LT(fine / finer, 9.0) << fine << " / " << finer;
}

TEST(StabilizedRk3, RealStabilityIntervalIs5_84AndStiffModesAreDampedInsideIt) {
  // x' = lambda x with fixed steps h lambda = z: x after N steps is R(z)^N. R(-5.80) = 0.894 and
  // R(-5.88) = 1.122 (so the interval ends between them, at 5.8379); at 95% of it, where the
  // step bound puts the stiffest mode, R(-5.546) = 0.287: such modes are damped, not carried.
  auto after = [](double z, int steps) {
    auto system = MakeSystem(1, [](double, const double* x, double* xdot) { xdot[0] = -1000.0 * x[0]; });
    IntegratorOptions o;
    o.method = Method::kStabilizedRk3;
    o.fixed_step = -z / 1000.0;
    auto integrator = MakeIntegrator(system, o);
    double x = 1.0;
    integrator->Reset(0.0, &x);
    integrator->AdvanceTo(steps * o.fixed_step, &x);
    return x;
  };
  EXPECT_NEAR(after(-5.80, 1), 0.8944, 1e-3);
  EXPECT_LT(std::abs(after(-5.80, 300)), 1e-9);  // 0.894^300 = 2.6e-15
  EXPECT_NEAR(after(-5.88, 1), 1.1223, 1e-3);
  EXPECT_GT(std::abs(after(-5.88, 300)), 1e10);  // 1.122^300 = 1e15
  EXPECT_NEAR(after(-0.95 * 5.8379, 1), 0.2869, 1e-3);
}

TEST(MakeIntegrator, Rk4WithoutAStepIsRejected) {
  auto system = Decay();
  IntegratorOptions o;
  o.method = Method::kRk4;
  try {
    MakeIntegrator(system, o);
    FAIL() << "accepted rk4 without a step";
  } catch (const std::invalid_argument& e) {
    EXPECT_STREQ(e.what(), "rk4 needs a fixed step (--step)");
  }
}

TEST(MakeIntegrator, WrongNumberOfAbsoluteTolerancesIsRejected) {
  auto system = Oscillator();
  IntegratorOptions o;
  o.atol_per_state = {1e-6};
  EXPECT_THROW(MakeIntegrator(system, o), std::invalid_argument);
}

TEST(MakeIntegrator, SystemWithoutStatesJustAdvancesTime) {
  auto system = MakeSystem(0, [](double, const double*, double*) {});
  auto integrator = MakeIntegrator(system, IntegratorOptions{});
  integrator->Reset(0.0, nullptr);
  integrator->AdvanceTo(2.5, nullptr);
  EXPECT_EQ(integrator->time(), 2.5);
}

TEST(ParseMethod, AcceptsEveryNameAndAlias) {
  EXPECT_EQ(ParseMethod("bdf"), Method::kBdf);
  EXPECT_EQ(ParseMethod("adams"), Method::kAdams);
  EXPECT_EQ(ParseMethod("dopri5"), Method::kDormandPrince);
  EXPECT_EQ(ParseMethod("dormand-prince"), Method::kDormandPrince);
  EXPECT_EQ(ParseMethod("bs3"), Method::kBogackiShampine);
  EXPECT_EQ(ParseMethod("bogacki-shampine"), Method::kBogackiShampine);
  EXPECT_EQ(ParseMethod("srk3"), Method::kStabilizedRk3);
  EXPECT_EQ(ParseMethod("stabilized-rk3"), Method::kStabilizedRk3);
  EXPECT_EQ(ParseMethod("rk4"), Method::kRk4);
  for (Method m : {Method::kBdf, Method::kAdams, Method::kDormandPrince, Method::kBogackiShampine,
                   Method::kStabilizedRk3, Method::kRk4})
    EXPECT_EQ(ParseMethod(MethodName(m)), m);
}

TEST(ParseMethod, BadNameListsTheValidOnes) {
  try {
    ParseMethod("euler");
    FAIL() << "accepted 'euler'";
  } catch (const std::invalid_argument& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("euler"), std::string::npos) << msg;
    for (const char* name : {"bdf", "adams", "dopri5", "bs3", "srk3", "rk4"})
      EXPECT_NE(msg.find(name), std::string::npos) << msg;
  }
}

}  // namespace
}  // namespace multibond
