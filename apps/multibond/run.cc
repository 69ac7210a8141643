// multibond run: simulate a model into a results folder (results.csv, .mat, .h5 as asked for,
// then run.json).

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <iostream>
#include <memory>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <nlohmann/json.hpp>

#include "cli.h"
#include "multibond/core/interrupt.h"
#include "multibond/io/atomic_file.h"
#include "multibond/io/output_folder.h"
#include "multibond/io/column_store.h"
#include "multibond/io/results_files.h"
#include "multibond/io/results_writer.h"
#include "run_options.h"

namespace multibond::cli {

namespace {

namespace fs = std::filesystem;

struct RunCommand {
  RunArgs run;
  std::string model, out;
  std::string format = "csv";
  bool quiet = false, compress = false;
  bool steady = false;  ///< --steady: run.initial = "steady"
};

/// "560 kB", "1.2 GB": a size for a person.
std::string HumanBytes(std::uint64_t bytes) {
  const double b = static_cast<double>(bytes);
  if (b < 1e6) return fmt::format("{:.3g} kB", b / 1e3);
  if (b < 1e9) return fmt::format("{:.3g} MB", b / 1e6);
  return fmt::format("{:.3g} GB", b / 1e9);
}

int Run(const RunCommand& a, const std::vector<std::string>& argv) {
  const auto started = std::chrono::steady_clock::now();
  std::vector<ResultFormat> formats;
  try {
    formats = ParseResultFormats(a.format);
  } catch (const std::invalid_argument& e) {
    throw CliExit{kExitUsage, e.what()};
  }
  if (a.steady && a.run.initial && *a.run.initial != "steady")
    throw CliExit{kExitUsage, fmt::format("--steady and --initial {} ask for two different starts: give one", *a.run.initial)};
  RunArgs run_args = a.run;
  if (a.steady) run_args.initial = "steady";
  PreparedRun p = PrepareRun(a.model, run_args);
  const LoadedModel& lm = p.lm;
  const auto& model = p.model;
  RunOptions& o = p.options;
  const bool tty = isatty(fileno(stderr)) && !a.quiet;
  if (tty) o.progress = [&](double f) { std::fprintf(stderr, "\r  t = %-10.4g s  %3.0f%%", o.t_start + f * (o.t_end - o.t_start), 100 * f); };

  // The binary formats keep every row in memory: bounded by the results-size limit, said before
  // the run.
  const long expected_rows = NumOutputIntervals(o) + 1;
  if (NeedsColumnStore(formats)) {
    const std::uint64_t limit = ParseLimits(a.run.load.limits).results_bytes;
    const std::size_t columns = MakeColumns(*model, o.all_variables).size();
    const std::uint64_t bytes = ColumnStoreBytes(static_cast<std::uint64_t>(expected_rows), columns);
    if (bytes > limit)
      throw CliExit{kExitUsage, fmt::format("--format {} keeps the results in memory: {} rows x {} columns x 8 bytes = {}, more than "
                                            "the limit results-size; raise it with --limit results-size=N (now {}), use a larger output "
                                            "interval (--dt), or write csv only",
                                            a.format, expected_rows, columns, HumanBytes(bytes), limit)};
  }

  // The model compiled: only now is the output folder touched.
  ThrowIfStopRequested("loading and compiling the model");
  std::vector<fs::path> outputs = {fs::path(a.out) / "run.json"};
  for (ResultFormat f : AllResultFormats()) outputs.push_back(fs::path(a.out) / ResultFileName(f));
  outputs.push_back(fs::path(a.out) / kEventsFileName);
  RefuseWritingOnto(outputs, {a.model});
  const OutputFolder folder(a.out, CommandLine(argv));
  ReportRemovedTemporaries(folder);
  ResultsFiles results(folder.path(), formats, expected_rows, a.compress);
  AtomicFile run_json(folder.File("run.json"));  // a name it cannot take is said before the run
  RunSummary summary;
  const auto simulate_start = std::chrono::steady_clock::now();
  try {
    summary = Simulate(*model, o, results);
  } catch (const std::invalid_argument& e) {
    std::cerr << "error: " << e.what() << '\n';
    return kExitUsage;
  }
  // The integration's part: the time in Simulate less the rows' writing (the observer's part).
  const double integrate_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - simulate_start).count() - results.write_seconds();
  if (tty) std::fprintf(stderr, "\n");
  // --jit auto: a compile the run did not wait for goes on in a process of its own and fills the
  // cache, so that the next run of this model starts on the generated code (rhs_engine says so).
  if (a.run.jit == "auto") {
    if (const std::string program = JitFinisher(); !program.empty()) {
      const std::string kept = p.code->HandOver(program);
      if (tty && !kept.empty()) std::fprintf(stderr, "note: the generated code: %s\n", kept.c_str());
    }
  }
  nlohmann::json record = MakeRunRecord(a.model, lm.text, lm.graph.name(), o, summary, argv);
  record["rhs_engine"] = p.engine();
  record["states"] = model->num_states();
  // What the model file was warned of as it was read (on the terminal too): a run whose numbers
  // may not mean what the file meant says so in its record.
  nlohmann::json model_warnings = nlohmann::json::array();
  for (const Diagnostic& d : lm.warnings)
    model_warnings.push_back({{"code", d.code}, {"where", d.where.ToString()}, {"element", d.element}, {"message", d.message}});
  record["model_warnings"] = std::move(model_warnings);
  record["options"]["jit"] = a.run.jit;
  record["options"]["coordinates"] = p.coordinates;
  record["options"]["initial"] = p.initial;
  if (p.initial == "steady") {
    // The steady state the run started from, by state name (the model's own initial values are
    // in the model file).
    nlohmann::json start = nlohmann::json::object();
    for (int i = 0; i < model->num_states(); ++i) start[model->state_names()[static_cast<size_t>(i)]] = o.initial_state[i];
    record["initial_state"] = std::move(start);
  }
  record["options"]["ideal_constraints"] = lm.compile.ideal_constraints;  // derivative causality solved by constraints
  record["options"]["algebraic_loops"] = lm.compile.solve_algebraic_loops ? "solve" : "error";
  // What the compiled model has, whichever way (rigid parts, Sf constraints, cut inertias).
  record["constraint_efforts"] = model->num_multipliers();
  record["algebraic_loops_solved"] = model->algebraic_loops().size();
  // The parameters as the run used them: final values, units, formulas, and which were set.
  nlohmann::json parameters = nlohmann::json::object();
  for (const ModelParameter& q : lm.parameters) {
    nlohmann::json& j = parameters[q.name];
    j["value"] = q.value;
    j["unit"] = q.unit;
    if (q.is_formula()) j["formula"] = q.text;
    j["set"] = q.set;
  }
  record["parameters"] = std::move(parameters);
  // The binary files hold the record as it is here (their own sizes and hashes are in run.json);
  // their time is in write_results, and the record says only that.
  results.Finish(record);
  // Where the time went (docs/scaling.md): each phase's wall time; write_results is the rows'
  // writing and the files' finishing.
  nlohmann::json phases = nlohmann::json::object();
  for (const auto& [phase, seconds] : p.phase_seconds) phases[phase] = seconds;
  phases["integrate"] = std::max(0.0, integrate_seconds);
  phases["write_results"] = results.write_seconds();
  record["phase_seconds"] = std::move(phases);
  record["command_wall_seconds"] = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  // Published together, run.json last: it records the size and hash of each results file it goes
  // with ("results": results.csv's, "files": every one), and a results file without a run.json
  // beside it is from a command that did not finish.
  if (const nlohmann::json csv = results.CsvRecord(); !csv.is_null()) record["results"] = csv;
  record["files"] = results.FilesRecord();
  run_json.Write(DumpRecord(record));
  run_json.Finish();  // a full disk shows here, before anything is published
  std::error_code ignored;
  fs::remove(folder.File("run.json"), ignored);  // an earlier run's record never describes these results
  // Nor do an earlier run's results in a format this run does not write.
  for (ResultFormat f : AllResultFormats())
    if (std::find(formats.begin(), formats.end(), f) == formats.end()) fs::remove(folder.File(ResultFileName(f)), ignored);
  if (summary.event_counts.empty()) fs::remove(folder.File(kEventsFileName), ignored);
  results.Publish();
  run_json.Publish();
  if (!a.quiet || summary.status != RunStatus::kOk) {
    std::cout << fmt::format("{}: {} to t = {:g} s with {} ({} steps, {} right-hand sides, {:.3f} s wall)\n",
                             lm.graph.name(), RunStatusName(summary.status), summary.t_reached, p.solver, summary.stats.steps,
                             summary.stats.rhs_evals, summary.wall_seconds);
    if (model->has_energy_account())
      std::cout << fmt::format("energy: work {:.9g} J, stored {:.9g} J, dissipated {:.9g} J, residual {:.3g}\n", summary.energy_work,
                               summary.energy_stored, summary.energy_dissipated, summary.energy_residual);
    std::vector<std::string> written;
    for (ResultFormat f : formats) written.push_back(fmt::format("{}/{}", a.out, ResultFileName(f)));
    if (!summary.event_counts.empty()) written.push_back(fmt::format("{}/{}", a.out, kEventsFileName));
    std::cout << fmt::format("wrote {} and {}/run.json\n", fmt::join(written, ", "), a.out);
  }
  for (const std::string& w : summary.warnings) std::cerr << "warning: " << w << '\n';  // also in run.json
  if (summary.status == RunStatus::kFailed) {
    std::cerr << "error: the simulation failed " << summary.message << "\n  the results up to then are kept; run.json marks the run as failed\n"
              << "  hint: " << FailureHint(o, summary.message) << '\n';
    return kExitSolver;
  }
  if (summary.status == RunStatus::kInterrupted) {
    std::cerr << summary.message << "; the results up to then are kept\n";
    return InterruptedExitCode();
  }
  return kExitOk;
}

}  // namespace

