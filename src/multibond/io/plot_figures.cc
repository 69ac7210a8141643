#include "multibond/core/diagnostic_codes.h"
#include "multibond/io/plot_figures.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <optional>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include "multibond/core/error.h"
#include "multibond/core/utf8.h"
#include "multibond/io/model_loader.h"
#include "multibond/io/yaml_bounds.h"

namespace multibond {

namespace {

constexpr std::array<const char*, 3> kAxes = {"x", "y", "z"};

const std::vector<std::string> kTopKeys = {"title", "intro", "sections", "figures", "checks"};
const std::vector<std::string> kSectionKeys = {"title", "figures"};
const std::vector<std::string> kFigureKeys = {"name", "label", "caption", "shows", "bond_graph", "panels"};
const std::vector<std::string> kPanelKeys = {"kind", "title", "quantity", "unit", "curves", "body", "zoom", "coordinates"};
const std::vector<std::string> kCurveKeys = {"column", "columns", "vector", "title", "color", "from_start", "scale"};
const std::vector<std::string> kCheckKeys = {"quantity", "column", "norm", "value", "tolerance", "unit", "note"};
const std::vector<std::string> kKinds = {"time", "path", "orientation"};

/// Reads one figure list's YAML tree into a FigureList, every problem into the sink.
class Reader {
 public:
  Reader(std::string file, DiagnosticSink& sink) : file_(std::move(file)), sink_(sink) {}

  FigureList Read(const YAML::Node& root) {
    FigureList out;
    if (!root.IsMap()) {
      sink_.Error(codes::kPlotList, Loc(root), "", "a figure list must be a YAML mapping with 'figures' or 'sections'",
                  "see docs/plots.md, or examples/differential/figures.yaml");
      return out;
    }
    Keys(root, kTopKeys, "");
    out.title = Text(root["title"], "title");
    out.intro = Text(root["intro"], "intro");
    if (root["figures"]) Figures(root["figures"], -1, "figures", out);
    if (const YAML::Node s = root["sections"]) {
      if (!s.IsSequence()) {
        sink_.Error(codes::kPlotType, Loc(s), "sections", "'sections' must be a list", "each item: {title: ..., figures: [...]}");
      } else {
        for (size_t i = 0; i < s.size(); ++i) {
          const std::string where = fmt::format("sections[{}]", i);
          if (!Keys(s[i], kSectionKeys, where)) continue;
          out.sections.push_back(Text(s[i]["title"], where + ".title"));
          Figures(s[i]["figures"], static_cast<int>(out.sections.size()) - 1, where + ".figures", out);
        }
      }
    }
    if (!root["figures"] && !root["sections"])
      sink_.Error(codes::kPlotList, Loc(root), "", "the figure list has neither 'figures' nor 'sections'", "see docs/plots.md");
    if (const YAML::Node c = root["checks"]) {
      if (!c.IsSequence()) sink_.Error(codes::kPlotType, Loc(c), "checks", "'checks' must be a list", "see docs/plots.md");
      else
        for (size_t i = 0; i < c.size(); ++i) Checks(c[i], fmt::format("checks[{}]", i), out);
    }
    return out;
  }

 private:
  SourceLocation Loc(const YAML::Node& n) const {
    const YAML::Mark m = n.Mark();
    return m.line < 0 ? SourceLocation{file_, 0, 0} : SourceLocation{file_, m.line + 1, m.column + 1};
  }

  /// Reports keys not in `allowed` (did you mean?) and keys given twice; false when `n` is no mapping.
  bool Keys(const YAML::Node& n, const std::vector<std::string>& allowed, const std::string& where) {
    if (!n.IsMap()) {
      sink_.Error(codes::kPlotType, Loc(n), where, "expected a mapping (key: value lines)", "see docs/plots.md");
      return false;
    }
    std::set<std::string> seen;
    for (const auto& kv : n) {
      const std::string key = kv.first.IsScalar() ? kv.first.Scalar() : "?";
      if (!seen.insert(key).second)
        sink_.Error(codes::kPlotDuplicateKey, Loc(kv.first), where, fmt::format("duplicate key '{}'", key), "give each key once");
      if (std::find(allowed.begin(), allowed.end(), key) != allowed.end()) continue;
      const std::string guess = DidYouMean(key, allowed);
      std::string list;
      for (const auto& a : allowed) list += (list.empty() ? "" : ", ") + a;
      sink_.Error(codes::kPlotUnknownKey, Loc(kv.first), where, fmt::format("unknown key '{}'", key),
                  guess.empty() ? "known keys here: " + list : fmt::format("did you mean '{}'?", guess));
    }
    return true;
  }

