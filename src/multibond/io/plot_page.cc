#include "multibond/io/plot_page.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include <fmt/format.h>

#include "multibond/io/results_folder.h"
#include "multibond/io/safe_text.h"

namespace multibond {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
/// The most entries of a run.json object (options, solver_stats) the page lists.
constexpr size_t kMaxJsonEntries = 100;

/// A number for reading: 4 significant digits, no exponent for ordinary magnitudes (HTML).
std::string Show(double v, int digits = 4) {
  if (!std::isfinite(v)) return std::isnan(v) ? "n/a" : (v > 0 ? "&infin;" : "&minus;&infin;");
  if (v == 0) return "0";
  const double a = std::abs(v);
  auto sign = [](std::string s) { return s.front() == '-' ? "\u2212" + s.substr(1) : s; };
  if (a >= 1e-3 && a < 1e6) {
    const int decimals = std::max(0, digits - 1 - static_cast<int>(std::floor(std::log10(a))));
    return sign(fmt::format("{:.{}f}", v, decimals));
  }
  const int e = static_cast<int>(std::floor(std::log10(a)));
  const std::string ms = sign(fmt::format("{:.{}f}", v / std::pow(10.0, e), digits - 1));
  return fmt::format("{}\u00b710<sup>{}</sup>", ms, e < 0 ? "\u2212" + std::to_string(-e) : std::to_string(e));
}

/// |(p.x, p.y, p.z)| at a row (NaN when a component is missing).
double NormAt(const PlotTable& t, const std::string& prefix, size_t row) {
  double sum = 0;
  for (const char* a : {".x", ".y", ".z"}) {
    if (!t.Has(prefix + a)) return kNaN;
    const double v = t.Col(prefix + a)[row];
    sum += v * v;
  }
  return std::sqrt(sum);
}

/// The value of a placeholder "OP COLUMN" (NaN when its column is missing); false for an unknown OP.
bool Placeholder(const std::string& op, const std::string& arg, const PlotTable& t, double& v) {
  const double inf = std::numeric_limits<double>::infinity();
  if (op == "end_time" || op == "start_time") v = op == "end_time" ? t.Time1() : t.Time0();
  else if (op == "first") v = t.First(arg);
  else if (op == "last") v = t.Last(arg);
  else if (op == "min" || op == "max" || op == "max_abs") {
    const auto [lo, hi] = t.Range(arg, -inf, inf);
    v = !t.Has(arg) || lo > hi ? kNaN : op == "min" ? lo : op == "max" ? hi : std::max(std::abs(lo), std::abs(hi));
  } else if (op == "last_norm") v = NormAt(t, arg, t.rows() - 1);
  else if (op == "max_norm") {
    v = NormAt(t, arg, 0);
    for (size_t r = 1; r < t.rows() && std::isfinite(v); ++r) v = std::max(v, NormAt(t, arg, r));
  } else return false;
  return true;
}

/// The value at `path` in run.json, or null.
const nlohmann::json* JsonAt(const nlohmann::json& j, std::initializer_list<const char*> path) {
  const nlohmann::json* p = &j;
  for (const char* k : path) {
    if (!p->is_object() || !p->contains(k)) return nullptr;
    p = &(*p)[k];
  }
  return p;
}

/// A JSON value as HTML text ("" for null).
std::string JsonHtml(const nlohmann::json* p) {
  if (!p || p->is_null()) return "";
  if (p->is_string()) return HtmlEscape(p->get<std::string>());
  if (p->is_number_integer()) return p->dump();
  if (p->is_number()) {
    // As written, without padding: 1e-08 -> 1·10^-8.
    std::string g = fmt::format("{:.6g}", p->get<double>());
    const size_t e = g.find('e');
    if (e == std::string::npos) return g;
    const int exponent = std::stoi(g.substr(e + 1));
    const std::string mantissa = g.substr(0, e);
    return fmt::format("{}10<sup>{}</sup>", mantissa == "1" ? "" : mantissa + "\u00b7",
                       exponent < 0 ? "\u2212" + std::to_string(-exponent) : std::to_string(exponent));
  }
  if (p->is_boolean()) return p->get<bool>() ? "yes" : "no";
  return HtmlEscape(p->dump().substr(0, 200));
}

std::string JsonText(const nlohmann::json& j, std::initializer_list<const char*> path) { return JsonHtml(JsonAt(j, path)); }

/// "key value, key value ..." of a run.json object.
std::string JsonEntries(const nlohmann::json* p) {
  if (!p || !p->is_object()) return "";
  std::string out;
  size_t n = 0;
  for (auto it = p->begin(); it != p->end(); ++it, ++n) {
    if (n == kMaxJsonEntries) return out + ", &hellip;";
    out += fmt::format("{}{} <strong>{}</strong>", out.empty() ? "" : ", ", HtmlEscape(it.key()), JsonHtml(&it.value()));
  }
  return out;
}

std::string RunTable(const nlohmann::json& run, const PlotTable& t) {
  std::ostringstream s;
  s << "<table class=\"numbers\">\n<caption>The run (run.json)</caption>\n";
  auto row = [&](const char* what, const std::string& value) {
    if (!value.empty()) s << fmt::format("<tr><th>{}</th><td>{}</td></tr>\n", what, value);
  };
  const std::string file = JsonText(run, {"model", "file"});
  row("model", JsonText(run, {"model", "name"}) + (file.empty() ? "" : " (" + file + ")"));
  const std::string sha = JsonText(run, {"model", "sha256"});
  row("model SHA-256", sha.empty() ? "" : "<code>" + sha + "</code>");
  row("status", JsonText(run, {"status"}));
  row("time", fmt::format("{} to {} s, {} rows in results.csv, {} columns", Show(t.Time0(), 3), Show(t.Time1(), 3), t.rows(), t.names().size()));
  row("options", JsonEntries(JsonAt(run, {"options"})));
  row("solver statistics", JsonEntries(JsonAt(run, {"solver_stats"})));
  const std::string wall = JsonText(run, {"wall_seconds"});
  row("wall time", wall.empty() ? "" : wall + " s");
  row("multibond", JsonText(run, {"multibond_version"}));
  s << "</table>\n";
  return s.str();
}

/// The energy account: run.json's and the last row of results.csv.
std::string EnergyTable(const PlotTable& t, const nlohmann::json& run) {
  if (!run.contains("energy") && !t.Has("energy.work")) return "";
  std::ostringstream s;
  s << "<table class=\"numbers\">\n<caption>Energy account: work in = kinetic + potential + dissipated</caption>\n";
  s << "<tr><th>source</th><th>work in [J]</th><th>stored [J]</th><th>dissipated [J]</th><th>balance</th></tr>\n";
  if (run.contains("energy"))
    s << fmt::format(
        "<tr><td>run.json</td><td>{}</td><td>{}</td><td>{}</td><td>residual {} (largest over the run: {}), relative to the "
        "largest energy handled</td></tr>\n",
        JsonText(run, {"energy", "work"}), JsonText(run, {"energy", "stored"}), JsonText(run, {"energy", "dissipated"}),
        JsonText(run, {"energy", "residual"}), JsonText(run, {"energy", "max_abs_residual"}));
  if (t.Has("energy.work")) {
    const double w = t.Last("energy.work"), k = t.Last("energy.kinetic"), v = t.Last("energy.potential"), d = t.Last("energy.dissipated");
    const double balance = w - (k + v + d);
    s << fmt::format(
        "<tr><td>results.csv, last row</td><td>{}</td><td>{} (kinetic {}, potential {})</td><td>{}</td><td>work &minus; "
        "(kinetic + potential + dissipated) = {} J, {} of the work; residual column {}</td></tr>\n",
        Show(w, 9), Show(k + v, 9), Show(k, 6), Show(v, 6), Show(d, 9), Show(balance, 3), Show(w != 0 ? balance / w : kNaN, 3),
        Show(t.Last("energy.residual"), 3));
  }
  s << "</table>\n";
  return s.str();
}

/// The figure list's checks: expected values at the end of the run against the simulated ones.
std::string ChecksTable(const PlotTable& t, const std::vector<Check>& checks) {
  if (checks.empty()) return "";
  std::ostringstream s;
  s << fmt::format("<table class=\"numbers\">\n<caption>At the end of the run, t = {} s, against the expected values</caption>\n", Show(t.Time1(), 3));
  s << "<tr><th>quantity</th><th>simulated</th><th>expected</th><th>difference</th><th>tolerance</th><th>unit</th><th></th><th>from</th></tr>\n";
  for (const Check& c : checks) {
    const double v = c.norm ? NormAt(t, c.column, t.rows() - 1) : t.Last(c.column);
    const double diff = v - c.value;
    const std::string verdict = !std::isfinite(v) ? "<span class=\"warn\">no column</span>"
                                : std::abs(diff) <= c.tolerance ? "ok"
                                                                : "<span class=\"warn\">outside</span>";
    s << fmt::format("<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>\n", MarkupToHtml(c.quantity),
                     Show(v, 6), Show(c.value, 6), Show(diff, 2), Show(c.tolerance, 2), MarkupToHtml(c.unit), verdict, TextToHtml(c.note, t));
  }
  s << "</table>\n";
  return s.str();
}

/// `text` cut to at most `max` bytes (with an ellipsis), HTML-escaped.
std::string ShortHtml(const std::string& text, size_t max) {
  return HtmlEscape(text.substr(0, max)) + (text.size() > max ? "&hellip;" : "");
}

/// The run's events: how many of each kind, then the first kMaxPageEvents of events.csv.
std::string EventsTable(const std::vector<PlotEvent>& events) {
  if (events.empty()) return "";
  std::string kinds;
  for (const EventStyle& style : EventStyles()) {
    const auto n = std::count_if(events.begin(), events.end(), [&](const PlotEvent& e) { return e.kind == style.kind; });
    if (n > 0) kinds += fmt::format("{}<span style=\"color: {}\">&#9646;</span> {} {}", kinds.empty() ? "" : ", ", style.color, style.kind, n);
  }
  std::ostringstream s;
  s << "<table class=\"numbers\" id=\"run-events\">\n";
  s << fmt::format("<caption>Events (events.csv): {} &mdash; {}; each is a line on the plots against time</caption>\n", events.size(), kinds);
  s << "<tr><th>time [s]</th><th>kind</th><th>element</th><th>description</th></tr>\n";
  for (size_t k = 0; k < events.size() && k < kMaxPageEvents; ++k) {
    const PlotEvent& e = events[k];
    const EventStyle* style = FindEventStyle(e.kind);
    s << fmt::format("<tr><td>{:.10g}</td><td>{}{}</td><td>{}</td><td>{}</td></tr>\n", e.time,
                     style ? fmt::format("<span style=\"color: {}\">&#9646;</span> ", style->color) : "", ShortHtml(e.kind, 40),
                     ShortHtml(e.element, 200), ShortHtml(e.description, 500));
  }
  if (events.size() > kMaxPageEvents)
    s << fmt::format("<tr><td colspan=\"4\">and {} more (events.csv lists them all)</td></tr>\n", events.size() - kMaxPageEvents);
  s << "</table>\n";
  return s.str();
}

constexpr const char* kCss = R"(body { font-family: "DejaVu Sans", Helvetica, Arial, sans-serif; max-width: 1280px; margin: 1em auto; padding: 0 1em; color: #222; line-height: 1.45; }
h1 { font-size: 1.6em; margin-bottom: 0.2em; } h2 { margin-top: 2em; border-bottom: 1px solid #ccc; }
nav a { margin-right: 0.6em; white-space: nowrap; }
figure { margin: 1.5em 0 2.5em 0; } figure img { max-width: 100%; height: auto; border: 1px solid #ddd; }
figcaption { margin-top: 0.5em; } figcaption .caption { font-weight: bold; } figcaption .files { font-size: 0.85em; color: #555; }
table.numbers { border-collapse: collapse; margin: 1em 0; font-size: 0.92em; }
table.numbers caption { text-align: left; font-weight: bold; padding-bottom: 0.3em; }
table.numbers td, table.numbers th { border: 1px solid #ccc; padding: 0.25em 0.6em; text-align: left; vertical-align: top; }
.warn { color: #a40; } code { font-size: 0.9em; })";

}  // namespace

std::string MarkupToHtml(const std::string& s) {
  std::string out, plain;
  for (size_t i = 0; i < s.size(); ++i) {
    if (s[i] == '\\' && i + 1 < s.size()) {
      plain += s[++i];
      continue;
    }
    if ((s[i] == '_' || s[i] == '^') && i + 1 < s.size() && s[i + 1] == '{') {
      const size_t close = s.find('}', i + 2);
      if (close != std::string::npos) {
        const char* tag = s[i] == '_' ? "sub" : "sup";
        out += HtmlEscape(plain) + fmt::format("<{}>{}</{}>", tag, MarkupToHtml(s.substr(i + 2, close - i - 2)), tag);
        plain.clear();
        i = close;
        continue;
      }
    }
    plain += s[i];
  }
  return out + HtmlEscape(plain);
}

std::string TextToHtml(const std::string& text, const PlotTable& table) {
  std::string out;
  size_t at = 0;
  while (at < text.size()) {
    const size_t open = text.find("{{", at), close = open == std::string::npos ? open : text.find("}}", open + 2);
    if (close == std::string::npos) break;
    const std::string inner = text.substr(open + 2, close - open - 2);
    const size_t space = inner.find(' ');
    const std::string op = inner.substr(0, space), arg = space == std::string::npos ? "" : inner.substr(space + 1);
    double v = kNaN;
    out += MarkupToHtml(text.substr(at, open - at));
    out += Placeholder(op, arg, table, v) ? Show(v) : HtmlEscape(text.substr(open, close + 2 - open));
    at = close + 2;
  }
  return out + MarkupToHtml(text.substr(std::min(at, text.size())));
}

std::string ResultsPageHtml(const PlotTable& table, const nlohmann::json& run, const FigureList& list,
                            const std::vector<std::string>& warnings, int figures_dir, const std::vector<PlotEvent>& events,
                            const PageApp* app) {
  auto present = [&](const Figure& f, const char* ext) { return IsNonEmptyRegularFile(figures_dir, f.name + ext); };
  const std::string model = JsonText(run, {"model", "name"}).empty() ? "a run" : JsonText(run, {"model", "name"});
  const std::string heading = list.title.empty() ? fmt::format("Results of {}", model) : TextToHtml(list.title, table);
  std::ostringstream h;
  h << "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n";
  h << "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n";
  h << fmt::format("<title>multibond: {}</title>\n", model);
  h << "<style>\n" << kCss << "\n</style>\n";
  const bool interactive = app && app->assets;
  if (interactive) h << fmt::format("<link rel=\"stylesheet\" href=\"{}\">\n", kPageStyle);
  h << "</head>\n<body>\n";
  h << fmt::format("<h1>{}</h1>\n", heading);
  if (!list.intro.empty()) h << "<p>" << TextToHtml(list.intro, table) << "</p>\n";
  h << "<p>Drawn by <code>multibond plot</code> from <code>results.csv</code> and <code>run.json</code> in this folder. Click a "
       "figure for its SVG; each one's gnuplot script is in <code>plots/</code> (run it again from this folder: "
       "<code>gnuplot plots/NAME.gp</code>).</p>\n";
  if (app) {
    h << "<section id=\"interactive\">\n<div id=\"mb-app\">";
    h << (interactive ? "<p>Loading the interactive view&hellip; (it needs JavaScript)</p>" : "");
    h << "</div>\n";
    for (const std::string& note : app->notes) h << "<p class=\"warn\">" << HtmlEscape(note) << "</p>\n";
    h << "</section>\n";
  }
  h << "<nav><strong>Figures:</strong> <a href=\"#summary\">summary</a>";
  if (!events.empty()) h << " <a href=\"#run-events\">events</a>";
  for (const Figure& f : list.figures)
    if (present(f, ".png")) h << fmt::format(" <a href=\"#{}\">{}</a>", f.name, f.label.empty() ? f.name : HtmlEscape(f.label));
  h << "</nav>\n";

  h << "<h2 id=\"summary\">Summary of the run</h2>\n";
  h << ChecksTable(table, list.checks) << EnergyTable(table, run) << RunTable(run, table) << EventsTable(events);
  if (!warnings.empty()) {
    h << "<p class=\"warn\"><strong>Left out when the figures were drawn:</strong></p>\n<ul class=\"warn\">\n";
    for (const std::string& w : warnings) h << "<li>" << HtmlEscape(w) << "</li>\n";
    h << "</ul>\n";
  }
  int section = -2;
  for (const Figure& f : list.figures) {
    if (!present(f, ".png")) continue;
    if (f.section != section && f.section >= 0 && f.section < static_cast<int>(list.sections.size()))
      h << fmt::format("<h2>{}</h2>\n", MarkupToHtml(list.sections[static_cast<size_t>(f.section)]));
    section = f.section;
    const std::string target = "figures/" + f.name + (present(f, ".svg") ? ".svg" : ".png");
    h << fmt::format("<figure id=\"{}\">\n", f.name);
    h << fmt::format("<a href=\"{}\"><img src=\"figures/{}.png\" loading=\"lazy\" alt=\"{}\"></a>\n", target, f.name, HtmlEscape(f.Title()));
    h << fmt::format("<figcaption><span class=\"caption\">{}</span> {}<br><span class=\"files\">figures/{}.png, "
                     "<a href=\"{}\">{}</a>{}</span></figcaption>\n",
                     MarkupToHtml(f.Title()), TextToHtml(f.shows, table), f.name, target, target,
                     f.bond_graph ? "" : fmt::format(", script <a href=\"plots/{0}.gp\">plots/{0}.gp</a>", f.name));
    h << "</figure>\n";
  }
  if (interactive) {
    // The data's JSON has '<', '>' and '&' escaped (JsonForScript): no text can end the element.
    h << "<script type=\"application/json\" id=\"mb-data\">" << app->data_json << "</script>\n";
    h << fmt::format("<script src=\"{}\"></script>\n", kPageScript);
  }
  h << "</body>\n</html>\n";
  return h.str();
}

}  // namespace multibond
