// multibond run: simulate a model into a results folder (results.csv, then run.json).

#include <unistd.h>

#include <cstdio>
#include <iostream>
#include <memory>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "cli.h"
#include "multibond/core/interrupt.h"
#include "multibond/io/atomic_file.h"
#include "multibond/io/output_folder.h"
#include "multibond/io/results_writer.h"
#include "run_options.h"

namespace multibond::cli {

namespace {

namespace fs = std::filesystem;

struct RunCommand {
  RunArgs run;
  std::string model, out;
  bool quiet = false;
};

int Run(const RunCommand& a, const std::vector<std::string>& argv) {
  PreparedRun p = PrepareRun(a.model, a.run);
  const LoadedModel& lm = p.lm;
  const auto& model = p.model;
  RunOptions& o = p.options;
  const bool tty = isatty(fileno(stderr)) && !a.quiet;
  if (tty) o.progress = [&](double f) { std::fprintf(stderr, "\r  t = %-10.4g s  %3.0f%%", o.t_start + f * (o.t_end - o.t_start), 100 * f); };

  // The model compiled: only now is the output folder touched.
  ThrowIfStopRequested("loading and compiling the model");
  RefuseWritingOnto({fs::path(a.out) / "results.csv", fs::path(a.out) / "run.json"}, {a.model});
  const OutputFolder folder(a.out, CommandLine(argv));
  ReportRemovedTemporaries(folder);
  CsvWriter csv(folder.File("results.csv"), /*publish=*/false);
  AtomicFile run_json(folder.File("run.json"));  // a name it cannot take is said before the run
  RunSummary summary;
  try {
    summary = Simulate(*model, o, csv);
  } catch (const std::invalid_argument& e) {
    std::cerr << "error: " << e.what() << '\n';
    return kExitUsage;
  }
  if (tty) std::fprintf(stderr, "\n");
  nlohmann::json record = MakeRunRecord(a.model, lm.text, lm.graph.name(), o, summary, argv);
  record["rhs_engine"] = model->rhs_engine();
  record["options"]["jit"] = a.run.jit;
  record["options"]["coordinates"] = p.coordinates;
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
  // Published together, run.json last: it records the size and hash of the results.csv it goes
  // with, and a results.csv without a run.json beside it is from a command that did not finish.
  record["results"] = DataFileRecord("results.csv", csv.bytes(), csv.sha256());
  run_json.Write(DumpRecord(record));
  run_json.Finish();  // a full disk shows here, before anything is published
  std::error_code ignored;
  fs::remove(folder.File("run.json"), ignored);  // an earlier run's record never describes these results
  csv.Publish();
  run_json.Publish();
  if (!a.quiet || summary.status != RunStatus::kOk) {
    std::cout << fmt::format("{}: {} to t = {:g} s with {} ({} steps, {} right-hand sides, {:.3f} s wall)\n",
                             lm.graph.name(), RunStatusName(summary.status), summary.t_reached, p.solver, summary.stats.steps,
                             summary.stats.rhs_evals, summary.wall_seconds);
    if (model->has_energy_account())
      std::cout << fmt::format("energy: work {:.9g} J, stored {:.9g} J, dissipated {:.9g} J, residual {:.3g}\n", summary.energy_work,
                               summary.energy_stored, summary.energy_dissipated, summary.energy_residual);
    std::cout << fmt::format("wrote {}/results.csv and {}/run.json\n", a.out, a.out);
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
  CLI::App* cmd = app.add_subcommand("run", "Simulate and write DIR/results.csv and DIR/run.json");
  cmd->add_option("MODEL", a->model, "model file (YAML)")->required();
  cmd->add_option("-o,--output", a->out, "output folder")->required()->check(kPathName);
  AddRunOptions(cmd, a->run);
  cmd->add_flag("-q,--quiet", a->quiet, "no progress and no summary");
  return {cmd, [a](const std::vector<std::string>& argv) { return Run(*a, argv); }, [] { return true; }};
}

}  // namespace multibond::cli
