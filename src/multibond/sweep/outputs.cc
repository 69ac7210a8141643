// sweep.csv, sweep.json, the sensitivity ranking and the plots.

#include "multibond/sweep/outputs.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <numeric>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "multibond/core/process.h"
#include "multibond/io/atomic_file.h"
#include "multibond/io/results_writer.h"
#include "multibond/sweep/journal.h"
#include "multibond/version.h"

namespace multibond::sweep {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

const char* MethodName(Study::Method m) {
  switch (m) {
    case Study::Method::kGrid: return "grid";
    case Study::Method::kMonteCarlo: return "monte_carlo";
    case Study::Method::kLatinHypercube: return "latin_hypercube";
  }
  return "grid";
}

std::vector<double> Ranks(const std::vector<double>& x) {
  std::vector<size_t> order(x.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) { return x[a] < x[b]; });
  std::vector<double> r(x.size());
  for (size_t i = 0; i < order.size();) {
    size_t j = i;
    while (j + 1 < order.size() && x[order[j + 1]] == x[order[i]]) ++j;
    for (size_t k = i; k <= j; ++k) r[order[k]] = 0.5 * static_cast<double>(i + j) + 1.0;
    i = j + 1;
  }
  return r;
}

nlohmann::json Number(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); }

/// The gnuplot script of one quantity against one parameter, read from sweep.csv by column number.
std::string PlotScript(const std::string& q, int qcol, const std::string& p, int pcol, bool log_x, int status) {
  return fmt::format(
      "set terminal svg size 640,420 dynamic\n"
      "set output 'plots/{0}_vs_{2}.svg'\n"
      "set datafile separator ','\n"
      "set key off\nset grid\n{4}"
      "set xlabel '{2}'\nset ylabel '{0}'\nset title '{0} against {2}'\n"
      "plot 'sweep.csv' every ::1 using {3}:(strcol({5}) eq 'ok' ? ${1} : NaN) with linespoints pt 7 ps 0.5\n",
      q, qcol, p, pcol, log_x ? "set logscale x\n" : "", status);
}

}  // namespace

std::string SweepCsv(const Study& s, const std::vector<std::vector<double>>& design, const std::vector<RunResult>& results) {
  std::string o = "run";
  for (const Axis& a : s.axes) (o += ',') += a.name;
  o += ",status";
  for (const Keep& k : s.keep) (o += ',') += k.name;
  o += ",reason\n";
  for (const RunResult& r : results) {
    o += std::to_string(r.run);
    for (const double v : design[r.run]) (o += ',') += ExactText(v);
    o += r.ok ? ",ok" : ",failed";
    for (const double v : r.values) (o += ',') += ExactText(v);
    ((o += ',') += CsvCell(r.reason)) += '\n';
  }
  return o;
}

double Spearman(const std::vector<double>& x, const std::vector<double>& y) {
  if (x.size() < 3 || x.size() != y.size()) return kNaN;
  const std::vector<double> rx = Ranks(x), ry = Ranks(y);
  const double n = static_cast<double>(x.size()), mean = (n + 1.0) / 2.0;
  double sxy = 0.0, sxx = 0.0, syy = 0.0;
  for (size_t i = 0; i < x.size(); ++i) {
    sxy += (rx[i] - mean) * (ry[i] - mean);
    sxx += (rx[i] - mean) * (rx[i] - mean);
    syy += (ry[i] - mean) * (ry[i] - mean);
  }
  if (sxx == 0.0 || syy == 0.0) return kNaN;
  return sxy / std::sqrt(sxx * syy);
}

std::vector<Sensitivity> SensitivityRanking(const Study& s, const std::vector<std::vector<double>>& design,
                                            const std::vector<RunResult>& results) {
  std::vector<Sensitivity> out;
  for (size_t k = 0; k < s.keep.size(); ++k) {
    std::vector<Sensitivity> one;
    for (size_t j = 0; j < s.axes.size(); ++j) {
      std::vector<double> x, y;
      for (const RunResult& r : results)
        if (r.ok && std::isfinite(r.values[k])) {
          x.push_back(design[r.run][j]);
          y.push_back(r.values[k]);
        }
      one.push_back({s.keep[k].name, s.axes[j].name, Spearman(x, y), 0});
    }
    std::stable_sort(one.begin(), one.end(), [](const Sensitivity& a, const Sensitivity& b) {
      const double ma = std::isnan(a.spearman) ? -1.0 : std::abs(a.spearman), mb = std::isnan(b.spearman) ? -1.0 : std::abs(b.spearman);
      return ma > mb;
    });
    for (size_t i = 0; i < one.size(); ++i) one[i].rank = static_cast<int>(i) + 1;
    out.insert(out.end(), one.begin(), one.end());
  }
  return out;
}

