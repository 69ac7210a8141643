#include "multibond/analysis/bode.h"

#include <cmath>
#include <complex>
#include <limits>
#include <numbers>
#include <stdexcept>

#include <gtest/gtest.h>

#include "analysis/test_models.h"

namespace multibond::linear {
namespace {

using multibond::testing::MassSpringDamper;
using multibond::testing::TwoMasses;
constexpr double kPi = std::numbers::pi;

/// Force to spring force of m x'' + c x' + k x = F: G(jw) = k / (k - m w^2 + j c w).
std::complex<double> Oscillator(double f, double m = 1, double c = 2, double k = 100) {
  const double w = 2 * kPi * f;
  return k / std::complex<double>(k - m * w * w, c * w);
}

/// The phase of Oscillator in degrees, in (-180, 0]: -atan2(c w, k - m w^2).
double OscillatorPhase(double f, double m = 1, double c = 2, double k = 100) {
  const double w = 2 * kPi * f;
  return -std::atan2(c * w, k - m * w * w) * 180 / kPi;
}

TEST(Bode, OscillatorAtLowFrequencyIsStatic) {
  const LinearModel lm = MassSpringDamper(1, 2, 100);
  // |G|^2 = 1 / ((1 - w^2/100)^2 + (w/50)^2): at 1e-3 Hz that is 3.4e-6 dB above 0 dB; at 1e-4 Hz, 3.4e-8 dB.
  const std::vector<BodePoint> p = FrequencyResponse(lm, 0, 0, {1e-4, 1e-3});
  ASSERT_EQ(p.size(), 2u);
  EXPECT_NEAR(p[0].magnitude_db, 0.0, 1e-6);
  EXPECT_NEAR(p[0].phase_deg, 0.0, 1e-3);
  EXPECT_NEAR(p[1].magnitude_db, 20 * std::log10(std::abs(Oscillator(1e-3))), 1e-12);
  EXPECT_NEAR(p[1].magnitude_db, 3.36e-6, 0.01e-6);
  EXPECT_NEAR(p[1].phase_deg, OscillatorPhase(1e-3), 1e-12);
}

TEST(Bode, OscillatorAtResonanceIsFiveTimesStaticAndMinusNinetyDegrees) {
  const LinearModel lm = MassSpringDamper(1, 2, 100);
  const double fn = 10 / (2 * kPi);
  // G(j wn) = k / (j c wn) = 100 / 20j = -5j.
  const std::vector<BodePoint> p = FrequencyResponse(lm, 0, 0, {fn});
  ASSERT_EQ(p.size(), 1u);
  EXPECT_NEAR(p[0].magnitude_db, 20 * std::log10(5.0), 1e-12);
  EXPECT_NEAR(p[0].magnitude_db, 13.979400086720377, 1e-12);
  EXPECT_NEAR(p[0].phase_deg, -90.0, 1e-12);
  EXPECT_NEAR(std::abs(p[0].value - std::complex<double>(0, -5)), 0.0, 1e-12);
  EXPECT_EQ(p[0].frequency_hz, fn);
}

TEST(Bode, OscillatorPhaseIsContinuousAcrossTheResonanceAndTendsToMinus180) {
  const LinearModel lm = MassSpringDamper(1, 2, 100);
  const std::vector<double> f = DefaultFrequencies(lm);
  const std::vector<BodePoint> p = FrequencyResponse(lm, 0, 0, f);
  ASSERT_EQ(p.size(), f.size());
  for (size_t k = 0; k < p.size(); ++k) {
    SCOPED_TRACE(f[k]);
    EXPECT_NEAR(p[k].magnitude_db, 20 * std::log10(std::abs(Oscillator(f[k]))), 1e-9);
    EXPECT_NEAR(p[k].phase_deg, OscillatorPhase(f[k]), 1e-9);
    if (k > 0) {
      EXPECT_LT(p[k].phase_deg, p[k - 1].phase_deg);
    }
  }
  // High frequency: -180 degrees from above, 180 + phase -> c / (m w) [rad]; falling 40 dB per decade.
  const std::vector<BodePoint> high = FrequencyResponse(lm, 0, 0, {1e3, 1e4, 1e6});
  for (const BodePoint& h : high) {
    EXPECT_GT(h.phase_deg, -180.0);
    EXPECT_NEAR(h.phase_deg, OscillatorPhase(h.frequency_hz), 1e-9);
    // (the relative error of the asymptote is k / (m w^2): 2.5e-6 at 1 kHz)
    if (h.frequency_hz >= 1e4) {
      EXPECT_NEAR((180 + h.phase_deg) * kPi / 180, 2 / (2 * kPi * h.frequency_hz), 1e-6 * 2 / (2 * kPi * h.frequency_hz));
    }
    EXPECT_NEAR(h.magnitude_db, 20 * std::log10(std::abs(Oscillator(h.frequency_hz))), 1e-9);
  }
  EXPECT_NEAR(high[1].magnitude_db - high[2].magnitude_db, 80.0, 1e-6);
}

// Two oscillators in series (the second driven by the first's spring force): G = G1^2, whose
// phase goes from 0 to -360 degrees. Unwrapped, it is twice the single phase all along.
TEST(Bode, PhaseIsUnwrappedPastMinus180) {
  LinearModel lm;
  lm.A = Eigen::MatrixXd::Zero(4, 4);
  lm.A << -2, -100, 0, 0,  //
      1, 0, 0, 0,          //
      0, 100, -2, -100,    //
      0, 0, 1, 0;
  lm.B = Eigen::MatrixXd::Zero(4, 1);
  lm.B(0, 0) = 1;
  lm.C = Eigen::MatrixXd::Zero(1, 4);
  lm.C(0, 3) = 100;
  lm.D = Eigen::MatrixXd::Zero(1, 1);
  const std::vector<double> f = DefaultFrequencies(lm);
  const std::vector<BodePoint> p = FrequencyResponse(lm, 0, 0, f);
  for (size_t k = 0; k < p.size(); ++k) {
    SCOPED_TRACE(f[k]);
    EXPECT_NEAR(p[k].phase_deg, 2 * OscillatorPhase(f[k]), 1e-8);
    EXPECT_NEAR(p[k].magnitude_db, 40 * std::log10(std::abs(Oscillator(f[k]))), 1e-9);
  }
  EXPECT_LT(p.back().phase_deg, -350.0);
}

TEST(Bode, FeedthroughAndChoiceOfInputAndOutput) {
  // Two inputs, two outputs: output 1 = 3 u1 + 2 x with x' = -x + u0 ... only D reaches from u1.
  LinearModel lm;
  lm.A = Eigen::MatrixXd::Constant(1, 1, -1.0);
  lm.B = Eigen::MatrixXd::Zero(1, 2);
  lm.B(0, 0) = 1;
  lm.C = Eigen::MatrixXd::Zero(2, 1);
  lm.C(1, 0) = 2;
  lm.D = Eigen::MatrixXd::Zero(2, 2);
  lm.D(1, 1) = -3;
  // u1 -> y1: the constant -3 (phase 180, in (-180, 180]).
  std::vector<BodePoint> p = FrequencyResponse(lm, 1, 1, {0.1, 10});
  EXPECT_NEAR(p[0].magnitude_db, 20 * std::log10(3.0), 1e-12);
  EXPECT_EQ(p[0].phase_deg, 180.0);
  EXPECT_EQ(p[1].phase_deg, 180.0);
  // u0 -> y1: 2 / (1 + j w).
  const double w = 2 * kPi * 0.1;
  p = FrequencyResponse(lm, 0, 1, {0.1});
  EXPECT_NEAR(std::abs(p[0].value - 2.0 / std::complex<double>(1, w)), 0.0, 1e-14);
  EXPECT_NEAR(p[0].phase_deg, -std::atan(w) * 180 / kPi, 1e-12);
  // A pure feedthrough model (no states).
  LinearModel gain;
  gain.A.resize(0, 0);
  gain.B.resize(0, 1);
  gain.C.resize(1, 0);
  gain.D = Eigen::MatrixXd::Constant(1, 1, 10.0);
  p = FrequencyResponse(gain, 0, 0, {1.0});
  EXPECT_NEAR(p[0].magnitude_db, 20.0, 1e-12);
}

TEST(Bode, RefusesBadFrequenciesAndIndices) {
  const LinearModel lm = MassSpringDamper();
  for (double bad : {0.0, -1.0, std::numeric_limits<double>::infinity(), std::numeric_limits<double>::quiet_NaN()})
    EXPECT_THROW(FrequencyResponse(lm, 0, 0, {1.0, bad}), std::invalid_argument) << bad;
  EXPECT_THROW(FrequencyResponse(lm, 1, 0, {1.0}), std::invalid_argument);
  EXPECT_THROW(FrequencyResponse(lm, -1, 0, {1.0}), std::invalid_argument);
  EXPECT_THROW(FrequencyResponse(lm, 0, 1, {1.0}), std::invalid_argument);
  LinearModel wrong = lm;
  wrong.C.resize(1, 3);
  EXPECT_THROW(FrequencyResponse(wrong, 0, 0, {1.0}), std::invalid_argument);
  EXPECT_TRUE(FrequencyResponse(lm, 0, 0, {}).empty());
}

void ExpectLogGrid(const std::vector<double>& f, double lo, double hi, size_t count) {
  ASSERT_EQ(f.size(), count);
  EXPECT_NEAR(f.front(), lo, 1e-12 * lo);
  EXPECT_NEAR(f.back(), hi, 1e-12 * hi);
  const double ratio = std::pow(hi / lo, 1.0 / static_cast<double>(count - 1));
  for (size_t k = 1; k < f.size(); ++k) EXPECT_NEAR(f[k] / f[k - 1], ratio, 1e-12);
}

TEST(Bode, DefaultFrequenciesCoverTheModesWithFiftyPointsPerDecade) {
  // |lambda| = 10: a decade either side of 10 / 2 pi Hz, two decades, 101 points.
  ExpectLogGrid(DefaultFrequencies(MassSpringDamper()), 1 / (2 * kPi), 100 / (2 * kPi), 101);
  // Two masses: w^2 = 15.69... and 159.3...; log10(10 w2 / (w1 / 10)) = 2.503 decades -> 127 points.
  const double b = 350, disc = std::sqrt(b * b - 4 * 2 * 5000);
  const double w1 = std::sqrt((b - disc) / 4), w2 = std::sqrt((b + disc) / 4);
  const double decades = std::log10(100 * w2 / w1);
  const auto count = static_cast<size_t>(std::ceil(decades * 50)) + 1;
  EXPECT_EQ(count, 127u);
  ExpectLogGrid(DefaultFrequencies(TwoMasses()), w1 / (2 * kPi) / 10, w2 / (2 * kPi) * 10, count);
}

TEST(Bode, DefaultFrequenciesIgnoreZeroEigenvalues) {
  LinearModel lm;
  lm.A = Eigen::MatrixXd::Zero(3, 3);
  lm.A(1, 1) = -1e-12;  // below 1e-10 of the largest: a zero
  lm.A(2, 2) = -2 * kPi;
  ExpectLogGrid(DefaultFrequencies(lm), 0.1, 10, 101);
  // Nothing but zeros (a free mass), or no states: 0.01 to 100 Hz.
  lm.A = Eigen::MatrixXd::Zero(2, 2);
  lm.A(1, 0) = 1;
  ExpectLogGrid(DefaultFrequencies(lm), 0.01, 100, 201);
  ExpectLogGrid(DefaultFrequencies(LinearModel{}), 0.01, 100, 201);
}

}  // namespace
}  // namespace multibond::linear
