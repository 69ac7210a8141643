#include "multibond/io/results_reader.h"

#include <cstdlib>
#include <fstream>
#include <stdexcept>

#include <fmt/format.h>

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

ResultsTable ReadResults(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error(fmt::format("cannot read '{}'", path));
  ResultsTable t;
  std::string line;
  if (!std::getline(in, line)) throw std::runtime_error(fmt::format("{}: empty file", path));
  size_t start = 0;
  while (start <= line.size()) {
    const size_t comma = line.find(',', start);
    const std::string cell = line.substr(start, comma == std::string::npos ? std::string::npos : comma - start);
    const size_t bracket = cell.rfind(" [");
    t.names.push_back(bracket == std::string::npos ? cell : cell.substr(0, bracket));
    t.units.push_back(bracket == std::string::npos ? "" : cell.substr(bracket + 2, cell.size() - bracket - 3));
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  int lineno = 1;
  while (std::getline(in, line)) {
    ++lineno;
    if (line.empty()) continue;
    std::vector<double> row;
    row.reserve(t.names.size());
    const char* p = line.c_str();
    while (*p) {
      char* end = nullptr;
      row.push_back(std::strtod(p, &end));
      if (end == p) throw std::runtime_error(fmt::format("{}:{}: not a number", path, lineno));
      p = *end == ',' ? end + 1 : end;
    }
    if (row.size() != t.names.size())
      throw std::runtime_error(fmt::format("{}:{}: {} values for {} columns", path, lineno, row.size(), t.names.size()));
    t.rows.push_back(std::move(row));
  }
  return t;
}

}  // namespace multibond
