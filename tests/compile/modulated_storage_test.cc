// Storage laws that read time, signals or other states (compile/modulated_storage.cc;
// docs/model-format.md, "Storage laws"): the stored energy E(q, s) at fixed s, the power of the
// modulation dE/ds ds/dt as an instruction of the plan (against its closed form, at a state),
// its integral `<element>.modulation_work` counted in energy.work so that the residual stays at
// the integrator's accuracy; a spring whose stiffness doubles at t1 against the piecewise closed
// form of the oscillator; a capacitor whose plate moves, with the circuit open; and what is
// refused (a read whose rate the plan does not have; a law without a closed-form energy) or
// reported as an algebraic loop.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "multibond/compile/compiled_model.h"
#include "multibond/compile/generated_rhs.h"
#include "multibond/compile/equations.h"
#include "multibond/io/model_loader.h"
#include "multibond/sim/simulator.h"

namespace multibond {
namespace {

using ::testing::HasSubstr;

std::shared_ptr<const CompiledModel> Compiled(const std::string& yaml) {
  const LoadedModel lm = LoadModelString(yaml);
  return CompiledModel::Compile(lm.graph, lm.compile);
}

Diagnostic CompileError(const std::string& yaml) {
  try {
    Compiled(yaml);
  } catch (const ModelError& e) {
    return e.diagnostics().front();
  }
  ADD_FAILURE() << "compiled";
  return {};
}

RecordingObserver Simulated(const CompiledModel& m, double t_end, double dt, Method method, double max_step = 0.0, double rtol = 1e-11) {
  RunOptions o;
  o.t_end = t_end;
  o.dt = dt;
  o.integrator.method = method;
  o.integrator.rtol = rtol;
  o.integrator.atol = 1e-2 * rtol;
  o.integrator.max_step = max_step;
  RecordingObserver rec;
  const RunSummary s = Simulate(m, o, rec);
  EXPECT_EQ(s.status, RunStatus::kOk) << s.message;
  return rec;
}

/// A mass m on a spring whose law is `law` (of q, t and whatever it reads), from q0 with p0.
std::string Oscillator(const std::string& law, double m, double q0, double p0, const std::string& extra = "") {
  return "model: oscillator\n"
         "domain: translation\n"
         "elements:\n"
         "  v: {type: \"1\"}\n"
         "  mass: {type: I, inertia: " + std::to_string(m) + ", p0: " + std::to_string(p0) + "}\n"
         "  spring: {type: C, effort: \"" + law + "\", q0: " + std::to_string(q0) + "}\n"
         "bonds: [v -> mass, v -> spring]\n" + extra;
}

// The spring of tests (a): k(t) = k0 (1 + H(t - t1)), the step H written as the smooth
// (1 + tanh((t - t1)/tau))/2, whose work is all in the integral of the power (no event); with
// sign(t - t1) instead, below, the jump is booked at the kink's time event. The tanh is odd about
// t1, so the motion differs from that of the instant jump by O((omega tau)^2) only (here ~1e-9 of
// the amplitude), and so does the work booked from 1/2 Delta k q(t1)^2.
constexpr double kM = 1.0, kK0 = 4.0 * M_PI * M_PI, kT1 = 0.4005, kTau = 1e-5, kQ0 = 0.1, kP0 = 0.2;
const std::string kSwitched = "39.47841760435743*(1 + 0.5*(1 + tanh((t - 0.4005)/1e-5)))*q";

TEST(ModulatedStorage, AStiffnessThatReadsTimeStoresHalfKqSquaredAndBooksItsChangeAsWork) {
  const auto model = Compiled(Oscillator(kSwitched, kM, kQ0, kP0));
  ASSERT_TRUE(model->FindVariable("spring.modulation_work"));
  const int q = model->FindVariable("spring.q")->offset, w = model->FindVariable("spring.modulation_work")->offset;
  Eigen::VectorXd x = model->MakeInitialState(), xdot(x.size());
  Workspace ws = model->MakeWorkspace();
  for (const double t : {0.0, kT1 - 2 * kTau, kT1, kT1 + 0.5 * kTau, 1.0}) {
    const double u = (t - kT1) / kTau, k = kK0 * (1 + 0.5 * (1 + std::tanh(u)));
    const double dk = kK0 * 0.5 * (1 - std::tanh(u) * std::tanh(u)) / kTau;
    model->CalcDerivatives(t, x.data(), xdot.data(), ws);
    EXPECT_NEAR(model->StoredEnergy(model->graph().Find("spring"), t, x.data()), 0.5 * k * kQ0 * kQ0, 1e-12 * k) << t;
    // The power of the modulation: dE/dt at fixed q = 1/2 q^2 dk/dt.
    // (GiNaC's form of the derivative, 100000 t - 40050 for (t - t1)/tau, rounds differently.)
    EXPECT_NEAR(xdot[w], 0.5 * kQ0 * kQ0 * dk, 1e-10 * (0.5 * kQ0 * kQ0 * dk) + 1e-300) << t;
    EXPECT_NEAR(xdot[model->FindVariable("mass.p")->offset], -k * x[q], 1e-13 * k) << t;
  }
}

TEST(ModulatedStorage, EquationsShowThePowerOfTheModulation) {
  const std::string text = FormatEquations(*Compiled(Oscillator("(4 + t)*q", 1.0, 0.1, 0.0)), EquationFormat::kText);
  EXPECT_THAT(text, HasSubstr("d(spring.modulation_work)/dt = d/dt of the stored energy of spring at fixed q: spring.q^2/2"));
}

TEST(ModulatedStorage, ASpringWhoseStiffnessDoublesFollowsTheOscillatorPiecewiseAndTheAccountCloses) {
  // Before t1: omega1 = sqrt(k0/m); after: omega2 = sqrt(2 k0/m), from q and p at t1. The stored
  // energy jumps at t1 by the work the modulation does, 1/2 k0 q(t1)^2, and the residual stays at
  // the integrator's accuracy through the run (no time event, no --max-step: the switch is smooth).
  const double w1 = std::sqrt(kK0 / kM), w2 = std::sqrt(2 * kK0 / kM);
  const double q1 = kQ0 * std::cos(w1 * kT1) + kP0 / (kM * w1) * std::sin(w1 * kT1);
  const double p1 = -kM * w1 * kQ0 * std::sin(w1 * kT1) + kP0 * std::cos(w1 * kT1);
  auto exact = [&](double t, double* p) {
    if (t < kT1) {
      *p = -kM * w1 * kQ0 * std::sin(w1 * t) + kP0 * std::cos(w1 * t);
      return kQ0 * std::cos(w1 * t) + kP0 / (kM * w1) * std::sin(w1 * t);
    }
    const double s = t - kT1;
    *p = -kM * w2 * q1 * std::sin(w2 * s) + p1 * std::cos(w2 * s);
    return q1 * std::cos(w2 * s) + p1 / (kM * w2) * std::sin(w2 * s);
  };
  const double amplitude = std::hypot(q1, p1 / (kM * w2)), e0 = 0.5 * kK0 * kQ0 * kQ0 + 0.5 * kP0 * kP0 / kM;
  const double jump = 0.5 * kK0 * q1 * q1;
  for (const Method method : {Method::kDormandPrince, Method::kBdf}) {
    SCOPED_TRACE(static_cast<int>(method));
    const auto model = Compiled(Oscillator(kSwitched, kM, kQ0, kP0));
    // BDF needs a tighter tolerance than dopri5 for a drift of the oscillator's energy below 1e-9.
    const RecordingObserver rec = Simulated(*model, 2.0, 1e-3, method, 0.0, method == Method::kBdf ? 1e-13 : 1e-11);
    const int it = rec.Index("time"), iq = rec.Index("spring.q"), ip = rec.Index("mass.p"), iw = rec.Index("spring.modulation_work");
    const int iwork = rec.Index("energy.work"), ik = rec.Index("energy.kinetic"), iu = rec.Index("energy.potential");
    double worst_q = 0, worst_p = 0, worst_residual = 0, worst_jump = 0;
    for (const auto& row : rec.rows()) {
      double p = 0;
      const double q = exact(row[it], &p);
      worst_q = std::max(worst_q, std::abs(row[iq] - q) / amplitude);
      worst_p = std::max(worst_p, std::abs(row[ip] - p) / (kM * w2 * amplitude));
      worst_residual = std::max(worst_residual, std::abs(row[rec.Index("energy.residual")]));
      // The stored energy is the start's plus the work booked (nothing else does work).
      EXPECT_NEAR(row[ik] + row[iu] - e0, row[iwork], 1e-9 * (e0 + jump)) << row[it];
      EXPECT_EQ(row[iwork], row[iw]);
      // No work before the switch; the jump's after it.
      if (row[it] > kT1) worst_jump = std::max(worst_jump, std::abs(row[iw] - jump) / jump);
      if (row[it] < kT1) {
        EXPECT_LT(row[iw], 1e-12 * jump) << row[it];
      }
    }
    EXPECT_LT(worst_q, 1e-7);
    EXPECT_LT(worst_p, 1e-7);
    EXPECT_LT(worst_residual, 1e-9);
    EXPECT_LT(worst_jump, 1e-7);
    EXPECT_LT(std::abs(rec.summary().max_abs_energy_residual), 1e-9);
    std::printf("switched spring (%s): |q - exact| %.2e, |p - exact| %.2e of the amplitude, max |residual| %.2e, work booked "
                "- 1/2 k0 q(t1)^2: %.2e of it\n",
                method == Method::kBdf ? "bdf" : "dopri5", worst_q, worst_p, rec.summary().max_abs_energy_residual, worst_jump);
  }
}

TEST(ModulatedStorage, AnInstantSwitchIsATimeEventAndTheJumpOfItsEnergyIsBookedThere) {
  // k(t) = k0 (1 + (1 + sign(t - t1))/2): the kink of sign is a time event, where the integration
  // stops; the power of the jump is a Dirac that no integral sees, so the jump of the stored
  // energy at fixed q, 1/2 k0 q(t1)^2, is booked there (BookModulationJumps). The motion is the
  // piecewise closed form to the integrator's accuracy.
  const double w1 = std::sqrt(kK0 / kM), w2 = std::sqrt(2 * kK0 / kM);
  const double q1 = kQ0 * std::cos(w1 * kT1) + kP0 / (kM * w1) * std::sin(w1 * kT1);
  const double p1 = -kM * w1 * kQ0 * std::sin(w1 * kT1) + kP0 * std::cos(w1 * kT1);
  const double amplitude = std::hypot(q1, p1 / (kM * w2)), jump = 0.5 * kK0 * q1 * q1;
  for (const auto& [law, method] : {std::pair{"39.47841760435743*(1 + 0.5*(1 + sign(t - 0.4005)))*q", Method::kDormandPrince},
                                    std::pair{"39.47841760435743*(1 + 0.5*(1 + sign(t - 0.4005)))*q", Method::kBdf}}) {
    SCOPED_TRACE(std::string(law) + (method == Method::kBdf ? " bdf" : " dopri5"));
    const auto model = Compiled(Oscillator(law, kM, kQ0, kP0));
    const RecordingObserver rec = Simulated(*model, 2.0, 1e-3, method, 0.0, method == Method::kBdf ? 1e-13 : 1e-11);
    ASSERT_EQ(rec.events().size(), 1u);
    EXPECT_EQ(rec.events().front().kind, "kink");
    double worst_q = 0, worst_jump = 0;
    for (const auto& row : rec.rows()) {
      const double t = row[0], s = t - kT1;
      const double q = t < kT1 ? kQ0 * std::cos(w1 * t) + kP0 / (kM * w1) * std::sin(w1 * t)
                               : q1 * std::cos(w2 * s) + p1 / (kM * w2) * std::sin(w2 * s);
      worst_q = std::max(worst_q, std::abs(row[rec.Index("spring.q")] - q) / amplitude);
      worst_jump = std::max(worst_jump, std::abs(row[rec.Index("spring.modulation_work")] - (t < kT1 ? 0.0 : jump)) / jump);
    }
    EXPECT_LT(worst_q, 1e-7);
    EXPECT_LT(worst_jump, 1e-8);
    EXPECT_LT(rec.summary().max_abs_energy_residual, 1e-9);
    std::printf("%s switch (%s): |q - exact| %.2e of the amplitude, work booked - 1/2 k0 q(t1)^2: %.2e of it, max |residual| "
                "%.2e\n",
                "sign", method == Method::kBdf ? "bdf" : "dopri5", worst_q,
                worst_jump, rec.summary().max_abs_energy_residual);
  }
}

TEST(ModulatedStorage, AClampRampOfStiffnessBooksItsWorkOverTheRamp) {
  // k(t) = k0 (1 + clamp((t - t1)/tau, 0, 1)): the power is 1/2 q^2 k0/tau on the ramp and 0
  // elsewhere; its corners are time events, so the integral of the power is exact on each piece,
  // and the work is the change of stored energy to the residual's accuracy.
  const auto model = Compiled(Oscillator("39.47841760435743*(1 + clamp((t - 0.4005)/0.01, 0, 1))*q", kM, kQ0, kP0));
  const RecordingObserver rec = Simulated(*model, 1.0, 1e-3, Method::kDormandPrince);
  EXPECT_GE(rec.events().size(), 2u);  // its corners (once for the law, once for the power, as GiNaC writes it)
  EXPECT_LT(rec.summary().max_abs_energy_residual, 1e-9);
  EXPECT_GT(rec.Last("spring.modulation_work"), 0.05);
}

/// A parallel-plate capacitor of area A and gap x (permittivity eps), holding the charge Q with
/// the circuit open (a current source of 0 A), whose plate is moved by a prescribed velocity:
/// the gap integrates the flow of `drive`, which pushes against a guide's friction b.
std::string PlateCapacitor(const std::string& energy_or_law, const std::string& key) {
  return "model: plate\n"
         "parameters: {eps: 8.854e-12, A: 0.01, Q: 2.0e-9, x0: 1.0e-3, v0: 2.0e-4, b: 3.0}\n"
         "elements:\n"
         "  open:  {type: Sf, flow: 0.0, domain: electrical}\n"
         "  cap:   {type: C, " + key + ": \"" + energy_or_law + "\", q0: Q, domain: electrical}\n"
         "  drive: {type: Sf, flow: {sine: {amplitude: v0, frequency: 2.0}}, domain: translation}\n"
         "  guide: {type: R, resistance: b, domain: translation}\n"
         "states:\n"
         "  gap: {kind: integral, of: drive, initial: [x0]}\n"
         "bonds: [open -> cap, drive -> guide]\n"
         "outputs: [{name: voltage, variable: cap.e}]\n";
}

TEST(ModulatedStorage, APlateCapacitorWithTheCircuitOpenBooksTheChangeOfItsEnergyAsWork) {
  // E = q^2 x / (2 eps A): the voltage q x/(eps A), and with no current (q = Q) the modulation's
  // work Q^2 (x - x0)/(2 eps A) equals the change of stored energy: both integrate the same
  // velocity, so the integrator's steps give them the same error, and the two agree to rounding.
  const double eps = 8.854e-12, area = 0.01, charge = 2.0e-9, x0 = 1.0e-3, v0 = 2.0e-4, f = 2.0;
  for (const auto& [formula, key] : {std::pair<std::string, std::string>{"q^2*gap/(2*eps*A)", "energy"},
                                     std::pair<std::string, std::string>{"q*gap/(eps*A)", "effort"}}) {
    SCOPED_TRACE(key);
    const auto model = Compiled(PlateCapacitor(formula, key));
    const RecordingObserver rec = Simulated(*model, 1.0, 1e-3, Method::kDormandPrince);
    const double e0 = charge * charge * x0 / (2 * eps * area);
    double worst_v = 0, worst_w = 0, worst_x = 0;
    for (const auto& row : rec.rows()) {
      const double t = row[rec.Index("time")];
      const double gap = x0 + v0 / (2 * M_PI * f) * (1 - std::cos(2 * M_PI * f * t));
      worst_x = std::max(worst_x, std::abs(row[rec.Index("gap")] - gap) / x0);
      EXPECT_NEAR(row[rec.Index("cap.q")], charge, 1e-14 * charge);  // no current (the interpolant at output times rounds)
      worst_v = std::max(worst_v, std::abs(row[rec.Index("voltage")] - charge * row[rec.Index("gap")] / (eps * area)) /
                                      (charge * x0 / (eps * area)));
      worst_w = std::max(worst_w, std::abs(row[rec.Index("cap.modulation_work")] - (row[rec.Index("cap.energy")] - e0)) / e0);
    }
    EXPECT_LT(worst_x, 1e-8);  // the integrator's accuracy at rtol 1e-11
    EXPECT_LT(worst_v, 1e-14);
    EXPECT_LT(worst_w, 1e-13);
    EXPECT_LT(rec.summary().max_abs_energy_residual, 1e-9);
    std::printf("plate capacitor (%s): gap %.2e, voltage %.2e, work - change of energy %.2e (of E0), max |residual| %.2e\n",
                key.c_str(), worst_x, worst_v, worst_w, rec.summary().max_abs_energy_residual);
  }
}

TEST(ModulatedStorage, AStiffnessReadThroughSignalsOfAStateIsOrderedAndItsRateFollowsTheChain) {
  // k = k0 (1 + s), s = pos^2 a signal of a state that integrates a rate: the law is evaluated
  // after the signal (a fresh workspace holds 0 there), and the power is 1/2 q^2 k0 2 pos rate.
  const std::string yaml = Oscillator("k*q", 1.0, 0.3, 0.0,
                                      "signals: {s: \"pos^2\", k: \"5*(1 + s)\"}\n"
                                      "states: {pos: {kind: integral, rate: \"0.5 + t\", initial: [0.2]}}\n");
  const auto model = Compiled(yaml);
  Eigen::VectorXd x = model->MakeInitialState(), xdot(x.size());
  Workspace ws = model->MakeWorkspace();
  const double t = 0.25, pos = 0.2, q = 0.3, k = 5 * (1 + pos * pos);
  model->CalcDerivatives(t, x.data(), xdot.data(), ws);
  EXPECT_NEAR(xdot[model->FindVariable("mass.p")->offset], -k * q, 1e-15);
  EXPECT_NEAR(xdot[model->FindVariable("spring.modulation_work")->offset], 0.5 * q * q * 5 * 2 * pos * (0.5 + t), 1e-15);
  EXPECT_NEAR(model->StoredEnergy(model->graph().Find("spring"), t, x.data()), 0.5 * k * q * q, 1e-15);
  // And the same bits from generated code.
  const auto code = GeneratedRhs::Start(model);
  ASSERT_TRUE(code->ready()) << code->engine();
  Eigen::VectorXd gdot(x.size());
  Workspace gws = model->MakeWorkspace(code.get());
  model->CalcDerivatives(t, x.data(), gdot.data(), gws);
  for (int i = 0; i < x.size(); ++i) EXPECT_EQ(gdot[i], xdot[i]) << model->state_names()[i];
}

TEST(ModulatedStorage, AVariableMassBooksTheKineticEnergyItsModulationTakes) {
  // f = p/m(t), m = m0 (1 + a t): E = p^2/(2 m), and with no force p stays, so the modulation's
  // work is E(t) - E(0) = p^2/(2 m0) (1/(1 + a t) - 1) (negative: a growing mass at constant
  // momentum slows).
  const std::string yaml =
      "model: growing\n"
      "domain: translation\n"
      "elements:\n"
      "  v: {type: \"1\"}\n"
      "  mass: {type: I, energy: \"p^2/(2*2*(1 + 0.5*t))\", p0: 3.0}\n"
      "  rest: {type: Se, effort: 0.0}\n"
      "bonds: [rest -> v, v -> mass]\n";
  const RecordingObserver rec = Simulated(*Compiled(yaml), 2.0, 0.01, Method::kBdf);
  const double want = 9.0 / 4.0 * (1.0 / (1.0 + 0.5 * 2.0) - 1.0);
  EXPECT_NEAR(rec.Last("mass.modulation_work"), want, 1e-9 * std::abs(want));
  EXPECT_NEAR(rec.Last("mass.energy"), 9.0 / 4.0 + want, 1e-9 * std::abs(want));
  EXPECT_LT(rec.summary().max_abs_energy_residual, 1e-9);
}

TEST(ModulatedStorage, AReadWithoutARateInThePlanIsRefusedNamingItAndTheSignalsBetween) {
  // The velocity v.f is a flow: its rate is no variable of the plan.
  const Diagnostic d = CompileError(Oscillator("k*q", 1.0, 0.3, 0.0, "signals: {k: \"5*(1 + v.f^2)\"}\n"));
  EXPECT_EQ(d.code, "law.energy");
  EXPECT_THAT(d.message, HasSubstr("'v.f', an effort, a flow"));
  EXPECT_THAT(d.message, HasSubstr("through the signal 'k'"));
  EXPECT_THAT(d.hint, HasSubstr("lag"));
  // Through a lag, the same velocity is a state whose rate the plan computes: accepted.
  EXPECT_NO_THROW(Compiled(Oscillator("k*q", 1.0, 0.3, 0.0,
                                      "signals: {k: \"5*(1 + speed^2)\"}\n"
                                      "states: {speed: {kind: lag, input: \"v.f\", time_constant: 0.01}}\n")));
  // A law whose integral in q has no closed form: its energy is asked for.
  const Diagnostic e = CompileError(Oscillator("tanh(q)*(1 + t)", 1.0, 0.3, 0.0));
  EXPECT_EQ(e.code, "law.energy");
  EXPECT_THAT(e.hint, HasSubstr("energy"));
}

TEST(ModulatedStorage, ALawThatReadsASignalOfItsOwnEffortIsAnAlgebraicLoop) {
  const Diagnostic d = CompileError(Oscillator("k*q", 1.0, 0.3, 0.0, "signals: {k: \"5*(1 + spring.e^2)\"}\n"));
  EXPECT_EQ(d.code, "causality.algebraic_loop");
}

TEST(ModulatedStorage, AnUnmodulatedLawHasNoModulationWorkAndItsFullOwnNameIsItsState) {
  const auto plain = Compiled(Oscillator("4*spring.q", 1.0, 0.5, 0.0));
  EXPECT_FALSE(plain->FindVariable("spring.modulation_work"));
  Eigen::VectorXd x = plain->MakeInitialState();
  EXPECT_NEAR(plain->PotentialEnergy(0.0, x.data()), 0.5 * 4 * 0.25, 1e-15);
}

}  // namespace
}  // namespace multibond
