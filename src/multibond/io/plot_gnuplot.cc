#include "multibond/io/plot_gnuplot.h"

#include <unistd.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <deque>
#include <fstream>
#include <iterator>
#include <sstream>
#include <stdexcept>
#include <vector>

#include <fmt/compile.h>
#include <fmt/format.h>

#include "multibond/core/interrupt.h"
#include "multibond/core/process.h"
#include "multibond/io/safe_text.h"

namespace multibond {

namespace {

/// A number for a script, exactly enough.
std::string Num(double v) { return std::isfinite(v) ? fmt::format("{:.10g}", v) : "NaN"; }

struct Window {
  double t0, t1;
};

/// min/max of a curve set over a time window (NaNs skipped); {inf, -inf} if empty.
std::pair<double, double> DataRange(const PlotTable& t, const std::vector<Curve>& curves, Window w, size_t coord = 0) {
  double lo = INFINITY, hi = -INFINITY;
  const auto& time = t.Col("time");
  for (const Curve& c : curves) {
    if (coord >= c.columns.size()) continue;
    const auto& col = t.Col(c.columns[coord]);
    const double v0 = col.front();
    for (size_t r = 0; r < t.rows(); ++r) {
      if (time[r] < w.t0 || time[r] > w.t1 || !std::isfinite(col[r])) continue;
      const double v = (col[r] - (c.from_start ? v0 : 0.0)) * c.scale;
      lo = std::min(lo, v);
      hi = std::max(hi, v);
    }
  }
  return {lo, hi};
}

/// Rows of the columns `cols`, comma-separated, each value written as results.csv writes it (the
/// shortest text that reads back as the same double: fmt's "{}"; nan, inf, -inf).
std::string DataBlock(const std::vector<const std::vector<double>*>& cols) {
  fmt::memory_buffer out;
  const std::size_t rows = cols.empty() ? 0 : cols.front()->size();
  for (std::size_t r = 0; r < rows; ++r) {
    for (std::size_t c = 0; c < cols.size(); ++c) {
      if (c) out.push_back(',');
      fmt::format_to(std::back_inserter(out), FMT_COMPILE("{}"), (*cols[c])[r]);
    }
    out.push_back('\n');
  }
  return fmt::to_string(out);
}

class ScriptWriter {
 public:
  ScriptWriter(const PlotTable& t, const Figure& f, const ScriptSettings& o, const std::vector<PlotEvent>& events)
      : t_(t), f_(f), o_(o), events_(events) {
    full_ = {t.Time0(), t.Time1()};
    const double span = full_.t1 - full_.t0;
    zoom_ = {full_.t0, full_.t0 + std::min(o.zoom_length, 0.25 * span)};
  }

