#include "multibond/io/plot_web.h"

#include <sys/stat.h>
#include <unistd.h>

#include <bit>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <optional>
#include <regex>
#include <sstream>
#include <stdexcept>

#include <fmt/format.h>
#include <openssl/evp.h>
#include <yaml-cpp/yaml.h>

#include "multibond/causality/causality.h"
#include "multibond/core/error.h"
#include "multibond/core/structure.h"
#include "multibond/io/dot_writer.h"
#include "multibond/io/plot_model.h"
#include "multibond/io/safe_text.h"

#ifndef MULTIBOND_WEB_BUILD_DIR
#define MULTIBOND_WEB_BUILD_DIR ""
#endif

namespace multibond {

namespace {

namespace fs = std::filesystem;

/// The largest asset file copied (the bundled script is about 0.6 MB).
constexpr std::uintmax_t kMaxAssetBytes = 16u << 20;
/// The largest Graphviz layout read back, and the most drawing operations kept.
constexpr std::uintmax_t kMaxLayoutBytes = 64u << 20;
constexpr std::size_t kMaxDrawOps = 1000000;
/// The longest text of a drawing operation kept (bytes).
constexpr std::size_t kMaxOpText = 200;

bool HasAssets(const fs::path& dir) {
  std::error_code ec;
  for (const char* name : {kPageScript, kPageStyle}) {
    const fs::file_status s = fs::status(dir / name, ec);
    if (ec || !fs::is_regular_file(s)) return false;
  }
  return true;
}

std::optional<std::string> ReadBounded(const fs::path& path, std::uintmax_t max_bytes) {
  std::error_code ec;
  const std::uintmax_t size = fs::file_size(path, ec);
  if (ec || size > max_bytes) return std::nullopt;
  std::ifstream in(path, std::ios::binary);
  if (!in) return std::nullopt;
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (text.size() > max_bytes) return std::nullopt;
  return text;
}

nlohmann::json Vec(const Eigen::Vector3d& v) { return nlohmann::json::array({v.x(), v.y(), v.z()}); }

/// 0, 1, 2 for an axis written x, -y, [0, 0, 1], ...; -1 when it does not read.
int AxisIndex(const YAML::Node& n) {
  if (!n) return 2;
  try {
    if (n.IsScalar()) {
      std::string s = n.Scalar();
      if (!s.empty() && (s[0] == '-' || s[0] == '+')) s = s.substr(1);
      if (s == "x") return 0;
      if (s == "y") return 1;
      if (s == "z") return 2;
      return -1;
    }
    if (n.IsSequence() && n.size() == 3) {
      int k = 0;
      double best = -1;
      for (int i = 0; i < 3; ++i) {
        const double a = std::abs(n[static_cast<std::size_t>(i)].as<double>());
        if (a > best) best = a, k = i;
      }
      return k;
    }
  } catch (const YAML::Exception&) {
  }
  return -1;
}

/// The box whose inertia about its centre is `I` (diagonal) for mass m: a^2 = 6 (Iyy + Izz - Ixx) / m.
nlohmann::json InertiaBox(const mech::MassProperties& mp) {
  const Eigen::Vector3d d = mp.inertia.diagonal();
  nlohmann::json size = nlohmann::json::array();
  for (int i = 0; i < 3; ++i) {
    const double s2 = mp.mass > 0 ? 6.0 * (d.sum() - 2.0 * d[i]) / mp.mass : 0.0;
    size.push_back(s2 > 0 && std::isfinite(s2) ? std::sqrt(s2) : 0.02);
  }
  return size;
}

/// A body's shape: the model's kind and axis, the dimensions from its mass properties (they hold
/// them whether the file wrote numbers or parameters): a cylinder of mass m, axial inertia Ia and
/// diametral Id has r = sqrt(2 Ia / m), L = sqrt(12 Id / m - 3 r^2); a sphere 2/5 m r^2.
nlohmann::json Shape(const mech::Body& b, const YAML::Node& spec) {
  const mech::MassProperties& mp = b.mass;
  const YAML::Node shape = spec && spec.IsMap() ? spec["shape"] : YAML::Node();
  std::string kind;
  YAML::Node dims;
  if (shape && shape.IsMap() && shape.size() == 1) {
    kind = shape.begin()->first.Scalar();
    dims = shape.begin()->second;
  }
  const Eigen::Vector3d d = mp.inertia.diagonal();
  if ((kind == "disc" || kind == "cylinder") && mp.mass > 0) {
    const int axis = AxisIndex(dims && dims.IsMap() ? dims["axis"] : YAML::Node());
    if (axis >= 0) {
      const double r2 = 2.0 * d[axis] / mp.mass;
      const double diametral = d[(axis + 1) % 3];
      const double l2 = 12.0 * diametral / mp.mass - 3.0 * r2;
      return {{"type", "cylinder"}, {"axis", axis}, {"diameter", 2.0 * std::sqrt(std::max(r2, 0.0))}, {"length", std::sqrt(std::max(l2, 0.0))}};
    }
  }
  if (kind == "box" && mp.mass > 0) return {{"type", "box"}, {"size", InertiaBox(mp)}};
  if (kind == "sphere" && mp.mass > 0) return {{"type", "sphere"}, {"diameter", 2.0 * std::sqrt(2.5 * d[0] / mp.mass)}};
  return {{"type", "inertia"}, {"size", InertiaBox(mp)}};
}

bool Finite(const nlohmann::json& v) { return v.is_number() && std::isfinite(v.get<double>()); }

/// [[x, y], ...] with finite numbers, or null.
nlohmann::json Points(const nlohmann::json& p) {
  if (!p.is_array() || p.empty() || p.size() > 100000) return nullptr;
  nlohmann::json out = nlohmann::json::array();
  for (const auto& xy : p) {
    if (!xy.is_array() || xy.size() != 2 || !Finite(xy[0]) || !Finite(xy[1])) return nullptr;
    out.push_back({xy[0].get<double>(), xy[1].get<double>()});
  }
  return out;
}

/// Graphviz's drawing operations (xdot, as -Tjson writes them), checked and reduced.
void AddOps(const nlohmann::json& obj, nlohmann::json& out, std::size_t& count) {
  static const std::regex colour("#[0-9a-fA-F]{3,8}|[a-z]{1,20}");
  for (const char* key : {"_draw_", "_ldraw_", "_hdraw_", "_tdraw_", "_hldraw_", "_tldraw_"}) {
    const auto it = obj.find(key);
    if (it == obj.end() || !it->is_array()) continue;
    for (const auto& op : *it) {
      if (!op.is_object() || !op.contains("op") || !op["op"].is_string() || ++count > kMaxDrawOps) continue;
      const std::string o = op["op"].get<std::string>();
      nlohmann::json r = {{"op", o}};
      if (o == "c" || o == "C") {
        const std::string c = op.value("color", std::string());
        r["color"] = std::regex_match(c, colour) ? c : "#000000";
      } else if (o == "F") {
        if (!op.contains("size") || !Finite(op["size"])) continue;
        r["size"] = op["size"];
      } else if (o == "S") {
        const std::string s = op.value("style", std::string());
        r["style"] = s == "dashed" || s == "dotted" || s == "solid" ? s : "solid";
      } else if (o == "e" || o == "E") {
        const auto& rect = op.value("rect", nlohmann::json());
        if (!rect.is_array() || rect.size() != 4) continue;
        bool ok = true;
        for (const auto& v : rect) ok = ok && Finite(v);
        if (!ok) continue;
        r["rect"] = rect;
      } else if (o == "p" || o == "P" || o == "L" || o == "b" || o == "B") {
        nlohmann::json p = Points(op.value("points", nlohmann::json()));
        if (p.is_null()) continue;
        r["points"] = std::move(p);
      } else if (o == "T") {
        const auto& pt = op.value("pt", nlohmann::json());
        if (!pt.is_array() || pt.size() != 2 || !Finite(pt[0]) || !Finite(pt[1]) || !op.contains("text") || !op["text"].is_string()) continue;
        const std::string align = op.value("align", std::string("c"));
        r["pt"] = pt;
        r["align"] = align == "l" || align == "r" ? align : "c";
        r["text"] = op["text"].get<std::string>().substr(0, kMaxOpText);
      } else {
        continue;
      }
      out.push_back(std::move(r));
    }
  }
}

double Inches(const nlohmann::json& v) {
  try {
    return v.is_string() ? std::stod(v.get<std::string>()) : v.is_number() ? v.get<double>() : 0.0;
  } catch (const std::exception&) {
    return 0.0;
  }
}

/// The bond graph drawing of `model`, laid out by Graphviz in `work`.
/// The page's bond graph from the model's DOT, laid out by Graphviz here unless `layout` (its
/// -Tjson output, e.g. from drawing the bond graph figure) is given.
nlohmann::json GraphOf(const PlotModel& model, const WorkFolder& work, const std::string& layout, std::vector<std::string>& notes) {
  if (model.dot.empty()) {
    notes.push_back("No bond graph: the model has structural errors (see 'multibond check').");
    return nullptr;
  }
  std::optional<std::string> text = layout;
  if (layout.empty()) {
    std::string error;
    text = LayOutBondGraph(model, work, "page-graph", {}, &error);
    if (!text) {
      notes.push_back(fmt::format("No bond graph: Graphviz did not lay it out ({}).", MessageText(error)));
      return nullptr;
    }
  }
  try {
    return GraphDrawing(nlohmann::json::parse(*text), model.loaded->graph);
  } catch (const std::exception& e) {
    notes.push_back(fmt::format("No bond graph: Graphviz's layout does not read ({}).", MessageText(e.what())));
    return nullptr;
  }
}

}  // namespace

std::optional<std::string> LayOutBondGraph(const PlotModel& model, const WorkFolder& work, const std::string& name,
                                           const std::vector<GraphvizOutput>& pictures, std::string* error) {
  const std::string dot = work.path() + "/plots/" + name + ".dot", layout = work.path() + "/plots/" + name + ".json";
  work.Write("plots/" + name + ".dot", model.dot);
  std::vector<GraphvizOutput> outputs;
  for (const GraphvizOutput& p : pictures) outputs.push_back({p.format, work.path() + "/" + p.path});
  outputs.push_back({"json", layout});
  if (!RenderWithGraphviz(dot, outputs, error)) return std::nullopt;
  std::optional<std::string> text = ReadBounded(layout, kMaxLayoutBytes);
  if (!text && error) *error = fmt::format("its layout is missing or larger than {} bytes", kMaxLayoutBytes);
  return text;
}

std::string Base64Doubles(const std::vector<double>& v) {
  static_assert(std::endian::native == std::endian::little, "the page reads little-endian doubles");
  static_assert(sizeof(double) == 8);
  const std::size_t bytes = v.size() * sizeof(double);
  std::string out(4 * ((bytes + 2) / 3) + 1, '\0');
  const int n = bytes == 0 ? 0 : EVP_EncodeBlock(reinterpret_cast<unsigned char*>(out.data()), reinterpret_cast<const unsigned char*>(v.data()),
                                                static_cast<int>(bytes));
  out.resize(static_cast<std::size_t>(n));
  return out;
}

std::string FindPageAssets() {
  if (const char* env = std::getenv("MULTIBOND_WEB_DIR"); env && *env) return HasAssets(env) ? env : "";
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  if (!ec) {
    const fs::path installed = exe.parent_path().parent_path() / "share" / "multibond" / "web";
    if (HasAssets(installed)) return installed.string();
  }
  if (*MULTIBOND_WEB_BUILD_DIR && HasAssets(MULTIBOND_WEB_BUILD_DIR)) return MULTIBOND_WEB_BUILD_DIR;
  return "";
}

std::string JsonForScript(const nlohmann::json& j) {
  const std::string text = j.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
  std::string out;
  out.reserve(text.size() + text.size() / 64);
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char ch = text[i];
    if (ch == '<') out += "\\u003c";
    else if (ch == '>') out += "\\u003e";
    else if (ch == '&') out += "\\u0026";
    else if (ch == '\xe2' && i + 2 < text.size() && text[i + 1] == '\x80' && (text[i + 2] == '\xa8' || text[i + 2] == '\xa9')) {
      out += text[i + 2] == '\xa8' ? "\\u2028" : "\\u2029";
      i += 2;
    } else {
      out += ch;
    }
  }
  return out;
}

