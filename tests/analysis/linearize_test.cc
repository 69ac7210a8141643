// The linearisation against closed forms: a mass-spring-damper's state space, a pendulum and a
// Duffing spring linearised about displaced states (laws given by formulas), a spinning body's
// Jacobian in angle coordinates against central differences along the rotation group, steady
// states, and what is refused.

#include "multibond/analysis/linearize.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include <Eigen/Eigenvalues>

#include "multibond/analysis/bode.h"
#include "multibond/analysis/modes.h"
#include "multibond/compile/compiled_model.h"
#include "multibond/io/model_loader.h"
#include "multibond/sim/simulator.h"
#include "support/rigid_gear_pair.h"

namespace multibond::linear {
namespace {

std::shared_ptr<const CompiledModel> Compiled(const std::string& path, const std::vector<ParameterOverride>& set = {}) {
  LoadedModel lm = LoadModelFile(std::string(MULTIBOND_SOURCE_DIR) + "/" + path, {}, set);
  return CompiledModel::Compile(std::move(lm.graph), lm.compile);
}

int Index(const std::vector<std::string>& names, const std::string& name) {
  const auto it = std::find(names.begin(), names.end(), name);
  EXPECT_NE(it, names.end()) << name;
  return static_cast<int>(it - names.begin());
}

TEST(Linearize, MassSpringDamperStateSpace) {
  const auto model = Compiled("examples/mass_spring_damper.yaml");
  const LinearModel lm = Linearize(*model, 0.0, model->MakeInitialState());
  ASSERT_EQ(lm.states.size(), 2u);  // the energy account's integrals are no coordinates
  const int p = Index(lm.states, "mass.p"), q = Index(lm.states, "spring.q");
  // m = 1, c = 2, k = 100:  dp/dt = F - k q - c p/m,  dq/dt = p/m.
  EXPECT_DOUBLE_EQ(lm.A(p, p), -2.0);
  EXPECT_DOUBLE_EQ(lm.A(p, q), -100.0);
  EXPECT_DOUBLE_EQ(lm.A(q, p), 1.0);
  EXPECT_DOUBLE_EQ(lm.A(q, q), 0.0);
  ASSERT_EQ(lm.inputs, std::vector<std::string>{"force"});
  EXPECT_DOUBLE_EQ(lm.B(p, 0), 1.0);
  EXPECT_DOUBLE_EQ(lm.B(q, 0), 0.0);
  ASSERT_EQ(lm.outputs, (std::vector<std::string>{"velocity", "spring_force"}));
  EXPECT_DOUBLE_EQ(lm.C(0, p), 1.0);
  EXPECT_DOUBLE_EQ(lm.C(0, q), 0.0);
  EXPECT_DOUBLE_EQ(lm.C(1, q), 100.0);
  EXPECT_DOUBLE_EQ(lm.D.cwiseAbs().maxCoeff(), 0.0);
  const Eigen::VectorXcd ev = lm.A.eigenvalues();
  for (const auto& l : ev) {
    EXPECT_NEAR(l.real(), -1.0, 1e-12);
    EXPECT_NEAR(std::abs(l.imag()), std::sqrt(99.0), 1e-12);
  }
  // Storage Hessians: 1/m and k; 1/2 x^T H x is the stored energy.
  ASSERT_EQ(lm.storages.size(), 2u);
  for (const Storage& s : lm.storages) EXPECT_DOUBLE_EQ(s.hessian(0, 0), s.element == "mass" ? 1.0 : 100.0) << s.element;
  ASSERT_EQ(lm.motion_names, std::vector<std::string>{"mass.f"});
  EXPECT_DOUBLE_EQ(lm.motion(0, p), 1.0);
}

TEST(Linearize, PendulumAboutADisplacedAngle) {
  // dp/dt = -m g L sin(angle) (a formula), d(angle)/dt = p/(m L^2): A = [[0, -m g L cos(a0)], [1/J, 0]].
  for (const double a0 : {0.0, 0.5, 2.0}) {
    const auto model = Compiled("examples/equations/pendulum.yaml", {{"theta0", std::to_string(a0)}});
    const LinearModel lm = Linearize(*model, 0.0, model->MakeInitialState());
    const int p = Index(lm.states, "J.p"), a = Index(lm.states, "angle");
    EXPECT_NEAR(lm.A(p, a), -9.81 * std::cos(a0), 1e-14) << a0;
    EXPECT_DOUBLE_EQ(lm.A(a, p), 1.0);
    EXPECT_DOUBLE_EQ(lm.A(p, p), 0.0);
    if (a0 == 0.0) {
      for (const auto& l : lm.A.eigenvalues()) {
        EXPECT_NEAR(std::abs(l.imag()), std::sqrt(9.81), 1e-12);
      }
    }
  }
}

TEST(Linearize, DuffingSpringStiffensWithDisplacement) {
  // Energy 1/2 k1 q^2 + 1/4 k3 q^4: stiffness k1 + 3 k3 q0^2 = 1 + 30 at q0 = 1, in A and in the Hessian.
  const auto model = Compiled("examples/equations/duffing.yaml");
  const LinearModel lm = Linearize(*model, 0.0, model->MakeInitialState());
  const int p = Index(lm.states, "mass.p"), q = Index(lm.states, "spring.q");
  EXPECT_NEAR(lm.A(p, q), -31.0, 1e-13);
  for (const Storage& s : lm.storages) {
    if (s.element == "spring") {
      EXPECT_NEAR(s.hessian(0, 0), 31.0, 1e-13);
    }
  }
  EXPECT_DOUBLE_EQ(lm.A(q, p), 1.0);
}

TEST(Linearize, BilinearDamperAtRestHasTheMeanOfItsRatesInModesAndBode) {
  // examples/linear/bilinear_damper.yaml: m = 250, k = 16000, damper c_bump max(f, 0) +
  // c_reb min(f, 0) with c_bump = 800, c_reb = 2400, at rest (f = 0, on the kink). Its slope is
  // c_mean = (c_bump + c_reb)/2: w_n = sqrt(k/m) = 8 rad/s, zeta = c_mean/(2 sqrt(k m)) = 0.4 (the
  // sum of both slopes, 3200, would give 0.8); the mobility force -> velocity at w_n is 1/c_mean.
  const double pi = std::acos(-1.0);
  struct Case {
    double m, k, c_bump, c_reb;
  };
  for (const Case& c : {Case{250, 16000, 800, 2400}, Case{2, 50, 3, 0.5}}) {
    SCOPED_TRACE(c.c_reb);
    const auto model = Compiled("examples/linear/bilinear_damper.yaml",
                                {{"m", fmt::format("{}", c.m)}, {"k", fmt::format("{}", c.k)},
                                 {"c_bump", fmt::format("{}", c.c_bump)}, {"c_reb", fmt::format("{}", c.c_reb)}});
    const LinearModel lm = Linearize(*model, 0.0, model->MakeInitialState());
    const double c_mean = (c.c_bump + c.c_reb) / 2, wn = std::sqrt(c.k / c.m), zeta = c_mean / (2 * std::sqrt(c.k * c.m));
    const int p = Index(lm.states, "body.p"), q = Index(lm.states, "spring.q");
    EXPECT_NEAR(lm.A(p, p), -c_mean / c.m, 1e-12 * c_mean / c.m);
    EXPECT_NEAR(lm.A(p, q), -c.k, 1e-12 * c.k);
    const std::vector<Mode> modes = ComputeModes(lm);
    ASSERT_EQ(modes.size(), 1u);
    EXPECT_NEAR(modes[0].frequency_hz, wn / (2 * pi), 1e-9 * wn / (2 * pi));
    EXPECT_NEAR(modes[0].damping_ratio, zeta, 1e-9);
    EXPECT_NEAR(modes[0].eigenvalue.real(), -zeta * wn, 1e-9 * wn);
    EXPECT_NEAR(modes[0].eigenvalue.imag(), wn * std::sqrt(1 - zeta * zeta), 1e-9 * wn);
    const int force = Index(lm.inputs, "force"), velocity = Index(lm.outputs, "velocity"), disp = Index(lm.outputs, "displacement");
    const std::vector<BodePoint> at_wn = FrequencyResponse(lm, force, velocity, {wn / (2 * pi)});
    ASSERT_EQ(at_wn.size(), 1u);
    EXPECT_NEAR(std::abs(at_wn[0].value - 1.0 / c_mean), 0.0, 1e-9 / c_mean);
    EXPECT_NEAR(at_wn[0].phase_deg, 0.0, 1e-9);
    // Far below the resonance the displacement is the spring's: 1/k.
    const std::vector<BodePoint> dc = FrequencyResponse(lm, force, disp, {1e-6 * wn / (2 * pi)});
    EXPECT_NEAR(dc[0].value.real(), 1.0 / c.k, 1e-9 / c.k);
  }
  // The file's own values: zeta = 0.4, not 0.8.
  const auto model = Compiled("examples/linear/bilinear_damper.yaml");
  const std::vector<Mode> modes = ComputeModes(Linearize(*model, 0.0, model->MakeInitialState()));
  ASSERT_EQ(modes.size(), 1u);
  EXPECT_NEAR(modes[0].damping_ratio, 0.4, 1e-12);
  EXPECT_NEAR(modes[0].frequency_hz, 8.0 / (2 * pi), 1e-12);
}

TEST(Linearize, BilinearDamperAwayFromTheKinkTakesTheRateOfItsSide) {
  // Moving in compression (f > 0) the damper is c_bump, in rebound c_reb: A(p, p) = -c/m.
  const auto model = Compiled("examples/linear/bilinear_damper.yaml");
  for (const double v : {0.1, -0.1}) {
    Eigen::VectorXd x = model->MakeInitialState();
    const LinearModel at_rest = Linearize(*model, 0.0, x);
    x(Index(at_rest.full_states, "body.p")) = 250.0 * v;
    const LinearModel lm = Linearize(*model, 0.0, x);
    const int p = Index(lm.states, "body.p");
    EXPECT_NEAR(lm.A(p, p), -(v > 0 ? 800.0 : 2400.0) / 250.0, 1e-12) << v;
    for (const std::string& note : lm.notes) EXPECT_EQ(note.find(kOnKinkNote), std::string::npos) << note;  // off the kink
  }
}

TEST(Linearize, AnOperatingPointOnAKinkIsSaid) {
  // At rest the damper's switching function f is 0: one note, naming the damper and its formula.
  const auto model = Compiled("examples/linear/bilinear_damper.yaml");
  const LinearModel lm = Linearize(*model, 0.0, model->MakeInitialState());
  std::vector<std::string> kinks;
  for (const std::string& note : lm.notes)
    if (note.rfind(kOnKinkNote, 0) == 0) kinks.push_back(note);
  ASSERT_EQ(kinks.size(), 1u);
  EXPECT_NE(kinks[0].find("the effort law of damper"), std::string::npos) << kinks[0];
  EXPECT_NE(kinks[0].find("max(j.f, 0)"), std::string::npos) << kinks[0];
}

TEST(Linearize, SpinningBodyMatchesCentralDifferencesOnTheRotationGroup) {
  // The spinning body of docs/model-format.md, tilted and spinning: A against central differences
  // of the variational equation. A perturbed orientation R = exp([theta x]) R0 and the nominal
  // one differ by M(t) = R(t) Rn(t)^T = exp([theta(t) x]); to first order in theta,
  // d(theta)/dt = vee(dM/dt) = vee(dR/dt R0^T + R dRn/dt^T) at t = 0.
  const std::string yaml = R"(
model: spinning_body
domain: rotation
elements:
  torque: {type: Se, effort: [0.0, 0.0, 0.0]}
  w:      {type: "1"}
  body:   {type: I, inertia: [0.1, 0.2, 0.3], rotation: R, p0: [0.02, 0.01, 0.05]}
states:
  R: {kind: orientation, of: w, initial: [[0.36, 0.48, -0.8], [-0.8, 0.6, 0.0], [0.48, 0.64, 0.6]]}
bonds:
  - torque -> w
  - w -> body
outputs:
  - {name: omega, variable: w.f}
)";
  LoadedModel loaded = LoadModelString(yaml);
  const auto model = CompiledModel::Compile(std::move(loaded.graph), loaded.compile);
  const Eigen::VectorXd x0 = model->MakeInitialState();
  const LinearModel lm = Linearize(*model, 0.0, x0);
  ASSERT_EQ(lm.states.size(), 6u);  // 3 momenta, 3 angles: not 12
  EXPECT_EQ(lm.states[3], "R.angle.x");
  // z -> x: momenta added, angles applied on the group; dz/dt = T(x)^+ dx/dt.
  using Rm3 = Eigen::Matrix<double, 3, 3, Eigen::RowMajor>;
  Eigen::VectorXd xdot0(x0.size());
  {
    Workspace ws = model->MakeWorkspace();
    model->CalcDerivatives(0.0, x0.data(), xdot0.data(), ws);
  }
  const Rm3 r0 = Eigen::Map<const Rm3>(x0.data() + 3), rdot0 = Eigen::Map<const Rm3>(xdot0.data() + 3);
  auto zdot = [&](const Eigen::VectorXd& z) {
    Eigen::VectorXd x = x0;
    for (int k = 0; k < 3; ++k) x[k] += z[k];
    const Eigen::Vector3d th = z.tail<3>();
    const Eigen::Matrix3d rot = th.norm() > 0 ? Eigen::AngleAxisd(th.norm(), th.normalized()).toRotationMatrix() : Eigen::Matrix3d::Identity();
    const Rm3 r = rot * r0;
    Eigen::Map<Rm3>(x.data() + 3) = r;
    Workspace ws = model->MakeWorkspace();
    Eigen::VectorXd xdot(x.size());
    model->CalcDerivatives(0.0, x.data(), xdot.data(), ws);
    const Eigen::Matrix3d s = Eigen::Map<const Rm3>(xdot.data() + 3) * r0.transpose() + r * rdot0.transpose();
    Eigen::VectorXd out(6);
    out << xdot.head<3>(), s(2, 1), s(0, 2), s(1, 0);
    return out;
  };
  const double h = 1e-6;
  for (int j = 0; j < 6; ++j) {
    Eigen::VectorXd e = Eigen::VectorXd::Zero(6);
    e[j] = h;
    const Eigen::VectorXd fd = (zdot(e) - zdot(-e)) / (2 * h);
    for (int i = 0; i < 6; ++i) EXPECT_NEAR(lm.A(i, j), fd[i], 1e-7 * (1.0 + std::abs(fd[i]))) << i << "," << j;
  }
  // No torque: the angular momentum is constant (its rows are zero), and the torque enters it.
  EXPECT_EQ(lm.A.topRows(3).cwiseAbs().maxCoeff(), 0.0);
  EXPECT_DOUBLE_EQ(lm.B(2, 2), 1.0);
}

TEST(Linearize, SteadyStateOfAMassSpringDamperUnderAConstantForce) {
  const auto model = Compiled("examples/mass_spring_damper.yaml");
  const Eigen::VectorXd x = FindSteadyState(*model, 1.0, model->MakeInitialState());
  const int q = static_cast<int>(std::find(model->state_names().begin(), model->state_names().end(), "spring.q") - model->state_names().begin());
  EXPECT_NEAR(x[q], 0.01, 1e-14);  // F / k
  EXPECT_NEAR(x[0], 0.0, 1e-14);
}

TEST(Linearize, SteadyStateFarFromTheStart) {
  // examples/equations/pi_steady.yaml from rest (its initial values set to zero): the steady
  // state, 10 away in the sensor's reading, was beyond KINSOL's default step bound (1000 |z0|,
  // and z0 = 0: a step of 1) and failed with KIN_MXNEWT_5X_EXCEEDED.
  const auto model = Compiled("examples/equations/pi_steady.yaml", {{"w_meas0", "0"}});
  Eigen::VectorXd start = model->MakeInitialState();
  start.setZero();
  const Eigen::VectorXd x = FindSteadyState(*model, 0.0, start);
  auto at = [&](const char* name) {
    return x[std::find(model->state_names().begin(), model->state_names().end(), name) - model->state_names().begin()];
  };
  EXPECT_NEAR(at("rotor.p"), 0.02 * 10.0, 1e-12);              // J w_ref
  EXPECT_NEAR(at("speed_control.i"), 0.05 * 10.0 / 2.0, 1e-12);  // b w_ref / ki
  EXPECT_NEAR(at("sensor"), 10.0, 1e-12);
}

TEST(Linearize, SteadyStateOfAPendulumFromNearTheTop) {
  // From 3 rad at rest Newton finds the nearest equilibrium: the inverted one at pi, unstable
  // (a real positive eigenvalue sqrt(g/L)).
  const auto model = Compiled("examples/equations/pendulum.yaml", {{"theta0", "3.0"}});
  const Eigen::VectorXd x = FindSteadyState(*model, 0.0, model->MakeInitialState());
  const int a = static_cast<int>(std::find(model->state_names().begin(), model->state_names().end(), "angle") - model->state_names().begin());
  EXPECT_NEAR(x[a], M_PI, 1e-12);
  const LinearModel lm = Linearize(*model, 0.0, x);
  double largest = -1e9;
  for (const auto& l : lm.A.eigenvalues()) largest = std::max(largest, l.real());
  EXPECT_NEAR(largest, std::sqrt(9.81), 1e-9);
}

TEST(Linearize, RigidGearOnASpringInIndependentCoordinates) {
  // A pinion J1 = 0.01 and a wheel J2 = 0.04 at half its speed (a rigid TF: J2 is cut by an ideal
  // constraint), the wheel on a torsion spring k = 2 to the ground: J_eq = J1 + J2/4 = 0.02 on
  // the pinion, the spring's stiffness there k/4: w^2 = (k/4)/J_eq = 25, w = 5 rad/s.
  const std::string yaml = testing::RigidGearPair("rigid_gear_spring", "", "0.0", "0.5", "{type: C, stiffness: 2.0}",
                                                  "outputs:\n  - {name: w1, variable: j1.f}\n");
  LoadedModel loaded = LoadModelString(yaml);
  loaded.compile.ideal_constraints = true;
  const auto model = CompiledModel::Compile(std::move(loaded.graph), loaded.compile);
  ASSERT_TRUE(model->has_constraints());
  const LinearModel lm = Linearize(*model, 0.0, model->MakeInitialState());
  ASSERT_EQ(lm.states.size(), 2u);  // one of the two momenta depends on the other
  for (const auto& l : lm.A.eigenvalues()) {
    EXPECT_NEAR(l.real(), 0.0, 1e-12);
    EXPECT_NEAR(std::abs(l.imag()), 5.0, 1e-12);
  }
  // The torque accelerates the pinion at 1/J_eq: C B = d(w1)/dt per unit torque = 50.
  EXPECT_NEAR((lm.C * lm.B)(0, 0), 50.0, 1e-12);
}

TEST(Linearize, RigidDifferentialTangentMatchesCentralDifferences) {
  // The rigid differential in motion (after 1 s of the drive), its multipliers solved at every
  // evaluation: the exact tangent (the multipliers' derivative by the constraint equations
  // differentiated once more) against central differences of the right-hand side along every
  // state entry.
  LoadedModel loaded = LoadModelFile(std::string(MULTIBOND_SOURCE_DIR) + "/examples/differential_ideal.yaml");
  const auto model = CompiledModel::Compile(std::move(loaded.graph), loaded.compile);
  ASSERT_TRUE(model->has_constraints());
  RunOptions o;
  o.t_end = 1.0;
  o.dt = 0.5;
  o.integrator.rtol = 1e-10;
  o.integrator.atol = 1e-12;
  RecordingObserver rec;
  ASSERT_EQ(Simulate(*model, o, rec).status, RunStatus::kOk);
  const int n = model->num_states();
  Eigen::VectorXd x(n);
  for (int i = 0; i < n; ++i) x[i] = rec.rows().back()[1 + i];
  Workspace ws = model->MakeWorkspace(), dws = model->MakeWorkspace();
  Eigen::VectorXd xdot(n), tangent(n), plus(n), minus(n);
  model->CalcDerivatives(1.0, x.data(), xdot.data(), ws);
  double largest = 0.0, worst = 0.0;
  for (int j = 0; j < n; ++j) {
    Eigen::VectorXd e = Eigen::VectorXd::Zero(n);
    e[j] = 1.0;
    model->CalcTangent(1.0, x.data(), e.data(), nullptr, tangent.data(), ws, dws);
    const double h = 1e-6 * std::max(1.0, std::abs(x[j]));
    Eigen::VectorXd xp = x, xm = x;
    xp[j] += h;
    xm[j] -= h;
    model->CalcDerivatives(1.0, xp.data(), plus.data(), ws);
    model->CalcDerivatives(1.0, xm.data(), minus.data(), ws);
    model->CalcDerivatives(1.0, x.data(), xdot.data(), ws);
    const Eigen::VectorXd fd = (plus - minus) / (2 * h);
    largest = std::max(largest, fd.cwiseAbs().maxCoeff());
    worst = std::max(worst, (fd - tangent).cwiseAbs().maxCoeff());
  }
  EXPECT_GT(largest, 1.0);
  EXPECT_LT(worst, 1e-8 * largest) << "largest entry " << largest;
}

}  // namespace
}  // namespace multibond::linear