  std::string Run() {
    const std::string& name = f_.name;
    std::ostringstream s;
    s << "# " << GnuplotComment(f_.Title()) << "\n";
    s << "# Written by multibond from results.csv. Run it again from the results folder:\n";
    s << fmt::format("#   gnuplot plots/{}.gp\n", name);
    s << "# It writes figures/" << name << ".png and .svg, and plots/" << name
      << ".ranges (each panel's data extent: panel, xmin, xmax, ymin, ymax[, zmin, zmax]).\n";
    s << "set encoding utf8\n";
    s << "set datafile separator \",\"\n";
    s << "# results.csv columns used (1-based), in the datablock $d below (the values as results.csv has them):\n";
    std::vector<const std::vector<double>*> block = {&t_.Col(t_.names().front())};
    s << "#   $d column 1 = results.csv column 1: time [" << GnuplotComment(t_.Unit("time")) << "]\n";
    int next = 2;
    for (const std::string& col : f_.Columns()) {
      block_[col] = next;
      block.push_back(&t_.Col(col));
      s << fmt::format("#   $d column {} = results.csv column {}: {} [{}]\n", next, t_.Find(col) + 1, GnuplotComment(col),
                       GnuplotComment(t_.Unit(col)));
      ++next;
    }
    s << "$d << EOD\n" << DataBlock(block) << "EOD\n";
    s << "set datafile nocolumnheaders\n";
    s << fmt::format("set print \"plots/{}.ranges\"\n", name);
    s << "set style data lines\n";
    s << "set grid lc rgb \"#dddddd\"\n";
    s << "set border lc rgb \"#444444\"\n";
    s << "set key outside right top Left reverse samplen 2 spacing 1.2\n";

    const size_t n = f_.panels.size();
    const bool has_path = std::any_of(f_.panels.begin(), f_.panels.end(), [](const Panel& p) { return p.kind != PanelKind::kTime; });
    const bool has_zoom = std::any_of(f_.panels.begin(), f_.panels.end(), [](const Panel& p) { return p.zoom; });
    // Time panels go on a grid (with their start-transient companion on the right); a figure with
    // a 3D panel places its panels side by side by hand, giving each a square.
    int rows = static_cast<int>(n), cols = 1, width = 1100, height = 80 + 400 * rows;
    std::vector<std::string> placement(n);
    if (has_path) {
      width = n == 1 ? 1000 : static_cast<int>(850 * n), height = n == 1 ? 900 : 760;
      for (size_t i = 0; i < n; ++i)
        placement[i] = n == 1 ? "  set origin 0, 0\n  set size 1, 0.95\n"
                              : fmt::format("  set origin {}, {}\n  set size {}, {}\n", Num(static_cast<double>(i) / n),
                                            f_.panels[i].kind == PanelKind::kTime ? "0.02" : "0", Num(1.0 / n),
                                            f_.panels[i].kind == PanelKind::kTime ? "0.9" : "0.95");
    } else if (has_zoom) {
      cols = 2, width = 1500, height = 80 + 430 * rows;
    }

    s << "do for [format in \"png svg\"] {\n";
    s << "  if (format eq \"png\") {\n";
    s << fmt::format("    set terminal pngcairo size {},{} enhanced font \"DejaVu Sans,11\" background \"white\"\n", width, height);
    s << "  } else {\n";
    s << fmt::format("    set terminal svg size {},{} dynamic enhanced font \"DejaVu Sans,11\" background \"white\"\n", width, height);
    s << "  }\n";
    s << fmt::format("  set output \"figures/{}.\".format\n", name);
    const std::string title = GnuplotString(f_.Title());
    if (has_path)
      s << fmt::format("  set multiplot title {} font \",15\"\n", title);
    else
      s << fmt::format("  set multiplot layout {},{} title {} font \",15\"\n", rows, cols, title);
    for (size_t i = 0; i < n; ++i) {
      const Panel& p = f_.panels[i];
      s << placement[i];
      if (p.kind == PanelKind::kTime) {
        TimePanelScript(s, p, full_, p.id, "");
        if (p.zoom)
          TimePanelScript(s, p, zoom_, p.id + "-zoom", fmt::format(", start transient ({}\u2013{} s)", Num(zoom_.t0), Num(zoom_.t1)));
      } else {
        PathPanelScript(s, p);
      }
    }
    s << "  unset multiplot\n";
    s << "  unset output\n";
    s << "}\n";
    return s.str();
  }

 private:
  /// A unit for a label: the panel's own (markup), else the header's, shown as it is.
  std::string Unit(const Panel& p) const { return p.unit.empty() ? FileUnit(p.curves.front().columns.front()) : p.unit; }
  std::string FileUnit(const std::string& column) const { return GnuplotLiteralText(t_.Unit(column)); }

  /// Prints the panel's data extent (first pass only).
  static void PrintRanges(std::ostringstream& s, const std::string& id, bool z) {
    s << "  if (format eq \"png\") {\n";
    if (z)
      s << fmt::format(
          "    print sprintf(\"{}\\t%.17g\\t%.17g\\t%.17g\\t%.17g\\t%.17g\\t%.17g\", GPVAL_DATA_X_MIN, GPVAL_DATA_X_MAX, "
          "GPVAL_DATA_Y_MIN, GPVAL_DATA_Y_MAX, GPVAL_DATA_Z_MIN, GPVAL_DATA_Z_MAX)\n",
          id);
    else
      s << fmt::format(
          "    print sprintf(\"{}\\t%.17g\\t%.17g\\t%.17g\\t%.17g\", GPVAL_DATA_X_MIN, GPVAL_DATA_X_MAX, GPVAL_DATA_Y_MIN, "
          "GPVAL_DATA_Y_MAX)\n",
          id);
    s << "  }\n";
  }

