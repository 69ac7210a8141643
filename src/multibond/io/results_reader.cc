#include "multibond/io/results_reader.h"

#include <algorithm>
#include <charconv>
#include <cstdlib>
#include <fstream>
#include <stdexcept>

#include <fmt/format.h>

#include "multibond/io/safe_text.h"

namespace multibond {

int ResultsTable::Index(const std::string& name) const {
  for (size_t i = 0; i < names.size(); ++i)
    if (names[i] == name) return static_cast<int>(i);
  throw std::out_of_range(fmt::format("results have no column '{}'", name));
}

bool ResultsTable::Has(const std::string& name) const {
  for (const auto& n : names)
    if (n == name) return true;
  return false;
}

std::vector<double> ResultsTable::Column(const std::string& name) const {
  const int c = Index(name);
  std::vector<double> out;
  out.reserve(rows.size());
  for (const auto& r : rows) out.push_back(r[c]);
  return out;
}

NameAndUnit SplitNameAndUnit(std::string cell) {
  if (!cell.empty() && cell.back() == '\r') cell.pop_back();
  const size_t open = cell.rfind(" [");
  if (open == std::string::npos || cell.back() != ']') return {std::move(cell), ""};
  return {cell.substr(0, open), cell.substr(open + 2, cell.size() - open - 3)};
}

ResultsTable ReadResults(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error(fmt::format("cannot read '{}'", path));
  ResultsTable t;
  int lineno = 0;
  for (const std::string& cell : ReadHeaderCells(in, path, lineno)) {
    NameAndUnit nu = SplitNameAndUnit(cell);
    t.names.push_back(std::move(nu.name));
    t.units.push_back(std::move(nu.unit));
  }
  std::string line;
  std::vector<double> row;
  while (std::getline(in, line)) {
    ++lineno;
    if (line.empty()) continue;
    ParseRow(line, t.names, path, lineno, row);
    t.rows.push_back(row);
  }
  return t;
}

/// The header's cells, as CsvCell writes them: a cell opening with a double quote runs to the
/// matching quote ("" is one quote) across commas and line breaks (further lines are read, counted
/// in `lineno`); a quote elsewhere is kept as it is, as files written before names were quoted have.
std::vector<std::string> ReadHeaderCells(std::istream& in, const std::string& path, int& lineno, size_t max_cells) {
  std::string line;
  if (!std::getline(in, line)) throw std::runtime_error(fmt::format("{}: empty file", path));
  lineno = 1;
  std::vector<std::string> cells(1);
  bool cell_start = true, quoted = false;
  int quote_line = 0;
  size_t i = 0;
  while (true) {
    if (i == line.size()) {
      if (!quoted) break;
      if (!std::getline(in, line)) throw std::runtime_error(fmt::format("{}:{}: a quoted column name is not closed", path, quote_line));
      ++lineno;
      cells.back() += '\n';
      i = 0;
      continue;
    }
    const char c = line[i++];
    const bool at_start = cell_start;
    cell_start = false;
    if (quoted) {
      if (c != '"') cells.back() += c;
      else if (i < line.size() && line[i] == '"') cells.back() += '"', ++i;
      else quoted = false;
    } else if (c == ',') {
      if (cells.size() >= max_cells)
        throw std::runtime_error(fmt::format("{}: the header has more than {} columns, more than plot reads", path, max_cells));
      cells.emplace_back();
      cell_start = true;
    } else if (c == '"' && at_start) {
      quoted = true;
      quote_line = lineno;
    } else {
      cells.back() += c;
    }
  }
  return cells;
}

void ParseRow(std::string_view line, const std::vector<std::string>& names, const std::string& path, int lineno,
              std::vector<double>& row) {
  if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
  const size_t cells = static_cast<size_t>(std::count(line.begin(), line.end(), ',')) + 1;
  if (cells != names.size())
    throw std::runtime_error(fmt::format("{}:{}: {} values for {} columns", path, lineno, cells, names.size()));
  row.resize(cells);
  size_t start = 0;
  for (size_t c = 0; c < cells; ++c) {
    size_t end = line.find(',', start);
    if (end == std::string_view::npos) end = line.size();
    std::string_view cell = line.substr(start, end - start);
    while (!cell.empty() && cell.front() == ' ') cell.remove_prefix(1);
    while (!cell.empty() && cell.back() == ' ') cell.remove_suffix(1);
    std::string_view digits = cell;
    if (!digits.empty() && digits.front() == '+') digits.remove_prefix(1);
    const auto [ptr, ec] = std::from_chars(digits.data(), digits.data() + digits.size(), row[c]);
    if (digits.empty() || ec != std::errc() || ptr != digits.data() + digits.size()) {
      const std::string_view shown = cell.substr(0, 40);
      throw std::runtime_error(fmt::format("{}:{}: not a number: '{}{}' in column {} ('{}')", path, lineno, MessageText(shown),
                                           shown.size() < cell.size() ? "..." : "", c + 1, MessageText(names[c])));
    }
    start = end + 1;
  }
}

}  // namespace multibond
