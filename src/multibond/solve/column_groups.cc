#include "multibond/solve/column_groups.h"

#include <algorithm>

namespace multibond {

ColumnGroups GroupColumns(const JacobianPattern& p) {
  const int n = p.n;
  // Rows to columns (the pattern's transpose).
  std::vector<int> row_start(n + 1, 0), row_column(p.row_index.size());
  for (int i : p.row_index) ++row_start[i + 1];
  for (int i = 0; i < n; ++i) row_start[i + 1] += row_start[i];
  std::vector<int> next(row_start.begin(), row_start.end() - 1);
  for (int j = 0; j < n; ++j)
    for (int k = p.col_start[j]; k < p.col_start[j + 1]; ++k) row_column[next[p.row_index[k]]++] = j;

  std::vector<int> group(n, -1), taken_by(n, -1);  // taken_by[g] == j: group g conflicts with column j
  int groups = 0;
  for (int j = 0; j < n; ++j) {
    for (int k = p.col_start[j]; k < p.col_start[j + 1]; ++k) {
      const int i = p.row_index[k];
      for (int r = row_start[i]; r < row_start[i + 1]; ++r)
        if (group[row_column[r]] >= 0) taken_by[group[row_column[r]]] = j;
    }
    int g = 0;
    while (g < groups && taken_by[g] == j) ++g;
    group[j] = g;
    groups = std::max(groups, g + 1);
  }
  ColumnGroups out;
  out.start.assign(groups + 1, 0);
  for (int j = 0; j < n; ++j) ++out.start[group[j] + 1];
  for (int g = 0; g < groups; ++g) out.start[g + 1] += out.start[g];
  out.column.resize(n);
  std::vector<int> fill(out.start.begin(), out.start.end() - 1);
  for (int j = 0; j < n; ++j) out.column[fill[group[j]]++] = j;
  return out;
}

}  // namespace multibond