  std::string Text(const YAML::Node& n, const std::string& where) {
    if (!n) return "";
    if (!n.IsScalar()) {
      sink_.Error(codes::kPlotType, Loc(n), where, "expected a text", "write it on one line, or as a YAML block (>)");
      return "";
    }
    return n.Scalar();
  }

  bool Bool(const YAML::Node& n, const std::string& where) {
    if (!n) return false;
    bool b = false;
    if (n.IsScalar() && YAML::convert<bool>::decode(n, b)) return b;
    sink_.Error(codes::kPlotType, Loc(n), where, "expected true or false");
    return false;
  }

  double Number(const YAML::Node& n, const std::string& where, double fallback) {
    if (!n) return fallback;
    double v = 0;
    if (n.IsScalar() && YAML::convert<double>::decode(n, v) && std::isfinite(v)) return v;
    sink_.Error(codes::kPlotType, Loc(n), where, "expected a finite number");
    return fallback;
  }

  /// A results.csv column name (any text but empty).
  std::string Column(const YAML::Node& n, const std::string& where) {
    const std::string c = Text(n, where);
    if (n && n.IsScalar() && c.empty()) sink_.Error(codes::kPlotColumn, Loc(n), where, "empty column name");
    return c;
  }

  void Figures(const YAML::Node& list, int section, const std::string& where, FigureList& out) {
    if (!list || !list.IsSequence()) {
      sink_.Error(codes::kPlotType, list ? Loc(list) : SourceLocation{file_, 0, 0}, where, "expected a list of figures", "see docs/plots.md");
      return;
    }
    for (size_t i = 0; i < list.size(); ++i) {
      const YAML::Node f = list[i];
      const std::string at = fmt::format("{}[{}]", where, i);
      if (!Keys(f, kFigureKeys, at)) continue;
      Figure fig;
      fig.section = section;
      fig.name = Text(f["name"], at + ".name");
      const std::string element = fig.name.empty() ? at : fig.name;
      if (!f["name"]) sink_.Error(codes::kPlotName, Loc(f), at, "a figure needs a 'name' (its file name)", "e.g. name: mass-position");
      else if (!IsFigureName(fig.name))
        sink_.Error(codes::kPlotName, Loc(f["name"]), at, fmt::format("'{}' is not a figure name", fig.name),
                    "use 1 to 100 letters, digits, '_', '-' or '.', starting with a letter or digit");
      else if (!names_.insert(fig.name).second)
        sink_.Error(codes::kPlotName, Loc(f["name"]), element, fmt::format("a second figure named '{}'", fig.name), "give each figure its own name");
      fig.label = Text(f["label"], element + ".label");
      fig.caption = Text(f["caption"], element + ".caption");
      fig.shows = Text(f["shows"], element + ".shows");
      fig.bond_graph = Bool(f["bond_graph"], element + ".bond_graph");
      const YAML::Node panels = f["panels"];
      if (fig.bond_graph) {
        if (panels) sink_.Error(codes::kPlotPanels, Loc(panels), element, "a bond graph figure has no panels", "remove 'panels'");
      } else if (!panels || !panels.IsSequence() || panels.size() == 0) {
        sink_.Error(codes::kPlotPanels, panels ? Loc(panels) : Loc(f), element, "a figure needs 'panels': a list of at least one",
                    "e.g. panels: [{curves: [{column: mass.p}]}]");
      } else {
        for (size_t k = 0; k < panels.size(); ++k) {
          Panel p = ReadPanel(panels[k], fmt::format("{}.panels[{}]", element, k));
          p.id = std::string(1, static_cast<char>('a' + std::min<size_t>(k, 25)));
          fig.panels.push_back(std::move(p));
        }
      }
      out.figures.push_back(std::move(fig));
    }
  }