std::string SweepJson(const Study& s, const SweepFacts& f, const std::vector<Sensitivity>& sensitivity) {
  nlohmann::json j;
  j["study"] = s.name;
  j["study_file"] = s.file;
  j["model"] = s.model;
  j["model_sha256"] = f.model_sha256;
  j["study_hash"] = f.study_hash;
  j["method"] = MethodName(s.method);
  if (s.method != Study::Method::kGrid) {
    j["samples"] = s.samples;
    j["seed"] = s.seed;
  }
  nlohmann::json axes = nlohmann::json::array();
  for (const Axis& a : s.axes) {
    nlohmann::json x{{"name", a.name}};
    switch (a.kind) {
      case Axis::Kind::kGrid:
        x.update({{"grid", {{"from", a.from}, {"to", a.to}, {"count", a.count}, {"scale", a.scale == Axis::Scale::kLog ? "log" : "linear"}}}});
        break;
      case Axis::Kind::kList: x["values"] = a.values; break;
      case Axis::Kind::kDistribution: {
        static const char* names[] = {"uniform", "loguniform", "normal", "lognormal"};
        const bool range = a.distribution == Axis::Distribution::kUniform || a.distribution == Axis::Distribution::kLogUniform;
        x["distribution"] = {{"name", names[static_cast<int>(a.distribution)]}, {range ? "low" : "mean", a.a}, {range ? "high" : "sd", a.b}};
        break;
      }
    }
    axes.push_back(x);
  }
  j["parameters"] = axes;
  nlohmann::json set = nlohmann::json::object();
  for (const auto& [n, v] : s.set) set[n] = v;
  j["set"] = set;
  nlohmann::json keep = nlohmann::json::array();
  for (const Keep& k : s.keep) {
    nlohmann::json x{{"name", k.name}, {"take", TakeName(k.take)}, {"of", k.of}};
    if (k.take == Keep::Take::kSettlingTime) x["band"] = k.band;
    if (k.take == Keep::Take::kCrossingTime) x["level"] = k.level;
    if (k.from != -HUGE_VAL) x["from"] = k.from;  // the window, when there is one (seconds)
    if (k.to != HUGE_VAL) x["to"] = k.to;
    if (!k.element.empty()) x["element"] = k.element;
    keep.push_back(x);
  }
  j["keep"] = keep;
  j["runs"] = f.runs;
  j["failed"] = f.failed;
  j["resumed"] = f.resumed;
  j["versions"] = {{"multibond", kVersion}, {"compiler", fmt::format("{} {}", "gcc", __VERSION__)}};
  j["rhs_engine"] = f.rhs_engine;
  j["parallel"] = {{"ranks", f.ranks}, {"threads_per_rank", f.threads}};
  j["wall_seconds"] = f.wall_seconds;
  j["time_in_runs"] = {{"load_seconds", f.timing.load}, {"compile_seconds", f.timing.compile}, {"simulate_seconds", f.timing.simulate},
                       {"runs_timed", f.timing.runs}};
  if (!sensitivity.empty()) {
    nlohmann::json sj = nlohmann::json::array();
    for (const Sensitivity& x : sensitivity)
      sj.push_back({{"quantity", x.quantity}, {"parameter", x.parameter}, {"spearman", Number(x.spearman)}, {"rank", x.rank}});
    j["sensitivity"] = sj;
  }
  return j.dump(2) + "\n";
}

std::vector<std::string> WriteOutputs(const std::string& dir, const Study& s, const std::vector<std::vector<double>>& design,
                                      const std::vector<RunResult>& results, const SweepFacts& facts) {
  namespace fs = std::filesystem;
  std::vector<Sensitivity> sensitivity;
  if (s.method != Study::Method::kGrid) {
    sensitivity = SensitivityRanking(s, design, results);
    std::string csv = "quantity,parameter,spearman,rank\n";
    for (const Sensitivity& x : sensitivity) csv += fmt::format("{},{},{},{}\n", x.quantity, x.parameter, ExactText(x.spearman), x.rank);
    WriteFileAtomic((fs::path(dir) / "sensitivity.csv").string(), csv);
  }
  WriteFileAtomic((fs::path(dir) / "sweep.csv").string(), SweepCsv(s, design, results));
  WriteFileAtomic((fs::path(dir) / "sweep.json").string(), SweepJson(s, facts, sensitivity));
  // Plots: one gnuplot script per quantity and parameter, run from the folder.
  std::vector<std::string> problems;
  fs::create_directories(fs::path(dir) / "plots");
  for (size_t k = 0; k < s.keep.size(); ++k) {
    // A quantity no run has a value of (a level never crossed, a window past the end): nothing
    // to draw; said once, instead of gnuplot's complaint for each parameter.
    const bool any = std::any_of(results.begin(), results.end(),
                                 [&](const RunResult& r) { return r.ok && k < r.values.size() && std::isfinite(r.values[k]); });
    if (!any) {
      problems.push_back(fmt::format("{}: not drawn: no run has a value of it (every one is NaN)", s.keep[k].name));
      continue;
    }
    for (size_t j = 0; j < s.axes.size(); ++j) {
      const Axis& a = s.axes[j];
      const bool log_x = (a.kind == Axis::Kind::kGrid && a.scale == Axis::Scale::kLog) ||
                         (a.kind == Axis::Kind::kDistribution &&
                          (a.distribution == Axis::Distribution::kLogUniform || a.distribution == Axis::Distribution::kLogNormal));
      const std::string name = fmt::format("{}_vs_{}", s.keep[k].name, a.name);
      const int pcol = static_cast<int>(j) + 2, status = static_cast<int>(s.axes.size()) + 2;
      const int qcol = status + 1 + static_cast<int>(k);
      const std::string script = PlotScript(s.keep[k].name, qcol, a.name, pcol, log_x, status);
      WriteFileAtomic((fs::path(dir) / "plots" / (name + ".gp")).string(), script);
      const std::string why = RunProcess({"gnuplot", "plots/" + name + ".gp"}, dir, (fs::path(dir) / "plots" / (name + ".log")).string());
      if (why.empty()) fs::remove(fs::path(dir) / "plots" / (name + ".log"));
      else problems.push_back(name + ": " + why);
    }
  }
  return problems;
}

}  // namespace multibond::sweep
