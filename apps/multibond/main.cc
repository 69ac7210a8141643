// multibond: the command-line front end. It parses arguments, calls the library and maps its
// three error channels to exit codes: 0 ok, 1 model error, 2 solver error, 64 usage,
// 74 output cannot be written, 130 interrupted.

#include <unistd.h>

#include <atomic>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <optional>

#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include "multibond/compile/equations.h"
#include "multibond/io/dot_writer.h"
#include "multibond/io/model_loader.h"
#include "multibond/io/plots.h"
#include "multibond/io/results_writer.h"
#include "multibond/version.h"

namespace mb = multibond;
namespace fs = std::filesystem;

namespace {

constexpr int kExitOk = 0, kExitModel = 1, kExitSolver = 2, kExitUsage = 64, kExitIo = 74, kExitInterrupted = 130;

std::atomic<bool> g_stop{false};
extern "C" void OnSignal(int) { g_stop.store(true); }

void PrintDiagnostics(const std::vector<mb::Diagnostic>& ds) {
  for (const auto& d : ds) std::cerr << d.ToString() << '\n';
}

int ModelFailure(const mb::ModelError& e, bool wrote_nothing) {
  PrintDiagnostics(e.diagnostics());
  int errors = 0;
  for (const auto& d : e.diagnostics()) errors += d.severity == mb::Diagnostic::Severity::kError;
  std::cerr << fmt::format("{} error{} in the model{}\n", errors, errors == 1 ? "" : "s", wrote_nothing ? "; nothing was written" : "");
  return kExitModel;
}

std::string Stroke(const mb::BondGraph& g, const mb::CausalAssignment& c, int b) {
  const mb::Bond& bond = g.bond(b);
  const int effort_from = c.stroke_at_head[b] ? bond.from : bond.to;
  return fmt::format("effort from {}, flow from {}", mb::Describe(g, effort_from), mb::Describe(g, g.Other(b, effort_from)));
}

mb::LoadedModel Load(const std::string& path) {
  mb::LoadedModel lm = mb::LoadModelFile(path);
  PrintDiagnostics(lm.warnings);
  return lm;
}

int Check(const std::string& path) {
  const mb::LoadedModel lm = Load(path);
  const mb::BondGraph& g = lm.graph;
  mb::DiagnosticSink sink;
  const mb::Structure s = mb::AnalyzeStructure(g, lm.compile.default_domain, sink);
  sink.ThrowIfErrors();
  mb::CausalAssignment c = mb::AssignCausality(g, s);
  if (lm.mechanism) mb::ExplainInMechanismTerms(*lm.mechanism, c.diagnostics);
  std::cout << fmt::format("model '{}' ({}): {} elements, {} bonds\n\n", g.name(), path, g.num_elements(), g.num_bonds());
  std::cout << "causality (the causal stroke is at the element that receives the effort):\n";
  for (int b = 0; b < g.num_bonds(); ++b) {
    const mb::Bond& bond = g.bond(b);
    const std::string arrow = c.stroke_at_head[b] ? fmt::format("{} -->| {}", g.element(bond.from).name, g.element(bond.to).name)
                                                  : fmt::format("{} |--> {}", g.element(bond.from).name, g.element(bond.to).name);
    std::cout << fmt::format("  {:<40} [{}]  {}\n", arrow, s.bond_dim[b], Stroke(g, c, b));
  }
  PrintDiagnostics(c.diagnostics);
  if (c.has_errors()) {
    if (!c.derivative.empty())
      std::cout << fmt::format("\nnot integrally causal: {} storage element{} in derivative causality\n", c.derivative.size(),
                               c.derivative.size() == 1 ? "" : "s");
    else
      std::cout << "\ncausality conflicts: see the errors above\n";
    return kExitModel;
  }
  const auto model = mb::CompiledModel::Compile(lm.graph, lm.compile);  // also finds algebraic loops
  (void)mb::MakeColumns(*model, false);  // and checks the declared outputs
  std::cout << fmt::format("\nintegrally causal; {} states ({} instructions in the plan):\n", model->num_states(), model->num_instructions());
  for (int i = 0; i < model->num_states(); ++i)
    std::cout << fmt::format("  {} [{}]\n", model->state_names()[i], model->state_units()[i]);
  return kExitOk;
}

int Equations(const std::string& path, const std::string& format) {
  const mb::LoadedModel lm = Load(path);
  const auto model = mb::CompiledModel::Compile(lm.graph, lm.compile);
  std::cout << mb::FormatEquations(*model, format == "latex" ? mb::EquationFormat::kLatex : mb::EquationFormat::kText);
  return kExitOk;
}

int Graph(const std::string& path, const std::string& out) {
  const mb::LoadedModel lm = Load(path);
  mb::DiagnosticSink sink;
  const mb::Structure s = mb::AnalyzeStructure(lm.graph, lm.compile.default_domain, sink);
  sink.ThrowIfErrors();
  const mb::CausalAssignment c = mb::AssignCausality(lm.graph, s);
  const std::string dot = mb::MakeDot(lm.graph, &s, &c, mb::LinkGrouping(lm));
  const fs::path outp(out);
  const std::string ext = outp.extension().string();
  const fs::path dot_path = ext == ".dot" || ext == ".gv" ? outp : fs::path(outp).replace_extension(".dot");
  if (dot_path.has_parent_path()) fs::create_directories(dot_path.parent_path());
  mb::WriteFileAtomic(dot_path.string(), dot);
  std::cout << "wrote " << dot_path.string() << '\n';
  const std::vector<std::string> formats = ext == ".png" ? std::vector<std::string>{"png"} : std::vector<std::string>{"svg"};
  for (const auto& f : formats) {
    const fs::path img = fs::path(dot_path).replace_extension("." + f);
    std::string err;
    if (mb::RenderWithGraphviz(dot_path.string(), img.string(), f, &err)) std::cout << "wrote " << img.string() << '\n';
    else std::cerr << "note: " << err << " (the DOT file is there; install graphviz to render it)\n";
  }
  return kExitOk;
}

struct RunArgs {
  std::string model, out;
  std::optional<double> t_end, dt, rtol, atol, step, max_step;
  std::optional<std::string> solver;
  bool all_variables = false, quiet = false, no_projection = false;
  std::string jit = "auto";
};

int Run(const RunArgs& a, const std::vector<std::string>& argv) {
  const mb::LoadedModel lm = Load(a.model);
  mb::CompileOptions co = lm.compile;
  co.generate_code = a.jit != "off";
  const auto model = mb::CompiledModel::Compile(lm.graph, co);
  if (a.jit == "on" && !model->uses_generated_code()) {
    std::cerr << "error: --jit on, but " << model->rhs_engine() << '\n';
    return kExitIo;
  }
  const mb::SimulationDefaults& d = lm.simulation;
  mb::RunOptions o;
  o.t_end = a.t_end.value_or(d.t_end.value_or(1.0));
  o.dt = a.dt.value_or(d.dt.value_or(1e-3));
  const std::string solver = a.solver.value_or(d.solver.value_or("bdf"));
  try {
    o.integrator.method = mb::ParseMethod(solver);
  } catch (const std::invalid_argument& e) {
    std::cerr << "error: " << e.what() << '\n';
    return kExitUsage;
  }
  o.integrator.rtol = a.rtol.value_or(d.rtol.value_or(1e-8));
  o.integrator.atol = a.atol.value_or(d.atol.value_or(1e-10));
  o.integrator.fixed_step = a.step.value_or(d.step.value_or(0.0));
  o.integrator.max_step = a.max_step.value_or(d.max_step.value_or(0.0));
  o.all_variables = a.all_variables;
  o.integrator.project = !a.no_projection;
  o.stop = &g_stop;
  (void)mb::MakeColumns(*model, o.all_variables);  // a bad output is a model error: before any file is touched
  const bool tty = isatty(fileno(stderr)) && !a.quiet;
  if (tty) o.progress = [&](double f) { std::fprintf(stderr, "\r  t = %-10.4g s  %3.0f%%", o.t_start + f * (o.t_end - o.t_start), 100 * f); };

  // The model compiled: only now is the output folder touched.
  std::error_code ec;
  fs::create_directories(a.out, ec);
  if (ec) {
    std::cerr << fmt::format("error: cannot create output folder '{}': {}\n", a.out, ec.message());
    return kExitIo;
  }
  mb::CsvWriter csv((fs::path(a.out) / "results.csv").string());
  std::signal(SIGINT, OnSignal);
  std::signal(SIGTERM, OnSignal);
  mb::RunSummary summary;
  try {
    summary = mb::Simulate(*model, o, csv);
  } catch (const std::invalid_argument& e) {
    std::cerr << "error: " << e.what() << '\n';
    return kExitUsage;
  }
  if (tty) std::fprintf(stderr, "\n");
  nlohmann::json record = mb::MakeRunRecord(a.model, lm.text, lm.graph.name(), o, summary, argv);
  record["rhs_engine"] = model->rhs_engine();
  record["options"]["jit"] = a.jit;
  mb::WriteFileAtomic((fs::path(a.out) / "run.json").string(), record.dump(2) + "\n");
  if (!a.quiet || summary.status != mb::RunStatus::kOk) {
    std::cout << fmt::format("{}: {} to t = {:g} s with {} ({} steps, {} right-hand sides, {:.3f} s wall)\n",
                             lm.graph.name(), mb::RunStatusName(summary.status), summary.t_reached, solver, summary.stats.steps,
                             summary.stats.rhs_evals, summary.wall_seconds);
    if (model->has_energy_account())
      std::cout << fmt::format("energy: work {:.9g} J, stored {:.9g} J, dissipated {:.9g} J, residual {:.3g}\n", summary.energy_work,
                               summary.energy_stored, summary.energy_dissipated, summary.energy_residual);
    std::cout << fmt::format("wrote {}/results.csv and {}/run.json\n", a.out, a.out);
  }
  if (summary.status == mb::RunStatus::kFailed) {
    std::cerr << "error: the simulation failed " << summary.message << "\n  the results up to then are kept; run.json marks the run as failed\n"
              << "  hint: try a tighter tolerance (--rtol), a stiff solver (--solver bdf) or check the model's parameters\n";
    return kExitSolver;
  }
  if (summary.status == mb::RunStatus::kInterrupted) {
    std::cerr << summary.message << "; the results up to then are kept\n";
    return kExitInterrupted;
  }
  return kExitOk;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"multibond: model and simulate mechanisms as multibond graphs", "multibond"};
  app.require_subcommand(1);
  app.set_version_flag("--version", std::string(mb::kVersion));

