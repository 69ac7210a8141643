#include "multibond/io/column_store.h"

#include <limits>

namespace multibond {

void ColumnStore::OnStart(const std::vector<Column>& columns) {
  columns_ = columns;
  data_.assign(columns.size(), {});
  for (std::vector<double>& d : data_) d.reserve(static_cast<size_t>(expected_rows_ > 0 ? expected_rows_ : 0));
  rows_ = 0;
}

void ColumnStore::OnSample(const std::vector<double>& row) {
  for (size_t c = 0; c < data_.size(); ++c) data_[c].push_back(c < row.size() ? row[c] : std::numeric_limits<double>::quiet_NaN());
  ++rows_;
}

std::uint64_t ColumnStoreBytes(std::uint64_t rows, std::uint64_t columns) {
  constexpr std::uint64_t kMax = std::numeric_limits<std::uint64_t>::max();
  if (columns != 0 && rows > kMax / 8 / columns) return kMax;
  return rows * columns * 8;
}

}  // namespace multibond
