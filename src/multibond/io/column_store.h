#pragma once
/// \file
/// The samples of a run kept column by column, for the formats that write whole columns
/// (results.mat, results.h5). The memory is rows x columns x 8 bytes; `expected_rows` (the output
/// grid's size, NumOutputIntervals + 1) is reserved at the start, so a sample is copied without
/// allocating. The output grid is bounded (at most 1e8 rows); a front end bounds the product (the
/// CLI: by the `results-size` limit, before the run, see ColumnStoreBytes).

#include <cstdint>
#include <vector>

#include "multibond/sim/simulator.h"

namespace multibond {

class ColumnStore : public Observer {
 public:
  explicit ColumnStore(long expected_rows = 0) : expected_rows_(expected_rows) {}
  void OnStart(const std::vector<Column>& columns) override;
  void OnSample(const std::vector<double>& row) override;
  void OnFinish(const RunSummary&) override {}

  const std::vector<Column>& columns() const { return columns_; }
  /// Column c's values, one per row.
  const std::vector<double>& values(size_t c) const { return data_[c]; }
  long rows() const { return rows_; }

 private:
  long expected_rows_;
  std::vector<Column> columns_;
  std::vector<std::vector<double>> data_;
  long rows_ = 0;
};

/// The memory a ColumnStore takes for `rows` rows of `columns` columns, in bytes (saturating).
std::uint64_t ColumnStoreBytes(std::uint64_t rows, std::uint64_t columns);

}  // namespace multibond