  std::string model, format = "text", out;
  auto* check = app.add_subcommand("check", "Assign causality, print it and the state variables; exit 1 unless integrally causal");
  check->add_option("MODEL", model, "model file (YAML)")->required();

  auto* eq = app.add_subcommand("equations", "Print the state equations generated from the graph, with their causal paths");
  eq->add_option("MODEL", model, "model file (YAML)")->required();
  eq->add_option("--format", format, "text or latex")->check(CLI::IsMember({"text", "latex"}));

  auto* graph = app.add_subcommand("graph", "Draw the bond graph with causal strokes (Graphviz DOT, and SVG/PNG when dot is installed)");
  graph->add_option("MODEL", model, "model file (YAML)")->required();
  graph->add_option("-o,--output", out, "output file: .dot, .svg or .png")->required();

  RunArgs ra;
  auto* run = app.add_subcommand("run", "Simulate and write DIR/results.csv and DIR/run.json");
  run->add_option("MODEL", ra.model, "model file (YAML)")->required();
  run->add_option("-o,--output", ra.out, "output folder")->required();
  run->add_option("--t-end", ra.t_end, "end time [s] (default: the model's, else 1)")->check(CLI::PositiveNumber);
  run->add_option("--dt", ra.dt, "output interval [s] (default: the model's, else 1e-3)")->check(CLI::PositiveNumber);
  run->add_option("--solver", ra.solver, "bdf, adams, dopri5 or rk4 (default: the model's, else bdf)");
  run->add_option("--rtol", ra.rtol, "relative tolerance (default 1e-8)")->check(CLI::PositiveNumber);
  run->add_option("--atol", ra.atol, "absolute tolerance (default 1e-10)")->check(CLI::PositiveNumber);
  run->add_option("--step", ra.step, "fixed step [s] for rk4 (or a fixed-step dopri5)")->check(CLI::PositiveNumber);
  run->add_option("--max-step", ra.max_step, "largest step [s] of the adaptive methods")->check(CLI::PositiveNumber);
  run->add_flag("--all-variables", ra.all_variables, "add a column for every effort and flow");
  run->add_option("--jit", ra.jit,
                  "right-hand side as generated C++ compiled with the system compiler (auto: when one works; "
                  "off: the plan interpreter)")
      ->check(CLI::IsMember({"auto", "on", "off"}));
  run->add_flag("--no-projection", ra.no_projection,
                "do not re-orthonormalise orientation matrices after each step (shows the raw drift)");
  run->add_flag("-q,--quiet", ra.quiet, "no progress and no summary");

