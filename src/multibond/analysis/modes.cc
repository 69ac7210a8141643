#include "multibond/analysis/modes.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>

#include <fmt/format.h>

#include "multibond/io/safe_text.h"

namespace multibond::linear {

namespace {

void CheckSizes(const LinearModel& m) {
  const Eigen::Index n = m.A.rows();
  if (m.A.cols() != n) throw std::invalid_argument(fmt::format("A is {}x{}, not square", m.A.rows(), m.A.cols()));
  if (!m.A.allFinite()) throw std::invalid_argument("A has a value that is not finite");
  if (m.basis.size() != 0 && m.basis.cols() != n)
    throw std::invalid_argument(fmt::format("basis has {} columns for {} states", m.basis.cols(), n));
  const Eigen::Index full = m.basis.size() != 0 ? m.basis.rows() : n;
  for (const Storage& s : m.storages) {
    const auto k = static_cast<Eigen::Index>(s.states.size());
    if (s.hessian.rows() != k || s.hessian.cols() != k)
      throw std::invalid_argument(fmt::format("storage '{}': Hessian is {}x{} for {} states", MessageText(s.element), s.hessian.rows(),
                                              s.hessian.cols(), k));
    for (int i : s.states)
      if (i < 0 || i >= full) throw std::invalid_argument(fmt::format("storage '{}': state index {} out of range", MessageText(s.element), i));
  }
  if (m.motion.size() != 0 && (m.motion.cols() != n || m.motion.rows() != static_cast<Eigen::Index>(m.motion_names.size())))
    throw std::invalid_argument(fmt::format("motion is {}x{} for {} motions and {} states", m.motion.rows(), m.motion.cols(),
                                            m.motion_names.size(), n));
}

/// Energy participation (see the header); sets mode.participation and mode.stores_energy.
void Participation(const LinearModel& m, Mode& mode) {
  const Eigen::VectorXcd full = m.basis.size() != 0 ? Eigen::VectorXcd(m.basis.cast<std::complex<double>>() * mode.shape) : mode.shape;
  std::vector<double> energy(m.storages.size());
  double sum = 0.0, scale = 0.0;
  for (size_t e = 0; e < m.storages.size(); ++e) {
    const Storage& s = m.storages[e];
    Eigen::VectorXcd ve(static_cast<Eigen::Index>(s.states.size()));
    for (size_t k = 0; k < s.states.size(); ++k) ve(static_cast<Eigen::Index>(k)) = full(s.states[k]);
    energy[e] = (ve.adjoint() * s.hessian.cast<std::complex<double>>() * ve)(0, 0).real();
    sum += energy[e];
    scale += s.hessian.norm();
  }
  // What the sum is compared with to tell "no stored energy": the energy the whole shape would
  // have if every entry were in every storage element (the sum of |H_e| times |dx|^2). A shape
  // that the storage elements see only through rounding (the second, numerically parallel
  // eigenvector of a defective zero eigenvalue) has a sum ~1e-32 times that.
  scale *= full.squaredNorm();
  mode.participation.clear();
  mode.stores_energy = scale > 0.0 && std::abs(sum) > 1e-12 * scale;
  if (!mode.stores_energy) return;
  for (size_t e = 0; e < m.storages.size(); ++e) mode.participation.emplace_back(m.storages[e].element, energy[e] / sum);
  std::stable_sort(mode.participation.begin(), mode.participation.end(),
                   [](const auto& a, const auto& b) { return a.second > b.second; });
}

Mode MakeMode(const LinearModel& m, std::complex<double> lambda, Eigen::VectorXcd v) {
  Mode mode;
  mode.eigenvalue = lambda;
  mode.conjugate_pair = lambda.imag() != 0.0;
  const double r = std::abs(lambda);
  mode.frequency_hz = r / (2 * std::numbers::pi);
  mode.damped_frequency_hz = std::abs(lambda.imag()) / (2 * std::numbers::pi);
  mode.damping_ratio = r > 0.0 ? 0.0 - lambda.real() / r : 0.0;  // 0 - (+0) is +0: an undamped mode prints 0, not -0
  mode.time_constant_s = lambda.real() != 0.0 ? -1.0 / lambda.real() : std::numeric_limits<double>::infinity();
  Eigen::Index big = 0;
  for (Eigen::Index i = 1; i < v.size(); ++i)
    if (std::abs(v(i)) > std::abs(v(big))) big = i;
  if (v.size() > 0 && std::abs(v(big)) > 0.0) v /= v(big);
  if (v.size() > 0) v(big) = 1.0;  // exactly
  mode.shape = std::move(v);
  if (m.motion.size() != 0) {
    const Eigen::VectorXcd motion = m.motion.cast<std::complex<double>>() * mode.shape;
    mode.motion.assign(motion.data(), motion.data() + motion.size());
  }
  Participation(m, mode);
  return mode;
}

}  // namespace

std::vector<Mode> ComputeModes(const LinearModel& model) {
  CheckSizes(model);
  std::vector<Mode> modes;
  if (model.A.rows() == 0) return modes;
  const Eigen::EigenSolver<Eigen::MatrixXd> solver(model.A, true);
  if (solver.info() != Eigen::Success) throw std::runtime_error("the eigen-decomposition of A did not converge");
  const Eigen::VectorXcd& values = solver.eigenvalues();
  const Eigen::MatrixXcd vectors = solver.eigenvectors();
  // EigenSolver gives a real eigenvalue an imaginary part of exactly 0 (a 1x1 block of the real
  // Schur form) and a complex pair as exact conjugates: one mode per real one and per Im > 0.
  // A real part within rounding of 0 (an undamped oscillation) is 0: no spurious growth or decay.
  const double zero = 8 * std::numeric_limits<double>::epsilon() * model.A.norm();
  for (Eigen::Index i = 0; i < values.size(); ++i) {
    if (values(i).imag() < 0.0) continue;
    const std::complex<double> lambda(std::abs(values(i).real()) <= zero ? 0.0 : values(i).real(), values(i).imag());
    modes.push_back(MakeMode(model, lambda, vectors.col(i)));
  }
  std::stable_sort(modes.begin(), modes.end(), [](const Mode& a, const Mode& b) {
    if (a.frequency_hz != b.frequency_hz) return a.frequency_hz < b.frequency_hz;
    if (a.eigenvalue.real() != b.eigenvalue.real()) return a.eigenvalue.real() < b.eigenvalue.real();
    return a.eigenvalue.imag() < b.eigenvalue.imag();
  });
  return modes;
}

std::string ModesTable(const std::vector<Mode>& modes, int max_elements) {
  std::string out = fmt::format("{:>4}  {:>28}  {:>14}  {:>10}  {:>14}  {}\n", "mode", "eigenvalue [1/s]", "frequency [Hz]", "damping",
                                "time const [s]", "energy participation");
  for (size_t k = 0; k < modes.size(); ++k) {
    const Mode& m = modes[k];
    const std::string eig = m.conjugate_pair ? fmt::format("{:.6g} +/- {:.6g}i", m.eigenvalue.real(), m.eigenvalue.imag())
                                             : fmt::format("{:.6g}", m.eigenvalue.real());
    const std::string tau = std::isinf(m.time_constant_s) ? "inf" : fmt::format("{:.6g}", m.time_constant_s);
    std::string part;
    if (!m.stores_energy) {
      part = "no stored energy";
    } else {
      for (size_t e = 0; e < m.participation.size() && static_cast<int>(e) < max_elements; ++e)
        part += fmt::format("{}{} {:.0f}%", e ? ", " : "", MessageText(m.participation[e].first), 100 * m.participation[e].second);
    }
    out += fmt::format("{:>4}  {:>28}  {:>14.6g}  {:>10.4g}  {:>14}  {}\n", k + 1, eig, m.frequency_hz, m.damping_ratio, tau, part);
  }
  return out;
}

}  // namespace multibond::linear
