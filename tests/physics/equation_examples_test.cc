// The examples of examples/equations/ (models written with parameters, formulas, laws, states and
// signals) against their closed forms, each loaded from its file (with parameters set as
// `--set` would) and run with the file's simulation settings; and the same runs through generated
// code, which must give the interpreter's bits.

#include <algorithm>
#include <cmath>
#include <numbers>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include <gsl/gsl_errno.h>
#include <gsl/gsl_odeiv2.h>
#include <gsl/gsl_sf_lambert.h>
#include <gtest/gtest.h>

#include "multibond/analysis/linearize.h"
#include "support/example_runner.h"

namespace multibond {
namespace {

/// A model of examples/equations/ as loaded, and its run with the file's settings.
struct ExampleRun {
  LoadedModel model;
  RecordingObserver rec;
  /// The value of the file's top-level parameter `name`, as the model uses it.
  double Param(const std::string& name) const {
    for (const ModelParameter& p : model.parameters)
      if (p.name == name) return p.value;
    throw std::out_of_range("no parameter '" + name + "'");
  }
};

ExampleRun RunEquationExample(const std::string& file, const std::vector<ParameterOverride>& set = {}, bool generate_code = false) {
  ExampleRun r{LoadModelFile(testing::ExamplePath("equations/" + file), {}, set), {}};
  // A test that asks for generated code must not pass on the interpreter's fallback.
  const testing::Built b = testing::CompileWith(r.model, generate_code);
  const SimulationDefaults& s = r.model.simulation;
  RunOptions o;
  o.code = b.code;
  o.t_end = s.t_end.value_or(1.0);
  o.dt = s.dt.value_or(1e-3);
  o.integrator.method = s.solver ? ParseMethod(*s.solver) : Method::kBdf;
  o.integrator.rtol = s.rtol.value_or(1e-8);
  o.integrator.atol = s.atol.value_or(1e-10);
  o.integrator.fixed_step = s.step.value_or(0.0);
  o.integrator.max_step = s.max_step.value_or(0.0);
  Simulate(*b.model, o, r.rec);
  return r;
}

/// The times where the column `x` crosses zero, each found on the cubic Hermite interpolant of
/// the two samples around it with their values and slopes (`dxdt` times `rate`): its error is of
/// order dt^4 x'''' / 384, far below the accuracy asked of a period.
std::vector<double> ZeroCrossings(const RecordingObserver& rec, const std::string& x, const std::string& dxdt, double rate) {
  const int ix = rec.Index(x), iv = rec.Index(dxdt);
  std::vector<double> crossings;
  const auto& rows = rec.rows();
  for (size_t k = 0; k + 1 < rows.size(); ++k) {
    const double t0 = rows[k][0], t1 = rows[k + 1][0], h = t1 - t0;
    const double y0 = rows[k][ix], y1 = rows[k + 1][ix];
    if (!(y0 != 0.0 && (y0 < 0) != (y1 < 0))) continue;
    const double m0 = rate * rows[k][iv] * h, m1 = rate * rows[k + 1][iv] * h;
    auto p = [&](double s) {  // the Hermite cubic on s in [0, 1]
      const double s2 = s * s, s3 = s2 * s;
      return (2 * s3 - 3 * s2 + 1) * y0 + (s3 - 2 * s2 + s) * m0 + (-2 * s3 + 3 * s2) * y1 + (s3 - s2) * m1;
    };
    double lo = 0.0, hi = 1.0;  // bisection to the last bit: p changes sign on [lo, hi]
    for (int i = 0; i < 60; ++i) {
      const double mid = 0.5 * (lo + hi);
      ((p(mid) < 0) == (y0 < 0) ? lo : hi) = mid;
    }
    crossings.push_back(t0 + 0.5 * (lo + hi) * h);
  }
  return crossings;
}

/// The periods measured between crossings two apart (a full swing), for a run that starts at
/// rest at its largest excursion: the first crossing is at T/4.
std::vector<double> Periods(const std::vector<double>& crossings) {
  std::vector<double> periods;
  for (size_t k = 0; k + 2 < crossings.size(); ++k) periods.push_back(crossings[k + 2] - crossings[k]);
  return periods;
}

double MaxAbs(const RecordingObserver& rec, const std::string& column) {
  double m = 0.0;
  for (const auto& row : rec.rows()) m = std::max(m, std::abs(row[rec.Index(column)]));
  return m;
}

// --- pendulum.yaml: T = 4 sqrt(L/g) K(sin(theta0/2)) ---

TEST(PendulumExample, PeriodIsTheEllipticIntegralAtEveryAmplitude) {
  for (const char* theta0 : {"0.3", "1.0", "2.0", "2.9"}) {
    SCOPED_TRACE(std::string("theta0 = ") + theta0);
    const ExampleRun r = RunEquationExample("pendulum.yaml", {{"theta0", theta0}});
    ASSERT_EQ(r.rec.summary().status, RunStatus::kOk);
    const double L = r.Param("L"), g = r.Param("g"), m = r.Param("m"), th0 = r.Param("theta0");
    ASSERT_EQ(th0, std::stod(theta0));  // the override reached the model
    const double period = 4.0 * std::sqrt(L / g) * std::comp_ellint_1(std::sin(th0 / 2.0));
    // theta integrates w = J.p / (m L^2).
    const std::vector<double> crossings = ZeroCrossings(r.rec, "theta", "J.p", 1.0 / (m * L * L));
    ASSERT_GE(crossings.size(), 3u);
    EXPECT_NEAR(crossings[0], period / 4.0, 1e-6 * period);
    for (double measured : Periods(crossings)) EXPECT_NEAR(measured, period, 1e-6 * period);
  }
}

TEST(PendulumExample, GravitysWorkIsTheLossOfPotentialEnergy) {
  const ExampleRun r = RunEquationExample("pendulum.yaml", {{"theta0", "2.9"}});
  ASSERT_EQ(r.rec.summary().status, RunStatus::kOk);
  const double L = r.Param("L"), g = r.Param("g"), m = r.Param("m"), th0 = r.Param("theta0");
  const double mgl = m * g * L;
  const int theta = r.rec.Index("theta"), work = r.rec.Index("gravity.work"), kinetic = r.rec.Index("energy.kinetic");
  for (const auto& row : r.rec.rows()) {
    const double lost = mgl * (std::cos(row[theta]) - std::cos(th0));
    EXPECT_NEAR(row[work], lost, 1e-8 * mgl) << "t = " << row[0];
    EXPECT_NEAR(row[kinetic], lost, 1e-8 * mgl) << "t = " << row[0];
  }
  EXPECT_LT(testing::MaxEnergyResidual(r.rec), 1e-8);
}

// --- mtf_pendulum.yaml: the pendulum of MTFs under ideal constraints ---
// T = 4 sqrt((J0 + m L^2)/(m g L)) K(sin(theta0/2)); the rod's pull N = m (L w^2 + g cos(theta)),
// its push across m g sin(theta) J0/(J0 + m L^2).

TEST(MtfPendulumExample, PeriodIsTheEllipticIntegralUnderIdealConstraints) {
  for (const char* theta0 : {"0.5", "2.0", "2.5"}) {
    SCOPED_TRACE(std::string("theta0 = ") + theta0);
    const ExampleRun r = RunEquationExample("mtf_pendulum.yaml", {{"theta0", theta0}});
    ASSERT_EQ(r.rec.summary().status, RunStatus::kOk) << r.rec.summary().message;
    const double L = r.Param("L"), g = r.Param("g"), m = r.Param("m"), j0 = r.Param("J0"), th0 = r.Param("theta0");
    ASSERT_EQ(th0, std::stod(theta0));
    const double inertia = j0 + m * L * L;
    const double period = 4.0 * std::sqrt(inertia / (m * g * L)) * std::comp_ellint_1(std::sin(th0 / 2.0));
    // theta integrates w = hub.p / J0.
    const std::vector<double> crossings = ZeroCrossings(r.rec, "theta", "hub.p", 1.0 / j0);
    ASSERT_GE(crossings.size(), 3u);
    EXPECT_NEAR(crossings[0], period / 4.0, 1e-8 * period);
    for (double measured : Periods(crossings)) EXPECT_NEAR(measured, period, 1e-8 * period);
  }
}

TEST(MtfPendulumExample, TheRodsReactionIsItsClosedFormAndTheEnergyIsKept) {
  const ExampleRun r = RunEquationExample("mtf_pendulum.yaml");
  ASSERT_EQ(r.rec.summary().status, RunStatus::kOk) << r.rec.summary().message;
  const double L = r.Param("L"), g = r.Param("g"), m = r.Param("m"), j0 = r.Param("J0"), th0 = r.Param("theta0");
  const double inertia = j0 + m * L * L, mg = m * g;
  const int theta = r.rec.Index("theta"), hub = r.rec.Index("hub.p"), tension = r.rec.Index("tension"), shear = r.rec.Index("shear");
  const int work = r.rec.Index("gravity.work"), kinetic = r.rec.Index("energy.kinetic");
  const int px = r.rec.Index("mass_x.p"), py = r.rec.Index("mass_y.p");
  double largest = 0.0;
  for (const auto& row : r.rec.rows()) {
    const double th = row[theta], w = row[hub] / j0;
    EXPECT_NEAR(row[tension], m * (L * w * w + g * std::cos(th)), 1e-9 * mg) << "t = " << row[0];
    EXPECT_NEAR(row[shear], mg * std::sin(th) * j0 / inertia, 1e-9 * mg) << "t = " << row[0];
    // The cut masses move with the rod's end: v = L w (cos(theta), sin(theta)).
    EXPECT_NEAR(row[px], m * L * w * std::cos(th), 1e-10 * m * L) << "t = " << row[0];
    EXPECT_NEAR(row[py], m * L * w * std::sin(th), 1e-10 * m * L) << "t = " << row[0];
    const double lost = mg * L * (std::cos(th) - std::cos(th0));
    EXPECT_NEAR(row[work], lost, 1e-9 * mg * L) << "t = " << row[0];
    EXPECT_NEAR(row[kinetic], 0.5 * inertia * w * w, 1e-9 * mg * L) << "t = " << row[0];
    largest = std::max(largest, row[tension]);
  }
  // Through the bottom: w^2 = 2 m g L (1 - cos(theta0)) / (J0 + m L^2).
  EXPECT_NEAR(largest, m * (2 * mg * L * (1 - std::cos(th0)) / inertia + g), 1e-3 * mg);
  EXPECT_LT(testing::MaxEnergyResidual(r.rec), 1e-9);
}

TEST(MtfPendulumExample, ItsLinearisationAtTheBottomSwingsAtTheSmallAngleFrequency) {
  // w^2 = m g L / (J0 + m L^2), through the MTFs' second derivatives in the constraints.
  ExampleRun r{LoadModelFile(testing::ExamplePath("equations/mtf_pendulum.yaml"), {}, {{"theta0", "0"}}), {}};
  const auto model = CompiledModel::Compile(r.model.graph, r.model.compile);
  const linear::LinearModel lin = linear::Linearize(*model, 0.0, model->MakeInitialState());
  const double L = r.Param("L"), g = r.Param("g"), m = r.Param("m"), j0 = r.Param("J0");
  const double omega = std::sqrt(m * g * L / (j0 + m * L * L));
  double fastest = 0.0;
  for (const auto& l : lin.A.eigenvalues()) {
    EXPECT_NEAR(l.real(), 0.0, 1e-12);
    fastest = std::max(fastest, std::abs(l.imag()));
  }
  EXPECT_NEAR(fastest, omega, 1e-12 * omega);
}

// --- duffing.yaml: T = 4 int_0^x0 dx / sqrt(2 (V(x0) - V(x)) / m) ---

/// The period by the energy integral with x = x0 sin(th): 2 (V(x0) - V(x)) / m =
/// x0^2 cos^2(th) (k1 + k3 x0^2 (1 + sin^2 th) / 2) / m, so T = 4 int_0^{pi/2} dth / sqrt((k1 +
/// k3 x0^2 (1 + sin^2 th) / 2) / m), a smooth integrand, even about 0 and pi/2: the midpoint
/// rule converges geometrically (checked by halving n, and against the closed form below).
double DuffingPeriodByQuadrature(double m, double k1, double k3, double x0, int n) {
  double sum = 0.0;
  for (int i = 0; i < n; ++i) {
    const double s = std::sin((i + 0.5) * (std::numbers::pi / 2) / n);
    sum += 1.0 / std::sqrt((k1 + 0.5 * k3 * x0 * x0 * (1.0 + s * s)) / m);
  }
  return 4.0 * sum * (std::numbers::pi / 2) / n;
}

TEST(DuffingExample, PeriodIsTheEnergyIntegral) {
  const ExampleRun r = RunEquationExample("duffing.yaml");
  ASSERT_EQ(r.rec.summary().status, RunStatus::kOk);
  const double m = r.Param("m"), k1 = r.Param("k1"), k3 = r.Param("k3"), x0 = r.Param("x0");
  const double period = DuffingPeriodByQuadrature(m, k1, k3, x0, 64);
  EXPECT_NEAR(period, DuffingPeriodByQuadrature(m, k1, k3, x0, 32), 1e-15 * period);
  // The same integral in closed form: T = 4 K(k) / sqrt((k1 + k3 x0^2) / m), k^2 = k3 x0^2 / (2 (k1 + k3 x0^2)).
  const double w2 = (k1 + k3 * x0 * x0) / m;
  EXPECT_NEAR(period, 4.0 * std::comp_ellint_1(std::sqrt(k3 * x0 * x0 / (2.0 * m * w2))) / std::sqrt(w2), 1e-14 * period);
  EXPECT_NEAR(period, 2.1918, 1e-4);  // as the file's comment says
  const std::vector<double> crossings = ZeroCrossings(r.rec, "x", "mass.p", 1.0 / m);
  ASSERT_GE(crossings.size(), 3u);
  EXPECT_NEAR(crossings[0], period / 4.0, 1e-6 * period);
  for (double measured : Periods(crossings)) EXPECT_NEAR(measured, period, 1e-6 * period);
}

TEST(DuffingExample, EnergyIsConservedToRounding) {
  const ExampleRun r = RunEquationExample("duffing.yaml");
  ASSERT_EQ(r.rec.summary().status, RunStatus::kOk);
  const double k1 = r.Param("k1"), k3 = r.Param("k3"), x0 = r.Param("x0");
  const double v0 = 0.5 * k1 * x0 * x0 + 0.25 * k3 * std::pow(x0, 4);
  EXPECT_EQ(v0, 3.0);
  EXPECT_LT(MaxAbs(r.rec, "energy.residual"), 1e-13);  // over every sample, t = 0 included
  const int kinetic = r.rec.Index("energy.kinetic"), potential = r.rec.Index("energy.potential"), x = r.rec.Index("x");
  for (const auto& row : r.rec.rows()) {
    EXPECT_NEAR(row[kinetic] + row[potential], v0, 1e-12 * v0) << "t = " << row[0];
    // The stored energy is the file's V(x) itself.
    EXPECT_NEAR(row[potential], 0.5 * k1 * row[x] * row[x] + 0.25 * k3 * std::pow(row[x], 4), 1e-14 * v0) << "t = " << row[0];
  }
}

// --- tank.yaml: sqrt(V(t)) = sqrt(V0) - Cd a / 2 sqrt(2 g / A) t ---

TEST(TankExample, SquareRootOfTheVolumeFallsLinearly) {
  const ExampleRun r = RunEquationExample("tank.yaml");
  ASSERT_EQ(r.rec.summary().status, RunStatus::kOk);
  const double A = r.Param("A"), Cd = r.Param("Cd"), a = r.Param("a"), g = r.Param("g"), V0 = r.Param("V0");
  const double rate = Cd * a / 2.0 * std::sqrt(2.0 * g / A);
  EXPECT_NEAR(std::sqrt(V0) / rate, 150.5, 0.05);  // the emptying time the file's comment gives
  const int volume = r.rec.Index("volume"), outflow = r.rec.Index("outflow");
  for (const auto& row : r.rec.rows()) {
    const double root = std::sqrt(V0) - rate * row[0];
    EXPECT_NEAR(std::sqrt(row[volume]), root, 1e-8) << "t = " << row[0];
    // The orifice's flow, into the R from the 0-junction: Cd a sqrt(2 g V / A).
    EXPECT_NEAR(row[outflow], Cd * a * std::sqrt(2.0 * g * row[volume] / A), 1e-8 * Cd * a * std::sqrt(2.0 * g * V0 / A)) << "t = " << row[0];
  }
  EXPECT_LT(r.rec.Last("volume"), 0.25 * V0);  // the run covers most of the draining
}

TEST(TankExample, OrificeDissipatesTheStoredEnergyTheTankLoses) {
  const ExampleRun r = RunEquationExample("tank.yaml");
  ASSERT_EQ(r.rec.summary().status, RunStatus::kOk);
  const double A = r.Param("A"), rho = r.Param("rho"), g = r.Param("g"), V0 = r.Param("V0");
  const double e0 = rho * g * V0 * V0 / (2.0 * A);  // int_0^V0 rho g q / A dq
  const int stored = r.rec.Index("energy.potential"), dissipated = r.rec.Index("orifice.dissipated"), volume = r.rec.Index("volume");
  for (const auto& row : r.rec.rows()) {
    EXPECT_NEAR(row[stored], rho * g * row[volume] * row[volume] / (2.0 * A), 1e-12 * e0) << "t = " << row[0];
    EXPECT_NEAR(row[dissipated], e0 - row[stored], 1e-8 * e0) << "t = " << row[0];
  }
  EXPECT_GT(r.rec.Last("orifice.dissipated"), 0.9 * e0);
  EXPECT_LT(testing::MaxEnergyResidual(r.rec), 1e-8);
}

// --- motor_pi.yaml: at a steady w, V = w (Ra b + k^2) / k ---

TEST(MotorPiExample, SpeedReachesTheSetPointAndTheVoltageItsSteadyValue) {
  const ExampleRun r = RunEquationExample("motor_pi.yaml");
  ASSERT_EQ(r.rec.summary().status, RunStatus::kOk);
  const double Ra = r.Param("Ra"), k = r.Param("k"), b = r.Param("b"), w = r.Param("w_set");
  const double voltage = w * (Ra * b + k * k) / k;
  EXPECT_NEAR(voltage, 5.2, 1e-12);  // the file's comment
  EXPECT_NEAR(r.rec.Last("speed"), w, 1e-6);
  EXPECT_NEAR(r.rec.Last("voltage"), voltage, 1e-6);
  EXPECT_LT(testing::MaxEnergyResidual(r.rec), 1e-8);
}

// --- pi_steady.yaml: a PI loop started at steady state stays there; a lag from x0 ---

TEST(PiSteadyExample, APiControllerStartedAtSteadyStateStaysThereAndTheLagFollowsItsExponential) {
  // The plant J dw/dt = u - b w with u = kp (w_ref - w) + ki i, started at w = w_ref and
  // i0 = b w_ref / ki (the pid's `initial`, a formula of parameters): w = w_ref, u = b w_ref, i = i0
  // for all t. The sensor T dx/dt = w - x from x0 = w_meas0: x = w_ref + (x0 - w_ref) exp(-t/T).
  // The parameters set as --set sets them reach both initial values (formulas of them).
  const std::vector<std::vector<ParameterOverride>> sets = {
      {}, {{"w_ref", "20"}, {"b", "0.3"}, {"ki", "5"}, {"w_meas0", "-3"}, {"T", "0.05"}}};
  for (const auto& set : sets) {
    SCOPED_TRACE(set.size());
    const ExampleRun r = RunEquationExample("pi_steady.yaml", set);
    ASSERT_EQ(r.rec.summary().status, RunStatus::kOk);
    const double b = r.Param("b"), w_ref = r.Param("w_ref"), ki = r.Param("ki"), T = r.Param("T"), x0 = r.Param("w_meas0");
    if (set.empty()) {
      EXPECT_NEAR(b * w_ref, 0.5, 1e-15);  // the file's comment
      EXPECT_EQ(w_ref, 10.0);
    } else {
      EXPECT_EQ(w_ref, 20.0);
    }
    const int speed = r.rec.Index("speed"), torque = r.rec.Index("torque"), i = r.rec.Index("speed_control.i");
    const int measured = r.rec.Index("measured");
    ASSERT_GT(r.rec.rows().size(), 100u);
    EXPECT_EQ(r.rec.rows().front()[i], b * w_ref / ki);
    EXPECT_EQ(r.rec.rows().front()[measured], x0);
    for (const auto& row : r.rec.rows()) {
      EXPECT_NEAR(row[speed], w_ref, 1e-9 * w_ref) << "t = " << row[0];
      EXPECT_NEAR(row[torque], b * w_ref, 1e-9 * b * w_ref) << "t = " << row[0];
      EXPECT_NEAR(row[i], b * w_ref / ki, 1e-9 * b * w_ref / ki) << "t = " << row[0];
      EXPECT_NEAR(row[measured], w_ref + (x0 - w_ref) * std::exp(-row[0] / T), 1e-8) << "t = " << row[0];
    }
  }
}

TEST(PiSteadyExample, WithoutItsInitialValueTheLoopStartsFromZeroTorqueAndSags) {
  // The same model with the pid's integral at 0: u = 0 at the start, so the rotor slows
  // (dw/dt = -b w_ref / J = -25 rad/s^2 at t = 0) before the integral catches up: the initial
  // value is what holds it.
  std::string text = testing::ExampleText("equations/pi_steady.yaml");
  const std::string initial = ", initial: \"b*w_ref/ki\"";
  ASSERT_NE(text.find(initial), std::string::npos);
  text.erase(text.find(initial), initial.size());
  const LoadedModel lm = LoadModelString(text, "pi_steady.yaml");
  const auto model = CompiledModel::Compile(lm.graph, lm.compile);
  const RecordingObserver rec = testing::RunCompiled(*model, 1.0, 1e-2);
  ASSERT_EQ(rec.summary().status, RunStatus::kOk);
  EXPECT_EQ(rec.rows().front()[rec.Index("torque")], 0.0);
  EXPECT_LT(rec.At("speed", 0.1), 10.0 - 0.5);
}

// The controller's and the sensor's units follow from their formulas: the integral of an error in
// rad/s is in rad, the lag of shaft.f in rad/s; a PID's own `unit` is its output's. (Before, every
// signal state without a unit of its own was '-', and a PID's unit went to its integral.)
TEST(PiSteadyExample, TheSignalStatesUnitsFollowFromTheirInputs) {
  std::string text = testing::ExampleText("equations/pi_steady.yaml");
  auto replace = [&text](const std::string& from, const std::string& to) {
    ASSERT_NE(text.find(from), std::string::npos) << from;
    text.replace(text.find(from), from.size(), to);
  };
  replace(", time_constant: T, initial: w_meas0, unit: rad/s}", ", time_constant: T, initial: w_meas0}");
  replace("kp: kp, ki: ki, initial: \"b*w_ref/ki\"}", "kp: kp, ki: ki, kd: 0.01, tf: 0.01, initial: \"b*w_ref/ki\", unit: N m}");
  replace("  - {name: measured, variable: sensor}", "  - {name: measured, variable: sensor}\n  - {name: command, variable: speed_control.u}");
  const LoadedModel lm = LoadModelString(text, "pi_steady.yaml");
  const auto model = CompiledModel::Compile(lm.graph, lm.compile);
  auto unit_of = [&](const std::string& state) {
    const auto& names = model->state_names();
    const auto it = std::find(names.begin(), names.end(), state);
    EXPECT_NE(it, names.end()) << state;
    return it == names.end() ? std::string() : model->state_units()[it - names.begin()];
  };
  EXPECT_EQ(unit_of("speed_control.i"), "rad");    // the integral of w_ref - shaft.f [rad/s]
  EXPECT_EQ(unit_of("speed_control.d"), "rad/s");  // the filtered error
  EXPECT_EQ(unit_of("sensor"), "rad/s");           // a lag of shaft.f
  auto command_unit = [](const CompiledModel& m) {
    for (const Column& c : MakeColumns(m, false))
      if (c.name == "command") return c.unit;
    return std::string("no column 'command'");
  };
  EXPECT_EQ(command_unit(*model), "N m");
  // Without a unit of its own, the PID's output takes the unit of the source it drives (motor:
  // Se, effort "speed_control.u", rotation: N m); a PID whose output drives no source alone has none.
  text = testing::ExampleText("equations/pi_steady.yaml");
  replace("  - {name: measured, variable: sensor}", "  - {name: measured, variable: sensor}\n  - {name: command, variable: speed_control.u}");
  EXPECT_EQ(command_unit(*CompiledModel::Compile(LoadModelString(text, "pi_steady.yaml").graph)), "N m");
  replace("effort: \"speed_control.u\"", "effort: \"2*speed_control.u\"");
  EXPECT_EQ(command_unit(*CompiledModel::Compile(LoadModelString(text, "pi_steady.yaml").graph)), "-");
}

// --- speed_dependent_load.yaml: J dw/dt = tau0 - c w - d w^2 ---

TEST(SpeedDependentLoadExample, SpeedFollowsTheRiccatiSolutionToItsSteadyValue) {
  const ExampleRun r = RunEquationExample("speed_dependent_load.yaml");
  ASSERT_EQ(r.rec.summary().status, RunStatus::kOk);
  const double J = r.Param("J"), tau0 = r.Param("tau0"), c = r.Param("c"), d = r.Param("d");
  const double root = std::sqrt(c * c + 4.0 * d * tau0);
  const double w_inf = (root - c) / (2.0 * d), w_2 = -(root + c) / (2.0 * d), tau = J / root;
  EXPECT_NEAR(w_inf, 21.5037, 1e-4);  // the file's comment
  EXPECT_NEAR(tau, 1.4704, 1e-4);
  const int speed = r.rec.Index("speed"), wz = r.rec.Index("flywheel.omega.z");
  for (const auto& row : r.rec.rows()) {
    const double e = std::exp(-row[0] / tau);
    EXPECT_NEAR(row[speed], w_inf * (1.0 - e) / (1.0 - w_inf / w_2 * e), 1e-6) << "t = " << row[0];
    EXPECT_EQ(row[speed], row[wz]);
    // The load's torque is the formula of the speed, along z only.
    EXPECT_EQ(row[r.rec.Index("load.torque.z")], -c * row[speed] - d * row[speed] * std::abs(row[speed])) << "t = " << row[0];
    EXPECT_EQ(row[r.rec.Index("load.torque.x")], 0.0);
    EXPECT_EQ(row[r.rec.Index("load.torque.y")], 0.0);
  }
  EXPECT_NEAR(r.rec.Last("speed"), w_inf, 1e-6);
  EXPECT_LT(testing::MaxEnergyResidual(r.rec), 1e-8);
  // The motor's work is the flywheel's kinetic energy plus the work the load took.
  EXPECT_NEAR(r.rec.Last("motor.source.work") + r.rec.Last("load.source.work"), 0.5 * J * w_inf * w_inf, 1e-6 * 0.5 * J * w_inf * w_inf);
}

// --- switched_spring.yaml: omega1 = sqrt(k0/m) before t1, omega2 = sqrt(2 k0/m) after ---

TEST(SwitchedSpringExample, MotionIsTheOscillatorsPiecewiseAndTheSwitchsWorkTheEnergysJump) {
  const ExampleRun r = RunEquationExample("switched_spring.yaml");
  ASSERT_EQ(r.rec.summary().status, RunStatus::kOk);
  const double m = r.Param("m"), k0 = r.Param("k0"), t1 = r.Param("t1"), q0 = r.Param("q0"), v0 = r.Param("v0");
  const double w1 = std::sqrt(k0 / m), w2 = std::sqrt(2.0 * k0 / m);
  const double q1 = q0 * std::cos(w1 * t1) + v0 / w1 * std::sin(w1 * t1), v1 = -q0 * w1 * std::sin(w1 * t1) + v0 * std::cos(w1 * t1);
  const double amplitude = std::hypot(q1, v1 / w2), jump = 0.5 * k0 * q1 * q1, e0 = 0.5 * k0 * q0 * q0 + 0.5 * m * v0 * v0;
  EXPECT_NEAR(jump, 0.0770, 1e-4);  // the file's comment
  const int x = r.rec.Index("x"), p = r.rec.Index("mass.p"), work = r.rec.Index("spring.modulation_work");
  const int stored = r.rec.Index("spring.energy"), kinetic = r.rec.Index("energy.kinetic");
  for (const auto& row : r.rec.rows()) {
    const double t = row[0], s = t - t1;
    const double q = t < t1 ? q0 * std::cos(w1 * t) + v0 / w1 * std::sin(w1 * t) : q1 * std::cos(w2 * s) + v1 / w2 * std::sin(w2 * s);
    const double v = t < t1 ? -q0 * w1 * std::sin(w1 * t) + v0 * std::cos(w1 * t) : -q1 * w2 * std::sin(w2 * s) + v1 * std::cos(w2 * s);
    EXPECT_NEAR(row[x], q, 1e-7 * amplitude) << "t = " << t;
    EXPECT_NEAR(row[p], m * v, 1e-7 * m * w2 * amplitude) << "t = " << t;
    // The switch's work: none before it, the stored energy's jump after it (booked at the kink's
    // time event), and the energy stored is the start's plus the work.
    EXPECT_NEAR(row[work], t < t1 ? 0.0 : jump, 1e-9 * jump) << "t = " << t;
    EXPECT_NEAR(row[stored] + row[kinetic], e0 + row[work], 1e-9 * (e0 + jump)) << "t = " << t;
  }
  EXPECT_LT(MaxAbs(r.rec, "energy.residual"), 1e-9);
  ASSERT_EQ(r.rec.events().size(), 1u);  // the switch, a kink of time
  EXPECT_EQ(r.rec.events().front().kind, "kink");
}

// --- modulated_capacitor.yaml: with no current, voltage = Q x/(eps A), work = the energy's change ---

TEST(ModulatedCapacitorExample, VoltageFollowsTheGapAndTheWorkIsTheChangeOfStoredEnergy) {
  const ExampleRun r = RunEquationExample("modulated_capacitor.yaml");
  ASSERT_EQ(r.rec.summary().status, RunStatus::kOk);
  const double eps = r.Param("eps"), A = r.Param("A"), Q = r.Param("Q"), x0 = r.Param("x0"), v0 = r.Param("v0"), f = r.Param("freq");
  const double e0 = Q * Q * x0 / (2.0 * eps * A), w = 2.0 * std::numbers::pi * f;
  EXPECT_NEAR(Q * (x0 + 2.0 * v0 / w) / (eps * A), 23.31, 0.005);  // the file's comment at t = 0.25 s
  const int gap = r.rec.Index("gap"), voltage = r.rec.Index("voltage"), work = r.rec.Index("cap.modulation_work");
  const int stored = r.rec.Index("cap.energy");
  for (const auto& row : r.rec.rows()) {
    const double x = x0 + v0 / w * (1.0 - std::cos(w * row[0]));
    EXPECT_NEAR(row[gap], x, 1e-8 * x0) << "t = " << row[0];
    EXPECT_NEAR(row[voltage], Q * row[gap] / (eps * A), 1e-14 * Q * x0 / (eps * A)) << "t = " << row[0];
    EXPECT_NEAR(row[work], Q * Q * (x - x0) / (2.0 * eps * A), 1e-8 * e0) << "t = " << row[0];
    EXPECT_NEAR(row[work], row[stored] - e0, 1e-13 * e0) << "t = " << row[0];
  }
  EXPECT_LT(MaxAbs(r.rec, "energy.residual"), 1e-12);
  // The drive's work is what the guide dissipated.
  EXPECT_NEAR(r.rec.Last("drive.work"), r.rec.Last("guide.dissipated"), 1e-9 * r.rec.Last("guide.dissipated"));
}

// --- electrostatic_transducer.yaml: a two-port C from one energy; statics, an independent integration, energy ---

/// The transducer's equations written by hand (the file's comment), for GSL: states q (charge),
/// x (gap), p (the plate's momentum), y (the spring's extension).
struct Transducer {
  double eps_a, V, Rs, m, k, b;
};

int TransducerRates(double, const double s[], double ds[], void* params) {
  const Transducer& c = *static_cast<const Transducer*>(params);
  const double q = s[0], x = s[1], v = s[2] / c.m, y = s[3];
  ds[0] = (c.V - q * x / c.eps_a) / c.Rs;                         // the current through Rs
  ds[1] = v;                                                       // the gap opens with the plate
  ds[2] = -q * q / (2.0 * c.eps_a) - c.k * y - c.b * v;            // attraction, spring, damper
  ds[3] = v;
  return GSL_SUCCESS;
}

TEST(ElectrostaticTransducerExample, FollowsTheHandWrittenEquationsAndSettlesAtTheStatics) {
  const ExampleRun r = RunEquationExample("electrostatic_transducer.yaml");
  ASSERT_EQ(r.rec.summary().status, RunStatus::kOk);
  Transducer c{r.Param("eps") * r.Param("A"), r.Param("V"), r.Param("Rs"), r.Param("m"), r.Param("k"), r.Param("b")};
  const double x0 = r.Param("x0");
  // The statics: k (x0 - x) x^2 = eps A V^2 / 2 on (2 x0 / 3, x0), by bisection to the last bit.
  double lo = 2.0 * x0 / 3.0, hi = x0;
  for (int i = 0; i < 200 && hi - lo > 0.0; ++i) {
    const double mid = 0.5 * (lo + hi);
    (c.k * (x0 - mid) * mid * mid > c.eps_a * c.V * c.V / 2.0 ? lo : hi) = mid;  // decreasing there
  }
  const double x_rest = 0.5 * (lo + hi), q_rest = c.eps_a * c.V / x_rest;
  EXPECT_NEAR(x_rest, 0.92559e-3, 0.000005e-3);  // the file's comment
  EXPECT_NEAR(q_rest, 114.79e-9, 0.005e-9);
  // GSL's Runge-Kutta-Prince-Dormand (8, 9), each state against its own scale.
  gsl_odeiv2_system sys{TransducerRates, nullptr, 4, &c};
  const double scale[4] = {q_rest, x0, c.m * 0.1, x0};
  gsl_odeiv2_driver* d = gsl_odeiv2_driver_alloc_scaled_new(&sys, gsl_odeiv2_step_rk8pd, 1e-9, 1e-13, 1e-13, 1.0, 0.0, scale);
  double s[4] = {0.0, x0, 0.0, 0.0}, t = 0.0;
  const int iq = r.rec.Index("plates.q.charge"), ix = r.rec.Index("plates.q.gap"), ip = r.rec.Index("plate.p"), iy = r.rec.Index("spring.q");
  const int iv = r.rec.Index("voltage"), iforce = r.rec.Index("force");
  double p_max = 0.0;
  for (const auto& row : r.rec.rows()) p_max = std::max(p_max, std::abs(row[ip]));
  ASSERT_GT(p_max, 1e-5);  // the plate moves
  for (const auto& row : r.rec.rows()) {
    if (row[0] > t) {
      ASSERT_EQ(gsl_odeiv2_driver_apply(d, &t, row[0], s), GSL_SUCCESS) << "t = " << row[0];
    }
    EXPECT_NEAR(row[iq], s[0], 1e-7 * q_rest) << "t = " << row[0];
    EXPECT_NEAR(row[ix], s[1], 1e-7 * x0) << "t = " << row[0];
    EXPECT_NEAR(row[ip], s[2], 1e-6 * p_max) << "t = " << row[0];
    EXPECT_NEAR(row[iy], s[3], 1e-7 * x0) << "t = " << row[0];
    // The efforts are the energy's gradient at the state.
    EXPECT_NEAR(row[iv], row[iq] * row[ix] / c.eps_a, 1e-13 * c.V) << "t = " << row[0];
    EXPECT_NEAR(row[iforce], row[iq] * row[iq] / (2.0 * c.eps_a), 1e-13 * c.k * x0) << "t = " << row[0];
    // The gap and the spring integrate the same velocity.
    EXPECT_NEAR(row[ix] - x0, row[iy], 1e-12 * x0) << "t = " << row[0];
  }
  gsl_odeiv2_driver_free(d);
  // At rest: the statics.
  EXPECT_NEAR(r.rec.Last("plates.q.gap"), x_rest, 1e-9 * x0);
  EXPECT_NEAR(r.rec.Last("plates.q.charge"), q_rest, 1e-9 * q_rest);
  EXPECT_NEAR(r.rec.Last("force"), c.k * (x0 - x_rest), 1e-8 * c.k * x0);
  // Work in = stored + dissipated: the source's work is the electric, spring and kinetic energy and
  // what Rs and the damper turned into heat.
  const double work = r.rec.Last("source.work");
  EXPECT_NEAR(work, c.V * q_rest, 1e-8 * c.V * q_rest);
  const double stored = r.rec.Last("plates.energy") + r.rec.Last("spring.energy") + r.rec.Last("plate.energy");
  EXPECT_NEAR(stored, q_rest * q_rest * x_rest / (2.0 * c.eps_a) + c.k * (x_rest - x0) * (x_rest - x0) / 2.0, 1e-8 * work);
  EXPECT_NEAR(work, stored + r.rec.Last("series.dissipated") + r.rec.Last("damper.dissipated"), 1e-9 * work);
  EXPECT_LT(MaxAbs(r.rec, "energy.residual"), 1e-9);  // relative (docs/model-format.md, "Output files")
}

// --- diode_charger.yaml: a nonlinear algebraic loop (a resistor and a diode in series) ---

/// The current of a resistor Rs and a diode (Is, n Vt) in series across u: Lambert's W.
double SeriesDiodeCurrent(double u, double Rs, double Is, double nvt) {
  return nvt / Rs * gsl_sf_lambert_W0(Rs * Is / nvt * std::exp((u + Rs * Is) / nvt)) - Is;
}

struct Rectifier {
  double V, w, Rs, Is, nvt, C, RL;
};

int RectifierRate(double t, const double y[], double dy[], void* params) {
  const Rectifier& c = *static_cast<const Rectifier*>(params);
  dy[0] = (SeriesDiodeCurrent(c.V * std::sin(c.w * t) - y[0], c.Rs, c.Is, c.nvt) - y[0] / c.RL) / c.C;
  return GSL_SUCCESS;
}

TEST(DiodeChargerExample, TheLoopsCurrentIsLambertsWAndTheCapacitorFollowsItsEquation) {
  const ExampleRun r = RunEquationExample("diode_charger.yaml");
  ASSERT_EQ(r.rec.summary().status, RunStatus::kOk);
  const Rectifier c{r.Param("V"), 2.0 * std::numbers::pi * r.Param("freq"), r.Param("Rs"), r.Param("Is"),
                    r.Param("n") * r.Param("Vt"), r.Param("Cap"), r.Param("RL")};
  const int iv = r.rec.Index("v_out"), ii = r.rec.Index("current"), iq = r.rec.Index("cap.q");
  const double i_max = MaxAbs(r.rec, "current");
  ASSERT_GT(i_max, 0.1);  // the diode conducts
  gsl_odeiv2_system sys{RectifierRate, nullptr, 1, const_cast<Rectifier*>(&c)};
  gsl_odeiv2_driver* d = gsl_odeiv2_driver_alloc_y_new(&sys, gsl_odeiv2_step_rk8pd, 1e-7, 1e-14, 1e-13);
  double v = 0.0, t = 0.0, v_min = 1e9, v_max = -1e9;
  for (const auto& row : r.rec.rows()) {
    if (row[0] > t) {
      ASSERT_EQ(gsl_odeiv2_driver_apply(d, &t, row[0], &v), GSL_SUCCESS) << "t = " << row[0];
    }
    // The loop solved at this state: its current is the closed form's at the capacitor's voltage.
    const double u = c.V * std::sin(c.w * row[0]) - row[iv];
    EXPECT_NEAR(row[ii], SeriesDiodeCurrent(u, c.Rs, c.Is, c.nvt), 1e-12 * i_max) << "t = " << row[0];
    EXPECT_DOUBLE_EQ(row[iv], row[iq] / c.C);
    EXPECT_NEAR(row[iv], v, 1e-8 * c.V) << "t = " << row[0];
    if (row[0] >= 0.08) {
      v_min = std::min(v_min, row[iv]);
      v_max = std::max(v_max, row[iv]);
    }
  }
  gsl_odeiv2_driver_free(d);
  EXPECT_NEAR(v_min, 2.852, 0.0005);  // the file's comment
  EXPECT_NEAR(v_max, 3.194, 0.0005);
  // Work in = stored + dissipated, once energy has flowed (the residual is relative to it).
  const double work = r.rec.Last("source.work");
  EXPECT_NEAR(work, r.rec.Last("cap.energy") + r.rec.Last("series.dissipated") + r.rec.Last("diode.dissipated") + r.rec.Last("load.dissipated"),
              1e-9 * work);
  for (const auto& row : r.rec.rows()) {
    if (row[0] >= 1e-3) {
      EXPECT_LT(std::abs(row[r.rec.Index("energy.residual")]), 1e-9) << "t = " << row[0];
    }
  }
}

// --- diode_thermal.yaml: a nonlinear loop through a law and a signal (a self-heating diode) ---

struct ThermalDiode {
  double V, Rs, L, Is0, T0, Tc, nkq, Ta, Rth;
  /// The diode's voltage at current i and junction temperature T.
  double Voltage(double i, double T) const { return nkq * T * std::log1p(i / (Is0 * std::exp((T - T0) / Tc))); }
  /// The loop's root at current i: T = Ta + Rth i e(i, T), increasing in T (|Rth i de/dT| < 1), by bisection.
  double Junction(double i) const {
    double lo = Ta - 1.0, hi = Ta + 1000.0;
    for (int k = 0; k < 200; ++k) {
      const double mid = 0.5 * (lo + hi);
      (mid - Ta - Rth * i * Voltage(i, mid) < 0.0 ? lo : hi) = mid;
    }
    return 0.5 * (lo + hi);
  }
};

int ThermalDiodeRate(double, const double y[], double dy[], void* params) {
  const ThermalDiode& c = *static_cast<const ThermalDiode*>(params);
  const double i = y[0];
  dy[0] = (c.V - c.Rs * i - c.Voltage(i, c.Junction(i))) / c.L;
  return GSL_SUCCESS;
}

TEST(DiodeThermalExample, TheLoopThroughTheJunctionTemperatureHoldsAtEveryOutput) {
  const ExampleRun r = RunEquationExample("diode_thermal.yaml");
  ASSERT_EQ(r.rec.summary().status, RunStatus::kOk);
  const ThermalDiode c{r.Param("V"),  r.Param("Rs"), r.Param("L"),  r.Param("Is0"), r.Param("T0"),
                       r.Param("Tc"), r.Param("n") * r.Param("kq"), r.Param("Ta"), r.Param("Rth")};
  const int ii = r.rec.Index("current"), ie = r.rec.Index("v_diode"), iT = r.rec.Index("junction");
  gsl_odeiv2_system sys{ThermalDiodeRate, nullptr, 1, const_cast<ThermalDiode*>(&c)};
  gsl_odeiv2_driver* d = gsl_odeiv2_driver_alloc_y_new(&sys, gsl_odeiv2_step_rk8pd, 1e-7, 1e-14, 1e-13);
  double i = 0.0, t = 0.0;
  for (const auto& row : r.rec.rows()) {
    if (row[0] > t) {
      ASSERT_EQ(gsl_odeiv2_driver_apply(d, &t, row[0], &i), GSL_SUCCESS) << "t = " << row[0];
    }
    // The loop at the run's own current: the junction temperature and the voltage it gives.
    const double T = c.Junction(row[ii]);
    EXPECT_NEAR(row[iT], T, 1e-9 * T) << "t = " << row[0];
    EXPECT_NEAR(row[ie], c.Voltage(row[ii], T), 1e-10) << "t = " << row[0];
    EXPECT_NEAR(row[ii], i, 1e-9) << "t = " << row[0];
  }
  gsl_odeiv2_driver_free(d);
  // The file's comment: the settled current, the junction's rise and its voltage against Ta's.
  const double i_end = r.rec.Last("current");
  EXPECT_NEAR(i_end, 1.304, 0.0005);
  EXPECT_NEAR(r.rec.Last("junction") - c.Ta, 18.1, 0.05);
  EXPECT_NEAR(r.rec.Last("v_diode"), 0.696, 0.0005);
  EXPECT_NEAR(c.Voltage(i_end, c.Ta) - r.rec.Last("v_diode"), 0.025, 0.0005);
  const double work = r.rec.Last("source.work");
  EXPECT_NEAR(work, r.rec.Last("coil.energy") + r.rec.Last("series.dissipated") + r.rec.Last("diode.dissipated"), 1e-9 * work);
  EXPECT_LT(std::abs(r.rec.Last("energy.residual")), 1e-9);
}

// --- generated code: the same bits ---

TEST(EquationExamples, GeneratedCodeGivesTheInterpretersBits) {
  for (const char* file : {"pendulum.yaml", "duffing.yaml", "tank.yaml", "motor_pi.yaml", "speed_dependent_load.yaml", "pi_steady.yaml",
                           "switched_spring.yaml", "modulated_capacitor.yaml", "electrostatic_transducer.yaml", "mtf_pendulum.yaml"}) {
    SCOPED_TRACE(file);
    const ExampleRun interpreted = RunEquationExample(file, {}, false), generated = RunEquationExample(file, {}, true);
    ASSERT_EQ(interpreted.rec.summary().status, RunStatus::kOk);
    ASSERT_EQ(generated.rec.summary().status, RunStatus::kOk);
    ASSERT_EQ(interpreted.rec.rows().size(), generated.rec.rows().size());
    for (size_t k = 0; k < interpreted.rec.rows().size(); ++k)
      ASSERT_EQ(interpreted.rec.rows()[k], generated.rec.rows()[k]) << "row " << k;
  }
}

}  // namespace
}  // namespace multibond
