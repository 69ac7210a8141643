// Linear analysis of the examples against closed forms and against an independent Jacobian:
// the two-mass example's modes from the generalized eigenproblem, and the compliant
// differential's modes against central differences of its variational equation; the
// electrostatic transducer (a multiport C) at rest against its hand-written Jacobian.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <complex>
#include <string>

#include <Eigen/Eigenvalues>

#include "multibond/analysis/linearize.h"
#include "multibond/analysis/modes.h"
#include "multibond/compile/compiled_model.h"
#include "multibond/io/model_loader.h"

namespace multibond::linear {
namespace {

using Rm3 = Eigen::Matrix<double, 3, 3, Eigen::RowMajor>;

std::shared_ptr<const CompiledModel> Compiled(const std::string& path) {
  LoadedModel lm = LoadModelFile(std::string(MULTIBOND_SOURCE_DIR) + "/" + path);
  return CompiledModel::Compile(std::move(lm.graph), lm.compile);
}

/// The Jacobian of the variational equation in the linear model's coordinates by central
/// differences, computed from the right-hand side alone (not from the tangent pass): a momentum or
/// displacement coordinate moves its entry; an angle moves its orientation R to exp([h e_i x]) R,
/// and the angles' rates are read from M = R Rn^T as vee(dR/dt Rn^T + R dRn/dt^T).
Eigen::MatrixXd CentralDifferenceJacobian(const CompiledModel& model, const LinearModel& lm, double h) {
  const Eigen::VectorXd& x0 = lm.x0;
  const Eigen::Index n = x0.size(), nz = static_cast<Eigen::Index>(lm.states.size());
  Workspace ws = model.MakeWorkspace();
  Eigen::VectorXd xdot0(n);
  model.CalcDerivatives(lm.at, x0.data(), xdot0.data(), ws);
  // Which coordinate each column is: a state entry, or an angle (its orientation's offset and axis).
  struct Coordinate {
    int state = -1, orientation = -1, axis = 0;
  };
  std::vector<Coordinate> coords(nz);
  for (Eigen::Index j = 0; j < nz; ++j) {
    const Eigen::VectorXd col = lm.basis.col(j);
    if (col.cwiseAbs().sum() == 1.0 && col.maxCoeff() == 1.0) {
      Eigen::Index i;
      col.maxCoeff(&i);
      coords[j].state = static_cast<int>(i);
    } else {
      Eigen::Index first;
      col.cwiseAbs().maxCoeff(&first);
      coords[j].orientation = static_cast<int>(first - first % 9);  // blocks of 9 start at multiples of 9 only by chance: found below
    }
  }
  // Orientation offsets from the names "<R>.angle.<axis>" and the state names "<R>.<ij>".
  for (Eigen::Index j = 0; j < nz; ++j) {
    if (coords[j].state >= 0) continue;
    const std::string& name = lm.states[j];
    const std::string base = name.substr(0, name.find(".angle."));
    coords[j].axis = name.back() - 'x';
    const auto it = std::find_if(lm.full_states.begin(), lm.full_states.end(), [&](const std::string& s) { return s.rfind(base + ".", 0) == 0; });
    coords[j].orientation = static_cast<int>(it - lm.full_states.begin());
  }
  auto rates = [&](const Eigen::VectorXd& x) {
    Eigen::VectorXd xdot(n);
    model.CalcDerivatives(lm.at, x.data(), xdot.data(), ws);
    Eigen::VectorXd z(nz);
    for (Eigen::Index i = 0; i < nz; ++i) {
      if (coords[i].state >= 0) {
        z[i] = xdot[coords[i].state];
        continue;
      }
      const int o = coords[i].orientation;
      const Eigen::Matrix3d s = Eigen::Map<const Rm3>(xdot.data() + o) * Eigen::Map<const Rm3>(x0.data() + o).transpose() +
                                Eigen::Map<const Rm3>(x.data() + o) * Eigen::Map<const Rm3>(xdot0.data() + o).transpose();
      const int a = coords[i].axis;
      z[i] = a == 0 ? s(2, 1) : (a == 1 ? s(0, 2) : s(1, 0));
    }
    return z;
  };
  auto moved = [&](Eigen::Index j, double step) {
    Eigen::VectorXd x = x0;
    if (coords[j].state >= 0) {
      x[coords[j].state] += step;
      return x;
    }
    const int o = coords[j].orientation;
    Eigen::Vector3d axis = Eigen::Vector3d::Zero();
    axis[coords[j].axis] = 1.0;
    const Rm3 r = Eigen::AngleAxisd(step, axis).toRotationMatrix() * Eigen::Map<const Rm3>(x0.data() + o);
    Eigen::Map<Rm3>(x.data() + o) = r;
    return x;
  };
  Eigen::MatrixXd a(nz, nz);
  for (Eigen::Index j = 0; j < nz; ++j) {
    const double step = h * std::max(1.0, std::abs(coords[j].state >= 0 ? x0[coords[j].state] : 0.0));
    a.col(j) = (rates(moved(j, step)) - rates(moved(j, -step))) / (2 * step);
  }
  return a;
}

TEST(LinearExamples, TwoMassModesAreThoseOfTheGeneralizedEigenproblem) {
  const auto model = Compiled("examples/linear/two_mass.yaml");
  const LinearModel lm = Linearize(*model, 0.0, model->MakeInitialState());
  const std::vector<Mode> modes = ComputeModes(lm);
  ASSERT_EQ(modes.size(), 2u);
  // det(K - w^2 M) = 0 with M = diag(1, 2), K = [[150, -50], [-50, 50]]: w^4 - 175 w^2 + 2500 = 0.
  const double d = std::sqrt(175.0 * 175.0 - 4 * 2500.0);
  const double w[2] = {std::sqrt((175.0 - d) / 2), std::sqrt((175.0 + d) / 2)};
  for (int k = 0; k < 2; ++k) {
    EXPECT_NEAR(modes[k].frequency_hz, w[k] / (2 * M_PI), 1e-12 * w[k]);
    EXPECT_EQ(modes[k].damping_ratio, 0.0);
    // Energy participation: with the displacement shape phi (K phi = w^2 M phi), the time-averaged
    // energies are m_i w^2 phi_i^2 / 4 (kinetic) and k (stretch)^2 / 4 (potential), half each in total.
    const double w2 = w[k] * w[k];
    const double phi1 = 1.0, phi2 = (150.0 - w2) / 50.0;  // first row of (K - w^2 M) phi = 0
    const double e_m1 = w2 * phi1 * phi1, e_m2 = 2.0 * w2 * phi2 * phi2, e_k1 = 100.0 * phi1 * phi1,
                 e_k2 = 50.0 * (phi1 - phi2) * (phi1 - phi2), total = e_m1 + e_m2 + e_k1 + e_k2;
    std::map<std::string, double> share(modes[k].participation.begin(), modes[k].participation.end());
    EXPECT_NEAR(share["mass1"], e_m1 / total, 1e-12);
    EXPECT_NEAR(share["mass2"], e_m2 / total, 1e-12);
    EXPECT_NEAR(share["spring1"], e_k1 / total, 1e-12);
    EXPECT_NEAR(share["spring2"], e_k2 / total, 1e-12);
  }
}

TEST(LinearExamples, TransducerAtRestIsTheHandWrittenJacobianWithMaxwellsCrossTerm) {
  // examples/equations/electrostatic_transducer.yaml at its static equilibrium (the file's
  // comment): states q, x (the multiport's charge and gap), p (the plate), y (the spring).
  const auto model = Compiled("examples/equations/electrostatic_transducer.yaml");
  const double eps_a = 8.854e-12 * 0.01, x0 = 1.0e-3, V = 1200.0, Rs = 1.0e5, m = 0.01, k = 1000.0, b = 1.0;
  double lo = 2.0 * x0 / 3.0, hi = x0;  // k (x0 - x) x^2 = eps A V^2 / 2, decreasing on (2 x0 / 3, x0)
  for (int i = 0; i < 200; ++i) (k * (x0 - 0.5 * (lo + hi)) * 0.25 * (lo + hi) * (lo + hi) > eps_a * V * V / 2.0 ? lo : hi) = 0.5 * (lo + hi);
  const double x = 0.5 * (lo + hi), q = eps_a * V / x;
  Eigen::VectorXd state = model->MakeInitialState();
  const std::vector<std::string>& names = model->state_names();
  auto at = [&](const std::string& name) {
    const auto it = std::find(names.begin(), names.end(), name);
    EXPECT_NE(it, names.end()) << name;
    return static_cast<Eigen::Index>(it - names.begin());
  };
  state[at("plates.q.charge")] = q;
  state[at("plates.q.gap")] = x;
  state[at("spring.q")] = x - x0;
  const LinearModel lm = Linearize(*model, 0.0, state);
  const std::vector<std::string> order = {"plates.q.charge", "plates.q.gap", "plate.p", "spring.q"};
  ASSERT_EQ(lm.states, order);
  Eigen::Matrix4d hand = Eigen::Matrix4d::Zero();
  hand(0, 0) = -x / (eps_a * Rs);  // dq/dt = (V - q x / (eps A)) / Rs
  hand(0, 1) = -q / (eps_a * Rs);
  hand(1, 2) = 1.0 / m;            // dx/dt = p / m
  hand(2, 0) = -q / eps_a;         // dp/dt = -q^2 / (2 eps A) - k y - b p / m
  hand(2, 2) = -b / m;
  hand(2, 3) = -k;
  hand(3, 2) = 1.0 / m;            // dy/dt = p / m
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) EXPECT_NEAR(lm.A(i, j), hand(i, j), 1e-12 * hand.row(i).cwiseAbs().maxCoeff()) << i << ", " << j;
  // The multiport's Hessian: d voltage / dx = d force / dq = q / (eps A) (Maxwell), d voltage / dq = x / (eps A), d force / dx = 0.
  const auto plates = std::find_if(lm.storages.begin(), lm.storages.end(), [](const Storage& st) { return st.element == "plates"; });
  ASSERT_NE(plates, lm.storages.end());
  ASSERT_EQ(plates->hessian.rows(), 2);
  EXPECT_NEAR(plates->hessian(0, 0), x / eps_a, 1e-12 * x / eps_a);
  EXPECT_NEAR(plates->hessian(0, 1), q / eps_a, 1e-12 * q / eps_a);
  EXPECT_EQ(plates->hessian(1, 0), plates->hessian(0, 1));
  EXPECT_NEAR(plates->hessian(1, 1), 0.0, 1e-12 * q / eps_a);
  // The slow mode: the plate on the spring softened by the attraction at fixed V, k_eff = k -
  // eps A V^2 / x^3, to within the electrical pole's correction (w0 Rs C = 3e-3 at most).
  const std::vector<Mode> modes = ComputeModes(lm);
  const double k_eff = k - eps_a * V * V / (x * x * x), w0 = std::sqrt(k_eff / m);
  const auto slow = std::find_if(modes.begin(), modes.end(), [](const Mode& md) { return md.conjugate_pair; });
  ASSERT_NE(slow, modes.end());
  EXPECT_NEAR(slow->frequency_hz * 2.0 * M_PI, w0, 1e-5 * w0);  // measured: 7e-7
  EXPECT_NEAR(slow->damping_ratio, b / (2.0 * std::sqrt(k_eff * m)), 3e-3 * slow->damping_ratio);  // measured: 1.5e-3
}

TEST(LinearExamples, ANonlinearLoopLinearisesToItsSmallSignalModel) {
  // examples/equations/diode_charger.yaml at a state where the diode conducts: the loop (Rs and
  // the diode in series) linearises to Rs + rd, rd = n Vt / (i + Is) the diode's dynamic
  // resistance at the loop's current, so d(dq/dt)/dq = -(1/(Rs + rd) + 1/RL) / Cap (the implicit
  // function theorem through the torn loop; linearisation refused such models before).
  const auto model = Compiled("examples/equations/diode_charger.yaml");
  const double V = 5.0, w = 2.0 * M_PI * 50.0, Rs = 10.0, Is = 1e-12, nvt = 0.025852, C = 1e-3, RL = 200.0;
  Eigen::VectorXd x = model->MakeInitialState();
  const auto q = std::find(model->state_names().begin(), model->state_names().end(), "cap.q") - model->state_names().begin();
  const double t = 0.005, v = 4.0;  // the source's crest (5 V), the capacitor at 4 V: the diode conducts
  x[q] = v * C;
  const LinearModel lm = Linearize(*model, t, x);
  ASSERT_EQ(lm.states, std::vector<std::string>{"cap.q"});
  // The loop's current at that state, from u = V sin(w t) - v = Rs i + n Vt ln(1 + i/Is), by bisection.
  const double u = V * std::sin(w * t) - v;
  double lo = 0.0, hi = u / Rs;
  for (int k = 0; k < 200; ++k) (Rs * 0.5 * (lo + hi) + nvt * std::log1p(0.5 * (lo + hi) / Is) < u ? lo : hi) = 0.5 * (lo + hi);
  const double i = 0.5 * (lo + hi), rd = nvt / (i + Is);
  ASSERT_GT(i, 0.01);
  const double expected = -(1.0 / (Rs + rd) + 1.0 / RL) / C;
  EXPECT_NEAR(lm.A(0, 0), expected, 1e-9 * std::abs(expected));
  // And against central differences of the right-hand side (the loop solved at each state).
  const Eigen::MatrixXd fd = CentralDifferenceJacobian(*model, lm, 1e-9);
  EXPECT_NEAR(lm.A(0, 0), fd(0, 0), 1e-6 * std::abs(expected));
}

TEST(LinearExamples, CompliantDifferentialMatchesAnIndependentJacobian) {
  const auto model = Compiled("examples/differential.yaml");
  const LinearModel lm = Linearize(*model, 0.0, model->MakeInitialState());
  ASSERT_GT(lm.states.size(), 100u);
  const Eigen::MatrixXd fd = CentralDifferenceJacobian(*model, lm, 1e-6);
  const double scale = lm.A.cwiseAbs().maxCoeff();
  EXPECT_LT((lm.A - fd).cwiseAbs().maxCoeff(), 1e-6 * scale);  // the differences' own truncation and rounding

  // The modes: the fastest one and the lightly damped oscillations, against the difference
  // Jacobian's eigenvalues, and the storage that carries each.
  const std::vector<Mode> modes = ComputeModes(lm);
  const Eigen::VectorXcd fd_ev = fd.eigenvalues();
  auto nearest = [&](std::complex<double> l) {
    double best = 1e300;
    for (const auto& m : fd_ev) best = std::min(best, std::abs(m - l));
    return best;
  };
  const Mode* fastest = &modes.front();
  int lightly_damped = 0;
  for (const Mode& m : modes) {
    if (std::abs(m.eigenvalue) > std::abs(fastest->eigenvalue)) fastest = &m;
    if (m.conjugate_pair && m.damping_ratio > 0.0 && m.damping_ratio < 0.2 && m.frequency_hz > 1.0) {
      ++lightly_damped;
      EXPECT_LT(nearest(m.eigenvalue), 1e-5 * std::abs(m.eigenvalue)) << m.eigenvalue;
      ASSERT_FALSE(m.participation.empty());
      // An oscillation holds its energy half in the couplings (compliances: bearings, meshes,
      // mounts), half in the bodies' motion (the virial theorem; exact for one degree of freedom
      // at any damping, since |lambda|^2 = k/m): the participation names the couplings.
      double in_couplings = 0.0;
      for (const auto& [element, share] : m.participation)
        if (model->graph().element(model->graph().Find(element)).kind == ElementKind::kC) in_couplings += share;
      EXPECT_NEAR(in_couplings, 0.5, 1e-9) << m.eigenvalue;
    }
  }
  EXPECT_GE(lightly_damped, 3);
  EXPECT_LT(nearest(fastest->eigenvalue), 1e-5 * std::abs(fastest->eigenvalue)) << fastest->eigenvalue;
}

}  // namespace
}  // namespace multibond::linear
