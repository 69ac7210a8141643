#pragma once
/// \file
/// The runs of a study: the value of every swept parameter in every run, drawn once, up front and
/// the same on every thread and rank. A grid is the Cartesian product of its axes (the first axis
/// varies slowest); Monte Carlo draws each run from its own generator, seeded from the study's
/// seed and the run's index (so a run's values depend on nothing else); a Latin hypercube
/// stratifies each axis into `samples` equal-probability bins, one sample per bin, the bins'
/// order a permutation drawn from the seed. Distributions map a uniform number through their
/// inverse distribution function (GSL's), so the hypercube's strata are strata of probability.

#include <cstdint>
#include <vector>

#include "multibond/sweep/study.h"

namespace multibond::sweep {

/// Most runs a study may have (a grid's product of counts, or `samples`).
inline constexpr long kMaxRuns = 10'000'000;

/// The number of runs of the study (a grid: the product of its axes' sizes, at most kMaxRuns + 1).
long CountRuns(const Study& study);
/// The runs: Design(study)[run][axis]. Throws std::invalid_argument beyond kMaxRuns.
std::vector<std::vector<double>> Design(const Study& study);

/// A number in (0, 1), never 0 nor 1: the middle of one of 2^52 equal bins, from the high bits of `bits`.
double OpenUnit(std::uint64_t bits);
/// The value of `axis` (a distribution) at probability u in (0, 1).
double Quantile(const Axis& axis, double u);

}  // namespace multibond::sweep