nlohmann::json PageData(const PlotTable& table, const std::vector<PlotEvent>& events) {
  nlohmann::json data;
  nlohmann::json columns = nlohmann::json::array(), values = nlohmann::json::array();
  for (std::size_t k = 0; k < table.names().size(); ++k) {
    columns.push_back({{"name", table.names()[k]}, {"unit", table.units()[k]}});
    values.push_back(Base64Doubles(table.Col(table.names()[k])));
  }
  data["columns"] = std::move(columns);
  data["values"] = std::move(values);
  nlohmann::json ev = nlohmann::json::array();
  for (std::size_t k = 0; k < events.size() && k < kMaxDataEvents; ++k) {
    const PlotEvent& e = events[k];
    const EventStyle* style = FindEventStyle(e.kind);
    ev.push_back({{"time", e.time}, {"kind", e.kind}, {"element", e.element}, {"description", e.description},
                  {"color", style ? style->color : "#888888"}});
  }
  data["events"] = std::move(ev);
  data["event_count"] = events.size();
  return data;
}

namespace {

/// The apex of a bevel gear: where the axes of mesh `g` cross at t = 0, as a signed distance
/// along the body's own drawn axis (+e_axis of its frame, `axis` 0, 1, 2) from its centre; none
/// when a body or the carrier is unknown, b is a rack, the mesh's axis of the body is not its
/// drawn axis, or the axes pass each other (skew: farther apart than 1e-6 of the centres' distance).
std::optional<double> BevelApex(const mech::Mechanism& m, const mech::GearMesh& g, const mech::Body& b, int axis) {
  const auto find = [&](const std::string& name) -> const mech::Body* {
    for (const mech::Body& x : m.bodies())
      if (x.name == name) return &x;
    return nullptr;
  };
  const mech::Body* a = find(g.body_a);
  const mech::Body* c = find(g.body_b);
  if (!a || !c || g.rack_b || axis < 0 || axis > 2) return std::nullopt;
  Eigen::Matrix3d Rc = Eigen::Matrix3d::Identity();
  if (g.carrier != mech::kGround) {
    const mech::Body* carrier = find(g.carrier);
    if (!carrier) return std::nullopt;
    Rc = carrier->orientation;
  }
  // The axes as lines through the gears' centres, inertial frame: p + s w.
  if (!(g.axis_a.norm() > 0) || !(g.axis_b.norm() > 0)) return std::nullopt;
  const Eigen::Vector3d wa = (Rc * g.axis_a).normalized(), wb = (Rc * g.axis_b).normalized();
  const Eigen::Vector3d pa = a->position, pb = c->position;
  const double k = wa.dot(wb), denom = 1.0 - k * k;
  if (!(denom > 1e-6)) return std::nullopt;
  const Eigen::Vector3d d = pa - pb;
  const double sa = (k * wb.dot(d) - wa.dot(d)) / denom, sb = (wb.dot(d) - k * wa.dot(d)) / denom;
  const Eigen::Vector3d xa = pa + sa * wa, xb = pb + sb * wb;
  if (!((xa - xb).norm() <= 1e-6 * d.norm() + 1e-12 * (pa.norm() + pb.norm()))) return std::nullopt;
  // The body's drawn axis must be the mesh's axis of it.
  const Eigen::Vector3d u = b.orientation.col(axis), w = g.body_a == b.name ? wa : wb;
  if (!(u.cross(w).norm() <= 1e-6)) return std::nullopt;
  const double apex = (0.5 * (xa + xb) - b.position).dot(u);
  if (!std::isfinite(apex)) return std::nullopt;
  return apex;
}

}  // namespace

