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
///     DIR/plots/<name>.gp               the gnuplot script of each; run it again from DIR with
///                                       `gnuplot plots/<name>.gp`
///     DIR/plots/<name>.ranges           what each panel plotted: its data extent as gnuplot saw
///                                       it (panel, x, y, z min/max)
///
/// WriteResultsPage then writes DIR/index.html (plot_page.h).

#include <cstddef>
#include <functional>
#include <string>
#include <vector>

#include "multibond/io/dot_writer.h"
#include "multibond/io/limits.h"
#include "multibond/io/model_loader.h"
#include "multibond/io/plot_figures.h"

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
};

/// Drawing options for a mechanism's bond graph, grouped by link: each joint's and drive's
/// elements inside its child link's cluster, each gear mesh inside its gear `a`'s, each relative
/// velocity "X~Y" inside X's; bonds labelled by dimension only. The links come from the model
/// file's mechanism sections (bodies, joints, gears, drives); a model without them gets the plain
/// grouping by name prefix.
DotOptions LinkGrouping(const LoadedModel& model);

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
PlotReport MakeFigures(const std::string& results_dir, const PlotOptions& options = {});

/// Writes `results_dir`/index.html: the run's record, its events (events.csv) and every figure of
/// `report.figures` found in `results_dir`/figures (the general figures when `report` has none),
/// with `report`'s warnings, after the interactive view of every column (plot_web.h: its data in
/// the page, its script and style copied next to it from FindPageAssets(); the bond graph and the
/// 3D view from `model_path` when given). Throws std::runtime_error when results.csv cannot be
/// read or the page cannot be written. Figures are shown only when they are regular files (not
/// links) in figures/.
void WriteResultsPage(const std::string& results_dir, const PlotReport& report = {}, const InputLimits& limits = {},
                      const std::string& model_path = "");

}  // namespace multibond
