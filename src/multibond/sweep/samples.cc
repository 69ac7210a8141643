// The design of a study: grids, lists, Monte Carlo and Latin hypercube samples.

#include "multibond/sweep/samples.h"

#include <algorithm>
#include <cmath>
#include <random>
#include <stdexcept>

#include <fmt/format.h>
#include <gsl/gsl_cdf.h>

namespace multibond::sweep {

namespace {

/// The values of a grid or list axis.
std::vector<double> AxisValues(const Axis& a) {
  if (a.kind == Axis::Kind::kList) return a.values;
  std::vector<double> v(static_cast<size_t>(a.count));
  for (int i = 0; i < a.count; ++i) {
    const double f = static_cast<double>(i) / (a.count - 1);
    if (a.scale == Axis::Scale::kLog)
      v[i] = a.from * std::pow(a.to / a.from, f);  // exact at whole powers: 100 * 100^0.5 = 1000
    else
      v[i] = a.from + f * (a.to - a.from);
  }
  // The ends exactly as given (from * (to/from)^1 may differ from `to` in the last bit).
  v.front() = a.from;
  v.back() = a.to;
  return v;
}

/// A generator for (seed, stream, index): mt19937_64 seeded with the three words mixed by
/// SplitMix64, so that nearby indices give unrelated sequences.
std::mt19937_64 Generator(std::uint64_t seed, std::uint64_t stream, std::uint64_t index) {
  auto mix = [](std::uint64_t z) {
    z += 0x9E3779B97F4A7C15ULL;
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
    return z ^ (z >> 31);
  };
  return std::mt19937_64(mix(mix(mix(seed) ^ stream) ^ index));
}

}  // namespace

double OpenUnit(std::uint64_t bits) { return (static_cast<double>(bits >> 12) + 0.5) * 0x1p-52; }

double Quantile(const Axis& a, double u) {
  switch (a.distribution) {
    case Axis::Distribution::kUniform: return a.a + u * (a.b - a.a);
    case Axis::Distribution::kLogUniform: return std::exp(std::log(a.a) + u * (std::log(a.b) - std::log(a.a)));
    case Axis::Distribution::kNormal: return a.a + a.b * gsl_cdf_ugaussian_Pinv(u);
    case Axis::Distribution::kLogNormal: return std::exp(a.a + a.b * gsl_cdf_ugaussian_Pinv(u));
  }
  return a.a;
}

long CountRuns(const Study& s) {
  if (s.method != Study::Method::kGrid) return s.samples;
  long n = 1;
  for (const Axis& a : s.axes) {
    const long k = a.kind == Axis::Kind::kList ? static_cast<long>(a.values.size()) : a.count;
    if (k <= 0) return 0;
    if (n > kMaxRuns / k) return kMaxRuns + 1;
    n *= k;
  }
  return n;
}

std::vector<std::vector<double>> Design(const Study& s) {
  const long n = CountRuns(s);
  if (n > kMaxRuns) throw std::invalid_argument(fmt::format("the study has more than {} runs", kMaxRuns));
  const size_t d = s.axes.size();
  std::vector<std::vector<double>> runs(static_cast<size_t>(n), std::vector<double>(d));
  if (s.method == Study::Method::kGrid) {
    std::vector<std::vector<double>> values;
    for (const Axis& a : s.axes) values.push_back(AxisValues(a));
    for (long r = 0; r < n; ++r) {
      long rest = r;
      for (size_t j = d; j-- > 0;) {
        const long k = static_cast<long>(values[j].size());
        runs[r][j] = values[j][rest % k];
        rest /= k;
      }
    }
    return runs;
  }
  // Latin hypercube: per axis, the bin of each run (a permutation drawn from stream axis + 1).
  std::vector<std::vector<long>> bins(d);
  if (s.method == Study::Method::kLatinHypercube)
    for (size_t j = 0; j < d; ++j) {
      bins[j].resize(static_cast<size_t>(n));
      for (long i = 0; i < n; ++i) bins[j][i] = i;
      std::mt19937_64 g = Generator(s.seed, j + 1, 0);
      for (long i = n - 1; i > 0; --i) {  // Fisher-Yates with a bound by multiplication (no modulo bias to speak of)
        const long k = static_cast<long>(OpenUnit(g()) * static_cast<double>(i + 1));
        std::swap(bins[j][i], bins[j][std::min(k, i)]);
      }
    }
  for (long r = 0; r < n; ++r) {
    std::mt19937_64 g = Generator(s.seed, 0, static_cast<std::uint64_t>(r));
    for (size_t j = 0; j < d; ++j) {
      double u = OpenUnit(g());
      if (s.method == Study::Method::kLatinHypercube)
        u = std::min((static_cast<double>(bins[j][r]) + u) / static_cast<double>(n), 1.0 - 0x1p-53);
      runs[r][j] = Quantile(s.axes[j], u);
    }
  }
  return runs;
}

}  // namespace multibond::sweep