  std::string plot_dir, plot_model;
  auto* plot = app.add_subcommand("plot", "Draw the paper's figures (Figs. 2-33) from a results folder and write DIR/index.html");
  plot->add_option("DIR", plot_dir, "results folder of 'multibond run'")->required();
  plot->add_option("--model", plot_model, "model file, for the bond graph (default: the one named in DIR/run.json)");

  app.add_subcommand("version", "Print the version");

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);
    return code == 0 ? kExitOk : kExitUsage;
  }
  const std::vector<std::string> args(argv, argv + argc);
  try {
    if (app.got_subcommand("version")) {
      std::cout << "multibond " << mb::kVersion << '\n';
      return kExitOk;
    }
    if (*check) return Check(model);
    if (*eq) return Equations(model, format);
    if (*graph) return Graph(model, out);
    if (*run) return Run(ra, args);
    if (*plot) {
      mb::PlotOptions po;
      po.model_path = plot_model;
      const mb::PlotReport report = mb::MakePaperFigures(plot_dir, po);
      for (const auto& w : report.warnings) std::cerr << "warning: " << w << '\n';
      mb::WriteResultsPage(plot_dir, report);
      std::cout << fmt::format("wrote {} figure files in {}/figures and {}/index.html\n", report.files.size(), plot_dir, plot_dir);
      return report.files.empty() ? kExitIo : kExitOk;
    }
  } catch (const mb::ModelError& e) {
    return ModelFailure(e, *run || *graph);
  } catch (const mb::SolverError& e) {
    std::cerr << "error: solver failure " << e.what() << '\n';
    return kExitSolver;
  } catch (const std::filesystem::filesystem_error& e) {
    std::cerr << "error: " << e.what() << '\n';
    return kExitIo;
  } catch (const std::exception& e) {
    std::cerr << "error: " << e.what() << '\n';
    return kExitIo;
  }
  return kExitUsage;
}
