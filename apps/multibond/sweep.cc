// multibond sweep STUDY -o DIR: parameter sweeps and Monte Carlo studies (docs/sweeps.md), on
// threads and, under mpirun, on MPI ranks. The study is read and checked against the model before
// any run (a problem of it: exit 64, located); the library does the rest (src/multibond/sweep/).

#include <filesystem>
#include <iostream>
#include <memory>
#include <optional>
#include <sstream>

#include <fmt/format.h>
#include <unistd.h>

#include "cli.h"
#include "multibond/core/interrupt.h"
#include "multibond/io/yaml_document.h"
#include "multibond/sweep/mpi_backend.h"
#include "multibond/sweep/samples.h"
#include "multibond/sweep/sweep.h"
#include "run_options.h"

namespace multibond::cli {

namespace {

struct SweepArgs {
  sweep::StudyArguments study;
  std::string out;
  RunArgs run;
  int threads = 0;
  bool resume = false, no_progress = false;
};

/// Every diagnostic a problem of the study (sweep.*): exit 64, else the model's.
bool StudyProblem(const ModelError& e) {
  for (const Diagnostic& d : e.diagnostics())
    if (d.code.rfind("sweep.", 0) != 0) return false;
  return !e.diagnostics().empty();
}

int RunSweepCommand(const SweepArgs& a, const std::vector<std::string>& argv) {
  // Under mpirun only rank 0 speaks: the others' messages would be the same.
  std::ostringstream quiet;
  std::streambuf* cerr_buf = nullptr;
  if (sweep::EnvironmentRank() != 0) cerr_buf = std::cerr.rdbuf(quiet.rdbuf());
  struct Restore {
    std::streambuf* b;
    ~Restore() {
      if (b) std::cerr.rdbuf(b);
    }
  } restore{cerr_buf};

  const InputLimits limits = ParseLimits(a.run.load.limits);
  std::string model_text;
  std::unique_ptr<sweep::Runner> runner;
  sweep::Study study;
  try {
    DiagnosticSink problems;
    sweep::StudyArguments args = a.study;
    for (const ParameterOverride& o : ParseSets(a.run.load.sets)) args.set.push_back({o.name, o.value});
    study = sweep::StudyFromArguments(args, limits, problems, model_text);
    runner = std::make_unique<sweep::Runner>(study, model_text, limits, a.run.jit, problems);
    if (sweep::CountRuns(study) > sweep::kMaxRuns) throw CliExit{kExitUsage, fmt::format("the study has more than {} runs", sweep::kMaxRuns)};
  } catch (const ModelError& e) {
    if (!StudyProblem(e)) throw;
    PrintDiagnostics(e.diagnostics());
    std::cerr << fmt::format("{} problem{} in the study; nothing was run\n", e.diagnostics().size(), e.diagnostics().size() == 1 ? "" : "s");
    return kExitUsage;
  }
  // The run options: the command line over the study's `simulation:` over the model's.
  RunArgs run = a.run;
  if (!run.t_end) run.t_end = study.t_end;
  if (!run.dt) run.dt = study.dt;
  if (!run.rtol) run.rtol = study.rtol;
  if (!run.atol) run.atol = study.atol;
  if (!run.solver) run.solver = study.solver;
  run.load.sets.clear();
  for (const auto& [n, v] : study.set) run.load.sets.push_back(n + "=" + v);
  const PreparedRun nominal = PrepareRun(study.model, run);
  if (nominal.initial == "steady")
    throw CliExit{kExitUsage, "the model starts its runs from a steady state (simulation: initial: steady), which a sweep does not yet find "
                              "for each of its runs: remove it, or sweep from the initial values"};
  runner->set_run_options(nominal.options);

  std::unique_ptr<sweep::MpiSession> mpi;
  if (sweep::LaunchedByMpirun()) mpi = std::make_unique<sweep::MpiSession>();
  sweep::SweepOptions o;
  o.dir = a.out;
  o.command = CommandLine(argv);
  o.threads = a.threads;
  o.resume = a.resume;
  o.progress = !a.no_progress && ::isatty(STDERR_FILENO) && (!mpi || mpi->rank() == 0);
  o.stop = &StopFlag();
  sweep::SweepOutcome out;
  try {
    try {
      out = sweep::RunSweep(study, *runner, model_text, o, mpi.get());
    } catch (const std::invalid_argument& e) {  // --resume of another study's folder
      throw CliExit{kExitUsage, e.what()};
    }
  } catch (const Interrupted& e) {
    if (mpi && mpi->size() > 1) {
      std::cerr << "error: " << e.what() << '\n';
      mpi->Abort(e.ExitCode());
    }
    std::cerr << "error: " << e.what() << '\n';
    return e.ExitCode();
  } catch (...) {
    if (!mpi || mpi->size() == 1) throw;
    // The other ranks would wait for this one forever: say why, then end them all.
    int code = kExitIo;
    try {
      throw;
    } catch (const CliExit& e) {
      std::cerr << "error: " << e.message << '\n';
      code = e.code;
    } catch (const std::exception& e) {
      std::cerr << "error: " << e.what() << '\n';
    }
    mpi->Abort(code);
  }
  if (mpi && mpi->rank() != 0) return kExitOk;
  const sweep::SweepFacts& f = out.facts;
  std::cout << fmt::format("sweep '{}': {} runs ({} failed{}) in {:.3g} s on {} rank{} x {} thread{}; model: {}\n", study.name, f.runs,
                           f.failed, f.resumed ? fmt::format(", {} from the journal", f.resumed) : "", f.wall_seconds, f.ranks,
                           f.ranks == 1 ? "" : "s", f.threads, f.threads == 1 ? "" : "s", nominal.engine());
  for (const sweep::RunResult& r : out.results)
    if (!r.ok) std::cerr << fmt::format("run {} failed: {}\n", r.run, r.reason);
  for (const std::string& p : out.plot_problems) std::cerr << "warning: plot " << p << '\n';
  std::cout << fmt::format("wrote {}\n", (std::filesystem::path(a.out) / "sweep.csv").string());
  return kExitOk;
}

}  // namespace

Command AddSweepCommand(CLI::App& app) {
  auto a = std::make_shared<SweepArgs>();
  CLI::App* cmd = app.add_subcommand("sweep", "Run a parameter sweep or Monte Carlo study (docs/sweeps.md); under mpirun, over its ranks");
  cmd->add_option("study", a->study.path, "study file (names the model), or a model file with the study given here")->required();
  cmd->add_option("-o,--output", a->out, "output folder: sweep.csv, sweep.json, plots/")->required()->check(kPathName);
  cmd->add_option("--grid", a->study.grids, "NAME=FROM:TO[:lin|log]:COUNT, a grid of a model parameter (repeatable: the product)");
  cmd->add_option("--list", a->study.lists, "NAME=V1,V2,...: listed values of a model parameter");
  cmd->add_option("--sample", a->study.samples_of, "NAME=uniform|loguniform:LOW:HIGH or normal|lognormal:MEAN:SD (Monte Carlo)");
  cmd->add_option("--samples", a->study.samples, "number of runs of a sampled study")->check(CLI::Range(1L, 100000000L));
  cmd->add_option("--seed", a->study.seed, "seed of a sampled study (runs are reproducible from it)");
  cmd->add_option("--method", a->study.method, "grid, monte_carlo or latin_hypercube")->check(CLI::IsMember({"grid", "monte_carlo", "latin_hypercube"}));
  cmd->add_option("--keep", a->study.keeps, "NAME=[final|max|min|mean|rms|settling_time[@BAND]|crossing_time@LEVEL|event_time:]EXPRESSION");
  cmd->add_option("--threads", a->threads, "worker threads (per rank; default: every core, 1 per rank under mpirun)")->check(CLI::Range(1, 1024));
  cmd->add_flag("--results", a->study.results, "also each run's full results: DIR/runs/run-<index>.csv");
  cmd->add_flag("--resume", a->resume, "go on with an interrupted sweep in the folder (the same study)");
  cmd->add_flag("--no-progress", a->no_progress, "no progress line");
  AddRunOptions(cmd, a->run);
  return {cmd, [a](const std::vector<std::string>& argv) { return RunSweepCommand(*a, argv); }, [] { return true; }};
}

}  // namespace multibond::cli