  Panel ReadPanel(const YAML::Node& n, const std::string& where) {
    Panel p;
    if (!Keys(n, kPanelKeys, where)) return p;
    const std::string kind = n["kind"] ? Text(n["kind"], where + ".kind") : "time";
    if (kind == "path") p.kind = PanelKind::kPath;
    else if (kind == "orientation") p.kind = PanelKind::kOrientation;
    else if (kind != "time") {
      const std::string guess = DidYouMean(kind, kKinds);
      sink_.Error(codes::kPlotKind, Loc(n["kind"]), where, fmt::format("unknown panel kind '{}'", kind),
                  guess.empty() ? "use time, path or orientation" : fmt::format("did you mean '{}'?", guess));
    }
    p.title = Text(n["title"], where + ".title");
    p.quantity = Text(n["quantity"], where + ".quantity");
    p.unit = Text(n["unit"], where + ".unit");
    p.zoom = Bool(n["zoom"], where + ".zoom");
    p.coordinates = Bool(n["coordinates"], where + ".coordinates");
    if (p.kind != PanelKind::kTime && (n["zoom"] || n["coordinates"] || n["quantity"]))
      sink_.Error(codes::kPlotPanel, Loc(n), where, "'zoom', 'coordinates' and 'quantity' belong to time panels");
    if (p.kind == PanelKind::kOrientation) {
      const std::string body = Column(n["body"], where + ".body");
      if (!n["body"]) sink_.Error(codes::kPlotPanel, Loc(n), where, "an orientation panel needs 'body': the body whose R columns it draws");
      if (n["curves"]) sink_.Error(codes::kPlotPanel, Loc(n["curves"]), where, "an orientation panel takes 'body', not 'curves'");
      for (int j = 1; j <= 3; ++j)
        p.curves.push_back({{fmt::format("{}.R.1{}", body, j), fmt::format("{}.R.2{}", body, j), fmt::format("{}.R.3{}", body, j)},
                            fmt::format("column {}: tip of {}_{{{}}}", j, kAxes[j - 1], body), PlotColors()[j - 1]});
      return p;
    }
    if (n["body"]) sink_.Error(codes::kPlotPanel, Loc(n["body"]), where, "'body' belongs to orientation panels", "remove it, or write kind: orientation");
    const YAML::Node curves = n["curves"];
    if (!curves || !curves.IsSequence() || curves.size() == 0) {
      sink_.Error(codes::kPlotPanel, curves ? Loc(curves) : Loc(n), where, "a panel needs 'curves': a list of at least one",
                  "e.g. curves: [{column: mass.p}] or [{vector: body.r}]");
      return p;
    }
    for (size_t i = 0; i < curves.size(); ++i) ReadCurve(curves[i], fmt::format("{}.curves[{}]", where, i), p);
    return p;
  }