  void TimePanelScript(std::ostringstream& s, const Panel& p, Window w, const std::string& id, const std::string& title_suffix) {
    s << "  # panel " << id << "\n";
    s << "  unset arrow\n  unset label\n";
    s << "  set key outside right top Left reverse samplen 2 spacing 1.2\n";
    s << "  set lmargin 12\n  set rmargin 13\n";
    s << fmt::format("  set title {}\n", GnuplotString(p.title + title_suffix));
    s << fmt::format("  set xrange [{}:{}]\n", Num(w.t0), Num(w.t1));
    s << fmt::format("  set xlabel {}\n", GnuplotString(fmt::format("time t [{}]", FileUnit("time"))));
    const std::string quantity = p.quantity.empty() ? "value" : p.quantity;
    s << fmt::format("  set ylabel {}\n", GnuplotString(fmt::format("{} [{}]", quantity, Unit(p))));
    s << "  set xtics autofreq\n  set ytics autofreq\n  set format y \"%h\"\n";
    const auto [lo, hi] = DataRange(t_, p.curves, w);
    if (p.coordinates && std::isfinite(lo)) {
      s << fmt::format("  set yrange [{}:{}]\n", Num(std::floor((lo - 0.1) * 10) / 10), Num(std::ceil((hi + 0.1) * 10) / 10));
    } else if (std::isfinite(lo) && hi - lo <= 1e-12 * std::max(1.0, std::abs(lo))) {
      const double pad = std::max(1e-12, 0.1 * std::abs(lo)) + (lo == 0 ? 1.0 : 0.0);
      s << fmt::format("  set yrange [{}:{}]\n", Num(lo - pad), Num(hi + pad));  // a constant: no autoscale warning
    } else {
      s << "  set autoscale y\n";
    }
    const EventMarks marks = GnuplotEventMarks(events_, w.t0, w.t1);
    s << marks.arrows;
    s << "  plot ";
    for (size_t k = 0; k < p.curves.size(); ++k) {
      const Curve& c = p.curves[k];
      const int col = block_.at(c.columns.front());
      std::string expr = fmt::format("{}", col);
      if (c.from_start || c.scale != 1.0) {
        expr = fmt::format("(${}", col);
        if (c.from_start) expr += fmt::format(" - ({})", std::isfinite(t_.First(c.columns.front())) ? fmt::format("{:.17g}", t_.First(c.columns.front())) : "NaN");
        expr += ")";
        if (c.scale != 1.0) expr = fmt::format("({}*{})", expr, fmt::format("{:.17g}", c.scale));
      }
      s << fmt::format("{}$d using 1:{} lw 1.5 lc rgb \"{}\" title {}", k ? ", \\\n       " : "", expr, c.color, GnuplotString(c.title));
    }
    s << marks.keys << "\n";
    PrintRanges(s, id, false);
  }

  void PathPanelScript(std::ostringstream& s, const Panel& p) {
    s << "  # panel " << p.id << "\n";
    s << "  unset arrow\n  unset label\n";
    s << fmt::format("  set title {}\n", GnuplotString(p.title));
    s << "  unset lmargin\n  unset rmargin\n";
    s << "  set key inside left top Left reverse samplen 2 spacing 1.2\n";
    s << "  set view 62, 30, 1.12, 1\n  set view equal xyz\n  set xyplane relative 0\n";
    s << "  set xtics autofreq\n  set ytics autofreq\n  set ztics autofreq\n  set format y \"%h\"\n";
    std::array<double, 3> lo{}, hi{};
    if (p.kind == PanelKind::kOrientation) {
      lo = {-1.05, -1.05, -1.05};
      hi = {1.05, 1.05, 1.05};
      s << "  set xtics 0.5\n  set ytics 0.5\n  set ztics 0.5\n";
      // The unit vectors at the end of the run, from the origin: the tips end where the arrows point.
      for (size_t k = 0; k < p.curves.size(); ++k) {
        std::array<double, 3> v{};
        for (int i = 0; i < 3; ++i) v[i] = t_.Last(p.curves[k].columns[i]);
        s << fmt::format("  set arrow {} from 0,0,0 to {},{},{} lw 1.2 lc rgb \"{}\" dt 2 filled head size screen 0.015,20\n", k + 1,
                         Num(v[0]), Num(v[1]), Num(v[2]), p.curves[k].color);
      }
      s << fmt::format("  set label 1 {} at screen 0.98, screen 0.03 right font \",10\"\n",
                       GnuplotString(fmt::format("arrows and dots: the unit vectors at the end, t = {} s", Num(t_.Time1()))));
    } else {
      // A cube around the path: equal scales on the three axes.
      double half = 0;
      std::array<double, 3> mid{};
      for (size_t i = 0; i < 3; ++i) {
        const auto [a, b] = DataRange(t_, p.curves, full_, i);
        mid[i] = 0.5 * (a + b);
        half = std::max(half, 0.5 * (b - a));
      }
      half = half * 1.1 + 1e-9;
      for (int i = 0; i < 3; ++i) lo[i] = mid[i] - half, hi[i] = mid[i] + half;
    }
    const std::string unit = p.kind == PanelKind::kOrientation ? "-" : Unit(p);
    s << fmt::format("  set xrange [{}:{}]\n  set yrange [{}:{}]\n  set zrange [{}:{}]\n", Num(lo[0]), Num(hi[0]), Num(lo[1]), Num(hi[1]),
                     Num(lo[2]), Num(hi[2]));
    s << fmt::format("  set xlabel {}\n  set ylabel {}\n  set zlabel {} rotate parallel\n", GnuplotString(fmt::format("x [{}]", unit)),
                     GnuplotString(fmt::format("y [{}]", unit)), GnuplotString(fmt::format("z [{}]", unit)));
    // Tips that trace the same circle (x and y of a link spinning about z, y and z of one spinning
    // about x) must both show: each column is drawn narrower than the one before, on top of it.
    constexpr std::array<const char*, 3> kStyle = {"lw 7", "lw 3.5", "lw 1.2"};
    const size_t last = t_.rows() - 1;
    s << "  splot ";
    for (size_t k = 0; k < p.curves.size(); ++k) {
      const Curve& c = p.curves[k];
      const std::string using_spec = fmt::format("{}:{}:{}", block_.at(c.columns[0]), block_.at(c.columns[1]), block_.at(c.columns[2]));
      s << fmt::format("{}$d every {} using {} {} lc rgb \"{}\" title {}", k ? ", \\\n        " : "", std::max(1, o_.path_stride),
                       using_spec, p.kind == PanelKind::kOrientation ? kStyle[k % 3] : "lw 1.5", c.color, GnuplotString(c.title));
      // Where it is at the end of the run (a link that does not turn traces a point).
      s << fmt::format(", \\\n        $d every ::{}::{} using {} with points pt 7 ps 1.6 lc rgb \"{}\" notitle", last, last,
                       using_spec, c.color);
    }
    s << "\n";
    PrintRanges(s, p.id, true);
    s << "  unset arrow\n  unset label\n  set view 60, 30, 1, 1\n  set autoscale\n";
  }

