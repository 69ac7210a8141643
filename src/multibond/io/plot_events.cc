#include "multibond/io/plot_events.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <map>
#include <stdexcept>

#include <fmt/format.h>

#include "multibond/io/did_you_mean.h"
#include "multibond/io/results_files.h"
#include "multibond/io/safe_text.h"

namespace multibond {

namespace {

constexpr const char* kHeader = "time [s],kind,element,description";

[[noreturn]] void Bad(const std::string& path, int line, const std::string& what) {
  throw std::runtime_error(fmt::format("{}:{}: {}", path, line, what));
}

/// `text` shortened to `max` bytes (with "...") and made printable, for a message.
std::string Shown(std::string_view text, size_t max = 40) {
  return MessageText(text.substr(0, max)) + (text.size() > max ? "..." : "");
}

/// One CSV record (RFC 4180) from `in` into `cells`: false at the end of the input. A cell opening
/// with a quote runs to the matching quote ("" is one quote) across commas and line breaks; a
/// quote elsewhere, or text after a closing quote, is an error. A CR before each line break is
/// dropped. `lineno` is the record's last line; `first` gets its first.
bool ReadRecord(std::istream& in, const std::string& path, int& lineno, int& first, std::vector<std::string>& cells) {
  std::string line;
  if (!std::getline(in, line)) return false;
  first = ++lineno;
  cells.assign(1, "");
  bool quoted = false, closed = false;
  size_t i = 0;
  while (true) {
    if (i == line.size() || (i + 1 == line.size() && line[i] == '\r')) {
      if (!quoted) break;
      if (!std::getline(in, line)) Bad(path, first, "a quoted cell is not closed");
      ++lineno;
      cells.back() += '\n';
      i = 0;
      continue;
    }
    const char c = line[i++];
    if (quoted) {
      if (c != '"') cells.back() += c;
      else if (i < line.size() && line[i] == '"') cells.back() += '"', ++i;
      else quoted = false, closed = true;
    } else if (c == ',') {
      if (cells.size() >= 4) Bad(path, first, "more than 4 cells (time, kind, element, description); quote a cell that holds a comma");
      cells.emplace_back();
      closed = false;
    } else if (closed) {
      Bad(path, lineno, fmt::format("text after a quoted cell: '{}'", Shown(line.substr(i - 1))));
    } else if (c == '"') {
      if (!cells.back().empty()) Bad(path, lineno, "a quote inside a cell that does not start with one (RFC 4180: quote the whole cell, double the quote)");
      quoted = true;
    } else {
      cells.back() += c;
    }
  }
  return true;
}

}  // namespace

const std::vector<EventStyle>& EventStyles() {
  static const std::vector<EventStyle> styles = {
      {"impact", "#b2182b", 1, "1"},    {"contact", "#762a83", 2, "1"}, {"separation", "#c51b7d", 2, "1"},
      {"stick", "#2166ac", 2, "1"},     {"slip", "#e08214", 2, "1"},    {"lock", "#1b7837", 4, "1"},
      {"unlock", "#8c510a", 4, "1"},    {"limit", "#01665e", 5, "1"},   {"time", "#a0a0a0", 3, "1"},
  };
  return styles;
}

const EventStyle* FindEventStyle(std::string_view kind) {
  for (const EventStyle& s : EventStyles())
    if (kind == s.kind) return &s;
  return nullptr;
}

std::vector<PlotEvent> ParseEvents(std::istream& in, const std::string& path, size_t max_events, bool* more) {
  if (more) *more = false;
  int lineno = 0, first = 0;
  std::vector<std::string> cells;
  if (!ReadRecord(in, path, lineno, first, cells)) Bad(path, 1, "empty file: expected the header " + std::string(kHeader));
  std::string header;
  for (const std::string& c : cells) header += (header.empty() ? "" : ",") + c;
  if (header != kHeader) Bad(path, 1, fmt::format("the header is '{}', not '{}'", Shown(header, 80), kHeader));
  std::vector<std::string> kinds;
  for (const EventStyle& s : EventStyles()) kinds.push_back(s.kind);
  std::vector<PlotEvent> events;
  while (ReadRecord(in, path, lineno, first, cells)) {
    if (cells.size() == 1 && cells[0].empty()) continue;
    if (cells.size() != 4)
      Bad(path, first, fmt::format("{} cell{}, expected 4: time, kind, element, description", cells.size(), cells.size() == 1 ? "" : "s"));
    if (events.size() == max_events) {
      if (more) *more = true;
      break;
    }
    PlotEvent e;
    std::string_view t = cells[0];
    while (!t.empty() && t.front() == ' ') t.remove_prefix(1);
    while (!t.empty() && t.back() == ' ') t.remove_suffix(1);
    if (!t.empty() && t.front() == '+') t.remove_prefix(1);
    const auto [ptr, ec] = std::from_chars(t.data(), t.data() + t.size(), e.time);
    if (t.empty() || ec != std::errc() || ptr != t.data() + t.size() || !std::isfinite(e.time))
      Bad(path, first, fmt::format("the time '{}' is not a finite number", Shown(cells[0])));
    if (!FindEventStyle(cells[1])) {
      const std::string guess = DidYouMean(cells[1], kinds);
      Bad(path, first, fmt::format("unknown kind '{}'{}", Shown(cells[1]),
                                   guess.empty() ? "; the kinds are impact, contact, separation, stick, slip, lock, unlock, limit, time"
                                                 : fmt::format(" (did you mean '{}'?)", guess)));
    }
    e.kind = std::move(cells[1]);
    e.element = std::move(cells[2]);
    e.description = std::move(cells[3]);
    events.push_back(std::move(e));
  }
  return events;
}

PlotEvents ReadPlotEvents(const ResultsFolder& folder, const nlohmann::json& run) {
  PlotEvents out;
  const std::string path = folder.PathOf(kEventsFileName);
  // What run.json says about events.csv, where it says it.
  const nlohmann::json* listed = nullptr;
  if (run.contains("files") && run["files"].is_array())
    for (const nlohmann::json& f : run["files"])
      if (f.is_object() && f.contains("file") && f["file"] == kEventsFileName) listed = &f;
  const nlohmann::json* count =
      run.contains("events") && run["events"].is_object() && run["events"].contains("count") ? &run["events"]["count"] : nullptr;
  try {
    struct stat st {};
    const Fd fd = folder.OpenInput(kEventsFileName, kMaxEventsBytes, nullptr, &st);
    if (fd.get() < 0) {
      if (listed) out.warnings.push_back(fmt::format("run.json lists {}, but the folder has none: the events are not marked", MessageText(path)));
      return out;
    }
    if (listed && listed->contains("bytes") && (*listed)["bytes"].is_number_integer() &&
        (*listed)["bytes"].get<long long>() != static_cast<long long>(st.st_size))
      out.warnings.push_back(fmt::format("{} has {} bytes, run.json lists {}: it is not the file of the run; its events are marked as it has them",
                                         MessageText(path), st.st_size, (*listed)["bytes"].get<long long>()));
    BoundedFileBuf buf(fd.get(), kMaxEventsBytes);
    std::istream in(&buf);
    bool more = false;
    out.events = ParseEvents(in, path, kMaxEvents, &more);
    if (buf.exceeded()) throw std::runtime_error(fmt::format("'{}' grew beyond {} bytes while it was read", path, kMaxEventsBytes));
    if (more)
      out.warnings.push_back(fmt::format("{} has more than {} events: only the first {} are marked and listed", MessageText(path), kMaxEvents, kMaxEvents));
    else if (count && count->is_number_integer() && count->get<long long>() != static_cast<long long>(out.events.size()))
      out.warnings.push_back(fmt::format("run.json counts {} events, {} has {}: they are marked as the file has them", count->get<long long>(),
                                         MessageText(path), out.events.size()));
  } catch (const std::runtime_error& e) {
    out.events.clear();
    out.warnings.push_back(fmt::format("{}; the events are not marked", MessageText(e.what())));
  }
  return out;
}

EventMarks GnuplotEventMarks(const std::vector<PlotEvent>& events, double t0, double t1, size_t max_marks) {
  EventMarks marks;
  const std::vector<EventStyle>& styles = EventStyles();
  auto rank = [&](const std::string& kind) { return static_cast<size_t>(FindEventStyle(kind) - styles.data()); };
  std::vector<const PlotEvent*> in;
  for (const PlotEvent& e : events)
    if (e.time >= t0 && e.time <= t1 && FindEventStyle(e.kind)) in.push_back(&e);
  if (in.empty()) return marks;
  std::stable_sort(in.begin(), in.end(), [](const PlotEvent* a, const PlotEvent* b) { return a->time < b->time; });
  std::vector<size_t> per_kind(styles.size(), 0);
  for (const PlotEvent* e : in) ++per_kind[rank(e->kind)];

  // One line per event, or per bin of the axis when there are too many: the bin's first event of
  // its first kind.
  std::vector<const PlotEvent*> shown;
  const bool thinned = in.size() > max_marks && max_marks > 0;
  if (!thinned) {
    shown = in;
  } else {
    std::vector<const PlotEvent*> bins(max_marks, nullptr);
    const double span = t1 - t0;
    for (const PlotEvent* e : in) {
      const double x = span > 0 ? (e->time - t0) / span * static_cast<double>(max_marks) : 0.0;
      const size_t b = std::min(max_marks - 1, static_cast<size_t>(std::max(0.0, x)));
      if (!bins[b] || rank(e->kind) < rank(bins[b]->kind)) bins[b] = e;
    }
    for (const PlotEvent* e : bins)
      if (e) shown.push_back(e);
  }
  marks.arrows = thinned ? fmt::format("  # {} events on [{:.10g}, {:.10g}], thinned: one line for each of {} equal bins that holds any\n",
                                       in.size(), t0, t1, max_marks)
                         : fmt::format("  # {} event{} (events.csv)\n", in.size(), in.size() == 1 ? "" : "s");
  for (const PlotEvent* e : shown) {
    const EventStyle& s = styles[rank(e->kind)];
    marks.arrows += fmt::format("  # {}: {}\n", e->kind, GnuplotComment(e->element.substr(0, 80)));
    marks.arrows += fmt::format("  set arrow from first {:.17g}, graph 0 to first {:.17g}, graph 1 nohead back lw {} lc rgb \"{}\" dt {}\n",
                                e->time, e->time, s.width, s.color, s.dash);
  }
  for (size_t k = 0; k < styles.size(); ++k)
    if (per_kind[k] > 0)
      marks.keys += fmt::format(", \\\n       NaN with lines lw {} lc rgb \"{}\" dt {} title '{} ({}{})'", styles[k].width, styles[k].color,
                                styles[k].dash, styles[k].kind, per_kind[k], thinned ? ", thinned" : "");
  return marks;
}

}  // namespace multibond
