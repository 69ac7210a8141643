#pragma once
/// \file
/// Reading a results.csv back (header "name [unit]", one row per output time). Header cells may be
/// CSV-quoted (RFC 4180), as CsvWriter writes names holding a comma, a quote or a line break.

#include <cstddef>
#include <istream>
#include <string>
#include <string_view>
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

/// The most columns a results.csv may have (a header of more is refused before it takes more
/// memory: about 150 bytes a column).
constexpr size_t kMaxResultsColumns = 2'000'000;

/// The cells of a CSV header line read from `in` (a quoted cell may span lines; `lineno` is set
/// to the last line read); `path` is for messages. Throws std::runtime_error, also when there are
/// more than `max_cells` cells.
std::vector<std::string> ReadHeaderCells(std::istream& in, const std::string& path, int& lineno,
                                         size_t max_cells = kMaxResultsColumns);

/// The numbers of a data row (`line`, without its line break; a trailing CR is ignored) into
/// `row`: exactly names.size() comma-separated numbers (nan and inf included, as the writer writes
/// them; spaces around a number allowed). Throws std::runtime_error "path:lineno: N values for M
/// columns" or "path:lineno: not a number: 'text' in column C ('name')" (the text shortened and
/// made printable).
void ParseRow(std::string_view line, const std::vector<std::string>& names, const std::string& path, int lineno,
              std::vector<double>& row);

/// A header cell "name [unit]" split into its name and unit ("" when the cell has no unit).
struct NameAndUnit {
  std::string name, unit;
};
NameAndUnit SplitNameAndUnit(std::string cell);

}  // namespace multibond
