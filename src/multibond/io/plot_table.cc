#include "multibond/io/plot_table.h"

#include <algorithm>
#include <cmath>
#include <istream>
#include <limits>
#include <optional>
#include <stdexcept>

#include <fmt/format.h>

#include "multibond/io/limits.h"
#include "multibond/io/results_reader.h"

namespace multibond {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
/// The longest results.csv header plot reads, and the largest run.json.
constexpr std::uint64_t kMaxHeaderBytes = 256ull << 20;
constexpr std::uint64_t kMaxRunJsonBytes = 4ull << 20;

}  // namespace

PlotTable PlotTable::Load(const ResultsFolder& folder, std::uint64_t max_bytes, struct stat* st, Fd* keep) {
  const std::string path = folder.PathOf("results.csv");
  Fd fd = folder.OpenInput("results.csv", max_bytes, "results-size", st);
  if (fd.get() < 0) throw std::runtime_error(fmt::format("cannot read '{}': no such file (run 'multibond run MODEL -o DIR' first)", path));
  if (st->st_size == 0) throw std::runtime_error(fmt::format("{}: empty file", path));
  BoundedFileBuf buf(fd.get(), std::min<std::uint64_t>(max_bytes, kMaxHeaderBytes));
  std::istream in(&buf);
  PlotTable t;
  int lineno = 0;
  const std::vector<std::string> cells = ReadHeaderCells(in, path, lineno);
  if (buf.exceeded()) throw std::runtime_error(fmt::format("{}: the header is longer than {} bytes, more than plot reads", path, kMaxHeaderBytes));
  for (const std::string& cell : cells) {
    NameAndUnit nu = SplitNameAndUnit(cell);
    t.index_.emplace(nu.name, static_cast<int>(t.names_.size()));
    t.names_.push_back(std::move(nu.name));
    t.units_.push_back(std::move(nu.unit));
  }
  t.cols_.resize(t.names_.size());
  buf.set_limit(max_bytes);
  std::string line;
  std::vector<double> row;
  while (std::getline(in, line)) {
    ++lineno;
    if (line.empty() || line == "\r") continue;
    ParseRow(line, t.names_, path, lineno, row);
    for (size_t c = 0; c < row.size(); ++c) t.cols_[c].push_back(row[c]);
  }
  if (buf.exceeded())
    throw std::runtime_error(fmt::format("'{}' grew beyond {} bytes while it was read; {}", path, max_bytes, RaiseLimitHint("results-size", max_bytes)));
  if (t.rows() == 0) throw std::runtime_error(fmt::format("'{}' has no rows", path));
  if (!t.Has("time")) throw std::runtime_error(fmt::format("'{}' has no 'time' column", path));
  if (keep) *keep = std::move(fd);
  return t;
}

int PlotTable::Find(const std::string& name) const {
  auto it = index_.find(name);
  return it == index_.end() ? -1 : it->second;
}

double PlotTable::First(const std::string& name) const { return Has(name) ? Col(name).front() : kNaN; }
double PlotTable::Last(const std::string& name) const { return Has(name) ? Col(name).back() : kNaN; }

std::pair<double, double> PlotTable::Range(const std::string& name, double t0, double t1) const {
  double lo = INFINITY, hi = -INFINITY;
  if (!Has(name)) return {lo, hi};
  const auto& time = cols_[0];
  const auto& c = Col(name);
  for (size_t r = 0; r < rows(); ++r)
    if (time[r] >= t0 && time[r] <= t1 && std::isfinite(c[r])) lo = std::min(lo, c[r]), hi = std::max(hi, c[r]);
  return {lo, hi};
}

nlohmann::json ReadRunJson(const ResultsFolder& folder) {
  const std::optional<std::string> text = folder.ReadText("run.json", kMaxRunJsonBytes, nullptr);
  if (!text) return nlohmann::json::object();
  try {
    nlohmann::json j = nlohmann::json::parse(*text);
    if (j.is_object()) return j;
  } catch (const std::exception&) {
  }
  return nlohmann::json::object();
}

}  // namespace multibond
