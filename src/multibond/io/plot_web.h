#pragma once
/// \file
/// The interactive part of the results page (DIR/index.html, docs/plots.md): the data that the
/// page's script (web/src/page.js, bundled at build time with uPlot and three.js into
/// multibond-page.js and multibond-page.css) draws, embedded in the page as JSON, and the two
/// script files copied next to the page. The page needs no network and no server: it works from
/// file://.
///
/// The data: every column of results.csv (names, units, values), the run's events, and, when a
/// model file is given (--model: a results folder's run.json names its model, but `plot` does
/// not open files because a folder says so), the bond graph as Graphviz laid it out and, for a
/// mechanism, the scene of the 3D view (bodies with their shapes, joints, gears, points).
///
/// Every text in the data (names, units, event descriptions, graph labels) is shown by the
/// script as text (textContent), never as markup; inside the page's <script> element the JSON
/// has '<', '>' and '&' written as \u003c, \u003e, \u0026, so no text can close the element.

#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "multibond/io/limits.h"
#include "multibond/io/model_loader.h"
#include "multibond/io/plot_events.h"
#include "multibond/io/plot_model.h"
#include "multibond/io/plot_table.h"
#include "multibond/io/results_folder.h"

namespace multibond {

/// The page's script and style file names (in the assets folder and next to index.html).
inline constexpr const char* kPageScript = "multibond-page.js";
inline constexpr const char* kPageStyle = "multibond-page.css";

/// The most events the page's data holds (the first ones; the page says how many there were).
constexpr std::size_t kMaxDataEvents = 20000;
/// The most bodies, joints and points a scene holds; past them the 3D view is left out.
constexpr std::size_t kMaxSceneParts = 10000;

/// The most values (rows x columns) the page holds: 2^25, 256 MiB of doubles, about 350 MB of
/// page. A larger run gets the gallery without the interactive part, and a note.
constexpr std::size_t kMaxPageValues = std::size_t{1} << 25;

/// The folder holding kPageScript and kPageStyle, or "" when none does. Looked for in order:
/// $MULTIBOND_WEB_DIR; `<prefix>/share/multibond/web` next to the running program's
/// `<prefix>/bin` (an installed multibond); the build tree's `web/` (where CMake bundles them).
std::string FindPageAssets();

/// JSON text safe inside an HTML <script type="application/json"> element: '<', '>' and '&' as
/// \u003c, \u003e and \u0026 (JSON.parse reads them back), U+2028 and U+2029 escaped too.
std::string JsonForScript(const nlohmann::json& j);

/// A column's values as base64 of its little-endian IEEE doubles (every bit kept: the page's CSV
/// export gives back the values of results.csv; JSON.parse reads a string much faster than a
/// million numbers).
std::string Base64Doubles(const std::vector<double>& v);

/// The page's data without graph and scene: {"columns": [{"name", "unit"}...], "values": [one
/// Base64Doubles string per column], "events": [{"time", "kind", "element", "description",
/// "color"}] (at most kMaxDataEvents), "event_count"}.
nlohmann::json PageData(const PlotTable& table, const std::vector<PlotEvent>& events);

/// The 3D view's scene of a mechanism model, or null when it has no bodies (or more than
/// kMaxSceneParts parts): {"bodies": [{"name", "shape": {...}}], "joints": [{"name", "parent",
/// "child", "child_point", "parent_point"}], "gears": [...], "drives": [{"name", "body"}],
/// "points": [{"name", "body", "at"}]}. A body's shape is the model's (cylinder, with a disc's
/// thickness as its length; box; sphere: "axis" 0, 1, 2 for x, y, z), a geared body's disc or
/// cylinder is a gear with the mesh's tooth count ("cone" when the mesh's axes are not parallel:
/// a bevel gear, with "apex" when they cross at t = 0: the signed distance from the body's centre
/// along its own axis to the crossing, its pitch cone's apex), and a body given by mass and
/// inertia is the box of the same inertia ("type": "inertia", drawn see-through).
nlohmann::json SceneData(const LoadedModel& model);

/// The bond graph drawing from Graphviz's `-Tjson` output of MakeDot's graph `g` (its nodes
/// "e<k>" are element k): {"bb": [w, h], "nodes": [{"element", "box": [x, y, w, h], "draw":
/// [ops]}], "edges": [{"draw"}], "clusters": [{"draw"}]}. Only drawing operations of known kinds
/// with numbers, colours ("#rrggbb[aa]" or a word) and text are kept. Throws std::runtime_error
/// when `dot_json` is not Graphviz's layout.
nlohmann::json GraphDrawing(const nlohmann::json& dot_json, const BondGraph& g);

/// Writes the model's DOT (PlotModel::dot, not empty) as plots/<name>.dot in `work` and has
/// Graphviz lay it out once, writing its layout (-Tjson) as plots/<name>.json and each of
/// `pictures` (a format and a path in `work`, e.g. {"svg", "figures/bond-graph.svg"}) from the same
/// layout. Returns the layout's text, or nullopt with the reason in `error` (if non-null).
std::optional<std::string> LayOutBondGraph(const PlotModel& model, const WorkFolder& work, const std::string& name,
                                           const std::vector<GraphvizOutput>& pictures, std::string* error);

/// What the page's interactive part needs, gathered by PreparePage.
struct PageApp {
  std::string data_json;   ///< JsonForScript of the data
  bool assets = false;     ///< kPageScript and kPageStyle were copied next to the page
  std::vector<std::string> notes;  ///< what is left out and why (printable text)
};

/// Gathers the page's data from the folder's table and events and the model (PlotModel: none
/// given leaves out the graph and the scene with a note saying how to get them, one that does not
/// load with a note saying so), and copies the assets from `assets_dir` (FindPageAssets(); "" for
/// none) into the folder, through a private work folder and a rename (a planted link is replaced,
/// not followed). The bond graph is laid out by Graphviz from the model's DOT unless `layout`, the
/// layout of that DOT (`dot -Tjson`), is given. A table of more than `max_values` values gets no
/// interactive part (a note says why).
PageApp PreparePage(const ResultsFolder& folder, const PlotTable& table, const std::vector<PlotEvent>& events, const PlotModel& model,
                    const std::string& layout, const std::string& assets_dir, std::size_t max_values = kMaxPageValues);

}  // namespace multibond
