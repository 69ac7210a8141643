// The public Results: a run's columns by name.

#include <algorithm>
#include <stdexcept>

#include "multibond/api/lookup.h"
#include "multibond/multibond.h"

namespace multibond {

Results::Results(std::vector<std::string> names, std::vector<std::string> units, std::vector<std::vector<double>> columns,
                 Summary summary)
    : names_(std::move(names)), units_(std::move(units)), columns_(std::move(columns)), summary_(std::move(summary)) {
  if (names_.size() != columns_.size() || units_.size() != columns_.size())
    throw std::invalid_argument("Results: one name and one unit per column");
}

std::span<const double> Results::column(std::string_view name) const {
  const auto it = std::find(names_.begin(), names_.end(), name);
  if (it == names_.end()) ThrowUnknownName("column", name, names_);
  return columns_[static_cast<size_t>(it - names_.begin())];
}

double Results::At(std::string_view name, double t) const {
  const std::span<const double> v = column(name), time = times();
  if (v.empty()) throw std::invalid_argument("the results have no rows");
  const auto after = std::lower_bound(time.begin(), time.end(), t);
  if (after == time.begin()) return v.front();
  if (after == time.end()) return v.back();
  const size_t k = static_cast<size_t>(after - time.begin());
  const double t0 = time[k - 1], t1 = time[k];
  const double w = t1 > t0 ? (t - t0) / (t1 - t0) : 1.0;
  return v[k - 1] + w * (v[k] - v[k - 1]);
}

}  // namespace multibond
