// Formulas in the plan (compile/formulas.cc): nonlinear storage from an energy or a law, nonlinear
// resistors, sources and ratios of model variables, signals and signal states, each against a
// closed form or a conservation law; the interpreter and the generated code give the same bits;
// and the located errors.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "multibond/compile/compiled_model.h"
#include "multibond/compile/equations.h"
#include "multibond/compile/generated_rhs.h"
#include "multibond/sim/simulator.h"

namespace multibond {
namespace {

using ::testing::HasSubstr;

Formula F(const std::string& text) {
  const expr::ParseResult r = expr::Parse(text);
  EXPECT_FALSE(r.error) << text << ": " << (r.error ? r.error->message : "");
  return Formula{text, r.root, SourceLocation{"model.yaml", 7, 20}};
}

RecordingObserver Simulated(const CompiledModel& m, double t_end, double dt, Method method = Method::kDormandPrince,
                            std::shared_ptr<const GeneratedRhs> code = nullptr) {
  RunOptions o;
  o.code = std::move(code);
  o.t_end = t_end;
  o.dt = dt;
  o.integrator.method = method;
  o.integrator.rtol = 1e-11;
  o.integrator.atol = 1e-13;
  RecordingObserver rec;
  const RunSummary s = Simulate(m, o, rec);
  EXPECT_EQ(s.status, RunStatus::kOk) << s.message;
  return rec;
}

/// Times at which column `name` crosses zero downwards, by linear interpolation between samples.
std::vector<double> DownCrossings(const RecordingObserver& rec, const std::string& name) {
  const int c = rec.Index(name), t = rec.Index("time");
  std::vector<double> out;
  for (size_t k = 1; k < rec.rows().size(); ++k) {
    const double a = rec.rows()[k - 1][c], b = rec.rows()[k][c];
    if (a > 0 && b <= 0) {
      const double ta = rec.rows()[k - 1][t], tb = rec.rows()[k][t];
      out.push_back(ta + (tb - ta) * a / (a - b));
    }
  }
  return out;
}

/// A mass m on a spring whose energy is `energy` (of q), released from q0.
BondGraph Oscillator(const std::string& energy_or_law, bool is_energy, double m, double q0) {
  BondGraph g("oscillator");
  g.AddJunction("v", ElementKind::kOne);
  g.AddI("mass", Param::Scalar(m));
  Element spring;
  spring.name = "spring";
  spring.kind = ElementKind::kC;
  (is_energy ? spring.energy : spring.law_effort) = F(energy_or_law);
  spring.initial = Eigen::VectorXd::Constant(1, q0);
  g.Add(spring);
  g.Connect("v", "mass");
  g.Connect("v", "spring");
  return g;
}

/// Simpson's rule on n (even) intervals: the test's own quadrature of closed-form integrals.
template <typename Fn>
double Simpson(Fn f, double a, double b, int n) {
  const double h = (b - a) / n;
  double s = f(a) + f(b);
  for (int k = 1; k < n; ++k) s += (k % 2 ? 4.0 : 2.0) * f(a + k * h);
  return s * h / 3.0;
}

TEST(Formulas, DuffingFromItsEnergyKeepsItAndHasTheEnergyIntegralsPeriod) {
  // V(q) = 1/2 k1 q^2 + 1/4 k3 q^4 with k1 = 1, k3 = 10; m = 1, from rest at q0 = 1.
  const double k1 = 1.0, k3 = 10.0, q0 = 1.0, m = 1.0;
  auto V = [&](double q) { return 0.5 * k1 * q * q + 0.25 * k3 * q * q * q * q; };
  const auto model = CompiledModel::Compile(Oscillator("1/2*1*q^2 + 1/4*10*q^4", true, m, q0));
  // T = 4 int_0^q0 dq / sqrt(2 (V(q0) - V(q)) / m), with q = q0 sin(th) to lift the singularity.
  const double period = 4.0 * Simpson([&](double th) {
    const double c = std::cos(th);
    const double d = V(q0) - V(q0 * std::sin(th));
    return d > 0 ? q0 * c / std::sqrt(2.0 * d / m) : q0 / std::sqrt(q0 * (k1 * q0 + k3 * q0 * q0 * q0) / m);
  }, 0.0, M_PI / 2, 20000);
  const RecordingObserver rec = Simulated(*model, 3.0 * period, 1e-4);
  const std::vector<double> down = DownCrossings(rec, "spring.q");
  ASSERT_GE(down.size(), 3u);
  EXPECT_NEAR(down[2] - down[1], period, 1e-6 * period);
  // Energy: kinetic + the formula's stored energy stays V(q0) (nothing dissipates).
  const int ek = rec.Index("energy.kinetic"), ep = rec.Index("energy.potential");
  for (const auto& row : rec.rows()) EXPECT_NEAR(row[ek] + row[ep], V(q0), 1e-8);
  EXPECT_NEAR(rec.rows().front()[ep], V(q0), 1e-15);
}

std::string CompileErrorOf(const BondGraph& g) {
  try {
    CompiledModel::Compile(g);
  } catch (const ModelError& e) {
    return e.diagnostics().front().code;
  }
  return "compiled";
}

TEST(Formulas, ALawsEnergyIsItsIntegralInClosedFormOrByQuadrature) {
  // effort = k1 q + k3 q^3: stored energy 1/2 k1 q^2 + 1/4 k3 q^4 (GiNaC integrates it).
  const auto poly = CompiledModel::Compile(Oscillator("q + 10*q^3", false, 1.0, 0.5));
  Eigen::VectorXd x = poly->MakeInitialState();
  EXPECT_NEAR(poly->PotentialEnergy(x.data()), 0.5 * 0.25 + 2.5 * 0.0625, 1e-15);
  // effort = tanh(q): energy log(cosh(q)) (no closed form found: quadrature of the law).
  for (const double q0 : {0.25, 0.8, 2.0, -1.5, 4.0}) {
    const auto soft = CompiledModel::Compile(Oscillator("tanh(q)", false, 1.0, q0));
    x = soft->MakeInitialState();
    EXPECT_NEAR(soft->PotentialEnergy(x.data()), std::log(std::cosh(q0)), 1e-13 * std::log(std::cosh(q0))) << q0;
  }
  // A law that reads more than its own state (here t) needs its energy in closed form, at fixed
  // t, for the work of its modulation (tests/compile/modulated_storage_test.cc): tanh's integral
  // is not found, and the law is refused.
  EXPECT_EQ(CompileErrorOf(Oscillator("q*(1 + t)", false, 1.0, 1.0)), "compiled");
  EXPECT_EQ(CompileErrorOf(Oscillator("tanh(q)*(1 + t)", false, 1.0, 1.0)), "law.energy");
}

/// An inertia of 1 on the 1-junction `junction`, driven by the Se `source` whose effort is `formula`.
BondGraph Driven(const std::string& model, const std::string& junction, const std::string& inertia, const std::string& source,
                 const std::string& formula) {
  BondGraph g(model);
  g.AddJunction(junction, ElementKind::kOne);
  g.AddI(inertia, Param::Scalar(1.0));
  Element se;
  se.name = source;
  se.kind = ElementKind::kSe;
  se.value = {F(formula)};
  g.Add(se);
  g.Connect(source, junction);
  g.Connect(junction, inertia);
  return g;
}

/// A pendulum: J = m L^2, gravity's torque -m g L sin(theta) as a source of theta's formula.
BondGraph Pendulum(double theta0) {
  BondGraph g = Driven("pendulum", "w", "J", "gravity", "-1*9.81*1*sin(theta)");
  AuxState theta;
  theta.name = "theta";
  theta.kind = AuxState::Kind::kIntegral;
  theta.of = "w";
  theta.unit = "rad";
  theta.initial = Eigen::MatrixXd::Constant(1, 1, theta0);
  g.AddAux(theta);
  return g;
}

TEST(Formulas, PendulumPeriodIsTheEllipticIntegrals) {
  for (const double theta0 : {0.5, 2.0, 2.9}) {
    const auto model = CompiledModel::Compile(Pendulum(theta0));
    const double period = 4.0 * std::sqrt(1.0 / 9.81) * std::comp_ellint_1(std::sin(theta0 / 2));
    const RecordingObserver rec = Simulated(*model, 2.2 * period, 1e-4);
    const std::vector<double> down = DownCrossings(rec, "theta");
    ASSERT_GE(down.size(), 2u);
    EXPECT_NEAR(down[1] - down[0], period, 1e-6 * period) << "theta0 = " << theta0;
  }
}

/// Torricelli's tank (A = 2 m^2, rho g = 9810 Pa/m, V0 = 2 m^3) draining through an orifice
/// whose law `law` (R's flow of e, or effort of f) is `text`.
BondGraph Tank(Formula Element::*law, const std::string& text) {
  BondGraph g("tank");
  g.AddJunction("p", ElementKind::kZero);
  Element tank;
  tank.name = "tank";
  tank.kind = ElementKind::kC;
  tank.law_effort = F("1000*9.81*q/2");
  tank.initial = Eigen::VectorXd::Constant(1, 2.0);
  g.Add(tank);
  Element orifice;
  orifice.name = "orifice";
  orifice.kind = ElementKind::kR;
  orifice.*law = F(text);
  g.Add(orifice);
  g.Connect("p", "tank");
  g.Connect("p", "orifice");
  return g;
}

TEST(Formulas, APendulumThroughAModulusOfItsAngleHasTheSamePeriod) {
  // The bob at (L cos(theta), L sin(theta)) moves at (vx, vy) = (-L sin(theta), L cos(theta)) w,
  // through an MTF whose 2 x 1 modulus is a formula of the angle; gravity (0, -m g) acts on it;
  // the torque is M^T e = -m g L cos(theta).
  for (const double theta0 : {1.0, 2.5}) {
    BondGraph g("pendulum_mtf");
    g.AddJunction("w", ElementKind::kOne);
    g.AddI("J", Param::Scalar(1.0));
    Modulus arm;
    arm.constant = Eigen::MatrixXd::Zero(2, 1);
    arm.entries = {F("-sin(theta)"), F("cos(theta)")};
    g.AddMTF("arm", arm);
    g.AddJunction("v", ElementKind::kOne, 2);
    g.AddSe("gravity", SourceValue{{TimeFunction::Constant(0.0), TimeFunction::Constant(-9.81)}}, 2);
    g.Connect("w", "J");
    g.Connect("w", "arm");
    g.Connect("arm", "v");
    g.Connect("gravity", "v");
    AuxState theta;
    theta.name = "theta";
    theta.kind = AuxState::Kind::kIntegral;
    theta.of = "w";
    theta.initial = Eigen::MatrixXd::Constant(1, 1, theta0 - M_PI / 2);  // from the downward vertical
    g.AddAux(theta);
    // theta here is measured from the horizontal: the bob hangs at -pi/2.
    const auto model = CompiledModel::Compile(g);
    const double period = 4.0 * std::sqrt(1.0 / 9.81) * std::comp_ellint_1(std::sin(theta0 / 2));
    const RecordingObserver rec = Simulated(*model, 2.2 * period, 1e-4);
    std::vector<double> down;  // theta + pi/2 crossing zero downwards
    const int c = rec.Index("theta"), tc = rec.Index("time");
    for (size_t k = 1; k < rec.rows().size(); ++k) {
      const double a = rec.rows()[k - 1][c] + M_PI / 2, b = rec.rows()[k][c] + M_PI / 2;
      if (a > 0 && b <= 0) down.push_back(rec.rows()[k - 1][tc] + (rec.rows()[k][tc] - rec.rows()[k - 1][tc]) * a / (a - b));
    }
    ASSERT_GE(down.size(), 2u);
    EXPECT_NEAR(down[1] - down[0], period, 1e-6 * period) << theta0;
  }
}

TEST(Formulas, TorricelliDrainHasALinearSquareRoot) {
  // dV/dt = -Cd a sqrt(2 g V / A): sqrt(V) = sqrt(V0) - Cd a / 2 sqrt(2 g / A) t.
  const double A = 2.0, Cd = 0.6, a = 0.01, rho = 1000.0, g0 = 9.81, V0 = 2.0;
  const auto model = CompiledModel::Compile(Tank(&Element::law_flow, "0.6*0.01*sign(e)*sqrt(2*abs(e)/1000)"));
  const double rate = Cd * a / 2.0 * std::sqrt(2.0 * g0 / A);
  const double t_empty = std::sqrt(V0) / rate;
  const RecordingObserver rec = Simulated(*model, 0.8 * t_empty, 1.0);
  for (const auto& row : rec.rows()) {
    const double t = row[rec.Index("time")], v = row[rec.Index("tank.q")];
    EXPECT_NEAR(std::sqrt(v), std::sqrt(V0) - rate * t, 1e-8) << "t = " << t;
  }
  // Work in = stored + dissipated: the orifice dissipates what the tank loses.
  const double stored0 = rho * g0 / A * V0 * V0 / 2;
  EXPECT_NEAR(rec.Last("energy.potential") + rec.Last("orifice.dissipated"), stored0, 1e-6 * stored0);
  (void)rho;
}

/// A PI controller `pid` of the error `error`, output within [lo, hi], driving the plant
/// dx/dt = pid.u (the state `x`).
void AddPiLoop(BondGraph& g, const std::string& error, double kp, double ki, double lo, double hi) {
  AuxState pid;
  pid.name = "pid";
  pid.kind = AuxState::Kind::kPid;
  pid.input = F(error);
  pid.pid.kp = kp;
  pid.pid.ki = ki;
  pid.pid.u_min = lo;
  pid.pid.u_max = hi;
  g.AddAux(pid);
  AuxState x;
  x.name = "x";
  x.kind = AuxState::Kind::kIntegral;
  x.rate = F("pid.u");
  g.AddAux(x);
}

TEST(Formulas, ALagFollowsItsInputAndAPiControllerItsSetPoint) {
  BondGraph g("signals");
  Signal r;
  r.name = "setpoint";
  r.value = F("2");
  g.AddSignal(r);
  AuxState lag;
  lag.name = "lagged";
  lag.kind = AuxState::Kind::kLag;
  lag.input = F("setpoint");
  lag.time_constant = 0.5;
  g.AddAux(lag);
  // Plant dx/dt = u, PI with kp = 2, ki = 1 on e = r - x: critically damped,
  // x(t) = r - r (1 - t) e^-t.
  AddPiLoop(g, "setpoint - x", 2.0, 1.0, -HUGE_VAL, HUGE_VAL);
  const auto model = CompiledModel::Compile(g);
  const RecordingObserver rec = Simulated(*model, 5.0, 0.01);
  for (const auto& row : rec.rows()) {
    const double t = row[rec.Index("time")];
    EXPECT_NEAR(row[rec.Index("lagged")], 2.0 * (1.0 - std::exp(-t / 0.5)), 1e-8) << t;
    EXPECT_NEAR(row[rec.Index("x")], 2.0 - 2.0 * (1.0 - t) * std::exp(-t), 1e-8) << t;
  }
}

TEST(Formulas, APidsOutputStaysWithinItsLimits) {
  BondGraph g("limited");
  AddPiLoop(g, "10 - x", 5.0, 2.0, -1.0, 1.0);
  const auto model = CompiledModel::Compile(g);
  Workspace ws = model->MakeWorkspace();
  Eigen::VectorXd xv = model->MakeInitialState(), xdot(model->num_states());
  model->CalcDerivatives(0.0, xv.data(), xdot.data(), ws);
  double u = 0.0;
  model->Read(*model->FindVariable("pid.u"), xv.data(), ws, &u);
  EXPECT_EQ(u, 1.0);  // saturated: the raw output is 5 * 10
  // While saturated, x = t and, by back-calculation with tt = kp / ki (ki tt = kp = 5), the
  // integral obeys di/dt = e + (1 - u_raw) / 5 = (1 - 2 i) / 5: i = (1 - e^(-2t/5)) / 2, bounded
  // (without anti-windup it would grow as the integral of 10 - t, to ~50). The output leaves the
  // limit when 5 (10 - t) + 2 i = 1, just before t = 10; then x settles at 10.
  const RecordingObserver rec = Simulated(*model, 40.0, 0.01, Method::kBdf);
  for (const auto& row : rec.rows()) {
    const double t = row[rec.Index("time")];
    if (t > 9.0) break;
    EXPECT_NEAR(row[rec.Index("x")], t, 1e-8) << t;
    EXPECT_NEAR(row[rec.Index("pid.i")], 0.5 * (1.0 - std::exp(-0.4 * t)), 1e-8) << t;
  }
  EXPECT_NEAR(rec.Last("x"), 10.0, 1e-6);
  // The same loop with the back-calculation switched off (tt huge): the wound-up integral
  // overshoots far more.
  auto peak = [](const RecordingObserver& r) {
    double p = 0.0;
    for (const auto& row : r.rows()) p = std::max(p, row[r.Index("x")]);
    return p - 10.0;
  };
  BondGraph wound = g;
  AuxState loose = wound.aux_states()[0];
  BondGraph g2("wound");
  loose.pid.tt = 1e12;
  g2.AddAux(loose);
  g2.AddAux(wound.aux_states()[1]);
  const RecordingObserver rec2 = Simulated(*CompiledModel::Compile(g2), 40.0, 0.01, Method::kBdf);
  EXPECT_GT(peak(rec2), 10.0 * peak(rec));
}

TEST(Formulas, InterpreterAndGeneratedCodeGiveTheSameBits) {
  for (BondGraph g : {Pendulum(2.0), Oscillator("1/2*q^2 + 5/2*q^4", true, 1.0, 1.0)}) {
    const auto model = CompiledModel::Compile(g);
    const auto code = GeneratedRhs::Start(model);
    ASSERT_TRUE(code->ready()) << code->engine();
    const RecordingObserver a = Simulated(*model, 3.0, 0.01), b = Simulated(*model, 3.0, 0.01, Method::kDormandPrince, code);
    ASSERT_EQ(a.rows().size(), b.rows().size());
    for (size_t k = 0; k < a.rows().size(); ++k) EXPECT_EQ(a.rows()[k], b.rows()[k]) << "row " << k;
  }
}

// Large models' generated code comes in units (docs/design.md, "Generated code at scale"): each
// unit has the formulas' functions; the formulas' constants are read from the value table.
TEST(Formulas, SplitUnitsGiveTheSameBitsAndTakeTheConstantsFromTheTable) {
  GenerateOptions jit;
  jit.unit_chars = 1;  // every instruction a unit of its own (split units read the table always)
  for (BondGraph g : {Pendulum(2.0), Oscillator("1/2*q^2 + 5/2*q^4", true, 1.0, 1.0)}) {
    const auto model = CompiledModel::Compile(g);
    const auto code = GeneratedRhs::Start(model, jit);
    ASSERT_TRUE(code->ready()) << code->engine();
    EXPECT_THAT(code->engine(), HasSubstr(" units in "));
    const RecordingObserver a = Simulated(*model, 3.0, 0.01), b = Simulated(*model, 3.0, 0.01, Method::kDormandPrince, code);
    ASSERT_EQ(a.rows().size(), b.rows().size());
    for (size_t k = 0; k < a.rows().size(); ++k) EXPECT_EQ(a.rows()[k], b.rows()[k]) << "row " << k;
  }
  // One unit: the table when asked (a sweep).
  const CompiledModel::GeneratedUnits units =
      CompiledModel::Compile(Pendulum(2.0))->GenerateUnits(GenerateOptions::kDefaultUnitChars, /*value_table=*/true);
  ASSERT_EQ(units.units.size(), 1u);
  EXPECT_THAT(units.values, ::testing::Contains(-9.81));
  EXPECT_THAT(units.units.front(), ::testing::Not(HasSubstr("0x1.39eb851eb851fp+3")));  // 9.81 as a literal
}

TEST(Formulas, EquationsShowTheFormula) {
  const auto model = CompiledModel::Compile(Pendulum(1.0));
  const std::string text = FormatEquations(*model, EquationFormat::kText);
  EXPECT_THAT(text, HasSubstr("d(J.p)/dt = (-1*9.81*1*sin(theta))"));  // as written (F's text), a sign in brackets
  // A storage law at its state, and a signal state's rate with the signals it reads.
  EXPECT_THAT(FormatEquations(*CompiledModel::Compile(Oscillator("q + 10*q^3", false, 1.0, 0.5)), EquationFormat::kText),
              HasSubstr("d(mass.p)/dt = -(q + 10*q^3 at q = spring.q)"));
  BondGraph g("lagged");
  AuxState lag;
  lag.name = "lagged";
  lag.kind = AuxState::Kind::kLag;
  lag.input = F("sin(t)");
  lag.time_constant = 0.5;
  g.AddAux(lag);
  const std::string lagged = FormatEquations(*CompiledModel::Compile(g), EquationFormat::kText);
  EXPECT_THAT(lagged, HasSubstr("d(lagged)/dt = (sin(t) - lagged)/0.5"));
  EXPECT_THAT(lagged, HasSubstr("lagged.rate = (sin(t) - lagged)/0.5"));
}

ModelError CompileError(const BondGraph& g, const CompileOptions& o = {}) {
  try {
    CompiledModel::Compile(g, o);
  } catch (const ModelError& e) {
    return e;
  }
  ADD_FAILURE() << "compiled";
  return ModelError(Diagnostic{});
}

TEST(Formulas, AnUnknownNameIsLocatedInTheFormula) {
  BondGraph g = Pendulum(1.0);
  g.element(g.Find("gravity")).value = {F("-9.81*sin(thetta)")};
  const Diagnostic d = CompileError(g).diagnostics().front();
  EXPECT_EQ(d.code, "expr.unknown_variable");
  EXPECT_EQ(d.where.line, 7);
  EXPECT_EQ(d.where.column, 20 + 10);  // the column of "thetta"
  EXPECT_THAT(d.message, HasSubstr("thetta"));
}

TEST(Formulas, AnEnergyMustDependOnItsOwnStateAndReadOnlyWhatHasARate) {
  EXPECT_EQ(CompileError(Oscillator("5*t", true, 1.0, 1.0)).diagnostics().front().code, "law.energy");
  // Another state is a modulation whose work is booked; a flow has no rate in the plan.
  EXPECT_EQ(CompileErrorOf(Oscillator("q^2 + mass.p", true, 1.0, 1.0)), "compiled");
  const Diagnostic d = CompileError(Oscillator("q^2*(1 + v.f)", true, 1.0, 1.0)).diagnostics().front();
  EXPECT_EQ(d.code, "law.energy");
  EXPECT_EQ(d.where.column, 20 + 9);  // the column of "v.f"
}

TEST(Formulas, AResistorGivenTheOtherWayRoundIsSolvedForItsInput) {
  // A diode's current of its voltage, f = Is (exp(e/Vt) - 1), driven by a current: the causality
  // needs its voltage, e = Vt log(1 + f/Is), found by the bracketed Newton solve.
  const double Is = 1e-12, Vt = 0.025;
  for (const double current : {1e-3, 0.5, 2.0, -0.9e-12}) {
    BondGraph g("diode");
    g.AddSf("drive", SourceValue{{TimeFunction::Constant(current)}});
    Element d;
    d.name = "diode";
    d.kind = ElementKind::kR;
    d.law_flow = F("1e-12*(exp(e/0.025) - 1)");
    g.Add(d);
    g.Connect("drive", "diode");
    const auto model = CompiledModel::Compile(g);
    const auto code = GeneratedRhs::Start(model);
    ASSERT_TRUE(code->ready()) << code->engine();
    for (const GeneratedRhs* engine : {static_cast<const GeneratedRhs*>(nullptr), code.get()}) {
      Workspace ws = model->MakeWorkspace(engine);
      Eigen::VectorXd x = model->MakeInitialState(), xdot(model->num_states());
      model->CalcDerivatives(0.0, x.data(), xdot.data(), ws);
      double e = 0.0;
      model->Read(*model->FindVariable("diode.e"), x.data(), ws, &e);
      EXPECT_NEAR(e, Vt * std::log1p(current / Is), 4e-16 * std::abs(Vt * std::log1p(current / Is))) << current;
    }
  }
}

TEST(Formulas, TorricelliWithTheOrificeAsItsPressureDropSolvesForTheFlow) {
  // The orifice given as e = rho/2 (f / (Cd a))^2 (signed): the tank imposes the pressure, so the
  // flow is solved for; the same closed form as with the flow law.
  const double A = 2.0, Cd = 0.6, a = 0.01, g0 = 9.81, V0 = 2.0;
  const BondGraph g = Tank(&Element::law_effort, "1000/2*f*abs(f)/(0.6*0.01)^2");
  const auto model = CompiledModel::Compile(g);
  const auto code = GeneratedRhs::Start(model);
  ASSERT_TRUE(code->ready()) << code->engine();
  const double rate = Cd * a / 2.0 * std::sqrt(2.0 * g0 / A);
  const RecordingObserver rec = Simulated(*model, 100.0, 1.0), rec_jit = Simulated(*model, 100.0, 1.0, Method::kDormandPrince, code);
  for (const auto& row : rec.rows()) {
    const double t = row[rec.Index("time")], v = row[rec.Index("tank.q")];
    EXPECT_NEAR(std::sqrt(v), std::sqrt(V0) - rate * t, 1e-8) << "t = " << t;
  }
  EXPECT_EQ(rec.rows(), rec_jit.rows());
}

TEST(Formulas, ADivisionByZeroStopsTheRunNamingTheFormulaAndTheTime) {
  // F = 1/(1 - t) on a mass: infinite at t = 1.
  const auto model = CompiledModel::Compile(Driven("blowup", "v", "mass", "push", "1/(1 - t)"));
  RunOptions o;
  o.t_end = 2.0;
  o.dt = 0.25;
  o.integrator.method = Method::kRk4;
  o.integrator.fixed_step = 0.125;
  RecordingObserver rec;
  const RunSummary s = Simulate(*model, o, rec);
  EXPECT_EQ(s.status, RunStatus::kFailed);
  EXPECT_THAT(s.message, HasSubstr("push"));
  EXPECT_THAT(s.message, HasSubstr("1/(1 - t)"));
  EXPECT_THAT(s.message, HasSubstr("t = 1"));
  EXPECT_EQ(rec.rows().size(), 4u);  // t = 0 .. 0.75 kept
}

TEST(Formulas, AResistorThatDeliversPowerMustBeMarkedActive) {
  BondGraph g("negative");
  g.AddJunction("v", ElementKind::kOne);
  g.AddI("mass", Param::Scalar(1.0));
  g.element(g.Find("mass")).initial = Eigen::VectorXd::Constant(1, 1.0);
  Element r;
  r.name = "pump";
  r.kind = ElementKind::kR;
  r.law_effort = F("-0.1*f");
  g.Add(r);
  g.Connect("v", "mass");
  g.Connect("v", "pump");
  const auto model = CompiledModel::Compile(g);
  RunOptions o;
  o.t_end = 1.0;
  o.dt = 0.5;
  RecordingObserver rec;
  const RunSummary s = Simulate(*model, o, rec);
  EXPECT_EQ(s.status, RunStatus::kFailed);
  EXPECT_THAT(s.message, HasSubstr("pump delivers power"));
  g.element(g.Find("pump")).active = true;
  RecordingObserver rec2;
  EXPECT_EQ(Simulate(*CompiledModel::Compile(g), o, rec2).status, RunStatus::kOk);
  EXPECT_NEAR(rec2.Last("mass.p"), std::exp(0.1), 1e-6);  // dp/dt = +0.1 p
}

TEST(Formulas, AnAlgebraicLoopThroughFormulasIsFoundAndNamed) {
  // Two signals that read each other.
  BondGraph g("signals");
  Signal a, b;
  a.name = "a";
  a.value = F("b + 1");
  a.where = {"model.yaml", 3, 6};
  b.name = "b";
  b.value = F("2*a");
  b.where = {"model.yaml", 4, 6};
  g.AddSignal(a);
  g.AddSignal(b);
  const Diagnostic d = CompileError(g).diagnostics().front();
  EXPECT_EQ(d.code, "causality.algebraic_loop");
  EXPECT_TRUE(d.where.line == 3 || d.where.line == 4) << d.where.ToString();
  EXPECT_THAT(d.details.front(), HasSubstr("signals"));
  EXPECT_THAT(d.details.back(), HasSubstr("a"));
  // A source whose effort reads the inertia's effort, which the source itself sets, on a
  // 1-junction: refused by default; with loops solved, a loop through a formula, solved by
  // Newton's method: e = 1 + 0.5 e, so the mass is pushed with 2.
  const BondGraph m = Driven("push", "j", "mass", "push", "1 + 0.5*mass.e");
  EXPECT_EQ(CompileError(m).diagnostics().front().code, "causality.algebraic_loop");
  CompileOptions solve;
  solve.solve_algebraic_loops = true;
  const auto model = CompiledModel::Compile(m, solve);
  ASSERT_TRUE(model->has_nonlinear_loops());
  Workspace ws = model->MakeWorkspace();
  const Eigen::VectorXd x = model->MakeInitialState();
  Eigen::VectorXd xdot(x.size());
  model->CalcDerivatives(0.0, x.data(), xdot.data(), ws);
  EXPECT_NEAR(xdot[0], 2.0, 1e-14);
}

}  // namespace
}  // namespace multibond