  void ReadCurve(const YAML::Node& n, const std::string& where, Panel& p) {
    if (!Keys(n, kCurveKeys, where)) return;
    Curve c;
    c.title = Text(n["title"], where + ".title");
    c.from_start = Bool(n["from_start"], where + ".from_start");
    c.scale = Number(n["scale"], where + ".scale", 1.0);
    const int given = (n["column"] ? 1 : 0) + (n["columns"] ? 1 : 0) + (n["vector"] ? 1 : 0);
    if (given != 1) {
      sink_.Error(codes::kPlotCurve, Loc(n), where, "a curve takes exactly one of 'column', 'columns' and 'vector'",
                  p.kind == PanelKind::kTime ? "e.g. column: mass.p, or vector: body.r (x, y and z as three curves)"
                                             : "e.g. vector: body.r, or columns: [a, b, c] (x, y, z of the path)");
      return;
    }
    const size_t first = p.curves.size();
    if (p.kind == PanelKind::kTime) {
      if (n["columns"]) {
        sink_.Error(codes::kPlotCurve, Loc(n["columns"]), where, "'columns' belongs to path panels", "give one 'column' a curve, or 'vector'");
        return;
      }
      if (n["column"]) {
        c.columns = {Column(n["column"], where + ".column")};
        p.curves.push_back(c);
      } else {
        const std::string prefix = Column(n["vector"], where + ".vector");
        for (int k = 0; k < 3; ++k) {
          Curve part = c;
          part.columns = {prefix + "." + kAxes[k]};
          part.title = c.title.empty() ? std::string(kAxes[k]) : fmt::format("{}_{{{}}}", c.title, kAxes[k]);
          part.color = PlotColors()[k];
          p.curves.push_back(part);
        }
      }
    } else {
      if (n["column"]) {
        sink_.Error(codes::kPlotCurve, Loc(n["column"]), where, "a path takes three columns", "write columns: [x, y, z] or vector: PREFIX");
        return;
      }
      if (n["vector"]) {
        const std::string prefix = Column(n["vector"], where + ".vector");
        c.columns = {prefix + ".x", prefix + ".y", prefix + ".z"};
      } else if (!n["columns"].IsSequence() || n["columns"].size() != 3) {
        sink_.Error(codes::kPlotCurve, Loc(n["columns"]), where, "'columns' must list three columns: x, y and z of the path");
        return;
      } else {
        for (size_t k = 0; k < 3; ++k) c.columns.push_back(Column(n["columns"][k], fmt::format("{}.columns[{}]", where, k)));
      }
      if (c.from_start || c.scale != 1.0) sink_.Error(codes::kPlotCurve, Loc(n), where, "'from_start' and 'scale' belong to time panels");
      p.curves.push_back(c);
    }
    if (n["color"]) {
      const std::string color = Text(n["color"], where + ".color");
      const bool ok = color.size() == 7 && color[0] == '#' &&
                      std::all_of(color.begin() + 1, color.end(), [](char ch) { return std::isxdigit(static_cast<unsigned char>(ch)); });
      if (!ok) sink_.Error(codes::kPlotColor, Loc(n["color"]), where, fmt::format("'{}' is not a colour", color), "write it as #rrggbb, e.g. #1f77b4");
      else
        for (size_t k = first; k < p.curves.size(); ++k) p.curves[k].color = color;
    }
    for (size_t k = first; k < p.curves.size(); ++k)
      if (p.curves[k].color.empty()) p.curves[k].color = PlotColors()[(p.kind == PanelKind::kPath ? 2 : k) % PlotColors().size()];
  }

  void Checks(const YAML::Node& n, const std::string& where, FigureList& out) {
    if (!Keys(n, kCheckKeys, where)) return;
    Check c;
    c.quantity = Text(n["quantity"], where + ".quantity");
    c.unit = Text(n["unit"], where + ".unit");
    c.note = Text(n["note"], where + ".note");
    if (n["column"] && n["norm"]) sink_.Error(codes::kPlotCheck, Loc(n), where, "a check takes 'column' or 'norm', not both");
    else if (n["column"]) c.column = Column(n["column"], where + ".column");
    else if (n["norm"]) c.column = Column(n["norm"], where + ".norm"), c.norm = true;
    else sink_.Error(codes::kPlotCheck, Loc(n), where, "a check needs 'column' (a column's last value) or 'norm' (a vector's length at the end)");
    if (!n["value"]) sink_.Error(codes::kPlotCheck, Loc(n), where, "a check needs 'value', the expected value");
    c.value = Number(n["value"], where + ".value", 0.0);
    c.tolerance = Number(n["tolerance"], where + ".tolerance", 0.0);
    if (c.tolerance < 0) sink_.Error(codes::kPlotCheck, Loc(n["tolerance"]), where, "a tolerance cannot be negative");
    if (c.quantity.empty()) c.quantity = c.norm ? "|" + c.column + "|" : c.column;
    out.checks.push_back(std::move(c));
  }

