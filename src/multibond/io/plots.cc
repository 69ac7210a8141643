#include "multibond/io/plots.h"

#include "multibond/core/process.h"
#include "multibond/io/results_folder.h"
#include "multibond/io/results_reader.h"
#include "multibond/io/safe_text.h"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <yaml-cpp/yaml.h>

#include "multibond/causality/causality.h"
#include "multibond/core/structure.h"
#include "multibond/io/dot_writer.h"
#include "multibond/io/model_loader.h"
#include "multibond/io/results_writer.h"


namespace multibond {

namespace {

namespace fs = std::filesystem;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

/// The longest results.csv header plot reads, and the largest run.json.
constexpr std::uint64_t kMaxHeaderBytes = 256ull << 20;
constexpr std::uint64_t kMaxRunJsonBytes = 4ull << 20;

// The scenario of shared/spec/differential.md: drive speed and tooth ratios, for the analytic
// steady values the page compares with.
constexpr double kDriveSpeed = 50.0;         // rad/s about x, on G
constexpr double kRatioPinionCrown = 12.0 / 48.0;
constexpr double kRatioSunPlanet = 24.0 / 12.0;

// Colours of the x, y, z components (and of the columns 1, 2, 3 of an orientation matrix).
constexpr std::array<const char*, 3> kColors = {"#d62728", "#2ca02c", "#1f77b4"};
constexpr std::array<const char*, 3> kAxes = {"x", "y", "z"};

// ---------------------------------------------------------------------------------------------
// results.csv

/// results.csv in memory, column by column.
class Table {
 public:
  /// Reads the folder's results.csv (a regular file, not a link, of at most `max_bytes`): the
  /// header's names and units, then every row, each with exactly one number per column. Memory:
  /// 8 bytes a value, so at most about 4 times the file's size (one-character values), plus about
  /// 150 bytes a column. Throws std::runtime_error with the file, line and what is wrong.
  /// `st` gets the file's status; `keep`, when given, the open file.
  static Table Load(const ResultsFolder& folder, std::uint64_t max_bytes, struct stat* st, Fd* keep = nullptr) {
    const std::string path = folder.PathOf("results.csv");
    Fd fd = folder.OpenInput("results.csv", max_bytes, "results-size", st);
    if (fd.get() < 0) throw std::runtime_error(fmt::format("cannot read '{}': no such file (run 'multibond run MODEL -o DIR' first)", path));
    if (st->st_size == 0) throw std::runtime_error(fmt::format("{}: empty file", path));
    BoundedFileBuf buf(fd.get(), std::min<std::uint64_t>(max_bytes, kMaxHeaderBytes));
    std::istream in(&buf);
    Table t;
    int lineno = 0;
    const std::vector<std::string> cells = ReadHeaderCells(in, path, lineno);
    if (buf.exceeded()) throw std::runtime_error(fmt::format("{}: the header is longer than {} bytes, more than plot reads", path, kMaxHeaderBytes));
    for (const std::string& cell : cells) {
      NameAndUnit nu = SplitNameAndUnit(cell);
      t.index_.emplace(nu.name, static_cast<int>(t.names_.size()));
      t.names_.push_back(std::move(nu.name));
      t.units_.push_back(std::move(nu.unit));
    }
    t.cols_.resize(t.names_.size());
    buf.set_limit(max_bytes);
    std::string line;
    std::vector<double> row;
    while (std::getline(in, line)) {
      ++lineno;
      if (line.empty() || line == "\r") continue;
      ParseRow(line, t.names_, path, lineno, row);
      for (size_t c = 0; c < row.size(); ++c) t.cols_[c].push_back(row[c]);
    }
    if (buf.exceeded())
      throw std::runtime_error(fmt::format("'{}' grew beyond {} bytes while it was read; {}", path, max_bytes, RaiseLimitHint("results-size", max_bytes)));
    if (t.rows() == 0) throw std::runtime_error(fmt::format("'{}' has no rows", path));
    if (keep) *keep = std::move(fd);
    return t;
  }

  size_t rows() const { return cols_.empty() ? 0 : cols_[0].size(); }
  bool Has(const std::string& name) const { return index_.count(name) > 0; }
  /// 0-based column index; -1 if absent.
  int Find(const std::string& name) const {
    auto it = index_.find(name);
    return it == index_.end() ? -1 : it->second;
  }
  const std::vector<double>& Col(const std::string& name) const { return cols_.at(Find(name)); }
  std::string Unit(const std::string& name) const { return Has(name) ? units_[Find(name)] : ""; }
  double First(const std::string& name) const { return Has(name) ? Col(name).front() : kNaN; }
  double Last(const std::string& name) const { return Has(name) ? Col(name).back() : kNaN; }
  double Time0() const { return cols_[0].front(); }
  double Time1() const { return cols_[0].back(); }

  /// Largest |value| over rows with time in [t0, t1].
  double MaxAbs(const std::string& name, double t0 = -INFINITY, double t1 = INFINITY) const {
    if (!Has(name)) return kNaN;
    double m = 0;
    const auto& c = Col(name);
    for (size_t r = 0; r < rows(); ++r)
      if (cols_[0][r] >= t0 && cols_[0][r] <= t1 && std::isfinite(c[r])) m = std::max(m, std::abs(c[r]));
    return m;
  }
  /// The vector (name.x, name.y, name.z) at a row.
  std::array<double, 3> Vec(const std::string& name, size_t row) const {
    std::array<double, 3> v{kNaN, kNaN, kNaN};
    for (int k = 0; k < 3; ++k)
      if (Has(name + "." + kAxes[k])) v[k] = Col(name + "." + kAxes[k])[row];
    return v;
  }
  std::array<double, 3> LastVec(const std::string& name) const { return Vec(name, rows() - 1); }
  /// Column j (1-based) of body B's orientation matrix at a row.
  std::array<double, 3> RColumn(const std::string& body, int j, size_t row) const {
    std::array<double, 3> v{kNaN, kNaN, kNaN};
    for (int i = 1; i <= 3; ++i) {
      const std::string n = fmt::format("{}.R.{}{}", body, i, j);
      if (Has(n)) v[i - 1] = Col(n)[row];
    }
    return v;
  }
  /// Largest |r(t) - r(0)| of the vector `name` over the run.
  double MaxDisplacement(const std::string& name) const {
    double m = 0;
    const auto r0 = Vec(name, 0);
    for (size_t r = 0; r < rows(); ++r) {
      const auto v = Vec(name, r);
      m = std::max(m, std::hypot(v[0] - r0[0], v[1] - r0[1], v[2] - r0[2]));
    }
    return m;
  }

