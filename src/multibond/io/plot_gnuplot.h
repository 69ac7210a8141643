#pragma once
/// \file
/// gnuplot for `plot`: a figure's script, and running gnuplot on many scripts a few at a time.
///
/// A script holds the columns of results.csv that it draws, in a datablock (each value as
/// results.csv writes it, so no digit is lost; its comments say which column is which), so that
/// gnuplot does not parse the whole file again for every figure; it writes figures/<name>.png and .svg and plots/<name>.ranges (each panel's data
/// extent as gnuplot saw it: panel, x min/max, y min/max[, z min/max]). It runs from the results
/// folder: `gnuplot plots/<name>.gp`. Every text in it is an escaped gnuplot string or comment
/// (safe_text.h); units from results.csv are shown as they are (GnuplotLiteralText). A run's
/// events (plot_events.h) are marked on every time panel: a vertical line at each event's time
/// (`set arrow ... nohead back`), and a key entry per kind.

#include <functional>
#include <map>
#include <string>
#include <vector>

#include "multibond/io/plot_events.h"
#include "multibond/io/plot_figures.h"
#include "multibond/io/plot_table.h"
#include "multibond/io/results_folder.h"

namespace multibond {

struct ScriptSettings {
  /// Length of the start-transient panels [s], from the first time of the run (capped at a quarter of the run).
  double zoom_length = 0.5;
  /// 3D paths plot every n-th row (keeps the SVGs small).
  int path_stride = 5;
};

/// The gnuplot script of `figure` (which has panels; every column it uses is in `table`), with
/// `events` marked on its time panels (a panel without events in its window is as without any).
std::string GnuplotScript(const PlotTable& table, const Figure& figure, const ScriptSettings& settings = {},
                          const std::vector<PlotEvent>& events = {});

/// Runs `program` on plots/<name>.gp for each of `names` in `work` (its cwd), at most `jobs` at a
/// time. A log with text is published as plots/<name>.log in `plots_dir` (an older one is
/// removed). Returns the figures whose run failed, with the reason. Throws std::runtime_error
/// when the program cannot be started at all (after waiting for those running); when a stop is
/// asked for, ends every running gnuplot (EndProcess) and rethrows Interrupted. `progress`, if
/// any, is called with the number of runs ended and of all after each one ends.
std::map<std::string, std::string> RunGnuplot(const WorkFolder& work, int plots_dir, const std::vector<std::string>& names,
                                              const std::string& program, int jobs,
                                              const std::function<void(std::size_t, std::size_t)>& progress = {});

}  // namespace multibond
