#pragma once
/// \file
/// Reading a results.csv back (header "name [unit]", one row per output time). Header cells may be
/// CSV-quoted (RFC 4180), as CsvWriter writes names holding a comma, a quote or a line break.

#include <istream>
#include <string>
#include <vector>

namespace multibond {

struct ResultsTable {
  std::vector<std::string> names, units;
  std::vector<std::vector<double>> rows;

  /// Column index of `name`; throws std::out_of_range naming the column if absent.
  int Index(const std::string& name) const;
  bool Has(const std::string& name) const;
  double At(size_t row, const std::string& name) const { return rows.at(row).at(Index(name)); }
  double Last(const std::string& name) const { return rows.back().at(Index(name)); }
  std::vector<double> Column(const std::string& name) const;
};

/// Reads `path`; throws std::runtime_error with the file, line and what is wrong.
ResultsTable ReadResults(const std::string& path);

/// The cells of a CSV header line read from `in` (a quoted cell may span lines; `lineno` is set
/// to the last line read); `path` is for messages. Throws std::runtime_error.
std::vector<std::string> ReadHeaderCells(std::istream& in, const std::string& path, int& lineno);

/// A header cell "name [unit]" split into its name and unit ("" when the cell has no unit).
struct NameAndUnit {
  std::string name, unit;
};
NameAndUnit SplitNameAndUnit(std::string cell);

}  // namespace multibond