  const PlotTable& t_;
  const Figure& f_;
  const ScriptSettings& o_;
  const std::vector<PlotEvent>& events_;
  Window full_{}, zoom_{};
  std::map<std::string, int> block_;  ///< where each results.csv column lands in the datablock
};

/// The first `max` bytes of a program's log (in the work folder), made printable.
std::string ReadLog(const std::string& path, size_t max = 600) {
  std::ifstream in(path, std::ios::binary);
  std::string text(max + 1, '\0');
  in.read(text.data(), static_cast<std::streamsize>(text.size()));
  text.resize(static_cast<size_t>(in.gcount()));
  const bool cut = text.size() > max;
  if (cut) text.resize(max);
  while (!text.empty() && std::isspace(static_cast<unsigned char>(text.back()))) text.pop_back();
  return MessageText(text) + (cut ? "..." : "");
}

}  // namespace

std::string GnuplotScript(const PlotTable& table, const Figure& figure, const ScriptSettings& settings,
                          const std::vector<PlotEvent>& events) {
  return ScriptWriter(table, figure, settings, events).Run();
}

std::map<std::string, std::string> RunGnuplot(const WorkFolder& work, int plots_dir, const std::vector<std::string>& names,
                                              const std::string& program, int jobs,
                                              const std::function<void(std::size_t, std::size_t)>& progress) {
  struct Job {
    pid_t pid;
    std::string name, log;
  };
  std::deque<Job> running;
  std::map<std::string, std::string> failures;
  auto reap = [&](const Job& j) {
    std::string why;
    try {
      why = WaitProcess(j.pid, program);
    } catch (const Interrupted&) {
      for (const Job& other : running)
        if (other.pid != j.pid) EndProcess(other.pid);
      running.clear();
      throw;
    }
    const std::string log = ReadLog(work.path() + "/" + j.log);
    if (!why.empty()) failures[j.name] = why + (log.empty() ? "" : ": " + log);
    // The log is kept only when gnuplot said something (an older one goes).
    if (log.empty() || !work.Publish(j.log, plots_dir, j.name + ".log")) ::unlinkat(plots_dir, (j.name + ".log").c_str(), 0);
  };
  std::size_t ended = 0;
  auto reap_front = [&] {
    const Job j = running.front();
    reap(j);
    running.pop_front();
    if (progress) progress(++ended, names.size());
  };
  for (const std::string& name : names) {
    if (static_cast<int>(running.size()) >= std::max(1, jobs)) reap_front();
    Job j{-1, name, "plots/" + name + ".log"};
    std::string error;
    j.pid = StartProcess({program, "plots/" + name + ".gp"}, work.path(), work.path() + "/" + j.log, &error);
    if (j.pid < 0) {
      while (!running.empty()) reap_front();
      throw std::runtime_error(error + " (install gnuplot, e.g. the Debian package gnuplot-nox)");
    }
    running.push_back(j);
  }
  while (!running.empty()) reap_front();
  return failures;
}

}  // namespace multibond
