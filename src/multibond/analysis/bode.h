#pragma once
/// \file
/// Frequency response of a linearised model (linear_model.h) from one input to one output:
///   G(j omega) = C (j omega I - A)^-1 B + D,   omega = 2 pi f,
/// for the input's column of B and D and the output's row of C and D.

#include <complex>
#include <vector>

#include "multibond/analysis/linear_model.h"

namespace multibond::linear {

struct BodePoint {
  double frequency_hz = 0.0;
  double magnitude_db = 0.0;   ///< 20 log10 |G| (-inf where G = 0)
  double phase_deg = 0.0;      ///< arg G, unwrapped continuously along the grid
  std::complex<double> value;  ///< G(j 2 pi f)
};

/// G at each of `freqs_hz` [Hz], in the order given, from input `input` (index into
/// LinearModel::inputs) to output `output` (index into LinearModel::outputs). The system
/// (j omega I - A) x = B e_input is solved by a complex LU with partial pivoting at each frequency.
/// The phase starts in (-180, 180] at the first frequency; each next one differs from the one
/// before by less than 180 degrees in magnitude (it is unwrapped), so the grid must be fine
/// enough to follow the phase (DefaultFrequencies is). At a frequency where j omega is an
/// eigenvalue of A (an undamped resonance hit exactly) the values are not finite.
/// Throws std::invalid_argument for an index out of range, model sizes that disagree, or a
/// frequency that is not finite and positive.
std::vector<BodePoint> FrequencyResponse(const LinearModel& model, int input, int output, const std::vector<double>& freqs_hz);

/// A logarithmic grid of frequencies [Hz] covering the modes: from a decade below the smallest
/// nonzero |lambda| / 2 pi of A to a decade above the largest, 50 points per decade (at most 2000
/// points; a wider span gets fewer per decade), both ends included. Eigenvalues below 1e-10 times
/// the largest modulus count as zero (rigid-body and integrator modes). 0.01 to 100 Hz when A has
/// no nonzero eigenvalue.
std::vector<double> DefaultFrequencies(const LinearModel& model);

}  // namespace multibond::linear
