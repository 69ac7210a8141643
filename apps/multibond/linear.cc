// multibond linearize | modes | bode: the linear model about an operating point, its modes with
// energy participation, its frequency response (docs/linear-analysis.md). The commands parse,
// find the operating point (a run to --at T, or a steady state), call the analysis layer and
// write its files atomically into the output folder.

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <iostream>
#include <memory>
#include <sstream>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "cli.h"
#include "multibond/analysis/bode.h"
#include "multibond/analysis/linear_files.h"
#include "multibond/analysis/linearize.h"
#include "multibond/analysis/modes.h"
#include "multibond/core/interrupt.h"
#include "multibond/io/atomic_file.h"
#include "multibond/io/did_you_mean.h"
#include "multibond/io/output_folder.h"
#include "multibond/io/results_writer.h"
#include "run_options.h"

namespace multibond::cli {

namespace {

namespace fs = std::filesystem;

struct LinearArgs {
  RunArgs run;
  std::string model, out;
  std::optional<double> at;
  bool steady = false;
  bool quiet = false;
  // bode
  std::string input, output;
  std::vector<double> freqs;
};

struct OperatingPoint {
  double t = 0.0;
  Eigen::VectorXd x;
  RunSummary summary;
};

/// The state at --at T (a run from the start), or the initial state; then, with --steady, the
/// steady state found from there.
OperatingPoint FindOperatingPoint(const PreparedRun& p, const LinearArgs& a) {
  const CompiledModel& model = *p.model;
  OperatingPoint op;
  op.t = p.options.t_start;
  op.x = p.options.initial_state.size() > 0 ? p.options.initial_state : model.MakeInitialState();  // initial: steady
  if (a.at && *a.at != p.options.t_start) {
    RunOptions o;
    try {
      o = linear::RunToOperatingPoint(p.options, *a.at, "--at");
    } catch (const std::invalid_argument& e) {
      throw CliExit{kExitUsage, e.what()};
    }
    const bool tty = isatty(fileno(stderr)) && !a.quiet;
    if (tty) o.progress = [&](double f) { std::fprintf(stderr, "\r  running to the operating point: t = %-10.4g s  %3.0f%%", o.t_start + f * (o.t_end - o.t_start), 100 * f); };
    linear::FinalState last;
    op.summary = Simulate(model, o, last);
    if (tty) std::fprintf(stderr, "\n");
    if (op.summary.status != RunStatus::kOk)
      throw CliExit{kExitSolver, fmt::format("the run to the operating point at t = {:g} s stopped: {}", *a.at, op.summary.message)};
    op.t = *a.at;
    op.x = last.State(model.num_states());
  }
  if (a.steady) {
    try {
      op.x = linear::FindSteadyState(model, op.t, op.x);
    } catch (const std::runtime_error& e) {
      throw CliExit{kExitSolver, std::string(e.what()) + "\n  hint: start Newton's method nearer to it: --at T after a run that settles, or other initial values"};
    }
  }
  return op;
}

struct Prepared {
  PreparedRun p;
  OperatingPoint op;
  linear::LinearModel lm;
  nlohmann::json record;
};

Prepared Prepare(const LinearArgs& a, const std::vector<std::string>& argv, const char* command) {
  Prepared r{PrepareRun(a.model, a.run), {}, {}, {}};
  std::string why;
  if (!r.p.model->can_linearize(&why))
    throw CliExit{kExitModel, fmt::format("{}: cannot linearise a model with {}\n  hint: it runs; a variant with a compliant "
                                          "coupling (a stiff C and an R in place of the rigid one) can be linearised", a.model, why)};
  r.op = FindOperatingPoint(r.p, a);
  r.lm = linear::Linearize(*r.p.model, r.op.t, r.op.x);
  r.lm.steady = a.steady;
  r.record = MakeRunRecord(a.model, r.p.lm.text, r.p.lm.graph.name(), r.p.options, r.op.summary, argv);
  r.record["command"] = command;
  r.record["rhs_engine"] = r.p.engine();
  r.record["options"]["at"] = r.op.t;
  r.record["options"]["steady"] = a.steady;
  // An operating point on a kink: every linear command says so (linearize lists it among its
  // notes too), on the terminal and in the record.
  nlohmann::json warnings = nlohmann::json::array();
  for (const std::string& n : r.lm.notes)
    if (n.rfind(linear::kOnKinkNote, 0) == 0) {
      warnings.push_back(n);
      if (!a.quiet) std::cerr << "warning: " << n << '\n';
    }
  if (!warnings.empty()) r.record["warnings"] = warnings;
  return r;
}

/// Writes `files` (name, text) into the output folder, all or none.
void WriteFiles(const std::string& out, const std::string& model_path, const std::vector<std::pair<std::string, std::string>>& files,
                const std::vector<std::string>& argv) {
  std::vector<fs::path> paths;
  for (const auto& [name, text] : files) paths.push_back(fs::path(out) / name);
  RefuseWritingOnto(paths, {model_path});
  const OutputFolder folder(out, CommandLine(argv));
  ReportRemovedTemporaries(folder);
  std::vector<std::unique_ptr<AtomicFile>> staged;
  for (const auto& [name, text] : files) {
    staged.push_back(std::make_unique<AtomicFile>(folder.File(name)));
    staged.back()->Write(text);
    staged.back()->Finish();
  }
  for (auto& f : staged) f->Publish();
}

std::string EigenvalueSummary(const linear::LinearModel& lm) {
  return fmt::format("{}: {} states, {} inputs, {} outputs at t = {:g} s{}", lm.model, lm.states.size(), lm.inputs.size(),
                     lm.outputs.size(), lm.at, lm.steady ? " (steady state)" : "");
}

int Linearize(const LinearArgs& a, const std::vector<std::string>& argv) {
  Prepared r = Prepare(a, argv, "linearize");
  const nlohmann::json j = linear::LinearJson(r.lm, r.record);
  WriteFiles(a.out, a.model, {{"linear.json", DumpRecord(j)}, {"linear.m", linear::LinearOctaveScript(r.lm)}}, argv);
  if (!a.quiet) {
    std::cout << EigenvalueSummary(r.lm) << '\n';
    for (const std::string& n : r.lm.notes) std::cout << "note: " << n << '\n';
    std::cout << fmt::format("wrote {}/linear.json and {}/linear.m\n", a.out, a.out);
  }
  return kExitOk;
}

int Modes(const LinearArgs& a, const std::vector<std::string>& argv) {
  Prepared r = Prepare(a, argv, "modes");
  const std::vector<linear::Mode> modes = linear::ComputeModes(r.lm);
  nlohmann::json j = linear::ModesJson(modes, r.lm);
  j["record"] = r.record;
  WriteFiles(a.out, a.model, {{"modes.json", DumpRecord(j)}, {"linear.json", DumpRecord(linear::LinearJson(r.lm, r.record))}}, argv);
  if (!a.quiet) {
    std::cout << EigenvalueSummary(r.lm) << '\n' << linear::ModesTable(modes);
    std::cout << fmt::format("wrote {}/modes.json and {}/linear.json\n", a.out, a.out);
  }
  return kExitOk;
}

int Find(const std::vector<std::string>& names, const std::string& name, const char* what, const char* option) {
  for (size_t i = 0; i < names.size(); ++i)
    if (names[i] == name) return static_cast<int>(i);
  std::string known;
  for (const std::string& n : names) known += (known.empty() ? "" : ", ") + n;
  const std::string hint = DidYouMean(name, names);
  throw CliExit{kExitUsage, fmt::format("{} '{}' is no {} of the model{}\n  the {}s: {}", option, name, what,
                                        hint.empty() ? "" : " (did you mean '" + hint + "'?)", what, known.empty() ? "none" : known)};
}

int Bode(const LinearArgs& a, const std::vector<std::string>& argv) {
  Prepared r = Prepare(a, argv, "bode");
  const int in = Find(r.lm.inputs, a.input, "input", "--input");
  const int out = Find(r.lm.outputs, a.output, "output", "--output");
  const std::vector<double> freqs = a.freqs.empty() ? linear::DefaultFrequencies(r.lm) : a.freqs;
  std::vector<linear::BodePoint> points;
  try {
    points = linear::FrequencyResponse(r.lm, in, out, freqs);
  } catch (const std::invalid_argument& e) {
    throw CliExit{kExitUsage, e.what()};
  }
  const std::string csv = linear::BodeCsv(points);
  WriteFiles(a.out, a.model, {{"bode.csv", csv}, {"linear.json", DumpRecord(linear::LinearJson(r.lm, r.record))}}, argv);
  std::string plot_note;
  try {
    const std::vector<std::string> pictures =
        linear::DrawBodePlot(a.out, "bode.csv", "bode", fmt::format("{}: from {} to {}", r.lm.model, a.input, a.output));
    for (const std::string& f : pictures) plot_note += (plot_note.empty() ? "drew " : ", ") + f;
  } catch (const std::exception& e) {
    plot_note = std::string("no Bode plot: ") + e.what();  // the numbers are written; the picture needs gnuplot
  }
  if (!a.quiet) {
    std::cout << EigenvalueSummary(r.lm) << '\n';
    std::cout << fmt::format("frequency response from {} to {} at {} frequencies, {:g} to {:g} Hz\n", a.input, a.output, points.size(),
                             freqs.front(), freqs.back());
    std::cout << fmt::format("wrote {}/bode.csv and {}/linear.json\n", a.out, a.out);
    if (!plot_note.empty()) std::cout << plot_note << '\n';
  }
  return kExitOk;
}

/// `folder`: the output folder's option names (bode's --output names the output variable).
CLI::App* AddCommon(CLI::App& app, const char* name, const char* what, const std::shared_ptr<LinearArgs>& a,
                    const char* folder = "-o,--output") {
  CLI::App* cmd = app.add_subcommand(name, what);
  cmd->add_option("MODEL", a->model, "model file (YAML)")->required();
  cmd->add_option(folder, a->out, "output folder")->required()->check(kPathName);
  cmd->add_option("--at", a->at, "operating point: the state at time T [s] of a run from the start (default: the initial state)")
      ->check(kNonNegative);
  cmd->add_flag("--steady", a->steady, "operating point: a steady state found by Newton's method (from the state at --at, or the initial state)");
  AddRunOptions(cmd, a->run);
  cmd->add_flag("-q,--quiet", a->quiet, "no progress and no summary");
  return cmd;
}

}  // namespace

Command AddLinearizeCommand(CLI::App& app) {
  auto a = std::make_shared<LinearArgs>();
  CLI::App* cmd = AddCommon(app, "linearize", "Linearise about an operating point: write DIR/linear.json (A, B, C, D, eigenvalues) and DIR/linear.m", a);
  return {cmd, [a](const std::vector<std::string>& argv) { return Linearize(*a, argv); }, [] { return true; }};
}

Command AddModesCommand(CLI::App& app) {
  auto a = std::make_shared<LinearArgs>();
  CLI::App* cmd = AddCommon(app, "modes", "Modes of the linear model: frequency, damping, time constant, energy participation of each storage element (DIR/modes.json)", a);
  return {cmd, [a](const std::vector<std::string>& argv) { return Modes(*a, argv); }, [] { return true; }};
}

Command AddBodeCommand(CLI::App& app) {
  auto a = std::make_shared<LinearArgs>();
  CLI::App* cmd = AddCommon(app, "bode", "Frequency response of the linear model from one input to one output (DIR/bode.csv and a Bode plot)", a,
                             "-o,--dir");
  cmd->add_option("--input", a->input, "the input: a source (Se, Sf, drive) or one of its components")->required();
  cmd->add_option("--output", a->output, "the output: a declared output (or one of its components)")->required();
  cmd->add_option("--freq", a->freqs, "frequencies [Hz], comma-separated (default: a log grid around the modes)")->delimiter(',')->check(kPositive);
  return {cmd, [a](const std::vector<std::string>& argv) { return Bode(*a, argv); }, [] { return true; }};
}

}  // namespace multibond::cli