 private:
  std::vector<std::string> names_, units_;
  std::vector<std::vector<double>> cols_;
  std::map<std::string, int> index_;
};

double Dot(const std::array<double, 3>& a, const std::array<double, 3>& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
double Norm(const std::array<double, 3>& a) { return std::sqrt(Dot(a, a)); }
std::array<double, 3> Sub(const std::array<double, 3>& a, const std::array<double, 3>& b) {
  return {a[0] - b[0], a[1] - b[1], a[2] - b[2]};
}

// ---------------------------------------------------------------------------------------------
// Text in two markups. Captions and legends are written once, with _{sub} and ^{sup} as in
// gnuplot's enhanced text, and turned into HTML for the page.

/// "Q_{P1}" -> "Q<sub>P1</sub>", HTML-escaped.
std::string MarkupToHtml(const std::string& s) {
  std::string out, plain;
  for (size_t i = 0; i < s.size(); ++i) {
    if ((s[i] == '_' || s[i] == '^') && i + 1 < s.size() && s[i + 1] == '{') {
      const size_t close = s.find('}', i + 2);
      if (close != std::string::npos) {
        const char* tag = s[i] == '_' ? "sub" : "sup";
        out += HtmlEscape(plain) + fmt::format("<{}>{}</{}>", tag, HtmlEscape(s.substr(i + 2, close - i - 2)), tag);
        plain.clear();
        i = close;
        continue;
      }
    }
    plain += s[i];
  }
  return out + HtmlEscape(plain);
}

/// A gnuplot string (enhanced text markup kept): our own text, with file text (units) in it only
/// through GnuplotLiteralText.
std::string GpString(const std::string& s) { return GnuplotString(s); }

/// A number for a script or a page, exactly enough.
std::string Num(double v) { return std::isfinite(v) ? fmt::format("{:.10g}", v) : "NaN"; }

/// A number for reading: 4 significant digits, no exponent for ordinary magnitudes.
std::string Show(double v, int digits = 4) {
  if (!std::isfinite(v)) return "n/a";
  if (v == 0) return "0";
  const double a = std::abs(v);
  if (a >= 1e-3 && a < 1e6) {
    const int decimals = std::max(0, digits - 1 - static_cast<int>(std::floor(std::log10(a))));
    std::string s = fmt::format("{:.{}f}", v, decimals);
    if (s.front() == '-') s = "\u2212" + s.substr(1);
    return s;
  }
  const int e = static_cast<int>(std::floor(std::log10(a)));
  const double m = v / std::pow(10.0, e);
  std::string ms = fmt::format("{:.{}f}", m, digits - 1);
  if (ms.front() == '-') ms = "\u2212" + ms.substr(1);
  return fmt::format("{}\u00b710<sup>{}</sup>", ms, e < 0 ? "\u2212" + std::to_string(-e) : std::to_string(e));
}

// ---------------------------------------------------------------------------------------------
// The figures

/// One plotted series: a column against time, or three columns as a 3D path.
struct Curve {
  std::vector<std::string> columns;  ///< 1 (against time) or 3 (x, y, z of a path)
  std::string title;                 ///< legend (enhanced text)
  std::string color;
  bool from_start = false;  ///< plot v - v(t0)
  double scale = 1.0;       ///< then times this
};

enum class PanelKind { kTime, kPath, kOrientation };

struct Panel {
  PanelKind kind = PanelKind::kTime;
  std::string id;        ///< "a", "b", ... (the ranges file's key)
  std::string title;     ///< enhanced text
  std::string quantity;  ///< y label without unit (time panels)
  std::string unit;      ///< "" = the unit of the first column, from the header
  std::vector<Curve> curves;
  bool zoom = false;         ///< add a start-transient companion panel
  bool coordinates = false;  ///< y range: the data's, +-0.1 (positions of links that hardly move)
};

struct FigureSpec {
  int number = 0;
  std::string link, quantity;
  std::string caption;  ///< the paper's caption (markup)
  std::vector<Panel> panels;
  std::string Name() const { return fmt::format("fig{:02}-{}-{}", number, link, quantity); }
  std::vector<std::string> Columns() const {
    std::vector<std::string> out;
    for (const Panel& p : panels)
      for (const Curve& c : p.curves)
        for (const std::string& col : c.columns)
          if (std::find(out.begin(), out.end(), col) == out.end()) out.push_back(col);
    return out;
  }
};

/// x, y, z components of a vector output; legends "symbol_x" ... (just "x" ... without a symbol).
std::vector<Curve> Components(const std::string& prefix, const std::string& symbol, bool from_start = false, double scale = 1.0) {
  std::vector<Curve> out;
  for (int k = 0; k < 3; ++k)
    out.push_back({{prefix + "." + kAxes[k]}, symbol.empty() ? std::string(kAxes[k]) : fmt::format("{}_{{{}}}", symbol, kAxes[k]),
                   kColors[k], from_start, scale});
  return out;
}

Panel TimePanel(std::string id, std::string title, std::string quantity, std::vector<Curve> curves, bool zoom) {
  Panel p;
  p.id = std::move(id);
  p.title = std::move(title);
  p.quantity = std::move(quantity);
  p.curves = std::move(curves);
  p.zoom = zoom;
  return p;
}

Panel PathPanel(std::string id, std::string title, const std::string& prefix, const std::string& legend) {
  Panel p;
  p.kind = PanelKind::kPath;
  p.id = std::move(id);
  p.title = std::move(title);
  p.curves.push_back({{prefix + ".x", prefix + ".y", prefix + ".z"}, legend, kColors[2]});
  return p;
}

FigureSpec Orientation(int n, const std::string& b) {
  FigureSpec f{n, b, "orientation", fmt::format("Orientation matrix of link {}", b), {}};
  Panel p;
  p.kind = PanelKind::kOrientation;
  p.id = "a";
  p.title = fmt::format("columns of ^{{0}}_{{{}}}R: paths of the tips of {}'s unit vectors in frame 0", b, b);
  for (int j = 1; j <= 3; ++j)
    p.curves.push_back({{fmt::format("{}.R.1{}", b, j), fmt::format("{}.R.2{}", b, j), fmt::format("{}.R.3{}", b, j)},
                        fmt::format("column {}: tip of {}_{{{}}}", j, kAxes[j - 1], b), kColors[j - 1]});
  f.panels.push_back(p);
  return f;
}

FigureSpec CentreOfMass(int n, const std::string& b) {
  FigureSpec f{n, b, "com", fmt::format("Variation of coordinates of center of mass of link {} with time", b), {}};
  Panel a = TimePanel("a", fmt::format("(a) coordinates of the centre of mass C_{{{}}}", b), fmt::format("position of C_{{{}}}", b),
                      Components(b + ".r", ""), false);
  a.coordinates = true;
  Panel d = TimePanel("b", "(b) the same, minus the initial position: the deflection of the supports",
                      fmt::format("r - r(0) of C_{{{}}}", b), Components(b + ".r", "{/Symbol D}r", true, 1e6), false);
  d.unit = "\u00b5m";
  f.panels = {a, d};
  return f;
}

FigureSpec CentreOfMassPath(int n, const std::string& b) {
  FigureSpec f{n, b, "com", fmt::format("Variation of coordinates of center of mass of link {} with time", b), {}};
  Panel a = TimePanel("a", fmt::format("(a) coordinates of C_{{{}}}", b), fmt::format("position of C_{{{}}}", b),
                      Components(b + ".r", ""), false);
  a.coordinates = true;
  f.panels = {a, PathPanel("b", fmt::format("(b) path of C_{{{}}}", b), b + ".r", fmt::format("C_{{{}}}", b))};
  return f;
}

FigureSpec Momentum(int n, const std::string& b, bool translational) {
  FigureSpec f{n, b, "momentum", fmt::format("Variation of components of momentum of link {} with time", b), {}};
  if (translational) {
    f.panels.push_back(TimePanel("a", "(a) translational momentum p", "translational momentum p", Components(b + ".p", "p"), true));
    f.panels.push_back(TimePanel("b", "(b) angular momentum h (about C, in frame 0)", "angular momentum h", Components(b + ".h", "h"), true));
  } else {
    f.panels.push_back(TimePanel("a", "angular momentum h (about C, in frame 0)", "angular momentum h", Components(b + ".h", "h"), true));
  }
  return f;
}

FigureSpec Reaction(int n, const std::string& b, bool moment, const std::string& caption) {
  FigureSpec f{n, b, "reaction", caption, {}};
  const std::string pa = moment ? "(a) " : "";
  f.panels.push_back(TimePanel("a", fmt::format("{}reaction force on link {}", pa, b), "reaction force F", Components(b + ".F", "F"), true));
  if (moment)
    f.panels.push_back(TimePanel("b", fmt::format("(b) reaction moment on link {} (about C, in frame 0)", b), "reaction moment M",
                                 Components(b + ".M", "M"), true));
  return f;
}

FigureSpec RimPoint(int n, const std::string& point, const std::string& link) {
  const std::string q = fmt::format("Q_{{{}}}", link);
  FigureSpec f{n, link, "rim-point", fmt::format("Variation of coordinates of point {} on link {} with time", q, link), {}};
  f.panels.push_back(TimePanel("a", fmt::format("(a) coordinates of {}", q), fmt::format("position of {}", q),
                               Components(point, ""), false));
  f.panels.push_back(PathPanel("b", fmt::format("(b) path of {}", q), point, q));
  return f;
}

std::vector<FigureSpec> PaperFigures() {
  std::vector<FigureSpec> f;
  // A. Link G
  f.push_back(Orientation(3, "G"));
  f.push_back(CentreOfMass(4, "G"));
  f.push_back(Momentum(5, "G", false));
  {
    FigureSpec t{6, "G", "torque", "Variation of torque with time", {}};
    t.panels.push_back(TimePanel("a", "torque of the drive coupling on G", "drive torque {/Symbol t}",
                                 {{{"drive.torque"}, "{/Symbol t}_{drive}", kColors[0]}}, true));
    f.push_back(t);
  }
  f.push_back(Reaction(7, "G", false, "Variation of reaction force with time"));
  // B. Link A
  f.push_back(Orientation(8, "A"));
  f.push_back(CentreOfMass(9, "A"));
  f.push_back(Momentum(10, "A", false));
  f.push_back(Reaction(11, "A", true, "Variation of components of reaction force and moment of link A with time"));
  // C. Link S1
  f.push_back(Orientation(12, "S1"));
  f.push_back(CentreOfMass(13, "S1"));
  f.push_back(Momentum(14, "S1", false));
  f.push_back(Reaction(15, "S1", false, "Variation of components of reaction force of link S1 with time"));
  // D. Link S2
  f.push_back(Orientation(16, "S2"));
  f.push_back(CentreOfMass(17, "S2"));
  f.push_back(Momentum(18, "S2", false));
  f.push_back(Reaction(19, "S2", false, "Variation of components of reaction force of link S2 with time"));
  // E. Link P1, F. Link P2
  for (const auto& [base, p] : {std::pair{20, std::string("P1")}, std::pair{24, std::string("P2")}}) {
    f.push_back(Orientation(base, p));
    f.push_back(CentreOfMassPath(base + 1, p));
    f.push_back(Momentum(base + 2, p, true));
    f.push_back(Reaction(base + 3, p, true, fmt::format("Variation of reaction force and moment of link {} with time", p)));
  }
  f.push_back(RimPoint(28, "Q_P1", "P1"));
  f.push_back(RimPoint(29, "Q_P2", "P2"));
  // G. Link H
  f.push_back(Orientation(30, "H"));
  f.push_back(CentreOfMass(31, "H"));
  f.push_back(Momentum(32, "H", false));
  f.push_back(Reaction(33, "H", true, "Variation of reaction force and moment of link H with time"));
  return f;
}

constexpr const char* kBondGraphName = "fig02-bond-graph";
constexpr const char* kBondGraphCaption = "Multibond graph model of Differential gear train mechanism";

// ---------------------------------------------------------------------------------------------
// gnuplot scripts

/// Where each results.csv column lands in the figure's datablock (column 1 is time).
using BlockColumns = std::map<std::string, int>;

struct Window {
  double t0, t1;
};

/// min/max of a curve set over a time window (NaNs skipped); {inf, -inf} if empty.
std::pair<double, double> DataRange(const Table& t, const std::vector<Curve>& curves, Window w, size_t coord = 0) {
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

class ScriptWriter {
 public:
  ScriptWriter(const Table& t, const FigureSpec& f, const PlotOptions& o) : t_(t), f_(f), o_(o) {
    full_ = {t.Time0(), t.Time1()};
    const double span = full_.t1 - full_.t0;
    zoom_ = {full_.t0, full_.t0 + std::min(o.zoom_length, 0.25 * span)};
  }

  std::string Run() {
    const std::string name = f_.Name();
    std::ostringstream s;
    s << fmt::format("# Fig. {} of the paper: {}.\n", f_.number, f_.caption);
    s << "# Written by multibond from results.csv. Run it again from the results folder:\n";
    s << fmt::format("#   gnuplot plots/{}.gp\n", name);
    s << "# It writes figures/" << name << ".png and .svg, and plots/" << name
      << ".ranges (each panel's data extent: panel, xmin, xmax, ymin, ymax[, zmin, zmax]).\n";
    s << "set encoding utf8\n";
    s << "set datafile separator \",\"\n";
    s << "set datafile columnheaders\n";
    s << "# results.csv columns used (1-based), read once into the datablock $d (as text: no digit lost):\n";
    std::string using_spec = "(strcol(1))";
    s << "#   $d column 1 = results.csv column 1: time [" << GnuplotComment(t_.Unit("time")) << "]\n";
    int next = 2;
    for (const std::string& col : f_.Columns()) {
      block_[col] = next;
      using_spec += fmt::format(":(strcol({}))", t_.Find(col) + 1);
      s << fmt::format("#   $d column {} = results.csv column {}: {} [{}]\n", next, t_.Find(col) + 1, col, GnuplotComment(t_.Unit(col)));
      ++next;
    }
    s << "set table $d separator comma\n";
    s << "plot \"results.csv\" using " << using_spec << " with table\n";
    s << "unset table\n";
    s << "set datafile nocolumnheaders\n";
    s << fmt::format("set print \"plots/{}.ranges\"\n", name);
    s << "set style data lines\n";
    s << "set grid lc rgb \"#dddddd\"\n";
    s << "set border lc rgb \"#444444\"\n";
    s << "set key outside right top Left reverse samplen 2 spacing 1.2\n";

    const bool has_path = std::any_of(f_.panels.begin(), f_.panels.end(), [](const Panel& p) { return p.kind != PanelKind::kTime; });
    const bool has_zoom = std::any_of(f_.panels.begin(), f_.panels.end(), [](const Panel& p) { return p.zoom; });
    // Time panels go on a grid (with their start-transient companion on the right); a figure with
    // a 3D panel places its panels by hand, giving the 3D one a square.
    int rows = 1, cols = 1, width = 1000, height = 750;
    std::vector<std::string> placement(f_.panels.size());
    if (has_path) {
      width = f_.panels.size() == 1 ? 1000 : 1700, height = f_.panels.size() == 1 ? 900 : 760;
      if (f_.panels.size() == 1) {
        placement[0] = "  set origin 0, 0\n  set size 1, 0.95\n";
      } else {
        placement[0] = "  set origin 0, 0.02\n  set size 0.5, 0.9\n";
        placement[1] = "  set origin 0.5, 0\n  set size 0.5, 0.95\n";
      }
    } else if (has_zoom) {
      rows = static_cast<int>(f_.panels.size()), cols = 2, width = 1500, height = 80 + 430 * rows;
    } else {
      rows = static_cast<int>(f_.panels.size()), cols = 1, width = 1100, height = 80 + 400 * rows;
    }

    s << "do for [format in \"png svg\"] {\n";
    s << "  if (format eq \"png\") {\n";
    s << fmt::format("    set terminal pngcairo size {},{} enhanced font \"DejaVu Sans,11\" background \"white\"\n", width, height);
    s << "  } else {\n";
    s << fmt::format("    set terminal svg size {},{} dynamic enhanced font \"DejaVu Sans,11\" background \"white\"\n", width, height);
    s << "  }\n";
    s << fmt::format("  set output \"figures/{}.\".format\n", name);
    const std::string title = GpString(fmt::format("Fig. {}. {}", f_.number, f_.caption));
    if (has_path)
      s << fmt::format("  set multiplot title {} font \",15\"\n", title);
    else
      s << fmt::format("  set multiplot layout {},{} title {} font \",15\"\n", rows, cols, title);
    for (size_t i = 0; i < f_.panels.size(); ++i) {
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
  /// A unit for a label: the panel's own, else the header's, shown as it is (not as enhanced text).
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
    s << fmt::format("  set title {}\n", GpString(p.title + title_suffix));
    s << fmt::format("  set xrange [{}:{}]\n", Num(w.t0), Num(w.t1));
    s << fmt::format("  set xlabel {}\n", GpString(fmt::format("time t [{}]", FileUnit("time"))));
    s << fmt::format("  set ylabel {}\n", GpString(fmt::format("{} [{}]", p.quantity, Unit(p))));
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
    s << "  plot ";
    for (size_t k = 0; k < p.curves.size(); ++k) {
      const Curve& c = p.curves[k];
      const int col = block_.at(c.columns.front());
      std::string expr = fmt::format("{}", col);
      if (c.from_start || c.scale != 1.0) {
        expr = fmt::format("(${}", col);
        if (c.from_start) expr += fmt::format(" - ({})", std::isfinite(t_.First(c.columns.front())) ? fmt::format("{:.17g}", t_.First(c.columns.front())) : "NaN");
        expr += ")";
        if (c.scale != 1.0) expr = fmt::format("({}*{})", expr, Num(c.scale));
      }
      s << fmt::format("{}$d using 1:{} lw 1.5 lc rgb \"{}\" title {}", k ? ", \\\n       " : "", expr, c.color, GpString(c.title));
    }
    s << "\n";
    PrintRanges(s, id, false);
  }

  void PathPanelScript(std::ostringstream& s, const Panel& p) {
    s << "  # panel " << p.id << "\n";
    s << "  unset arrow\n  unset label\n";
    s << fmt::format("  set title {}\n", GpString(p.title));
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
                       GpString(fmt::format("arrows and dots: the unit vectors at the end, t = {} s", Num(t_.Time1()))));
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
    const std::string unit = p.kind == PanelKind::kOrientation ? "-" : FileUnit(p.curves.front().columns.front());
    s << fmt::format("  set xrange [{}:{}]\n  set yrange [{}:{}]\n  set zrange [{}:{}]\n", Num(lo[0]), Num(hi[0]), Num(lo[1]), Num(hi[1]),
                     Num(lo[2]), Num(hi[2]));
    s << fmt::format("  set xlabel {}\n  set ylabel {}\n  set zlabel {} rotate parallel\n", GpString(fmt::format("x [{}]", unit)),
                     GpString(fmt::format("y [{}]", unit)), GpString(fmt::format("z [{}]", unit)));
    // Tips that trace the same circle (x and y of a link spinning about z, y and z of one spinning
    // about x) must both show: each column is drawn narrower than the one before, on top of it.
    constexpr std::array<const char*, 3> kStyle = {"lw 7", "lw 3.5", "lw 1.2"};
    const size_t last = t_.rows() - 1;
    s << "  splot ";
    for (size_t k = 0; k < p.curves.size(); ++k) {
      const Curve& c = p.curves[k];
      const std::string using_spec = fmt::format("{}:{}:{}", block_.at(c.columns[0]), block_.at(c.columns[1]), block_.at(c.columns[2]));
      s << fmt::format("{}$d every {} using {} {} lc rgb \"{}\" title {}", k ? ", \\\n        " : "", std::max(1, o_.path_stride),
                       using_spec, p.kind == PanelKind::kOrientation ? kStyle[k % 3] : "lw 1.5", c.color, GpString(c.title));
      // Where it is at the end of the run (a link that does not turn traces a point).
      s << fmt::format(", \\\n        $d every ::{}::{} using {} with points pt 7 ps 1.6 lc rgb \"{}\" notitle", last, last,
                       using_spec, c.color);
    }
    s << "\n";
    PrintRanges(s, p.id, true);
    s << "  unset arrow\n  unset label\n  set view 60, 30, 1, 1\n  set autoscale\n";
  }

  const Table& t_;
  const FigureSpec& f_;
  const PlotOptions& o_;
  Window full_{}, zoom_{};
  BlockColumns block_;
};

// ---------------------------------------------------------------------------------------------
// Running gnuplot

struct Job {
  pid_t pid = -1;
  std::string name, log;
};

pid_t Start(const std::vector<std::string>& args, const std::string& cwd, const std::string& log, std::string* error) {
  return StartProcess(args, cwd, log, error);
}

std::string Finish(pid_t pid, const std::string& program) { return WaitProcess(pid, program); }

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

/// run.json of the folder as JSON ({} when it is absent or does not parse); throws when it is a
/// link, not a regular file or larger than kMaxRunJsonBytes.
nlohmann::json ReadRunJson(const ResultsFolder& folder) {
  const std::optional<std::string> text = folder.ReadText("run.json", kMaxRunJsonBytes, nullptr);
  if (!text) return nlohmann::json::object();
  try {
    nlohmann::json j = nlohmann::json::parse(*text);
    if (j.is_object()) return j;
  } catch (const std::exception&) {
  }
  return nlohmann::json::object();
}

/// `key` -> `value` of every "name: {field: value}" entry of a mechanism section (e.g. each joint's
/// child); `sub` reads value from a nested map ("a: {body: P1}").
void NestFromSection(const YAML::Node& root, const char* section, const char* field, const char* sub,
                     std::map<std::string, std::string>& nest) {
  const YAML::Node s = root[section];
  if (!s || !s.IsMap()) return;
  for (const auto& entry : s) {
    const YAML::Node v = entry.second;
    if (!v.IsMap() || !v[field]) continue;
    const YAML::Node target = sub ? v[field][sub] : v[field];
    if (target && target.IsScalar()) nest[entry.first.as<std::string>()] = target.as<std::string>();
  }
}

/// Fig. 2: the model's multibond graph with causal strokes, drawn in `work` and put into the
/// folder's figures/ and plots/. Returns the files written.
std::vector<std::string> DrawBondGraph(const ResultsFolder& folder, const WorkFolder& work, int figures, int plots,
                                       const std::string& model, std::vector<std::string>& warnings) {
  const LoadedModel lm = LoadModelFile(model);
  DiagnosticSink sink;
  const Structure s = AnalyzeStructure(lm.graph, lm.compile.default_domain, sink);
  if (sink.has_errors()) {
    warnings.push_back(fmt::format("Fig. 2 left out: the model '{}' has structural errors (see 'multibond check')", MessageText(model)));
    return {};
  }
  const CausalAssignment c = AssignCausality(lm.graph, s);
  const std::string dot = std::string(kBondGraphName) + ".dot";
  work.Write("plots/" + dot, MakeDot(lm.graph, &s, &c, LinkGrouping(lm)));
  std::vector<std::string> files;
  for (const char* format : {"png", "svg"}) {
    const std::string out = std::string(kBondGraphName) + "." + format;
    std::string error;
    if (RenderWithGraphviz(work.path() + "/plots/" + dot, work.path() + "/figures/" + out, format, &error) &&
        work.Publish("figures/" + out, figures, out))
      files.push_back(folder.PathOf("figures/" + out));
    else
      warnings.push_back(fmt::format("Fig. 2 ({}) left out: {}", format, MessageText(error)));
  }
  work.Publish("plots/" + dot, plots, dot);
  return files;
}

// ---------------------------------------------------------------------------------------------
// The page

/// Numbers read off a run for the page's texts and summary.
class Facts {
 public:
  explicit Facts(const Table& t) : t_(t) {}

  bool Has(const std::string& n) const { return t_.Has(n); }
  bool HasVec(const std::string& n) const { return t_.Has(n + ".x") && t_.Has(n + ".y") && t_.Has(n + ".z"); }
  double Last(const std::string& n) const { return t_.Last(n); }
  double First(const std::string& n) const { return t_.First(n); }
  double MaxAbs(const std::string& n) const { return t_.MaxAbs(n); }
  /// min and max of a column over the run.
  std::pair<double, double> Range(const std::string& n) const {
    if (!t_.Has(n)) return {kNaN, kNaN};
    const auto& c = t_.Col(n);
    return {*std::min_element(c.begin(), c.end()), *std::max_element(c.begin(), c.end())};
  }
  double LastNorm(const std::string& n) const { return HasVec(n) ? Norm(t_.LastVec(n)) : kNaN; }
  std::array<double, 3> FirstVec(const std::string& n) const { return t_.Vec(n, 0); }
  /// Largest |component| of a vector output over [t0, t1].
  double MaxAbsVec(const std::string& n, double t0 = -INFINITY, double t1 = INFINITY) const {
    if (!HasVec(n)) return kNaN;
    double m = 0;
    for (const char* a : kAxes) m = std::max(m, t_.MaxAbs(n + "." + a, t0, t1));
    return m;
  }
  /// Largest |r(t) - r(0)| of a vector output.
  double MaxDisplacement(const std::string& n) const { return HasVec(n) ? t_.MaxDisplacement(n) : kNaN; }
  /// Spin of a planet relative to the carrier A, about the planet's body x axis, at the end.
  double Spin(const std::string& p) const {
    if (!HasVec(p + ".omega") || !HasVec("A.omega") || !t_.Has(p + ".R.11")) return kNaN;
    const auto e = t_.RColumn(p, 1, t_.rows() - 1);
    return Dot(Sub(t_.LastVec(p + ".omega"), t_.LastVec("A.omega")), e);
  }
  /// Mass of a link: |p| / |v| at the end.
  double Mass(const std::string& b) const { return LastNorm(b + ".p") / LastNorm(b + ".v"); }
  /// Distance of a link's centre of mass from A's axis (through A's centre along A's z column).
  double RadiusFromA(const std::string& b) const {
    if (!HasVec(b + ".r") || !HasVec("A.r") || !t_.Has("A.R.13")) return kNaN;
    const size_t r = t_.rows() - 1;
    const auto d = Sub(t_.Vec(b + ".r", r), t_.Vec("A.r", r));
    const auto a = t_.RColumn("A", 3, r);
    const double along = Dot(d, a);
    return std::sqrt(std::max(0.0, Dot(d, d) - along * along));
  }
  /// Moment of inertia of a link about its body x axis: (h . e1) / (w . e1) at the end.
  double AxialInertia(const std::string& b) const {
    if (!HasVec(b + ".h") || !HasVec(b + ".omega") || !t_.Has(b + ".R.11")) return kNaN;
    const auto e = t_.RColumn(b, 1, t_.rows() - 1);
    return Dot(t_.LastVec(b + ".h"), e) / Dot(t_.LastVec(b + ".omega"), e);
  }
  /// The time after which `n` stays within +-band (relative) of its final value.
  double SettlingTime(const std::string& n, double band = 0.02) const {
    if (!t_.Has(n)) return kNaN;
    const auto& c = t_.Col(n);
    const auto& time = t_.Col("time");
    const double final = c.back(), tol = band * std::max(std::abs(final), 1e-12);
    for (size_t r = t_.rows(); r-- > 0;)
      if (!(std::abs(c[r] - final) <= tol)) return r + 1 < t_.rows() ? time[r + 1] : time[r];
    return time.front();
  }
  double T0() const { return t_.Time0(); }
  double T1() const { return t_.Time1(); }

  /// Slowest and fastest speed of a point over the second half of the run (central differences),
  /// each with the point's z there: {v_min, z, v_max, z}.
  std::array<double, 4> SpeedExtremes(const std::string& n) const {
    std::array<double, 4> out{INFINITY, kNaN, -INFINITY, kNaN};
    if (!HasVec(n) || t_.rows() < 3) return {kNaN, kNaN, kNaN, kNaN};
    const auto& time = t_.Col("time");
    const double half = 0.5 * (T0() + T1());
    for (size_t r = 1; r + 1 < t_.rows(); ++r) {
      if (time[r] < half) continue;
      const double v = Norm(Sub(t_.Vec(n, r + 1), t_.Vec(n, r - 1))) / (time[r + 1] - time[r - 1]);
      const double z = t_.Vec(n, r)[2];
      if (v < out[0]) out[0] = v, out[1] = z;
      if (v > out[2]) out[2] = v, out[3] = z;
    }
    return out;
  }

 private:
  const Table& t_;
};

std::string Triple(const std::array<double, 3>& v) {
  return fmt::format("({}, {}, {})", Show(v[0], 3), Show(v[1], 3), Show(v[2], 3));
}

/// What a figure shows, for the page: the physics, with this run's numbers.
std::string WhatItShows(int n, const Facts& f) {
  const std::string t_end = Show(f.T1(), 3);
  const std::string w_a = Show(f.Last("A.omega.z"));
  const double early = f.T0() + std::min(0.5, 0.25 * (f.T1() - f.T0()));
  auto um = [](double metres) { return Show(1e6 * metres, 3); };
  auto com = [&](const std::string& b, const std::string& holder, const std::string& ending) {
    return fmt::format(
        "The centre of mass of {} does not move: it stays at {} m, held by {}. Panel (b) magnifies what is left: the "
        "supports' springs (10<sup>6</sup> N/m) give by at most {} &micro;m while the train starts, and {}.",
        b, Triple(f.FirstVec(b + ".r")), holder, um(f.MaxDisplacement(b + ".r")), ending);
  };
  const std::string dies_out = "the deflection dies out with the start transient";
  auto fixed_orientation = [&](const std::string& b, const std::string& why) {
    return fmt::format(
        "{} The three columns of R stay at the unit vectors of frame 0: each tip is a point (the dots). Its largest angular "
        "velocity, during the start, is {} rad/s.",
        why, Show(f.MaxAbsVec(b + ".omega")));
  };
  auto planet_orientation = [&](const std::string& p) {
    return fmt::format(
        "{} is carried round z by A ({} rad/s) and spins about its own radial axis (body x) at {} rad/s relative to A. "
        "Column 1, the spin axis, points outwards and sweeps the horizontal circle with the carrier; columns 2 and 3 combine "
        "both rotations and wind over the sphere. The curves close after each turn of the carrier, because the planet turns "
        "|s|/|&omega;<sub>A</sub>| = 24/12 = 2 times relative to A per turn (S1 is held). (The paper's frames follow the "
        "D&ndash;H convention, in which the spin axis is z; here it is x, so the roles of the columns are swapped.)",
        p, w_a, Show(f.Spin(p)));
  };
  auto planet_com = [&](const std::string& p) {
    return fmt::format(
        "(a) x and y of the centre of {} oscillate with amplitude {} m (its distance from A's axis) at the carrier's "
        "rate, {} rad/s (a period of {} s); z stays at {} m. (b) The path is a circle round A's axis.",
        p, Show(f.RadiusFromA(p), 3), w_a, Show(2 * M_PI / std::abs(f.Last("A.omega.z")), 3), Show(f.Last(p + ".r.z"), 3));
  };
  auto planet_momentum = [&](const std::string& p) {
    return fmt::format(
        "(a) p = m<sub>P</sub> v turns with the carrier: |p| = m<sub>P</sub> |&omega;<sub>A</sub>| &rho; = {} N s, with "
        "p<sub>z</sub> = 0. (b) h = I<sub>axial</sub> s e<sub>x</sub> + I<sub>diametral</sub> &omega;<sub>A</sub> e<sub>z</sub>: "
        "the spin part lies along the planet's radial spin axis, which turns with A, hence x and y components of amplitude {} "
        "N m s; h<sub>z</sub> = {} N m s comes from the carrier's rotation. (The x and y components are there because the "
        "spin axis turns, not because the centre of mass moves: h is taken about the centre of mass.) The start transient "
        "dies out within about half a second.",
        Show(f.LastNorm(p + ".p")), Show(std::hypot(f.Last(p + ".h.x"), f.Last(p + ".h.y"))), Show(f.Last(p + ".h.z")));
  };
  auto planet_reaction = [&](const std::string& p) {
    return fmt::format(
        "(a) The bearing pulls {} towards A's axis with the centripetal force m<sub>P</sub> &omega;<sub>A</sub><sup>2</sup> "
        "&rho;: |F| = {} N at t = {} s, a vector that turns with the carrier (x and y oscillate at its rate, F<sub>z</sub> "
        "&asymp; 0). (b) The moment turns the spinning planet's axis with the carrier: the gyroscopic moment "
        "I<sub>axial</sub> s &omega;<sub>A</sub>, |M| = {} N m, horizontal and turning with A. The large start transients "
        "(meshes and bearings taking up the sudden drive) decay through the couplings' damping.",
        p, Show(f.LastNorm(p + ".F")), t_end, Show(f.LastNorm(p + ".M")));
  };
  auto rim = [&](const std::string& q, const std::string& column, const std::string& p) {
    const auto [z_lo, z_hi] = f.Range(column + ".z");
    const auto v = f.SpeedExtremes(column);
    return fmt::format(
        "{} is a point on {}'s rim, 0.05 m from its centre along the body y axis. (a) Its coordinates combine the carrier's "
        "rotation ({} rad/s) with the planet's spin ({} rad/s relative to A): z oscillates with the spin, between {} and {} m. "
        "(b) Its path in space closes after each turn of the carrier, since the planet turns exactly twice relative to A "
        "meanwhile (24 teeth on the suns, 12 on the planets, S1 held). The path has two cusps per turn: there the point "
        "touches the held S1 (z = {} m) and, the planet rolling on S1, stands still (slowest sampled speed {} m/s); where it meets "
        "S2 (z = {} m) it moves with S2's pitch circle, |&omega;<sub>S2</sub>| &middot; 0.1 m: {} m/s.",
        q, p, w_a, Show(f.Spin(p)), Show(z_lo, 3), Show(z_hi, 3), Show(v[1], 3), Show(v[0], 2), Show(v[3], 3), Show(v[2], 3));
  };
  switch (n) {
    case 2:
      return "The model that multibond simulates, drawn from the model file by <code>multibond graph</code>: every link is a "
             "1-junction of velocity with its mass (I) and a 1-junction of angular velocity with its inertia in the inertial "
             "frame (no Euler junction structure); the couplings (C and R in parallel, behind transformers that express "
             "them in the parent's frame) and the gear meshes (transformers between spins relative to the carrier) join "
             "them. The causal strokes show integral causality throughout. Elements are grouped by link: a link's box holds its "
             "I elements, the joint or drive that ties it to its parent, its velocity relative to the parent (X~Y) and the "
             "gear meshes in which it is the first gear, each in a nested box; bonds are labelled with their dimension. The "
             "SVG is zoomable; hover an element or a bond for its name and causality.";
    case 3:
      return fmt::format(
          "G spins about x at &omega;<sub>G,x</sub> = {} rad/s, the speed the drive imposes through its compliant coupling. "
          "Columns 2 and 3 of R, the tips of G's y and z axes, run round the unit circle in the y&ndash;z plane (both on the "
          "same circle: column 3 is the thin line on the wider column 2); column 1, the spin axis, stays at (1, 0, 0): a point.",
          Show(f.Last("G.omega.x")));
    case 4: return com("G", "its bearing to the housing", dies_out);
    case 5:
      return fmt::format(
          "Only h<sub>x</sub> matters: it jumps when the drive's step reaches G, overshoots while the rest of the train "
          "is brought up to speed, and settles at I<sub>G,x</sub> &middot; 50 rad/s = {} N m s. h<sub>y</sub> and "
          "h<sub>z</sub> stay below {} N m s (the bearing's tilt springs).",
          Show(f.Last("G.h.x")), Show(std::max(f.MaxAbs("G.h.y"), f.MaxAbs("G.h.z")), 2));
    case 6:
      return fmt::format(
          "The torque of the drive coupling (K = 1000 N m/rad, R = 5 N m s/rad) on G. At t = 0 the 50 rad/s step meets "
          "the damper: &tau; = 5 &middot; 50 = {} N m, the maximum. It then rings down (the coupling against the train's "
          "inertia) while the links spin up, and settles at {} N m by t = {} s: at steady speed nothing loads the train "
          "(S2 turns freely), and only the planets' translational dampers draw a trickle of power (about 10<sup>&minus;8</sup> "
          "N m, see the spec).",
          Show(f.First("drive.torque"), 3), Show(f.Last("drive.torque"), 2), t_end);
    case 7:
      return fmt::format(
          "The sum of the forces of G's couplings on its centre of mass (in the paper's caption, the link is G). The start "
          "shakes the housing on its mounts, and G's bearing drags G along: a y component of up to {} N that rings at the "
          "bearing's frequency and decays as the train settles ({} N at t = {} s). The x and z components stay small.",
          Show(f.MaxAbs("G.F.y"), 3), Show(f.LastNorm("G.F"), 2), t_end);
    case 8:
      return fmt::format(
          "A, the crown wheel and carrier of the planets, turns about z at &omega;<sub>A,z</sub> = {} rad/s = &minus;(12/48) "
          "&middot; 50: the 12:48 mesh turns it the other way round from G. Columns 1 and 2 of R run round the unit circle "
          "in the x&ndash;y plane (column 1 the wide line under column 2); column 3 stays at (0, 0, 1), a point.",
          w_a);
    case 9: return com("A", "its bearing to the housing", dies_out);
    case 10:
      return fmt::format(
          "h<sub>z</sub> = I<sub>A,z</sub> &omega;<sub>A,z</sub> settles at {} N m s, negative because A turns against G. "
          "The start transient (the mesh spring between G and A overshooting) dies out: &omega;<sub>A</sub> stays within 2 % "
          "of its final value after t = {} s.",
          Show(f.Last("A.h.z")), Show(f.SettlingTime("A.omega.z"), 2));
    case 11:
      return fmt::format(
          "(a) The net force on A: the two planets' bearings pull A in opposite directions and nearly cancel, being on "
          "opposite sides; what remains, with the housing's shaking through A's bearing, is up to {} N and decays to {} N "
          "at t = {} s. (b) The moment: the mesh with G accelerates A (M<sub>z</sub> up to {} N m) against the planets' "
          "reactions; it rings down with the drive coupling and is {} N m at the end.",
          Show(f.MaxAbsVec("A.F"), 3), Show(f.LastNorm("A.F"), 2), t_end, Show(f.MaxAbs("A.M.z"), 3), Show(f.LastNorm("A.M"), 2));
    case 12:
      return fixed_orientation("S1", "S1 is held by a stiff rotational coupling to the ground (10<sup>5</sup> N m/rad).");
    case 13: return com("S1", "its radial bearing to the housing", dies_out);
    case 14:
      return fmt::format(
          "S1 is held, so its angular momentum is zero but for the start: the planets push on S1 as they begin to roll on "
          "it and the holding coupling stops it. h<sub>z</sub> peaks at {} N m s and decays to {} N m s.",
          Show(f.MaxAbs("S1.h.z"), 3), Show(f.Last("S1.h.z"), 2));
    case 15:
      return fmt::format(
          "The forces of S1's couplings on its centre: the radial bearing follows the housing's start-up shaking (up to {} "
          "N, mostly along y) and the force dies away ({} N at t = {} s), S1 being held.",
          Show(f.MaxAbsVec("S1.F"), 3), Show(f.LastNorm("S1.F"), 2), t_end);
    case 16:
      return fmt::format(
          "S2 turns at &omega;<sub>S2,z</sub> = {} rad/s, twice the carrier's {} rad/s, because S1 is held (the Willis "
          "relation &omega;<sub>S1</sub> + &omega;<sub>S2</sub> = 2 &omega;<sub>A</sub>: the differential sends all the "
          "motion to the free side). Columns 1 and 2 of R run round the circle in the x&ndash;y plane (column 1 the wide line under column 2); "
          "column 3 is a point.",
          Show(f.Last("S2.omega.z")), w_a);
    case 17: return com("S2", "its radial bearing to the housing", dies_out);
    case 18:
      return fmt::format(
          "h<sub>z</sub> = I<sub>S2,z</sub> &omega;<sub>S2,z</sub> = {} N m s once the start transient is gone: constant, "
          "and negative like A's, S2 turning the same way at twice the rate.",
          Show(f.Last("S2.h.z")));
    case 19:
      return fmt::format(
          "The forces of S2's couplings on its centre: a start transient (up to {} N, mostly along y, from the housing's "
          "shaking through the radial bearing) that decays to {} N at t = {} s; the turning S2 is balanced and needs no "
          "steady force.",
          Show(f.MaxAbsVec("S2.F"), 3), Show(f.LastNorm("S2.F"), 2), t_end);
    case 20: return planet_orientation("P1");
    case 21: return planet_com("P1");
    case 22: return planet_momentum("P1");
    case 23: return planet_reaction("P1");
    case 24: return planet_orientation("P2") + " P2's body frame starts turned by &pi; about z, so that its x axis too points outwards.";
    case 25: return planet_com("P2") + " P2 is on the opposite side of the axis from P1: half a period apart.";
    case 26: return planet_momentum("P2");
    case 27: return planet_reaction("P2") + " Its force is opposite to P1's: on A, the two cancel.";
    case 28: return rim("Q<sub>P1</sub>", "Q_P1", "P1");
    case 29: return rim("Q<sub>P2</sub>", "Q_P2", "P2");
    case 30:
      return fixed_orientation("H", "The housing sits on stiff mounts (10<sup>6</sup> N m/rad), the paper's zero-velocity source through a coupling.");
    case 31: return com("H", "its mounts",
                           "a lightly damped vibration of the whole assembly on the mounts along y (about 194 rad/s, "
                           "damping ratio 0.2 %) decays only slowly over the run");
    case 32:
      return fmt::format(
          "The housing takes the reaction of the start: the torques that bring the train up to speed shake it on its "
          "mounts, with angular momentum up to {} N m s in the first tenths of a second (a fast ringing: H's rotation on "
          "its stiff mounts, &radic;(K/I) &asymp; 1400 rad/s). It decays to {} N m s: H is, in effect, fixed.",
          Show(f.MaxAbsVec("H.h"), 3), Show(f.LastNorm("H.h"), 2));
    case 33:
      return fmt::format(
          "(a) The mounts' force on H, (b) their moment: start transients of up to {} N and {} N m that the mounts' "
          "dampers take out. A lightly damped translational mode of the whole assembly on the mounts (about 194 rad/s, "
          "damping ratio 0.2 %) lasts the run: {} N at t = {} s (from {} N after the first {} s).",
          Show(f.MaxAbsVec("H.F"), 3), Show(f.MaxAbsVec("H.M"), 3), Show(f.LastNorm("H.F"), 2), t_end,
          Show(f.MaxAbsVec("H.F", early, f.T1()), 2), Show(early - f.T0(), 2));
    default: return "";
  }
}

/// The paper's sections of figures.
struct Section {
  int first, last;
  const char* title;
};
constexpr std::array<Section, 8> kSections = {{
    {2, 2, "The multibond graph (Fig. 2)"},
    {3, 7, "A. Link G (gear on the propeller shaft)"},
    {8, 11, "B. Link A (crown wheel or arm)"},
    {12, 15, "C. Link S1 (sun gear 1)"},
    {16, 19, "D. Link S2 (sun gear 2)"},
    {20, 23, "E. Link P1 (planet gear 1)"},
    {24, 29, "F. Link P2 (planet gear 2), and points on the planets' rims"},
    {30, 33, "G. Link H (housing)"},
}};

/// The value at `path` in run.json, or null.
const nlohmann::json* JsonAt(const nlohmann::json& j, std::initializer_list<const char*> path) {
  const nlohmann::json* p = &j;
  for (const char* k : path) {
    if (!p->is_object() || !p->contains(k)) return nullptr;
    p = &(*p)[k];
  }
  return p;
}

/// A string of run.json as it is ("" if absent or not a string).
std::string JsonString(const nlohmann::json& j, std::initializer_list<const char*> path) {
  const nlohmann::json* p = JsonAt(j, path);
  return p && p->is_string() ? p->get<std::string>() : "";
}

/// A value of run.json as HTML text ("" if absent).
std::string JsonText(const nlohmann::json& j, std::initializer_list<const char*> path) {
  const nlohmann::json* p = JsonAt(j, path);
  if (!p) return "";
  if (p->is_string()) return HtmlEscape(p->get<std::string>());
  if (p->is_number_integer()) return std::to_string(p->get<long long>());
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
  return HtmlEscape(p->dump());
}

/// Simulated against analytic: the steady state at the end of the run.
std::string SteadyTable(const Facts& f) {
  struct Row {
    std::string quantity;
    double simulated, analytic;
    std::string unit, relation;
  };
  const double w_a = -kRatioPinionCrown * kDriveSpeed;  // -12.5 rad/s
  const double spin = kRatioSunPlanet * std::abs(w_a);  // 25 rad/s
  std::vector<Row> rows;
  auto add = [&](bool have, Row r) {
    if (have) rows.push_back(std::move(r));
  };
  add(f.Has("G.omega.x"), {"&omega;<sub>G,x</sub>", f.Last("G.omega.x"), kDriveSpeed, "rad/s", "the drive's set speed"});
  add(f.Has("A.omega.z"), {"&omega;<sub>A,z</sub>", f.Last("A.omega.z"), w_a, "rad/s", "&minus;(12/48) &middot; 50: pinion&ndash;crown mesh"});
  add(f.HasVec("S1.omega"), {"|&omega;<sub>S1</sub>|", f.LastNorm("S1.omega"), 0.0, "rad/s", "S1 is held"});
  add(f.Has("S2.omega.z"), {"&omega;<sub>S2,z</sub>", f.Last("S2.omega.z"), 2 * w_a, "rad/s",
                            "Willis: &omega;<sub>S2</sub> = 2 &omega;<sub>A</sub> &minus; &omega;<sub>S1</sub>"});
  add(f.Has("S1.omega.z") && f.Has("S2.omega.z") && f.Has("A.omega.z"),
      {"&omega;<sub>S1,z</sub> + &omega;<sub>S2,z</sub> &minus; 2 &omega;<sub>A,z</sub>",
       f.Last("S1.omega.z") + f.Last("S2.omega.z") - 2 * f.Last("A.omega.z"), 0.0, "rad/s", "the Willis relation"});
  for (const char* p : {"P1", "P2"}) {
    const std::string ps = p;
    const double m = f.Mass(ps), rho = f.RadiusFromA(ps), inertia = f.AxialInertia(ps);
    add(std::isfinite(f.Spin(ps)), {fmt::format("|s<sub>{}</sub>|, spin relative to A", ps), std::abs(f.Spin(ps)), spin, "rad/s",
                                     "(24/12) |&omega;<sub>A</sub>|, S1 held"});
    add(f.HasVec(ps + ".F") && std::isfinite(m * rho),
        {fmt::format("|F<sub>{}</sub>|, bearing force", ps), f.LastNorm(ps + ".F"), m * w_a * w_a * rho, "N",
         fmt::format("centripetal m<sub>P</sub> &omega;<sub>A</sub><sup>2</sup> &rho;, m<sub>P</sub> = {} kg (|p|/|v|), &rho; = {} m",
                     Show(m), Show(rho))});
    add(f.HasVec(ps + ".M") && std::isfinite(inertia),
        {fmt::format("|M<sub>{}</sub>|, bearing moment", ps), f.LastNorm(ps + ".M"), inertia * spin * std::abs(w_a), "N m",
         fmt::format("gyroscopic I<sub>axial</sub> s &omega;<sub>A</sub>, I<sub>axial</sub> = {} kg m<sup>2</sup> (h&middot;e<sub>x</sub> / "
                     "&omega;&middot;e<sub>x</sub>)",
                     Show(inertia))});
  }
  add(f.Has("drive.torque"), {"drive torque &tau;", f.Last("drive.torque"), 0.0, "N m",
                              "no load at steady speed (the spec expects about 10<sup>&minus;8</sup> N m)"});
  std::ostringstream s;
  s << fmt::format("<table class=\"numbers\">\n<caption>At the end of the run, t = {} s, against the analytic steady values</caption>\n",
                   Show(f.T1(), 3));
  s << "<tr><th>quantity</th><th>simulated</th><th>analytic</th><th>difference</th><th>unit</th><th>from</th></tr>\n";
  for (const Row& r : rows) {
    const double diff = r.simulated - r.analytic;
    const std::string d = r.analytic != 0 ? fmt::format("{} %", Show(100 * diff / std::abs(r.analytic), 2)) : Show(diff, 2);
    s << fmt::format("<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>\n", r.quantity, Show(r.simulated, 6),
                     Show(r.analytic, 6), d, r.unit, r.relation);
  }
  if (f.Has("A.omega.z"))
    s << fmt::format("<tr><td>start transient</td><td colspan=\"5\">&omega;<sub>A</sub> stays within 2 % of its final value after t = {} s</td></tr>\n",
                     Show(f.SettlingTime("A.omega.z"), 3));
  s << "</table>\n";
  return s.str();
}

/// The energy account: run.json's and the last row of results.csv.
std::string EnergyTable(const Facts& f, const nlohmann::json& run) {
  std::ostringstream s;
  s << "<table class=\"numbers\">\n<caption>Energy account: work in = kinetic + potential + dissipated</caption>\n";
  s << "<tr><th>source</th><th>work in [J]</th><th>stored [J]</th><th>dissipated [J]</th><th>balance</th></tr>\n";
  if (run.contains("energy")) {
    s << fmt::format(
        "<tr><td>run.json</td><td>{}</td><td>{}</td><td>{}</td><td>residual {} (largest over the run: {}), relative to the "
        "largest energy handled</td></tr>\n",
        JsonText(run, {"energy", "work"}), JsonText(run, {"energy", "stored"}), JsonText(run, {"energy", "dissipated"}),
        JsonText(run, {"energy", "residual"}), JsonText(run, {"energy", "max_abs_residual"}));
  }
  if (f.Has("energy.work")) {
    const double w = f.Last("energy.work"), k = f.Last("energy.kinetic"), v = f.Last("energy.potential"),
                 d = f.Last("energy.dissipated");
    const double balance = w - (k + v + d);
    s << fmt::format(
        "<tr><td>results.csv, last row</td><td>{}</td><td>{} (kinetic {}, potential {})</td><td>{}</td><td>work &minus; "
        "(kinetic + potential + dissipated) = {} J, {} of the work; residual column {}</td></tr>\n",
        Show(w, 9), Show(k + v, 9), Show(k, 6), Show(v, 6), Show(d, 9), Show(balance, 3), Show(w != 0 ? balance / w : kNaN, 3),
        Show(f.Last("energy.residual"), 3));
  }
  s << "</table>\n";
  return s.str();
}

std::string RunTable(const nlohmann::json& run, const Facts& f) {
  std::ostringstream s;
  s << "<table class=\"numbers\">\n<caption>The run (run.json)</caption>\n";
  auto row = [&](const char* what, const std::string& value) {
    if (!value.empty()) s << fmt::format("<tr><th>{}</th><td>{}</td></tr>\n", what, value);
  };
  row("model", JsonText(run, {"model", "name"}) + (JsonText(run, {"model", "file"}).empty() ? "" : " (" + JsonText(run, {"model", "file"}) + ")"));
  row("model SHA-256", "<code>" + JsonText(run, {"model", "sha256"}) + "</code>");
  row("status", JsonText(run, {"status"}));
  row("time", fmt::format("{} to {} s, {} rows in results.csv", Show(f.T0(), 3), Show(f.T1(), 3), JsonText(run, {"samples"})));
  row("solver", fmt::format("{}, rtol {}, atol {}, output every {} s, projection {}", JsonText(run, {"options", "solver"}),
                            JsonText(run, {"options", "rtol"}), JsonText(run, {"options", "atol"}), JsonText(run, {"options", "dt"}),
                            JsonText(run, {"options", "projection"})));
  row("work done", fmt::format("{} steps, {} right-hand sides, {} Jacobians, {} s wall", JsonText(run, {"solver_stats", "steps"}),
                               JsonText(run, {"solver_stats", "rhs_evals"}), JsonText(run, {"solver_stats", "jac_evals"}),
                               JsonText(run, {"wall_seconds"})));
  row("multibond", JsonText(run, {"multibond_version"}));
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

DotOptions LinkGrouping(const LoadedModel& model) {
  DotOptions o;
  try {
    const YAML::Node root = YAML::Load(model.text);
    if (!root.IsMap() || !root["bodies"]) return o;
    NestFromSection(root, "joints", "child", nullptr, o.nest);
    NestFromSection(root, "drives", "body", nullptr, o.nest);
    NestFromSection(root, "gears", "a", "body", o.nest);
  } catch (const std::exception&) {
    return o;
  }
  // Relative velocities "child~parent" (and anything else named "X~Y") go with X.
  for (const Element& e : model.graph.elements()) {
    const std::string prefix = e.name.substr(0, e.name.find('.'));
    const size_t tilde = prefix.find('~');
    if (tilde != std::string::npos && tilde > 0) o.nest[prefix] = prefix.substr(0, tilde);
  }
  o.bond_names = false;
  return o;
}

std::vector<std::string> PaperFigureNames() {
  std::vector<std::string> out = {kBondGraphName};
  for (const FigureSpec& f : PaperFigures()) out.push_back(f.Name());
  return out;
}

PlotReport MakePaperFigures(const std::string& results_dir, const PlotOptions& options) {
  const ResultsFolder folder(results_dir);
  struct stat st {};
  Fd csv;
  const Table table = Table::Load(folder, options.limits.results_bytes, &st, &csv);
  if (!table.Has("time")) throw std::runtime_error(fmt::format("'{}' has no 'time' column", folder.PathOf("results.csv")));
  const nlohmann::json run = ReadRunJson(folder);
  const Fd figures_dir = folder.OutputDir("figures"), plots_dir = folder.OutputDir("plots");
  const int figures_fd = figures_dir.get(), plots_fd = plots_dir.get();
  // gnuplot and dot write into a private folder; finished files are renamed into place.
  const WorkFolder work(folder);
  work.AddInput(folder, "results.csv", csv.get(), st);
  PlotReport report;

  if (options.bond_graph) {
    if (options.model_path.empty()) {
      // run.json's model.file records the run; it is not an instruction to open a file.
      const std::string recorded = JsonString(run, {"model", "file"});
      report.warnings.push_back(fmt::format(
          "Fig. 2 left out: no model file given (give it with --model FILE){}", recorded.empty() ? "" :
          fmt::format("; run.json names '{}', which plot does not open by itself", MessageText(recorded.substr(0, 200)))));
    } else {
      try {
        for (std::string& f : DrawBondGraph(folder, work, figures_fd, plots_fd, options.model_path, report.warnings))
          report.files.push_back(std::move(f));
      } catch (const ModelError&) {
        // Not its text: the page may be shared, and the diagnostics quote the file.
        report.warnings.push_back(fmt::format("Fig. 2 left out: the model '{}' does not load (see 'multibond check' on it)",
                                              MessageText(options.model_path)));
      }
    }
  }

  // Write every script, then run gnuplot on them, a few at a time.
  std::vector<FigureSpec> figures;
  for (const FigureSpec& f : PaperFigures()) {
    std::vector<std::string> missing;
    for (const std::string& c : f.Columns())
      if (!table.Has(c)) missing.push_back(c);
    if (!missing.empty()) {
      std::string list;
      for (const auto& m : missing) list += (list.empty() ? "" : ", ") + m;
      report.warnings.push_back(fmt::format("Fig. {} ({}) left out: results.csv has no column {}", f.number, f.Name(), list));
      continue;
    }
    work.Write("plots/" + f.Name() + ".gp", ScriptWriter(table, f, options).Run());
    figures.push_back(f);
  }
  auto publish_scripts = [&] {
    for (const FigureSpec& f : figures) work.Publish("plots/" + f.Name() + ".gp", plots_fd, f.Name() + ".gp");
  };

  const int jobs = options.jobs > 0 ? options.jobs : std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
  std::vector<Job> running;
  std::map<std::string, std::string> failures;  // figure name -> reason
  auto reap = [&](const Job& j) {
    std::string why = Finish(j.pid, options.gnuplot);
    const std::string log = ReadLog(work.path() + "/" + j.log);
    if (!why.empty()) failures[j.name] = why + (log.empty() ? "" : ": " + log);
    // The log is kept only when gnuplot said something (an older one goes).
    if (log.empty() || !work.Publish(j.log, plots_fd, j.name + ".log")) ::unlinkat(plots_fd, (j.name + ".log").c_str(), 0);
  };
  for (const FigureSpec& f : figures) {
    if (static_cast<int>(running.size()) >= jobs) {
      reap(running.front());
      running.erase(running.begin());
    }
    Job j{-1, f.Name(), "plots/" + f.Name() + ".log"};
    std::string error;
    j.pid = Start({options.gnuplot, "plots/" + f.Name() + ".gp"}, work.path(), work.path() + "/" + j.log, &error);
    if (j.pid < 0) {
      for (const Job& r : running) reap(r);
      publish_scripts();
      throw std::runtime_error(error + " (install gnuplot, e.g. the Debian package gnuplot-nox; the scripts are in " +
                               folder.PathOf("plots") + ")");
    }
    running.push_back(j);
  }
  for (const Job& r : running) reap(r);
  publish_scripts();

  for (const FigureSpec& f : figures) {
    work.Publish("plots/" + f.Name() + ".ranges", plots_fd, f.Name() + ".ranges");
    if (failures.count(f.Name())) {
      report.warnings.push_back(fmt::format("Fig. {} ({}) failed: {}", f.number, f.Name(), failures[f.Name()]));
      continue;
    }
    for (const char* ext : {".png", ".svg"}) {
      const std::string name = f.Name() + ext;
      if (IsNonEmptyRegularFile(work.fd(), "figures/" + name) && work.Publish("figures/" + name, figures_fd, name))
        report.files.push_back(folder.PathOf("figures/" + name));
      else
        report.warnings.push_back(fmt::format("Fig. {}: gnuplot wrote no {}", f.number, MessageText(folder.PathOf("figures/" + name))));
    }
  }
  return report;
}

void WriteResultsPage(const std::string& results_dir, const PlotReport& report, const InputLimits& limits) {
  const ResultsFolder folder(results_dir);
  struct stat st {};
  const Table table = Table::Load(folder, limits.results_bytes, &st);
  const Facts facts(table);
  const nlohmann::json run = ReadRunJson(folder);
  const fs::path dir(results_dir);
  const Fd figures_dir = folder.ExistingDir("figures");

  // Every figure that is there, in the paper's order.
  struct Entry {
    int number;
    std::string name, caption;
  };
  std::vector<Entry> entries = {{2, kBondGraphName, kBondGraphCaption}};
  for (const FigureSpec& f : PaperFigures()) entries.push_back({f.number, f.Name(), f.caption});
  auto present = [&](const std::string& name, const char* ext) { return IsNonEmptyRegularFile(figures_dir.get(), name + ext); };

  std::ostringstream h;
  const std::string model = JsonText(run, {"model", "name"}).empty() ? "differential" : JsonText(run, {"model", "name"});
  h << "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n";
  h << "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n";
  h << fmt::format("<title>multibond: {}, the paper's figures</title>\n", model);
  h << "<style>\n" << kCss << "\n</style>\n</head>\n<body>\n";
  h << fmt::format("<h1>The differential gear train: the paper's figures, from this run ({})</h1>\n", model);
  h << "<p>Figures 2 to 33 of <em>Modeling and Simulation of Dynamics of Differential Gear Train Mechanism using Bond "
       "Graph</em> (section III), reproduced by multibond from <code>results.csv</code> and <code>run.json</code> in this "
       "folder. The scenario is fixed by <code>shared/spec/differential.md</code>: a 50 rad/s drive on the pinion G, sun "
       "gear S1 held, S2 free, every joint a stiff spring and damper (Table II). Click a figure for its SVG; each one's "
       "gnuplot script is in <code>plots/</code> (run it again from this folder: <code>gnuplot plots/figNN-&hellip;.gp</code>).</p>\n";
  h << "<nav><strong>Figures:</strong> <a href=\"#summary\">summary</a>";
  for (const Entry& e : entries)
    if (present(e.name, ".png")) h << fmt::format(" <a href=\"#fig{:02}\">{}</a>", e.number, e.number);
  h << "</nav>\n";

  h << "<h2 id=\"summary\">Summary of the run</h2>\n";
  h << "<p>After the start transient the train turns as the gear ratios say: the pinion at the drive's 50 rad/s, the "
       "crown wheel A at &minus;12.5 rad/s, the held sun S1 at rest and the free sun S2 at &minus;25 rad/s (Willis: "
       "&omega;<sub>S1</sub> + &omega;<sub>S2</sub> = 2 &omega;<sub>A</sub>); the planets spin at 25 rad/s relative to A, "
       "their bearings carrying the centripetal force and the gyroscopic moment; the work of the drive is accounted for "
       "by the energy stored and dissipated.</p>\n";
  h << SteadyTable(facts) << EnergyTable(facts, run) << RunTable(run, facts);
  if (!report.warnings.empty()) {
    h << "<p class=\"warn\"><strong>Left out when the figures were drawn:</strong></p>\n<ul class=\"warn\">\n";
    for (const std::string& w : report.warnings) h << "<li>" << HtmlEscape(w) << "</li>\n";
    h << "</ul>\n";
  }

  for (const Section& sec : kSections) {
    bool any = false;
    for (const Entry& e : entries) any = any || (e.number >= sec.first && e.number <= sec.last && present(e.name, ".png"));
    if (!any) continue;
    h << fmt::format("<h2>{}</h2>\n", sec.title);
    for (const Entry& e : entries) {
      if (e.number < sec.first || e.number > sec.last || !present(e.name, ".png")) continue;
      const std::string caption = fmt::format("Fig. {}. {}", e.number, MarkupToHtml(e.caption));
      const std::string target = present(e.name, ".svg") ? "figures/" + e.name + ".svg" : "figures/" + e.name + ".png";
      h << fmt::format("<figure id=\"fig{:02}\">\n", e.number);
      h << fmt::format("<a href=\"{}\"><img src=\"figures/{}.png\" alt=\"{}\"></a>\n", target, e.name,
                       HtmlEscape(fmt::format("Fig. {}. {}", e.number, e.caption)));
      h << fmt::format("<figcaption><span class=\"caption\">{}</span> {}<br><span class=\"files\">figures/{}.png, "
                       "<a href=\"{}\">{}</a>{}</span></figcaption>\n",
                       caption, WhatItShows(e.number, facts), e.name, target, target,
                       e.number == 2 ? "" : fmt::format(", script <a href=\"plots/{0}.gp\">plots/{0}.gp</a>", e.name));
      h << "</figure>\n";
    }
  }
  h << "</body>\n</html>\n";
  WriteFileAtomic((dir / "index.html").string(), h.str());
}

}  // namespace multibond
