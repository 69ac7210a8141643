#include "multibond/io/plots.h"

#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <map>
#include <optional>
#include <stdexcept>
#include <thread>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "multibond/core/interrupt.h"
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

/// How a figure is called in a warning: "Fig. 19 (fig19-S2-reaction)" or "figure 'spring-m'".
std::string Describe(const Figure& f) {
  return MessageText(f.label.empty() ? fmt::format("figure '{}'", f.name) : fmt::format("{} ({})", f.label, f.name));
}

/// The bond graph figure: the model's multibond graph with causal strokes, drawn in `work` (with
/// its layout for the page, in the same Graphviz run) and put into the folder's figures/ and
/// plots/.
void BondGraphFigure(const PlotInputs& in, const WorkFolder& work, int figures_fd, int plots_fd, const Figure& f,
                     const PlotOptions& options, PlotReport& report) {
  if (!options.bond_graph) return;
  const PlotModel& model = in.model;
  if (!model.given()) {
    // run.json's model.file records the run; it is not an instruction to open a file.
    const nlohmann::json& run = in.run;
    const nlohmann::json* file = run.contains("model") && run["model"].is_object() && run["model"].contains("file") ? &run["model"]["file"] : nullptr;
    const std::string recorded = file && file->is_string() ? file->get<std::string>() : "";
    report.warnings.push_back(fmt::format("{} left out: no model file given (give it with --model FILE){}", Describe(f),
                                          recorded.empty() ? "" : fmt::format("; run.json names '{}', which plot does not open by itself",
                                                                               MessageText(recorded.substr(0, 200)))));
    return;
  }
  if (!model.loaded) {
    // Not its text: the page may be shared, and the diagnostics quote the file.
    report.warnings.push_back(fmt::format("{} left out: the model '{}' does not load (see 'multibond check' on it)", Describe(f),
                                          MessageText(model.path)));
    return;
  }
  if (model.dot.empty()) {
    report.warnings.push_back(
        fmt::format("{} left out: the model '{}' has structural errors (see 'multibond check')", Describe(f), MessageText(model.path)));
    return;
  }
  std::string error;
  const std::optional<std::string> layout =
      LayOutBondGraph(model, work, f.name, {{"png", "figures/" + f.name + ".png"}, {"svg", "figures/" + f.name + ".svg"}}, &error);
  if (layout && report.graph_layout.empty()) report.graph_layout = *layout;
  for (const char* format : {"png", "svg"}) {
    const std::string out = f.name + "." + format;
    if (layout && work.Publish("figures/" + out, figures_fd, out))
      report.files.push_back(in.folder.PathOf("figures/" + out));
    else
      report.warnings.push_back(fmt::format("{} ({}) left out: {}", Describe(f), format, MessageText(layout ? "dot wrote no file" : error)));
  }
  work.Publish("plots/" + f.name + ".dot", plots_fd, f.name + ".dot");
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

PlotInputs::PlotInputs(const std::string& results_dir, const PlotOptions& options)
    : figures(options.figures_path.empty() ? FigureList{} : ReadFigureList(options.figures_path, options.limits)),
      folder(results_dir),
      table(PlotTable::Load(folder, options.limits.results_bytes, &csv_status)),
      run(ReadRunJson(folder)),
      events(ReadPlotEvents(folder, run)),
      model(PlotModel::Read(options.model_path, options.limits)) {}

PlotReport MakeFigures(const std::string& results_dir, const PlotOptions& options) {
  return MakeFigures(PlotInputs(results_dir, options), options);
}

PlotReport MakeFigures(const PlotInputs& in, const PlotOptions& options) {
  PlotReport report;
  const PlotTable& table = in.table;
  const ResultsFolder& folder = in.folder;
  report.figures = in.figures;
  for (const std::string& w : in.events.warnings) report.warnings.push_back(w);
  if (options.figures_path.empty()) report.figures = GeneralFigures(table, options, report.warnings);
  const Fd figures_dir = folder.OutputDir("figures"), plots_dir = folder.OutputDir("plots");
  const int figures_fd = figures_dir.get(), plots_fd = plots_dir.get();
  // gnuplot and dot write into a private folder; finished files are renamed into place.
  const WorkFolder work(folder);

  // Write every script, then run gnuplot on them, a few at a time.
  std::vector<const Figure*> drawn;
  size_t over = 0;
  for (const Figure& f : report.figures.figures) {
    if (f.bond_graph) {
      BondGraphFigure(in, work, figures_fd, plots_fd, f, options, report);
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
    work.Write("plots/" + f.name + ".gp", GnuplotScript(table, f, {options.zoom_length, options.path_stride}, in.events.events));
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

void WriteResultsPage(const PlotInputs& in, const PlotReport& report) {
  const Fd figures_dir = in.folder.ExistingDir("figures");
  std::vector<std::string> ignored;
  const FigureList general = report.figures.figures.empty() ? AutoFigures(in.table.names(), in.table.units(), PlotOptions{}.max_figures, ignored)
                                                            : FigureList{};
  const FigureList& list = report.figures.figures.empty() ? general : report.figures;
  // events.csv's warnings are the page's too, once (MakeFigures has given them already).
  std::vector<std::string> warnings = report.warnings;
  for (const std::string& w : in.events.warnings)
    if (std::find(warnings.begin(), warnings.end(), w) == warnings.end()) warnings.push_back(w);
  const PageApp app = PreparePage(in.folder, in.table, in.events.events, in.model, report.graph_layout, FindPageAssets());
  WriteFileAtomic((std::filesystem::path(in.folder.path()) / "index.html").string(),
                  ResultsPageHtml(in.table, in.run, list, warnings, figures_dir.get(), in.events.events, &app));
}

void WriteResultsPage(const std::string& results_dir, const PlotReport& report, const InputLimits& limits, const std::string& model_path) {
  PlotOptions options;
  options.limits = limits;
  options.model_path = model_path;
  WriteResultsPage(PlotInputs(results_dir, options), report);
}

}  // namespace multibond
