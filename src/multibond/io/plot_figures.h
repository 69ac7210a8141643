#pragma once
/// \file
/// What `plot` draws, as data: figures of panels of curves of results.csv columns. The general
/// plot makes such a list from any results.csv (plot_auto.h); a figure list file (YAML, see
/// docs/plots.md) gives one for a model, e.g. examples/differential/figures.yaml for the paper's
/// figures. Every text here is markup, gnuplot's enhanced text (_{sub}, ^{sup}; a backslash shows
/// the next character as it is): it reaches gnuplot only as an escaped string and the page only
/// HTML-escaped (safe_text.h).

#include <string>
#include <vector>

#include "multibond/io/limits.h"

namespace multibond {

/// Colours of the x, y, z components (and of the columns 1, 2, 3 of an orientation matrix), then more.
const std::vector<std::string>& PlotColors();

/// One plotted series: a column against time, or three columns as a 3D path.
struct Curve {
  std::vector<std::string> columns;  ///< 1 (against time) or 3 (x, y, z of a path)
  std::string title;                 ///< legend (markup)
  std::string color;                 ///< "#rrggbb"
  bool from_start = false;           ///< plot v - v(t0)
  double scale = 1.0;                ///< then times this
};

enum class PanelKind { kTime, kPath, kOrientation };

struct Panel {
  PanelKind kind = PanelKind::kTime;
  std::string id;        ///< "a", "b", ... (the ranges file's key)
  std::string title;     ///< markup
  std::string quantity;  ///< y label without unit (time panels)
  std::string unit;      ///< markup; "" = the unit of the first column, from the header
  std::vector<Curve> curves;
  bool zoom = false;         ///< add a start-transient companion panel
  bool coordinates = false;  ///< y range: the data's, +-0.1 (positions of links that hardly move)
};

struct Figure {
  std::string name;     ///< file base name: figures/<name>.png and .svg, plots/<name>.gp
  std::string label;    ///< "Fig. 5" ("" for none)
  std::string caption;  ///< markup
  std::string shows;    ///< what it shows, for the page (markup)
  int section = -1;     ///< index in FigureList::sections, -1 for none
  bool bond_graph = false;  ///< the model's bond graph, drawn with Graphviz (needs --model); no panels
  std::vector<Panel> panels;

  /// "Fig. 5. caption", or the caption alone.
  std::string Title() const { return label.empty() ? caption : label + ". " + caption; }
  /// Every column its panels use, each once, in order.
  std::vector<std::string> Columns() const;
};

/// An expected value at the end of the run, shown on the page against the simulated one.
struct Check {
  std::string quantity;  ///< markup
  std::string column;    ///< the column, or with `norm` the vector prefix (|(p.x, p.y, p.z)|)
  bool norm = false;
  double value = 0, tolerance = 0;
  std::string unit, note;  ///< markup
};

struct FigureList {
  std::string title, intro;           ///< the page's heading and first paragraph (markup; "" = the general ones)
  std::vector<std::string> sections;  ///< section titles (markup)
  std::vector<Figure> figures;        ///< in order; a section's figures follow each other
  std::vector<Check> checks;
};

/// The figure names of a list, in order.
std::vector<std::string> FigureNames(const FigureList& list);

/// True when `name` can be a figure's file name: 1 to 100 of [A-Za-z0-9_.-], starting with a
/// letter or digit.
bool IsFigureName(const std::string& name);

/// Reads a figure list file (docs/plots.md). It is untrusted input like a model file: at most
/// limits.file_bytes, UTF-8, YAML within limits.yaml_nodes and limits.depth, every key known
/// (did you mean?), every name and colour checked. Throws ModelError with every problem found,
/// each located (file:line:column).
FigureList ReadFigureList(const std::string& path, const InputLimits& limits = {});
/// The same for a figure list's text; `file` names it in diagnostics.
FigureList ParseFigureList(const std::string& text, const std::string& file = "<string>", const InputLimits& limits = {});

}  // namespace multibond