  std::string file_;
  DiagnosticSink& sink_;
  std::set<std::string> names_;
};

}  // namespace

const std::vector<std::string>& PlotColors() {
  static const std::vector<std::string> colors = {"#d62728", "#2ca02c", "#1f77b4", "#ff7f0e", "#9467bd",
                                                  "#8c564b", "#e377c2", "#7f7f7f", "#17becf", "#bcbd22"};
  return colors;
}

std::vector<std::string> Figure::Columns() const {
  std::vector<std::string> out;
  for (const Panel& p : panels)
    for (const Curve& c : p.curves)
      for (const std::string& col : c.columns)
        if (std::find(out.begin(), out.end(), col) == out.end()) out.push_back(col);
  return out;
}

std::vector<std::string> FigureNames(const FigureList& list) {
  std::vector<std::string> out;
  for (const Figure& f : list.figures) out.push_back(f.name);
  return out;
}

bool IsFigureName(const std::string& name) {
  if (name.empty() || name.size() > 100 || !std::isalnum(static_cast<unsigned char>(name[0]))) return false;
  return std::all_of(name.begin(), name.end(), [](char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' || c == '.'; });
}

FigureList ParseFigureList(const std::string& text, const std::string& file, const InputLimits& limits) {
  DiagnosticSink sink;
  if (text.size() > limits.file_bytes) {
    sink.Error(codes::kLimitFileSize, {file, 0, 0}, "", fmt::format("the figure list has {} bytes, more than {}", text.size(), limits.file_bytes),
               RaiseLimitHint("file-size", limits.file_bytes));
    sink.ThrowIfErrors();
  }
  if (const TextProblem t = FindTextProblem(text); t.found()) {
    const std::string before = text.substr(0, t.offset);
    const int line = 1 + static_cast<int>(std::count(before.begin(), before.end(), '\n'));
    const size_t nl = before.rfind('\n');
    const int column = 1 + static_cast<int>(nl == std::string::npos ? t.offset : t.offset - nl - 1);
    sink.Error(codes::kTextEncoding, {file, line, column}, "", fmt::format("the figure list is not UTF-8 text: {}", t.what), "save the file as UTF-8");
    sink.ThrowIfErrors();
  }
  YAML::Node root;
  try {
    // One parse: the tree is built from the events as they are bounded (node count, aliases
    // expanded; depth; self-aliases), and no further than the first one out of bounds.
    const std::optional<std::vector<YAML::Node>> loaded = LoadYamlBounded(text, file, limits, sink);
    if (!loaded) sink.ThrowIfErrors();
    const std::vector<YAML::Node>& documents = *loaded;
    if (documents.size() > 1) {
      sink.Error(codes::kPlotList, {file, 0, 0}, "", fmt::format("the file holds {} YAML documents; a figure list is one", documents.size()),
                 "remove the '---' line");
      sink.ThrowIfErrors();
    }
    if (!documents.empty()) root = documents.front();
  } catch (const YAML::Exception& e) {
    sink.Error(codes::kYamlSyntax, {file, e.mark.line + 1, e.mark.column + 1}, "", "YAML syntax error: " + e.msg,
               "check indentation, colons and brackets near this place");
    sink.ThrowIfErrors();
  }
  FigureList list = Reader(file, sink).Read(root);
  sink.ThrowIfErrors();
  return list;
}

/// Throws a ModelError about the figure list file as a whole.
[[noreturn]] void FileError(const std::string& path, const char* code, const std::string& message, const std::string& hint) {
  DiagnosticSink sink;
  sink.Error(code, {path, 0, 0}, "", message, hint);
  sink.ThrowIfErrors();
  throw std::logic_error("unreachable");
}

FigureList ReadFigureList(const std::string& path, const InputLimits& limits) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NONBLOCK);
  if (fd < 0) FileError(path, "io.open", fmt::format("cannot open the figure list: {}", std::strerror(errno)), "check the path given to --figures");
  struct stat st {};
  std::string text;
  bool regular = ::fstat(fd, &st) == 0 && S_ISREG(st.st_mode);
  if (regular && static_cast<std::uint64_t>(st.st_size) <= limits.file_bytes) {
    text.resize(static_cast<size_t>(st.st_size));
    size_t got = 0;
    while (got < text.size()) {
      const ssize_t n = ::read(fd, text.data() + got, text.size() - got);
      if (n <= 0) break;
      got += static_cast<size_t>(n);
    }
    text.resize(got);
  }
  ::close(fd);
  if (regular && static_cast<std::uint64_t>(st.st_size) > limits.file_bytes)
    FileError(path, codes::kLimitFileSize, fmt::format("the figure list has {} bytes, more than {}", st.st_size, limits.file_bytes),
              RaiseLimitHint("file-size", limits.file_bytes));
  if (!regular)
    FileError(path, codes::kIoNotRegular, "the figure list is not a regular file", "give a YAML file");
  return ParseFigureList(text, path, limits);
}

}  // namespace multibond
