#pragma once
/// \file
/// The paper's figures from a results folder, and a page that shows them.
///
/// MakePaperFigures reads DIR/results.csv (and DIR/run.json) of a run of the paper's differential
/// (examples/differential.yaml) and draws Figs. 3 to 33 of "Modeling and Simulation of Dynamics
/// of Differential Gear Train Mechanism using Bond Graph" with gnuplot, plus the multibond graph
/// (Fig. 2) with Graphviz when the model file is at hand:
///
///     DIR/figures/figNN-<link>-<quantity>.png and .svg   the pictures (figNN-...: see PaperFigureNames)
///     DIR/plots/figNN-<link>-<quantity>.gp               the gnuplot script of each; run it again from
///                                                          DIR with `gnuplot plots/figNN-....gp`
///     DIR/plots/figNN-<link>-<quantity>.ranges           what each panel plotted: its data extent as
///                                                          gnuplot saw it (panel, x, y, z min/max)
///
/// Scripts read results.csv directly, by column number (found from the header, "name [unit]").
/// WriteResultsPage then writes DIR/index.html: every figure with the paper's caption, a short
/// text on the physics it shows, and the run's summary (steady values against the analytic ones,
/// the energy account).

#include <string>
#include <vector>

#include "multibond/io/dot_writer.h"
#include "multibond/io/limits.h"
#include "multibond/io/model_loader.h"

namespace multibond {

/// Options of MakePaperFigures.
struct PlotOptions {
  /// Model file for the bond graph drawing (Fig. 2), as the user gave it. Without one, Fig. 2 is
  /// left out with a warning: the model named in DIR/run.json is a record of the run, and plot
  /// does not open a file because a results folder names it.
  std::string model_path;
  /// Draw Fig. 2 (needs Graphviz's `dot`).
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
  /// Bounds on what is read (results_bytes: the largest results.csv).
  InputLimits limits;
};

/// What MakePaperFigures did.
struct PlotReport {
  std::vector<std::string> files;     ///< every picture written (PNG and SVG), in figure order
  std::vector<std::string> warnings;  ///< figures left out and why (missing columns, gnuplot errors)
};

/// Drawing options for a mechanism's bond graph, grouped by link (the paper's Fig. 2): each
/// joint's and drive's elements inside its child link's cluster, each gear mesh inside its gear
/// `a`'s, each relative velocity "X~Y" inside X's; bonds labelled by dimension only. The links come
/// from the model file's mechanism sections (bodies, joints, gears, drives); a model without them
/// gets the plain grouping by name prefix.
DotOptions LinkGrouping(const LoadedModel& model);

/// The base names of the paper's figures, in order: "fig02-bond-graph", "fig03-G-orientation", ...,
/// "fig33-H-reaction" (figure number, link, quantity). Each is drawn as .png and .svg.
std::vector<std::string> PaperFigureNames();

/// Draws the paper's figures from `results_dir` (see the file comment). Throws std::runtime_error
/// when results.csv cannot be read or gnuplot cannot be run at all; a figure whose columns are
/// missing, or whose gnuplot run fails, is left out with a warning.
///
/// The folder may come from anyone (results_folder.h): only its own regular files results.csv
/// and run.json are read (a link, a file larger than the limit, a malformed results.csv is an
/// error); figures/ and plots/ are refused when they are links, and every file is written in a
/// private work folder and renamed into place. No text of the folder reaches gnuplot but as an
/// escaped string (safe_text.h), and warnings hold only printable text.
PlotReport MakePaperFigures(const std::string& results_dir, const PlotOptions& options = {});

/// Writes `results_dir`/index.html: every figure found in `results_dir`/figures with the paper's
/// caption and what it shows, and the run's summary from results.csv and run.json (steady values
/// against the analytic ones, energy account, solver). `report`'s warnings are listed on the page.
/// Throws std::runtime_error when results.csv cannot be read or the page cannot be written. Every
/// text from results.csv, run.json or a warning is HTML-escaped; figures are shown only when they
/// are regular files (not links) in figures/.
void WriteResultsPage(const std::string& results_dir, const PlotReport& report = {}, const InputLimits& limits = {});

}  // namespace multibond
