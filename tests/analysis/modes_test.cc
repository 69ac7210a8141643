#include "multibond/analysis/modes.h"

#include <algorithm>
#include <cmath>
#include <complex>
#include <limits>
#include <map>
#include <numbers>
#include <stdexcept>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "analysis/test_models.h"

namespace multibond::linear {
namespace {

using multibond::testing::MassSpringDamper;
using multibond::testing::TwoMasses;
constexpr double kPi = std::numbers::pi;

std::map<std::string, double> Shares(const Mode& m) {
  std::map<std::string, double> s;
  for (const auto& [e, v] : m.participation) s[e] = v;
  return s;
}

// Two masses, undamped. With displacements x = (x1, x2): M = diag(m1, m2), K = [[k1 + k2, -k2],
// [-k2, k2]]; the squares of the eigenfrequencies s = w^2 solve det(K - s M) = 0:
//   m1 m2 s^2 - (m1 k2 + m2 (k1 + k2)) s + k1 k2 = 0,
// and the shape is phi = (k2, k1 + k2 - s m1) (the first row of (K - s M) phi = 0). In the motion
// x = phi cos(w t), time-averaged: mass i holds (1/4) m_i w^2 phi_i^2, spring 1 (1/4) k1 phi_1^2,
// spring 2 (1/4) k2 (phi_2 - phi_1)^2; the total is (1/4)(w^2 phi'M phi + phi'K phi) =
// (1/2) phi'K phi, since w^2 phi'M phi = phi'K phi. So mass i's share is m_i w^2 phi_i^2 / (2 phi'K phi),
// spring 1's k1 phi_1^2 / (2 phi'K phi), spring 2's k2 (phi_2 - phi_1)^2 / (2 phi'K phi).
TEST(Modes, TwoMassesFrequenciesAndParticipationsMatchTheGeneralizedEigenproblem) {
  const double m1 = 1, m2 = 2, k1 = 100, k2 = 50;
  const std::vector<Mode> modes = ComputeModes(TwoMasses(m1, m2, k1, k2));
  ASSERT_EQ(modes.size(), 2u);
  const double b = m1 * k2 + m2 * (k1 + k2), disc = std::sqrt(b * b - 4 * m1 * m2 * k1 * k2);
  const double s[2] = {(b - disc) / (2 * m1 * m2), (b + disc) / (2 * m1 * m2)};
  for (int i = 0; i < 2; ++i) {
    SCOPED_TRACE(i);
    const Mode& mode = modes[static_cast<size_t>(i)];
    const double w = std::sqrt(s[i]);
    EXPECT_NEAR(mode.frequency_hz, w / (2 * kPi), 1e-12 * w);
    EXPECT_NEAR(mode.damped_frequency_hz, w / (2 * kPi), 1e-12 * w);
    EXPECT_NEAR(mode.eigenvalue.imag(), w, 1e-12 * w);
    // Undamped: exactly (the real part is within rounding of 0).
    EXPECT_EQ(mode.damping_ratio, 0.0);
    EXPECT_EQ(mode.time_constant_s, std::numeric_limits<double>::infinity());
    EXPECT_TRUE(mode.conjugate_pair);
    ASSERT_TRUE(mode.stores_energy);

    const double phi1 = k2, phi2 = k1 + k2 - s[i] * m1;
    const double phiKphi = k1 * phi1 * phi1 + k2 * (phi2 - phi1) * (phi2 - phi1);
    std::map<std::string, double> share = Shares(mode);
    ASSERT_EQ(share.size(), 4u);
    EXPECT_NEAR(share["m1"], m1 * s[i] * phi1 * phi1 / (2 * phiKphi), 1e-12);
    EXPECT_NEAR(share["m2"], m2 * s[i] * phi2 * phi2 / (2 * phiKphi), 1e-12);
    EXPECT_NEAR(share["k1"], k1 * phi1 * phi1 / (2 * phiKphi), 1e-12);
    EXPECT_NEAR(share["k2"], k2 * (phi2 - phi1) * (phi2 - phi1) / (2 * phiKphi), 1e-12);
    EXPECT_NEAR(share["m1"] + share["m2"] + share["k1"] + share["k2"], 1.0, 1e-12);
    // Virial: half kinetic, half potential.
    EXPECT_NEAR(share["m1"] + share["m2"], 0.5, 1e-12);
    // Largest first.
    for (size_t e = 1; e < mode.participation.size(); ++e) EXPECT_GE(mode.participation[e - 1].second, mode.participation[e].second);

    // The shape: q1 = x1, q2 = x2 - x1 (in phase), and the velocities of the masses are in the
    // ratio of the displacements.
    ASSERT_EQ(mode.shape.size(), 4);
    const std::complex<double> q1 = mode.shape(2), q2 = mode.shape(3);
    EXPECT_NEAR(std::abs(q2 / q1 - (phi2 - phi1) / phi1), 0.0, 1e-12 * std::abs((phi2 - phi1) / phi1) + 1e-12);
    ASSERT_EQ(mode.motion.size(), 2u);
    EXPECT_NEAR(std::abs(mode.motion[1] / mode.motion[0] - phi2 / phi1), 0.0, 1e-12 * std::abs(phi2 / phi1));
    // The velocity leads the displacement by 90 degrees: v = i w x.
    EXPECT_NEAR(std::abs(mode.motion[0] / q1 - std::complex<double>(0, w)), 0.0, 1e-12 * w);
    // Normalised: the largest component is exactly 1.
    Eigen::Index big = 0;
    mode.shape.cwiseAbs().maxCoeff(&big);
    EXPECT_EQ(mode.shape(big), std::complex<double>(1.0, 0.0));
  }
}

TEST(Modes, MassSpringDamperEigenvalueDampingAndTimeConstant) {
  const std::vector<Mode> modes = ComputeModes(MassSpringDamper(1, 2, 100));
  ASSERT_EQ(modes.size(), 1u);
  const Mode& m = modes[0];
  EXPECT_TRUE(m.conjugate_pair);
  EXPECT_NEAR(m.eigenvalue.real(), -1.0, 1e-12);
  EXPECT_NEAR(m.eigenvalue.imag(), std::sqrt(99.0), 1e-12);
  EXPECT_NEAR(m.damping_ratio, 0.1, 1e-13);
  EXPECT_NEAR(m.frequency_hz, 10 / (2 * kPi), 1e-13);
  EXPECT_NEAR(m.damped_frequency_hz, std::sqrt(99.0) / (2 * kPi), 1e-13);
  EXPECT_NEAR(m.time_constant_s, 1.0, 1e-12);
  // v = (lambda m, 1) in (p, q): the mass holds m |lambda|^2 = k = 100, the spring k = 100.
  ASSERT_TRUE(m.stores_energy);
  std::map<std::string, double> share = Shares(m);
  EXPECT_NEAR(share["m"], 0.5, 1e-12);
  EXPECT_NEAR(share["k"], 0.5, 1e-12);
  // |p| = |lambda| |q| = 10 |q|: p is the largest component, 1; q = 1 / lambda.
  EXPECT_EQ(m.shape(0), std::complex<double>(1.0, 0.0));
  EXPECT_NEAR(std::abs(m.shape(1) - 1.0 / m.eigenvalue), 0.0, 1e-14);
}

// The same oscillator in coordinates z = (p, q/2): basis = diag(1, 2) maps z back to (p, q).
// Without the basis, the spring's energy would be a quarter of what it is.
TEST(Modes, ParticipationUsesTheBasisToTheFullState) {
  linear::LinearModel lm = MassSpringDamper(1, 2, 100);
  lm.states = {"m.p", "k.q/2"};
  lm.A << -2, -200,  //
      0.5, 0;
  lm.basis = Eigen::MatrixXd::Zero(2, 2);
  lm.basis(0, 0) = 1;
  lm.basis(1, 1) = 2;
  const std::vector<Mode> modes = ComputeModes(lm);
  ASSERT_EQ(modes.size(), 1u);
  std::map<std::string, double> share = Shares(modes[0]);
  EXPECT_NEAR(share["m"], 0.5, 1e-12);
  EXPECT_NEAR(share["k"], 0.5, 1e-12);
  EXPECT_NEAR(modes[0].damping_ratio, 0.1, 1e-13);
}

TEST(Modes, OverdampedOscillatorHasTwoRealModesSortedByFrequency) {
  // c = 30: lambda = -15 -+ sqrt(125).
  const std::vector<Mode> modes = ComputeModes(MassSpringDamper(1, 30, 100));
  ASSERT_EQ(modes.size(), 2u);
  const double slow = -15 + std::sqrt(125.0), fast = -15 - std::sqrt(125.0);
  EXPECT_NEAR(modes[0].eigenvalue.real(), slow, 1e-12);
  EXPECT_NEAR(modes[1].eigenvalue.real(), fast, 1e-12);
  for (const Mode& m : modes) {
    EXPECT_EQ(m.eigenvalue.imag(), 0.0);
    EXPECT_FALSE(m.conjugate_pair);
    EXPECT_DOUBLE_EQ(m.damping_ratio, 1.0);
    EXPECT_EQ(m.damped_frequency_hz, 0.0);
    EXPECT_NEAR(m.time_constant_s, -1 / m.eigenvalue.real(), 1e-14);
    EXPECT_EQ(m.shape.imag().cwiseAbs().maxCoeff(), 0.0);
    // Real shape v = (lambda, 1): mass lambda^2, spring k.
    const double l2 = m.eigenvalue.real() * m.eigenvalue.real();
    std::map<std::string, double> share = Shares(m);
    EXPECT_NEAR(share["m"], l2 / (l2 + 100), 1e-12);
    EXPECT_NEAR(share["k"], 100 / (l2 + 100), 1e-12);
  }
}

TEST(Modes, GrowingModeHasNegativeDampingAndTimeConstant) {
  linear::LinearModel lm;
  lm.states = {"x"};
  lm.A = Eigen::MatrixXd::Constant(1, 1, 2.0);
  const std::vector<Mode> modes = ComputeModes(lm);
  ASSERT_EQ(modes.size(), 1u);
  EXPECT_EQ(modes[0].damping_ratio, -1.0);
  EXPECT_EQ(modes[0].time_constant_s, -0.5);
  EXPECT_FALSE(modes[0].stores_energy);
}

TEST(Modes, ModesWithoutStoredEnergyHaveNoParticipation) {
  // A free mass: p' = 0, q' = p / m. Both eigenvalues are 0; the eigenvector is a pure position,
  // which no storage element sees.
  linear::LinearModel lm;
  lm.states = {"m.p", "x"};
  lm.A = Eigen::MatrixXd::Zero(2, 2);
  lm.A(1, 0) = 0.5;
  lm.storages = {{"m", {0}, Eigen::MatrixXd::Constant(1, 1, 0.5)}};
  const std::vector<Mode> modes = ComputeModes(lm);
  ASSERT_EQ(modes.size(), 2u);
  for (const Mode& m : modes) {
    EXPECT_EQ(m.eigenvalue, std::complex<double>(0, 0));
    EXPECT_EQ(m.damping_ratio, 0.0);
    EXPECT_EQ(m.frequency_hz, 0.0);
    EXPECT_EQ(m.time_constant_s, std::numeric_limits<double>::infinity());
    EXPECT_FALSE(m.stores_energy);
    EXPECT_TRUE(m.participation.empty());
  }
  const std::string table = ModesTable(modes);
  EXPECT_NE(table.find("no stored energy"), std::string::npos) << table;
  EXPECT_NE(table.find("inf"), std::string::npos) << table;
}

TEST(Modes, TableListsTheLargestParticipationsInFrequencyOrder) {
  const std::vector<Mode> modes = ComputeModes(TwoMasses());
  const std::string table = ModesTable(modes, 2);
  // Header and one row per mode.
  EXPECT_EQ(std::count(table.begin(), table.end(), '\n'), 3) << table;
  const size_t row1 = table.find('\n') + 1, row2 = table.find('\n', row1) + 1;
  const std::string first = table.substr(row1, row2 - row1);
  // The slow mode: the masses move together, k1 and m2 hold most.
  const auto& p = modes[0].participation;
  EXPECT_NE(first.find(fmt::format("{} {:.0f}%, {} {:.0f}%", p[0].first, 100 * p[0].second, p[1].first, 100 * p[1].second)), std::string::npos)
      << table;
  EXPECT_EQ(first.find(p[2].first + " "), std::string::npos) << table;  // only two shown
  EXPECT_NE(first.find(fmt::format("{:.6g}", modes[0].frequency_hz)), std::string::npos) << table;
  EXPECT_NE(table.find("+/-"), std::string::npos);
}

TEST(Modes, TableShowsNoControlCharactersFromNames) {
  linear::LinearModel lm = MassSpringDamper();
  lm.storages[0].element = "m\x1b[31m";
  const std::string table = ModesTable(ComputeModes(lm));
  EXPECT_EQ(table.find('\x1b'), std::string::npos);
  EXPECT_NE(table.find("\\x1b"), std::string::npos) << table;
}

TEST(Modes, RefusesModelsWhoseSizesDisagree) {
  linear::LinearModel lm = MassSpringDamper();
  lm.storages[1].states = {5};
  EXPECT_THROW(ComputeModes(lm), std::invalid_argument);
  lm = MassSpringDamper();
  lm.A.resize(2, 3);
  lm.A.setZero();
  EXPECT_THROW(ComputeModes(lm), std::invalid_argument);
  lm = MassSpringDamper();
  lm.basis = Eigen::MatrixXd::Identity(3, 3);
  EXPECT_THROW(ComputeModes(lm), std::invalid_argument);
  lm = MassSpringDamper();
  lm.A(0, 0) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(ComputeModes(lm), std::invalid_argument);
}

TEST(Modes, EmptyModelHasNoModes) { EXPECT_TRUE(ComputeModes(linear::LinearModel{}).empty()); }

}  // namespace
}  // namespace multibond::linear
