#include "multibond/analysis/bode.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>

#include <Eigen/Dense>
#include <fmt/format.h>

namespace multibond::linear {

namespace {

/// `a` in (-pi, pi].
double Wrap(double a) {
  a = std::remainder(a, 2 * std::numbers::pi);  // [-pi, pi]
  return a <= -std::numbers::pi ? a + 2 * std::numbers::pi : a;
}

}  // namespace

std::vector<BodePoint> FrequencyResponse(const LinearModel& m, int input, int output, const std::vector<double>& freqs_hz) {
  const Eigen::Index n = m.A.rows();
  if (m.A.cols() != n || m.B.rows() != n || m.C.cols() != n || m.D.rows() != m.C.rows() || m.D.cols() != m.B.cols())
    throw std::invalid_argument(fmt::format("the model's sizes disagree: A {}x{}, B {}x{}, C {}x{}, D {}x{}", m.A.rows(), m.A.cols(),
                                            m.B.rows(), m.B.cols(), m.C.rows(), m.C.cols(), m.D.rows(), m.D.cols()));
  if (input < 0 || input >= m.B.cols())
    throw std::invalid_argument(fmt::format("input {} out of range: the model has {} inputs", input, m.B.cols()));
  if (output < 0 || output >= m.C.rows())
    throw std::invalid_argument(fmt::format("output {} out of range: the model has {} outputs", output, m.C.rows()));
  for (double f : freqs_hz)
    if (!std::isfinite(f) || f <= 0.0) throw std::invalid_argument(fmt::format("frequency {} Hz: it must be finite and positive", f));

  using Complex = std::complex<double>;
  const Eigen::MatrixXcd A = m.A.cast<Complex>();
  const Eigen::VectorXcd b = m.B.col(input).cast<Complex>();
  const Eigen::RowVectorXcd c = m.C.row(output).cast<Complex>();
  const Complex d = m.D(output, input);
  std::vector<BodePoint> points;
  points.reserve(freqs_hz.size());
  double phase = 0.0, last_arg = 0.0;
  for (size_t k = 0; k < freqs_hz.size(); ++k) {
    const double omega = 2 * std::numbers::pi * freqs_hz[k];
    Complex g = d;
    if (n > 0) {
      Eigen::MatrixXcd M = -A;
      M.diagonal().array() += Complex(0.0, omega);
      const Eigen::PartialPivLU<Eigen::MatrixXcd> lu(M);
      g += (c * lu.solve(b))(0, 0);
    }
    const double arg = std::arg(g);
    phase = k == 0 ? Wrap(arg) : phase + Wrap(arg - last_arg);
    last_arg = arg;
    points.push_back({freqs_hz[k], 20 * std::log10(std::abs(g)), phase * 180 / std::numbers::pi, g});
  }
  return points;
}

std::vector<double> DefaultFrequencies(const LinearModel& m) {
  double lo = 0.01, hi = 100.0;
  if (m.A.rows() > 0 && m.A.rows() == m.A.cols() && m.A.allFinite()) {
    const Eigen::VectorXcd values = m.A.eigenvalues();
    const double largest = values.cwiseAbs().maxCoeff();
    double smallest = largest;
    for (Eigen::Index i = 0; i < values.size(); ++i)
      if (std::abs(values(i)) > 1e-10 * largest) smallest = std::min(smallest, std::abs(values(i)));
    if (largest > 0.0) {
      lo = smallest / (2 * std::numbers::pi) / 10;
      hi = largest / (2 * std::numbers::pi) * 10;
    }
  }
  const double l0 = std::log10(lo), l1 = std::log10(hi);
  const int count = std::min(2000, static_cast<int>(std::ceil((l1 - l0) * 50 - 1e-9)) + 1);
  std::vector<double> f(static_cast<size_t>(count));
  for (int k = 0; k < count; ++k) f[static_cast<size_t>(k)] = std::pow(10.0, l0 + (l1 - l0) * k / (count - 1));
  f.front() = lo;
  f.back() = hi;
  return f;
}

}  // namespace multibond::linear
