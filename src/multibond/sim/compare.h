#pragma once
/// \file
/// Comparing two runs column by column (`multibond compare A.yaml B.yaml`): for every output
/// quantity both runs have (matched by column name), the largest absolute difference over time,
/// when it occurs, the scale of the quantity in run A and the relative difference. Both runs must
/// share one output grid, so that row k of A and row k of B are the same instant.

#include <string>
#include <vector>

#include "multibond/sim/simulator.h"

namespace multibond {

/// The difference of one column between run A and run B.
struct ColumnComparison {
  std::string name;          ///< column name without unit, e.g. "A.omega.z", "spring.q"
  std::string unit;          ///< A's unit
  std::string unit_b;        ///< B's unit (differs from `unit` only if the models disagree)
  double max_abs_diff = 0.0; ///< max over the samples of |a - b|; NaN if a value is NaN in one run only
  double time = 0.0;         ///< the (first) time at which max_abs_diff occurs
  double scale = 0.0;        ///< max over the samples of |a|
  /// max_abs_diff / scale. Guarded: 0 when both are 0, +infinity when A is identically 0 and B
  /// is not (there is no scale to relate the difference to).
  double relative = 0.0;
};

struct ComparisonReport {
  std::vector<ColumnComparison> columns;    ///< columns in both runs, in A's order unless sorted
  std::vector<std::string> only_in_a, only_in_b;  ///< column names present in one run only
  long samples = 0;                         ///< rows compared
  double t_first = 0.0, t_last = 0.0;       ///< the common output grid's first and last time
  /// The column with the largest relative difference (NaN counts as largest), or nullptr.
  const ColumnComparison* Worst() const;
};

/// Compares the columns of two runs (time excluded) on their common output grid. Throws
/// std::invalid_argument if the grids differ (number of samples, or a time that differs by more
/// than 1e-9 of the time span) or if either run has no "time" column first.
ComparisonReport CompareRecordings(const std::vector<Column>& columns_a, const std::vector<std::vector<double>>& rows_a,
                                   const std::vector<Column>& columns_b, const std::vector<std::vector<double>>& rows_b);
inline ComparisonReport CompareRecordings(const RecordingObserver& a, const RecordingObserver& b) {
  return CompareRecordings(a.columns(), a.rows(), b.columns(), b.rows());
}

enum class ComparisonOrder {
  kRelative,  ///< largest relative difference first (NaN first, then +infinity), ties by name
  kName,      ///< by column name
};
void SortComparison(ComparisonReport& report, ComparisonOrder order);

}  // namespace multibond
