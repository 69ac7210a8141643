#pragma once
/// \file
/// The results page, DIR/index.html: the run's record (run.json: model, status, options, solver
/// statistics, energy), the energy account, a figure list's checks (expected values at the end
/// of the run against the simulated ones), the run's events (events.csv: the first
/// kMaxPageEvents, then how many more), the warnings of the drawing, and every figure of the list
/// that is in figures/ with its caption and what it shows. Every text from results.csv,
/// run.json, the figure list or a warning is HTML-escaped (safe_text.h).

#include <cstddef>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "multibond/io/plot_events.h"
#include "multibond/io/plot_figures.h"
#include "multibond/io/plot_table.h"
#include "multibond/io/plot_web.h"

namespace multibond {

/// Markup ("Q_{P1}", "\_") -> HTML ("Q<sub>P1</sub>", "_"), HTML-escaped.
std::string MarkupToHtml(const std::string& markup);

/// A figure list's text with its placeholders filled from the run, as HTML: "{{OP COLUMN}}" with
/// OP one of first, last, min, max, max_abs (a column's value), last_norm, max_norm (the length
/// of the vector COLUMN.x, .y, .z), or "{{end_time}}", "{{start_time}}"; the rest is markup. A
/// placeholder whose column is missing shows "n/a"; an unknown OP is shown as it is.
std::string TextToHtml(const std::string& text, const PlotTable& table);

/// The most events the page lists; "and N more" says how many are left out.
constexpr std::size_t kMaxPageEvents = 200;

/// The page's HTML; `events` (events.csv, file text) are listed in a table, escaped. With `app`,
/// the interactive part (plot_web.h) comes first: its data as JSON in a
/// <script type="application/json" id="mb-data"> element, and, when its assets were copied,
/// the script and style that draw it.
std::string ResultsPageHtml(const PlotTable& table, const nlohmann::json& run, const FigureList& list,
                            const std::vector<std::string>& warnings, int figures_dir, const std::vector<PlotEvent>& events = {},
                            const PageApp* app = nullptr);

}  // namespace multibond
