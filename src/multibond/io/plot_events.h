#pragma once
/// \file
/// The events of a run (events.csv, docs/events.md) as `plot` shows them: a thin vertical line at
/// each event's time on every plot against time, coloured and dashed by kind with a key entry per
/// kind, and a table on the page.
///
/// events.csv is untrusted input like results.csv: only the folder's own regular file is read (not
/// a link), at most kMaxEventsBytes and kMaxEvents rows. It is an addition to the figures, not
/// their data: a file that cannot be read or is malformed leaves the events unmarked, with a
/// warning that says where (file:line) and what is wrong, and the figures are drawn all the same.

#include <cstddef>
#include <cstdint>
#include <istream>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "multibond/io/results_folder.h"

namespace multibond {

/// One row of events.csv.
struct PlotEvent {
  double time = 0;
  std::string kind, element, description;
};

/// How the events of a kind are marked: a line colour, a gnuplot dash type, a line width.
struct EventStyle {
  const char* kind;
  const char* color;  ///< "#rrggbb"
  int dash;           ///< gnuplot dt: 1 solid, 2 dashed, 3 short dashes, 4 dash-dot, 5 dash-dot-dot
  const char* width;  ///< gnuplot lw
};

/// Every kind events.csv may hold, in the order of the keys (and of precedence when marks are
/// thinned): impact, contact, separation, stick, slip, lock, unlock, limit, time (lighter).
const std::vector<EventStyle>& EventStyles();
/// The style of `kind`, or null for a kind that is not one of EventStyles().
const EventStyle* FindEventStyle(std::string_view kind);

/// The largest events.csv read, and the most events read from it (the rest are not marked, with a
/// warning).
constexpr std::uint64_t kMaxEventsBytes = 64ull << 20;
constexpr std::size_t kMaxEvents = 100'000;
/// The most event lines on one plot: past it, the plot's time axis is cut into this many equal
/// bins and each bin that holds events gets one line (of its first kind in EventStyles() order).
constexpr std::size_t kMaxEventMarks = 200;

/// Parses events.csv from `in` (`path` names it in messages): the header
/// `time [s],kind,element,description`, then one RFC 4180 record per event (a quoted cell may hold
/// commas, doubled quotes and line breaks), with a finite time and a known kind. Empty lines are
/// skipped. At most `max_events` events are read; `more` (when given) is set when there are more.
/// Throws std::runtime_error "path:line: what is wrong".
std::vector<PlotEvent> ParseEvents(std::istream& in, const std::string& path, std::size_t max_events = kMaxEvents,
                                   bool* more = nullptr);

/// What ReadPlotEvents found.
struct PlotEvents {
  std::vector<PlotEvent> events;      ///< empty when there is no events.csv or it is not used
  std::vector<std::string> warnings;  ///< printable text: why the events are not marked, or are not all marked
};

/// The folder's events.csv (none when it is absent). Never throws for what the folder holds: a
/// link, a file that is not regular or too large, a malformed file each give a warning and no
/// events. Checked against `run` (run.json) where it says something: a listed events.csv that is
/// missing, a size or an event count that differs, each a warning.
PlotEvents ReadPlotEvents(const ResultsFolder& folder, const nlohmann::json& run);

/// The gnuplot lines that mark `events` on a time plot of [t0, t1] (events outside it are left
/// out), for ScriptWriter: `arrows`, `set arrow` lines to put before the plot command, and `keys`,
/// one `NaN` curve per kind present, to append to it, titled "kind (count)". Empty strings when no
/// event falls in the window. File text reaches the script only in comments (GnuplotComment).
struct EventMarks {
  std::string arrows, keys;
};
EventMarks GnuplotEventMarks(const std::vector<PlotEvent>& events, double t0, double t1, std::size_t max_marks = kMaxEventMarks);

}  // namespace multibond