nlohmann::json SceneData(const LoadedModel& model) {
  if (!model.mechanism || model.mechanism->empty()) return nullptr;
  const mech::Mechanism& m = *model.mechanism;
  if (m.bodies().size() + m.joints().size() + m.points().size() + m.gears().size() > kMaxSceneParts) return nullptr;
  YAML::Node bodies;
  try {
    const YAML::Node root = YAML::Load(model.text);
    if (root.IsMap()) bodies = root["bodies"];
  } catch (const YAML::Exception&) {
  }
  nlohmann::json scene;
  scene["bodies"] = nlohmann::json::array();
  for (const mech::Body& b : m.bodies()) {
    nlohmann::json shape = Shape(b, bodies && bodies.IsMap() ? bodies[b.name] : YAML::Node());
    // A gear: a cylinder of a body in a mesh, toothed; a bevel gear when the axes meet at an angle.
    for (const mech::GearMesh& g : m.gears()) {
      if (shape["type"] != "cylinder" || (g.body_a != b.name && g.body_b != b.name)) continue;
      const bool a = g.body_a == b.name;
      shape["type"] = "gear";
      shape["teeth"] = a ? g.teeth_a : g.teeth_b;
      shape["cone"] = std::abs(g.axis_a.normalized().dot(g.axis_b.normalized())) < 0.9;
      // A bevel gear is drawn on its pitch cone, whose apex is where the two axes cross.
      if (shape["cone"] == true)
        if (const std::optional<double> apex = BevelApex(m, g, b, shape["axis"].get<int>())) shape["apex"] = *apex;
      break;
    }
    scene["bodies"].push_back({{"name", b.name}, {"shape", std::move(shape)}});
  }
  scene["joints"] = nlohmann::json::array();
  for (const mech::Joint& j : m.joints())
    scene["joints"].push_back({{"name", j.name}, {"kind", j.kind}, {"parent", j.parent}, {"child", j.child},
                               {"parent_point", Vec(j.parent_point)}, {"child_point", Vec(j.child_point)}});
  scene["gears"] = nlohmann::json::array();
  for (const mech::GearMesh& g : m.gears())
    scene["gears"].push_back({{"name", g.name}, {"a", g.body_a}, {"b", g.body_b}, {"teeth_a", g.teeth_a}, {"teeth_b", g.teeth_b}});
  scene["drives"] = nlohmann::json::array();
  for (const mech::Drive& d : m.drives()) scene["drives"].push_back({{"name", d.name}, {"body", d.body}});
  scene["points"] = nlohmann::json::array();
  for (const mech::Point& p : m.points()) scene["points"].push_back({{"name", p.name}, {"body", p.body}, {"at", Vec(p.at)}});
  return scene;
}

