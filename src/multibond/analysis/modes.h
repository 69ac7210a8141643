#pragma once
/// \file
/// The modes of a linearised model (linear_model.h): the eigenvalues and eigenvectors of A, each
/// with its frequency, damping, shape, the motion of the inertias it makes, and how its stored
/// energy is shared among the storage elements (energy participation).
///
/// Definitions, for an eigenvalue lambda = sigma + i omega_d of A with eigenvector v (z = v e^{lambda t};
/// a pair lambda, conj(lambda) together makes the real motion Re(v e^{lambda t})):
///   frequency_hz         |lambda| / 2 pi (the undamped natural frequency of a pair)
///   damped_frequency_hz  |omega_d| / 2 pi (0 for a real eigenvalue)
///   damping_ratio        -sigma / |lambda|: 0 undamped, 1 for a real negative eigenvalue, -1 for a
///                        real positive one (negative: the mode grows). For lambda = 0 (a rigid-body
///                        or integrator mode, neither decaying nor growing) it is defined as 0.
///   time_constant_s      -1 / sigma: the time in which the amplitude falls by 1/e; +infinity when
///                        sigma = 0 (written null in JSON); negative for a growing mode (its
///                        amplitude grows by e in |time_constant_s|).
///   participation        with dx = basis v (the shape in the full state) and, for each storage
///                        element e, v_e = dx restricted to e's state entries and H_e its energy's
///                        Hessian: E_e = Re(v_e^H H_e v_e). The time-averaged stored energy of the
///                        oscillation Re(v_e e^{i omega t}) in element e is (1/4) v_e^H H_e v_e (the
///                        quadratic energy (1/2) dx^T H dx averaged over a period), so E_e is
///                        proportional to it; for a real eigenvalue it is twice the shape's energy.
///                        share_e = E_e / sum E: the shares sum to 1. A mode that stores no energy
///                        (an integrator's state, a rigid-body position that no storage element
///                        sees: |sum E| <= 1e-12 (sum_e |H_e|_F) |dx|^2, with the shape scaled
///                        as below) has no participation, and stores_energy = false.
///                        With an indefinite Hessian (a law that is not convex at the point, e.g.
///                        an unstable equilibrium) a share may be negative or above 1.
///   shape                v scaled so that its largest component (in modulus; the first of equal
///                        ones) is real and 1.
///   motion               LinearModel::motion * shape: each inertia's flow per unit of the shape.

#include <complex>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Dense>

#include "multibond/analysis/linear_model.h"

namespace multibond::linear {

struct Mode {
  std::complex<double> eigenvalue;  ///< of a pair, the one with Im > 0
  double frequency_hz = 0.0;         ///< |lambda| / 2 pi
  double damped_frequency_hz = 0.0;  ///< |Im lambda| / 2 pi
  double damping_ratio = 0.0;        ///< -Re lambda / |lambda| (0 for lambda = 0)
  double time_constant_s = 0.0;      ///< -1 / Re lambda; +inf when Re lambda = 0
  /// Storage element -> share of the mode's stored energy, largest first; sums to 1. Empty when
  /// the mode stores no energy (stores_energy false).
  std::vector<std::pair<std::string, double>> participation;
  bool stores_energy = false;
  Eigen::VectorXcd shape;                   ///< in z (LinearModel::states), largest component 1
  std::vector<std::complex<double>> motion;  ///< LinearModel::motion_names, per unit shape
  bool conjugate_pair = false;               ///< this mode stands for lambda and conj(lambda)
};

/// The modes of `model`: the eigen-decomposition of A (Eigen::EigenSolver), one Mode per real
/// eigenvalue and one per complex-conjugate pair, sorted by frequency_hz, then by eigenvalue (real
/// part, then imaginary part). A real part within rounding of zero, |Re| <= 8 eps |A|_F, is
/// taken as 0 (an undamped oscillation gets damping 0 and an infinite time constant). An empty `basis` is taken as the identity (z is the full state).
/// Throws std::invalid_argument when the model's sizes disagree (A not square, basis, motion or
/// a storage's states not matching) or A has a value that is not finite, std::runtime_error when
/// the eigen-decomposition fails.
std::vector<Mode> ComputeModes(const LinearModel& model);

/// A table for a terminal, one row per mode in frequency order: eigenvalue, frequency [Hz],
/// damping ratio, time constant [s], and the `max_elements` largest participations
/// ("k1 62%, m2 30%"; "no stored energy" when it has none).
std::string ModesTable(const std::vector<Mode>& modes, int max_elements = 3);

}  // namespace multibond::linear