Command AddRunCommand(CLI::App& app) {
  auto a = std::make_shared<RunCommand>();
  CLI::App* cmd = app.add_subcommand("run", "Simulate and write DIR/results.csv (or .mat, .h5) and DIR/run.json");
  cmd->add_option("MODEL", a->model, "model file (YAML)")->required();
  cmd->add_option("-o,--output", a->out, "output folder")->required()->check(kPathName);
  cmd->add_option("--format", a->format,
                  "the result files to write, a comma-separated list of csv (results.csv), mat (results.mat, MATLAB 5 "
                  "compressed) and h5 (results.h5, HDF5)")
      ->default_val("csv");
  cmd->add_flag("--compress", a->compress,
                "compress results.mat and results.h5 (zlib): smaller by a few percent for values with full mantissas, more for "
                "constant columns, and several times slower to write");
  AddRunOptions(cmd, a->run);
  cmd->add_flag("--steady", a->steady,
                "start from a steady state: Newton's method (KINSOL) from the model's initial values, the sources held at their "
                "values at the start (the same as --initial steady; run.json records the state it found)");
  cmd->add_option("--initial", a->run.initial, "model: start from the model's initial values; steady: from a steady state (default: the "
                                              "file's simulation: initial, else model)")
      ->check(CLI::IsMember({"model", "steady"}));
  cmd->add_flag("-q,--quiet", a->quiet, "no progress and no summary");
  return {cmd, [a](const std::vector<std::string>& argv) { return Run(*a, argv); }, [] { return true; }};
}

}  // namespace multibond::cli