nlohmann::json GraphDrawing(const nlohmann::json& dot_json, const BondGraph& g) {
  if (!dot_json.is_object() || !dot_json.contains("bb") || !dot_json["bb"].is_string())
    throw std::runtime_error("not a Graphviz layout (no bounding box)");
  double x0 = 0, y0 = 0, x1 = 0, y1 = 0;
  if (std::sscanf(dot_json["bb"].get<std::string>().c_str(), "%lf,%lf,%lf,%lf", &x0, &y0, &x1, &y1) != 4 || !(x1 > x0) || !(y1 > y0) ||
      !std::isfinite(x1) || !std::isfinite(y1))
    throw std::runtime_error("not a Graphviz layout (bad bounding box)");
  nlohmann::json out;
  out["bb"] = {x1, y1};
  out["nodes"] = nlohmann::json::array();
  out["edges"] = nlohmann::json::array();
  out["clusters"] = nlohmann::json::array();
  std::size_t count = 0;
  static const std::regex node_id("e([0-9]{1,9})");
  for (const auto& o : dot_json.value("objects", nlohmann::json::array())) {
    if (!o.is_object()) continue;
    const std::string name = o.value("name", std::string());
    std::smatch m;
    nlohmann::json draw = nlohmann::json::array();
    AddOps(o, draw, count);
    if (std::regex_match(name, m, node_id)) {
      const int k = std::stoi(m[1].str());
      if (k >= g.num_elements()) continue;
      double x = 0, y = 0;
      if (std::sscanf(o.value("pos", std::string()).c_str(), "%lf,%lf", &x, &y) != 2 || !std::isfinite(x) || !std::isfinite(y)) continue;
      const double w = Inches(o.value("width", nlohmann::json())) * 72.0, h = Inches(o.value("height", nlohmann::json())) * 72.0;
      out["nodes"].push_back({{"element", g.element(k).name}, {"box", {x, y, std::isfinite(w) ? w : 0.0, std::isfinite(h) ? h : 0.0}},
                              {"draw", std::move(draw)}});
    } else if (!draw.empty()) {
      out["clusters"].push_back({{"draw", std::move(draw)}});
    }
  }
  for (const auto& e : dot_json.value("edges", nlohmann::json::array())) {
    if (!e.is_object()) continue;
    nlohmann::json draw = nlohmann::json::array();
    AddOps(e, draw, count);
    out["edges"].push_back({{"draw", std::move(draw)}});
  }
  return out;
}

