#pragma once
/// \file
/// `multibond plot DIR`: figures from a results folder, and a page that shows them.
///
/// MakeFigures reads DIR/results.csv (and DIR/run.json, and DIR/events.csv when the run had events:
/// they are marked on every plot against time, plot_events.h) and draws, with gnuplot, either the
/// general figures of any run (every output against time, grouped by element and unit, and the
/// energy account: plot_auto.h) or the figures of a figure list file (docs/plots.md; e.g.
/// examples/differential/figures.yaml, the paper's figures of the differential), plus the model's
/// bond graph with Graphviz when the model file is given:
///
///     DIR/figures/<name>.png and .svg   the pictures
///     DIR/plots/<name>.gp               the gnuplot script of each, with the columns it draws
///                                       in it; run it again from DIR with `gnuplot plots/<name>.gp`
///     DIR/plots/<name>.ranges           what each panel plotted: its data extent as gnuplot saw
///                                       it (panel, x, y, z min/max)
///
/// WriteResultsPage then writes DIR/index.html (plot_page.h). Each input is read once (PlotInputs)
/// and each drawing made once: results.csv is parsed once and each figure's script holds the
/// columns it draws (gnuplot does not read the whole file again), and the model's bond graph is
/// laid out by Graphviz once for its PNG, its SVG and the page.

#include <sys/stat.h>

#include <cstddef>
#include <functional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "multibond/io/limits.h"
#include "multibond/io/plot_events.h"
#include "multibond/io/plot_figures.h"
#include "multibond/io/plot_model.h"
#include "multibond/io/plot_table.h"
#include "multibond/io/results_folder.h"

namespace multibond {

/// Options of MakeFigures.
struct PlotOptions {
  /// A figure list file (docs/plots.md); "" for the general figures.
  std::string figures_path;
  /// Model file for the bond graph drawing, as the user gave it. Without one, a figure list's
  /// bond graph figure is left out with a warning (the model named in DIR/run.json is a record of
  /// the run: plot does not open a file because a results folder names it), and the general
  /// figures have none.
  std::string model_path;
  /// Draw the bond graph (needs Graphviz's `dot`).
  bool bond_graph = true;
  /// The gnuplot program (looked up on PATH).
  std::string gnuplot = "gnuplot";
  /// Length of the start-transient panels [s], from the first time of the run (capped at a
  /// quarter of the run).
  double zoom_length = 0.5;
  /// 3D paths plot every n-th row (keeps the SVGs small).
  int path_stride = 5;
  /// gnuplot processes at a time; 0 = the number of hardware threads.
  int jobs = 0;
  /// The most figures drawn (gnuplot runs); the rest are left out with a warning.
  std::size_t max_figures = 100;
  /// Bounds on what is read (results_bytes: the largest results.csv; file_bytes, yaml_nodes and
  /// depth: the figure list).
  InputLimits limits;
  /// Called as each figure's drawing ends (done of total), from the calling thread; none: quiet.
  std::function<void(std::size_t done, std::size_t total)> progress;
};

/// What MakeFigures did.
struct PlotReport {
  std::vector<std::string> files;     ///< every picture written (PNG and SVG), in figure order
  std::vector<std::string> warnings;  ///< figures left out and why (missing columns, gnuplot errors)
  FigureList figures;                 ///< the figures it was to draw (the page shows those drawn)
  /// Graphviz's layout of the model's bond graph (-Tjson), when a bond graph figure was drawn:
  /// the page's bond graph is drawn from it, not laid out again.
  std::string graph_layout;
};

/// What one `plot` reads, read once and shared by the figures and the page: the figure list,
/// results.csv, run.json, events.csv and the model file. The figure list is read first: a wrong
/// one is said before anything else is read or written.
struct PlotInputs {
  /// Reads `results_dir` and the files `options` names (figures_path, model_path) within
  /// `options.limits`. Throws as MakeFigures does.
  PlotInputs(const std::string& results_dir, const PlotOptions& options);

  FigureList figures;   ///< the figure list (none: the general figures are drawn)
  ResultsFolder folder;
  struct stat csv_status {};  ///< results.csv's status when it was read
  PlotTable table;
  nlohmann::json run;   ///< run.json ({} when absent)
  PlotEvents events;    ///< events.csv
  PlotModel model;      ///< the model file, loaded and drawn as DOT once
};

/// Draws the figures (see the file comment). Throws ModelError when the figure list is wrong
/// (nothing is written then), std::runtime_error when results.csv cannot be read or gnuplot
/// cannot be run at all, Interrupted when a stop is asked for (running gnuplots are ended); a
/// figure whose columns are missing, or whose gnuplot run fails, is left out with a warning.
///
/// The folder may come from anyone (results_folder.h): only its own regular files results.csv,
/// run.json and events.csv are read (a link, a file larger than the limit, a malformed results.csv
/// is an error; such an events.csv is a warning, and its events are not marked); figures/ and
/// plots/ are refused when they are links, and every file is written in a private work folder and
/// renamed into place. No text of the folder or of the figure list reaches gnuplot but as an
/// escaped string or comment (safe_text.h), and warnings hold only printable text.
PlotReport MakeFigures(const PlotInputs& inputs, const PlotOptions& options);
/// The same, reading the inputs first.
PlotReport MakeFigures(const std::string& results_dir, const PlotOptions& options = {});

/// Writes `inputs.folder`/index.html: the run's record, its events (events.csv) and every figure
/// of `report.figures` found in figures/ (the general figures when `report` has none), with
/// `report`'s warnings, after the interactive view of every column (plot_web.h: its data in the
/// page, its script and style copied next to it from FindPageAssets(); the bond graph and the 3D
/// view from the inputs' model when one was given: the bond graph's layout is the report's when
/// MakeFigures drew it). Throws std::runtime_error when the page cannot be written. Figures are
/// shown only when they are regular files (not links) in figures/.
void WriteResultsPage(const PlotInputs& inputs, const PlotReport& report);
/// The same, reading the folder and the model file (`model_path`, may be "") first.
void WriteResultsPage(const std::string& results_dir, const PlotReport& report = {}, const InputLimits& limits = {},
                      const std::string& model_path = "");

}  // namespace multibond
