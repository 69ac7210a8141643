#pragma once
/// \file
/// What `plot` reads from a results folder: results.csv in memory, column by column, and run.json
/// as JSON. Only the folder's own regular files are read, with bounds (results_folder.h).

#include <sys/stat.h>

#include <cstdint>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "multibond/io/results_folder.h"

namespace multibond {

/// results.csv in memory, column by column.
class PlotTable {
 public:
  /// Reads the folder's results.csv (a regular file, not a link, of at most `max_bytes`): the
  /// header's names and units, then every row, each with exactly one number per column. Memory:
  /// 8 bytes a value, so at most about 4 times the file's size (one-character values), plus about
  /// 150 bytes a column. Throws std::runtime_error with the file, line and what is wrong, also
  /// when there is no 'time' column. `st` gets the file's status; `keep`, when given, the open file.
  static PlotTable Load(const ResultsFolder& folder, std::uint64_t max_bytes, struct stat* st, Fd* keep = nullptr);

  size_t rows() const { return cols_.empty() ? 0 : cols_[0].size(); }
  /// Every column's name and unit, in the file's order (time first).
  const std::vector<std::string>& names() const { return names_; }
  const std::vector<std::string>& units() const { return units_; }
  bool Has(const std::string& name) const { return index_.count(name) > 0; }
  /// 0-based column index; -1 if absent.
  int Find(const std::string& name) const;
  const std::vector<double>& Col(const std::string& name) const { return cols_.at(static_cast<size_t>(Find(name))); }
  std::string Unit(const std::string& name) const { return Has(name) ? units_[static_cast<size_t>(Find(name))] : ""; }
  /// First and last value of a column (NaN if absent).
  double First(const std::string& name) const;
  double Last(const std::string& name) const;
  double Time0() const { return cols_[0].front(); }
  double Time1() const { return cols_[0].back(); }
  /// min and max of a column over rows with time in [t0, t1] (NaNs skipped); {inf, -inf} if none.
  std::pair<double, double> Range(const std::string& name, double t0, double t1) const;

 private:
  std::vector<std::string> names_, units_;
  std::vector<std::vector<double>> cols_;
  std::map<std::string, int> index_;
};

/// run.json of the folder as JSON ({} when it is absent or does not parse); throws when it is a
/// link, not a regular file or larger than 4 MB.
nlohmann::json ReadRunJson(const ResultsFolder& folder);

}  // namespace multibond