PageApp PreparePage(const ResultsFolder& folder, const PlotTable& table, const std::vector<PlotEvent>& events, const PlotModel& model,
                    const std::string& layout, const std::string& assets_dir, std::size_t max_values) {
  PageApp app;
  if (table.rows() * table.names().size() > max_values) {
    app.notes.push_back(fmt::format("No interactive view: the run has {} rows of {} columns, more than the page holds ({} values); "
                                    "the figures below are drawn from all of them.",
                                    table.rows(), table.names().size(), max_values));
    return app;
  }
  nlohmann::json data = PageData(table, events);
  data["graph"] = nullptr;
  data["scene"] = nullptr;
  const WorkFolder work(folder);
  if (!model.given()) {
    data["graph_note"] = "No bond graph: give the model file with 'multibond plot DIR --model MODEL' (run.json names it, but plot does "
                         "not open a file because a results folder names it).";
    data["scene_note"] = "No 3D view: give the model file with --model MODEL for the bodies' shapes.";
  } else {
    const std::string does_not_load = fmt::format(
        "No bond graph and no 3D view: the model '{}' does not load (see 'multibond check' on it).", MessageText(model.path));
    if (!model.loaded) {
      app.notes.push_back(does_not_load);
    } else {
      try {
        data["graph"] = GraphOf(model, work, layout, app.notes);
        data["scene"] = SceneData(*model.loaded);
        if (data["scene"].is_null()) data["scene_note"] = "No 3D view: the model has no bodies.";
      } catch (const ModelError&) {
        data["graph"] = nullptr;
        app.notes.push_back(does_not_load);
      }
    }
    if (!app.notes.empty()) data["graph_note"] = app.notes.front();
  }
  app.data_json = JsonForScript(data);
  if (!assets_dir.empty()) {
    bool copied = true;
    for (const char* name : {kPageScript, kPageStyle}) {
      const std::optional<std::string> text = ReadBounded(fs::path(assets_dir) / name, kMaxAssetBytes);
      if (!text) {
        copied = false;
        break;
      }
      work.Write(std::string("plots/") + name, *text);
    }
    for (const char* name : {kPageScript, kPageStyle}) copied = copied && work.Publish(std::string("plots/") + name, folder.fd(), name);
    app.assets = copied;
    if (!copied) app.notes.push_back(fmt::format("The interactive page's files could not be copied from '{}'.", MessageText(assets_dir)));
  } else {
    app.notes.push_back("The interactive page's script is not installed (multibond was built without node and npm: docs/plots.md).");
  }
  return app;
}

}  // namespace multibond
