#include "multibond/sim/compare.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <stdexcept>

#include <fmt/format.h>

namespace multibond {

namespace {

void CheckTimeColumn(const std::vector<Column>& columns, const char* run) {
  if (columns.empty() || columns.front().name != "time")
    throw std::invalid_argument(fmt::format("run {} has no 'time' column first: not the columns of a run", run));
}

/// Rows of A and B must be the same instants: same count and the same times (to 1e-9 of the span,
/// which absorbs the last rounding of t = k dt and nothing else).
void CheckSameGrid(const std::vector<std::vector<double>>& a, const std::vector<std::vector<double>>& b) {
  auto describe = [](const std::vector<std::vector<double>>& rows) {
    if (rows.empty()) return std::string("no samples");
    return fmt::format("{} samples from t = {:g} to {:g} s", rows.size(), rows.front().front(), rows.back().front());
  };
  const std::string hint = "both runs need the same output times: give them the same --t-end and --dt";
  if (a.size() != b.size())
    throw std::invalid_argument(fmt::format("the runs have different output grids: A has {}, B has {}; {}", describe(a), describe(b), hint));
  if (a.empty()) return;
  const double span = std::max(std::abs(a.back().front() - a.front().front()), std::abs(a.front().front()));
  const double tol = 1e-9 * (span > 0 ? span : 1.0);
  for (size_t k = 0; k < a.size(); ++k) {
    const double ta = a[k].front(), tb = b[k].front();
    if (!(std::abs(ta - tb) <= tol))
      throw std::invalid_argument(fmt::format("the runs have different output grids: sample {} is at t = {:g} s in A and {:g} s in B; {}",
                                              k, ta, tb, hint));
  }
}

/// NaN first, then larger first; ties by name, so the order is deterministic.
bool LargerFirst(const ColumnComparison& x, const ColumnComparison& y) {
  const bool nx = std::isnan(x.relative), ny = std::isnan(y.relative);
  if (nx != ny) return nx;
  if (!nx && x.relative != y.relative) return x.relative > y.relative;
  return x.name < y.name;
}

}  // namespace

const ColumnComparison* ComparisonReport::Worst() const {
  const ColumnComparison* worst = nullptr;
  for (const auto& c : columns)
    if (!worst || LargerFirst(c, *worst)) worst = &c;
  return worst;
}

ComparisonReport CompareRecordings(const std::vector<Column>& columns_a, const std::vector<std::vector<double>>& rows_a,
                                   const std::vector<Column>& columns_b, const std::vector<std::vector<double>>& rows_b) {
  CheckTimeColumn(columns_a, "A");
  CheckTimeColumn(columns_b, "B");
  for (const auto* rows : {&rows_a, &rows_b})
    for (const auto& row : *rows)
      if (row.size() != (rows == &rows_a ? columns_a : columns_b).size())
        throw std::invalid_argument("a row of a run does not have as many values as the run has columns");
  CheckSameGrid(rows_a, rows_b);

  ComparisonReport r;
  r.samples = static_cast<long>(rows_a.size());
  if (!rows_a.empty()) r.t_first = rows_a.front().front(), r.t_last = rows_a.back().front();

  std::map<std::string, int> in_b;
  for (size_t j = 1; j < columns_b.size(); ++j) in_b.emplace(columns_b[j].name, static_cast<int>(j));
  std::map<std::string, bool> matched;
  for (size_t i = 1; i < columns_a.size(); ++i) {
    const std::string& name = columns_a[i].name;
    const auto it = in_b.find(name);
    if (it == in_b.end()) {
      r.only_in_a.push_back(name);
      continue;
    }
    matched[name] = true;
    const int j = it->second;
    ColumnComparison c;
    c.name = name;
    c.unit = columns_a[i].unit;
    c.unit_b = columns_b[j].unit;
    bool nan = false;
    for (size_t k = 0; k < rows_a.size(); ++k) {
      const double a = rows_a[k][i], b = rows_b[k][j];
      if (!std::isnan(a)) c.scale = std::max(c.scale, std::abs(a));
      if (a == b || (std::isnan(a) && std::isnan(b))) continue;  // equal (also equal infinities, or NaN in both)
      const double d = std::abs(a - b);
      if (std::isnan(d)) {  // NaN in one run only: the largest difference there is
        if (!nan) c.time = rows_a[k].front();
        nan = true;
        continue;
      }
      if (!nan && d > c.max_abs_diff) c.max_abs_diff = d, c.time = rows_a[k].front();
    }
    if (nan) {
      c.max_abs_diff = c.relative = std::numeric_limits<double>::quiet_NaN();
    } else if (c.scale > 0) {
      c.relative = c.max_abs_diff / c.scale;
    } else {
      c.relative = c.max_abs_diff > 0 ? std::numeric_limits<double>::infinity() : 0.0;
    }
    r.columns.push_back(std::move(c));
  }
  for (size_t j = 1; j < columns_b.size(); ++j)
    if (!matched.count(columns_b[j].name)) r.only_in_b.push_back(columns_b[j].name);
  return r;
}

void SortComparison(ComparisonReport& report, ComparisonOrder order) {
  auto& c = report.columns;
  if (order == ComparisonOrder::kName)
    std::stable_sort(c.begin(), c.end(), [](const ColumnComparison& x, const ColumnComparison& y) { return x.name < y.name; });
  else
    std::stable_sort(c.begin(), c.end(), LargerFirst);
}

}  // namespace multibond
