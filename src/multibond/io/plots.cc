#include "multibond/io/plots.h"

#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <map>
#include <stdexcept>
#include <thread>

#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <yaml-cpp/yaml.h>

#include "multibond/causality/causality.h"
#include "multibond/core/interrupt.h"
#include "multibond/core/structure.h"
#include "multibond/io/atomic_file.h"
#include "multibond/io/plot_auto.h"
#include "multibond/io/plot_events.h"
#include "multibond/io/plot_gnuplot.h"
#include "multibond/io/plot_page.h"
#include "multibond/io/plot_table.h"
#include "multibond/io/plot_web.h"
#include "multibond/io/results_folder.h"
#include "multibond/io/safe_text.h"

namespace multibond {

namespace {

/// `key` -> `value` of every "name: {field: value}" entry of a mechanism section (e.g. each joint's
/// child); `sub` reads value from a nested map ("a: {body: P1}").
void NestFromSection(const YAML::Node& root, const char* section, const char* field, const char* sub,
                     std::map<std::string, std::string>& nest) {
  const YAML::Node s = root[section];
  if (!s || !s.IsMap()) return;
  for (const auto& entry : s) {
    const YAML::Node v = entry.second;
    if (!v.IsMap() || !v[field]) continue;
    const YAML::Node target = sub ? v[field][sub] : v[field];
    if (target && target.IsScalar()) nest[entry.first.as<std::string>()] = target.as<std::string>();
  }
}

/// How a figure is called in a warning: "Fig. 19 (fig19-S2-reaction)" or "figure 'spring-m'".
std::string Describe(const Figure& f) {
  return MessageText(f.label.empty() ? fmt::format("figure '{}'", f.name) : fmt::format("{} ({})", f.label, f.name));
}

/// The bond graph figure: the model's multibond graph with causal strokes, drawn in `work` and
/// put into the folder's figures/ and plots/. Returns the files written.
std::vector<std::string> DrawBondGraph(const ResultsFolder& folder, const WorkFolder& work, int figures, int plots, const Figure& f,
                                       const std::string& model, std::vector<std::string>& warnings) {
  const LoadedModel lm = LoadModelFile(model);
  DiagnosticSink sink;
  const Structure s = AnalyzeStructure(lm.graph, lm.compile.default_domain, sink);
  if (sink.has_errors()) {
    warnings.push_back(fmt::format("{} left out: the model '{}' has structural errors (see 'multibond check')", Describe(f), MessageText(model)));
    return {};
  }
  const CausalAssignment c = AssignCausality(lm.graph, s);
  const std::string dot = f.name + ".dot";
  work.Write("plots/" + dot, MakeDot(lm.graph, &s, &c, LinkGrouping(lm)));
  std::vector<std::string> files;
  for (const char* format : {"png", "svg"}) {
    const std::string out = f.name + "." + format;
    std::string error;
    if (RenderWithGraphviz(work.path() + "/plots/" + dot, work.path() + "/figures/" + out, format, &error) &&
        work.Publish("figures/" + out, figures, out))
      files.push_back(folder.PathOf("figures/" + out));
    else
      warnings.push_back(fmt::format("{} ({}) left out: {}", Describe(f), format, MessageText(error)));
  }
  work.Publish("plots/" + dot, plots, dot);
  return files;
}

/// The bond graph figure, or a warning saying why it is left out.
void BondGraphFigure(const ResultsFolder& folder, const WorkFolder& work, int figures_fd, int plots_fd, const Figure& f,
                     const PlotOptions& options, const nlohmann::json& run, PlotReport& report) {
  if (!options.bond_graph) return;
  if (options.model_path.empty()) {
    // run.json's model.file records the run; it is not an instruction to open a file.
    const nlohmann::json* file = run.contains("model") && run["model"].is_object() && run["model"].contains("file") ? &run["model"]["file"] : nullptr;
    const std::string recorded = file && file->is_string() ? file->get<std::string>() : "";
    report.warnings.push_back(fmt::format("{} left out: no model file given (give it with --model FILE){}", Describe(f),
                                          recorded.empty() ? "" : fmt::format("; run.json names '{}', which plot does not open by itself",
                                                                               MessageText(recorded.substr(0, 200)))));
    return;
  }
  try {
    for (std::string& file : DrawBondGraph(folder, work, figures_fd, plots_fd, f, options.model_path, report.warnings))
      report.files.push_back(std::move(file));
  } catch (const ModelError&) {
    // Not its text: the page may be shared, and the diagnostics quote the file.
    report.warnings.push_back(fmt::format("{} left out: the model '{}' does not load (see 'multibond check' on it)", Describe(f),
                                          MessageText(options.model_path)));
  }
}

/// The general figures, with the bond graph first when a model is given.
FigureList GeneralFigures(const PlotTable& table, const PlotOptions& options, std::vector<std::string>& warnings) {
  FigureList list = AutoFigures(table.names(), table.units(), options.max_figures, warnings);
  if (!options.model_path.empty() && options.bond_graph) {
    Figure bg;
    bg.name = "bond-graph";
    bg.caption = "The model's bond graph";
    bg.shows = "Drawn from the model file, with causal strokes, as 'multibond graph' draws it. The SVG is zoomable; hover an element "
               "or a bond for its name and causality.";
    bg.bond_graph = true;
    list.figures.insert(list.figures.begin(), bg);
  }
  return list;
}

}  // namespace

DotOptions LinkGrouping(const LoadedModel& model) {
  DotOptions o;
  try {
    const YAML::Node root = YAML::Load(model.text);
    if (!root.IsMap() || !root["bodies"]) return o;
    NestFromSection(root, "joints", "child", nullptr, o.nest);
    NestFromSection(root, "drives", "body", nullptr, o.nest);
    NestFromSection(root, "gears", "a", "body", o.nest);
  } catch (const std::exception&) {
    return o;
  }
  // Relative velocities "child~parent" (and anything else named "X~Y") go with X.
  for (const Element& e : model.graph.elements()) {
    const std::string prefix = e.name.substr(0, e.name.find('.'));
    const size_t tilde = prefix.find('~');
    if (tilde != std::string::npos && tilde > 0) o.nest[prefix] = prefix.substr(0, tilde);
  }
  o.bond_names = false;
  return o;
}

PlotReport MakeFigures(const std::string& results_dir, const PlotOptions& options) {
  PlotReport report;
  // A wrong figure list is said before anything is read or written.
  if (!options.figures_path.empty()) report.figures = ReadFigureList(options.figures_path, options.limits);
  const ResultsFolder folder(results_dir);
  struct stat st {};
  Fd csv;
  const PlotTable table = PlotTable::Load(folder, options.limits.results_bytes, &st, &csv);
  const nlohmann::json run = ReadRunJson(folder);
  PlotEvents events = ReadPlotEvents(folder, run);
  for (std::string& w : events.warnings) report.warnings.push_back(std::move(w));
  if (options.figures_path.empty()) report.figures = GeneralFigures(table, options, report.warnings);
  const Fd figures_dir = folder.OutputDir("figures"), plots_dir = folder.OutputDir("plots");
  const int figures_fd = figures_dir.get(), plots_fd = plots_dir.get();
  // gnuplot and dot write into a private folder; finished files are renamed into place.
  const WorkFolder work(folder);
  work.AddInput(folder, "results.csv", csv.get(), st);

  // Write every script, then run gnuplot on them, a few at a time.
  std::vector<const Figure*> drawn;
  size_t over = 0;
  for (const Figure& f : report.figures.figures) {
    if (f.bond_graph) {
      BondGraphFigure(folder, work, figures_fd, plots_fd, f, options, run, report);
      continue;
    }
    std::vector<std::string> missing;
    for (const std::string& c : f.Columns())
      if (!table.Has(c)) missing.push_back(c);
    if (!missing.empty()) {
      std::string list;
      for (size_t k = 0; k < missing.size() && k < 5; ++k) list += (list.empty() ? "" : ", ") + missing[k];
      if (missing.size() > 5) list += fmt::format(" and {} more", missing.size() - 5);
      report.warnings.push_back(fmt::format("{} left out: results.csv has no column {}", Describe(f), MessageText(list)));
      continue;
    }
    if (drawn.size() >= options.max_figures) {
      ++over;
      continue;
    }
    work.Write("plots/" + f.name + ".gp", GnuplotScript(table, f, {options.zoom_length, options.path_stride}, events.events));
    drawn.push_back(&f);
  }
  if (over > 0)
    report.warnings.push_back(fmt::format("{} figures of the list left out: at most {} are drawn (raise it with --max-figures N)", over,
                                          options.max_figures));
  std::vector<std::string> names;
  for (const Figure* f : drawn) names.push_back(f->name);
  auto publish_scripts = [&] {
    for (const std::string& n : names) work.Publish("plots/" + n + ".gp", plots_fd, n + ".gp");
  };
  const int jobs = options.jobs > 0 ? options.jobs : std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
  std::map<std::string, std::string> failures;
  try {
    failures = RunGnuplot(work, plots_fd, names, options.gnuplot, jobs, options.progress);
  } catch (const Interrupted&) {
    throw;
  } catch (const std::runtime_error& e) {
    publish_scripts();
    throw std::runtime_error(fmt::format("{}; the scripts are in {}", e.what(), folder.PathOf("plots")));
  }
  publish_scripts();

  for (const Figure* f : drawn) {
    work.Publish("plots/" + f->name + ".ranges", plots_fd, f->name + ".ranges");
    if (failures.count(f->name)) {
      report.warnings.push_back(fmt::format("{} failed: {}", Describe(*f), failures[f->name]));
      continue;
    }
    for (const char* ext : {".png", ".svg"}) {
      const std::string name = f->name + ext;
      if (IsNonEmptyRegularFile(work.fd(), "figures/" + name) && work.Publish("figures/" + name, figures_fd, name))
        report.files.push_back(folder.PathOf("figures/" + name));
      else
        report.warnings.push_back(fmt::format("{}: gnuplot wrote no {}", Describe(*f), MessageText(folder.PathOf("figures/" + name))));
    }
  }
  return report;
}

void WriteResultsPage(const std::string& results_dir, const PlotReport& report, const InputLimits& limits, const std::string& model_path) {
  const ResultsFolder folder(results_dir);
  struct stat st {};
  const PlotTable table = PlotTable::Load(folder, limits.results_bytes, &st);
  const nlohmann::json run = ReadRunJson(folder);
  const Fd figures_dir = folder.ExistingDir("figures");
  std::vector<std::string> ignored;
  const FigureList general = report.figures.figures.empty() ? AutoFigures(table.names(), table.units(), PlotOptions{}.max_figures, ignored)
                                                            : FigureList{};
  const FigureList& list = report.figures.figures.empty() ? general : report.figures;
  // events.csv again: its warnings are the page's too, once (MakeFigures has given them already).
  const PlotEvents events = ReadPlotEvents(folder, run);
  std::vector<std::string> warnings = report.warnings;
  for (const std::string& w : events.warnings)
    if (std::find(warnings.begin(), warnings.end(), w) == warnings.end()) warnings.push_back(w);
  const PageApp app = PreparePage(folder, table, events.events, model_path, limits, FindPageAssets());
  WriteFileAtomic((std::filesystem::path(results_dir) / "index.html").string(),
                  ResultsPageHtml(table, run, list, warnings, figures_dir.get(), events.events, &app));
}

}  // namespace multibond
