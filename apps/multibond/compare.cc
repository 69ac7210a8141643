// multibond compare A B: run two models on one output grid and report, per result column, the
// largest difference over time.

#include <algorithm>
#include <iostream>
#include <memory>
#include <tuple>

#include <fmt/format.h>

#include "cli.h"
#include "multibond/io/atomic_file.h"
#include "multibond/io/results_writer.h"
#include "multibond/sim/compare.h"
#include "multibond/version.h"
#include "run_options.h"

namespace multibond::cli {

namespace {

namespace fs = std::filesystem;

struct CompareCommand {
  RunArgs run;
  std::vector<std::string> set_a, set_b;  ///< parameters of A only, of B only (after --set, which is both's)
  std::string a, b, out;
  std::string sort = "diff";
  std::optional<int> top;
};

int Compare(const CompareCommand& c) {
  // Both models are loaded and compiled, and the report's folder checked, before anything runs.
  PreparedRun pa = PrepareRun(c.a, c.run, c.set_a, "--set-a");
  PreparedRun pb = PrepareRun(c.b, c.run, c.set_b, "--set-b");
  if (pa.options.t_end != pb.options.t_end || pa.options.dt != pb.options.dt)
    throw CliExit{kExitUsage, fmt::format("the models' output grids differ (A: t_end {:g} s, dt {:g} s; B: t_end {:g} s, dt {:g} s): "
                                          "give --t-end and --dt",
                                          pa.options.t_end, pa.options.dt, pb.options.t_end, pb.options.dt)};
  if (!c.out.empty()) {
    RefuseWritingOnto({c.out}, {c.a, c.b});
    const fs::path out(c.out);
    if (out.has_parent_path() && !fs::is_directory(out.parent_path()))
      throw CliExit{kExitIo, fmt::format("cannot write '{}': no folder '{}'", c.out, out.parent_path().string())};
    if (fs::is_directory(out)) throw CliExit{kExitIo, fmt::format("cannot write '{}': it is a directory", c.out)};  // before both runs
  }
  RecordingObserver ra, rb;
  for (auto [p, rec, name] : {std::tuple{&pa, &ra, "A"}, std::tuple{&pb, &rb, "B"}}) {
    RunSummary summary;
    try {
      summary = Simulate(*p->model, p->options, *rec);
    } catch (const std::invalid_argument& e) {
      throw CliExit{kExitUsage, e.what()};
    }
    if (summary.status == RunStatus::kFailed) {
      std::cerr << fmt::format("error: the simulation of {} ({}) failed {}\n  nothing to compare; nothing was written\n  hint: {}\n",
                               name, p->lm.file, summary.message, FailureHint(p->options, summary.message));
      return kExitSolver;
    }
    if (summary.status == RunStatus::kInterrupted) {
      std::cerr << summary.message << "; nothing was written\n";
      return InterruptedExitCode();
    }
    for (const std::string& w : summary.warnings) std::cerr << fmt::format("warning: {} ({}): {}\n", name, p->lm.file, w);
  }
  ComparisonReport report;
  try {
    report = CompareRecordings(ra, rb);
  } catch (const std::invalid_argument& e) {
    throw CliExit{kExitUsage, e.what()};
  }
  SortComparison(report, c.sort == "name" ? ComparisonOrder::kName : ComparisonOrder::kRelative);
  const size_t shown = c.top ? std::min<size_t>(*c.top, report.columns.size()) : report.columns.size();
  const std::string order = c.sort == "name" ? "by name" : "by relative difference, largest first";

  std::cout << fmt::format("A: {} (model '{}'; {})\nB: {} (model '{}'; {})\n", c.a, pa.lm.graph.name(), RunSettings(pa), c.b,
                           pb.lm.graph.name(), RunSettings(pb));
  std::cout << fmt::format("{} samples from t = {:g} to {:g} s (dt {:g} s); {} columns in both, {}{}\n", report.samples, report.t_first,
                           report.t_last, pa.options.dt, report.columns.size(), order,
                           shown < report.columns.size() ? fmt::format(", top {} shown", shown) : "");
  size_t width = 6;
  for (size_t k = 0; k < shown; ++k)
    width = std::max(width, report.columns[k].name.size() + report.columns[k].unit.size() + 3);
  width = std::min<size_t>(width, 48);
  std::cout << fmt::format("  {:<{}}  {:>12}  {:>10}  {:>12}  {:>10}\n", "column", width, "max |A-B|", "at t [s]", "scale max|A|",
                           "relative");
  for (size_t k = 0; k < shown; ++k) {
    const ColumnComparison& col = report.columns[k];
    std::cout << fmt::format("  {:<{}}  {:>12.4g}  {:>10.6g}  {:>12.4g}  {:>10.3g}{}\n", col.name + " [" + col.unit + "]", width,
                             col.max_abs_diff, col.time, col.scale, col.relative,
                             col.unit_b != col.unit ? fmt::format("  (unit in B: {})", col.unit_b) : "");
  }
  auto list = [](const std::vector<std::string>& names) {
    std::string s;
    for (const auto& n : names) s += (s.empty() ? "" : ", ") + n;
    return s;
  };
  std::cout << fmt::format("only in A ({}){}{}\n", report.only_in_a.size(), report.only_in_a.empty() ? "" : ": ", list(report.only_in_a));
  std::cout << fmt::format("only in B ({}){}{}\n", report.only_in_b.size(), report.only_in_b.empty() ? "" : ": ", list(report.only_in_b));
  if (const ColumnComparison* w = report.Worst())
    std::cout << fmt::format("largest relative difference: {:.3g} in {} at t = {:g} s\n", w->relative, w->name, w->time);

  if (!c.out.empty()) {
    std::string csv = fmt::format(
        "# multibond compare; A: {} ({}); B: {} ({}); t_end {:g} s, dt {:g} s, jit {}, all_variables {}, sort {}, top {}; multibond {}\n",
        c.a, RunSettings(pa), c.b, RunSettings(pb), pa.options.t_end, pa.options.dt, c.run.jit, c.run.all_variables, c.sort,
        c.top ? std::to_string(*c.top) : "all", kVersion);
    csv += fmt::format("# only in A ({}): {}\n# only in B ({}): {}\n", report.only_in_a.size(), list(report.only_in_a),
                       report.only_in_b.size(), list(report.only_in_b));
    csv += "column,unit,max_abs_diff,time,scale,relative_diff\n";
    for (size_t k = 0; k < shown; ++k) {
      const ColumnComparison& col = report.columns[k];
      csv += fmt::format("{},{},{},{},{},{}\n", CsvCell(col.name), CsvCell(col.unit), col.max_abs_diff, col.time, col.scale, col.relative);
    }
    try {
      WriteFileAtomic(c.out, csv);
    } catch (const std::exception& e) {
      throw CliExit{kExitIo, e.what()};
    }
    std::cout << "wrote " << c.out << '\n';
  }
  return kExitOk;
}

}  // namespace

Command AddCompareCommand(CLI::App& app) {
  auto c = std::make_shared<CompareCommand>();
  CLI::App* cmd =
      app.add_subcommand("compare", "Run two models on one output grid and report, per result column, the largest difference over time");
  cmd->add_option("A", c->a, "model file (YAML); its values give each column's scale")->required();
  cmd->add_option("B", c->b, "model file (YAML)")->required();
  cmd->add_option("-o,--output", c->out, "also write the report as CSV to FILE")->type_name("FILE")->check(kPathName);
  cmd->add_option("--sort", c->sort, "diff: largest relative difference first (default); name: by column name")
      ->check(CLI::IsMember({"diff", "name"}));
  cmd->add_option("--top", c->top, "report only the first N columns")->check(kPositive);
  AddRunOptions(cmd, c->run);
  cmd->add_option("--set-a", c->set_a,
                  "NAME=VALUE: a parameter of A only, after --set (which sets both models' parameters); e.g. the same "
                  "file twice with --set-b k=200 compares two values of k")
      ->type_name("NAME=VALUE")
      ->expected(1)
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
  cmd->add_option("--set-b", c->set_b, "NAME=VALUE: a parameter of B only, after --set")
      ->type_name("NAME=VALUE")
      ->expected(1)
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
  return {cmd, [c](const std::vector<std::string>&) { return Compare(*c); }, [c] { return !c->out.empty(); }};
}

}  // namespace multibond::cli
