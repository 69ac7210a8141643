// The interactive results page's data (io/plot_web.h): escaped JSON, exact values, the scene of a
// mechanism from its model, Graphviz's layout reduced to checked drawing operations, and the
// page's files copied into a folder without writing through a planted link.

#include "multibond/io/plot_web.h"

#include <openssl/evp.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "multibond/io/plot_page.h"
#include "multibond/mech/mechanism.h"
#include "support/temp_dir.h"

namespace multibond {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using multibond::testing::ReadFile;

std::vector<double> DecodeDoubles(const std::string& b64) {
  if (b64.empty()) return {};
  std::vector<unsigned char> bytes(b64.size());
  const int n = EVP_DecodeBlock(bytes.data(), reinterpret_cast<const unsigned char*>(b64.data()), static_cast<int>(b64.size()));
  const size_t padding = b64.size() >= 2 ? (b64.end()[-1] == '=') + (b64.end()[-2] == '=') : 0;
  std::vector<double> out((static_cast<size_t>(n) - padding) / 8);
  std::memcpy(out.data(), bytes.data(), out.size() * 8);
  return out;
}

TEST(PlotWebTest, JsonForScriptCannotCloseTheElementAndReadsBack) {
  const std::string hostile = "</script><script>alert(1)</script> <!-- & \xe2\x80\xa8 \xe2\x80\xa9 <img src=x onerror=alert(2)>";
  const nlohmann::json j = {{"name", hostile}, {"list", {hostile, 1.5}}};
  const std::string text = JsonForScript(j);
  EXPECT_EQ(text.find_first_of("<>&"), std::string::npos) << text;
  EXPECT_EQ(text.find("\xe2\x80\xa8"), std::string::npos);
  EXPECT_EQ(text.find("\xe2\x80\xa9"), std::string::npos);
  EXPECT_THAT(text, HasSubstr("\\u003c/script\\u003e"));
  EXPECT_EQ(nlohmann::json::parse(text), j);  // JSON.parse reads the same
}

TEST(PlotWebTest, ValuesKeepEveryBit) {
  const std::vector<double> v = {0.0, -0.0, 1.0 / 3.0, -2.5e-308, std::numeric_limits<double>::denorm_min(), 1e308,
                                 std::numeric_limits<double>::infinity(), std::numeric_limits<double>::quiet_NaN(), 0.1, 12345.678901234567};
  for (size_t n = 0; n <= v.size(); ++n) {  // every length: every padding of base64
    const std::vector<double> part(v.begin(), v.begin() + static_cast<long>(n));
    const std::vector<double> back = DecodeDoubles(Base64Doubles(part));
    ASSERT_EQ(back.size(), n);
    for (size_t k = 0; k < n; ++k) EXPECT_EQ(std::memcmp(&back[k], &part[k], 8), 0) << k;
  }
  EXPECT_EQ(Base64Doubles({}), "");
}

PlotTable TableOf(const fs::path& dir, const std::string& csv) {
  std::ofstream(dir / "results.csv") << csv;
  struct stat st {};
  return PlotTable::Load(ResultsFolder(dir.string()), 1 << 20, &st);
}

TEST(PlotWebTest, PageDataHasEveryColumnAndTheEvents) {
  const multibond::testing::TempDir d("multibond-plot-web");
  const PlotTable t = TableOf(d.path(), "time [s],x [m],\"<b>.y\" [N m]\n0,1,2\n0.5,-1.25,3\n");
  std::vector<PlotEvent> events(kMaxDataEvents + 5, PlotEvent{0.25, "impact", "wall", "a <b>hit</b>"});
  events[1].kind = "stick";
  const nlohmann::json data = PageData(t, events);
  ASSERT_EQ(data["columns"].size(), 3u);
  EXPECT_EQ(data["columns"][1], (nlohmann::json{{"name", "x"}, {"unit", "m"}}));
  EXPECT_EQ(data["columns"][2]["name"], "<b>.y");
  EXPECT_EQ(data["columns"][2]["unit"], "N m");
  EXPECT_EQ(DecodeDoubles(data["values"][1].get<std::string>()), (std::vector<double>{1, -1.25}));
  EXPECT_EQ(DecodeDoubles(data["values"][0].get<std::string>()), (std::vector<double>{0, 0.5}));
  EXPECT_EQ(data["events"].size(), kMaxDataEvents);
  EXPECT_EQ(data["event_count"], kMaxDataEvents + 5);
  EXPECT_EQ(data["events"][0]["color"], FindEventStyle("impact")->color);
  EXPECT_EQ(data["events"][1]["color"], FindEventStyle("stick")->color);
  EXPECT_EQ(data["events"][0]["description"], "a <b>hit</b>");  // text; escaped by JsonForScript, shown by textContent
}

TEST(PlotWebTest, SceneOfTheDifferential) {
  const LoadedModel m = LoadModelFile(std::string(MULTIBOND_SOURCE_DIR) + "/examples/differential.yaml");
  const nlohmann::json s = SceneData(m);
  ASSERT_TRUE(s.is_object());
  std::map<std::string, nlohmann::json> bodies;
  for (const auto& b : s["bodies"]) bodies[b["name"]] = b["shape"];
  ASSERT_EQ(bodies.size(), 7u);
  // A: disc 0.4 x 0.01 about z, the crown wheel of mesh_GA (48 teeth), bevel (its axis z meets G's x).
  EXPECT_EQ(bodies["A"]["type"], "gear");
  EXPECT_EQ(bodies["A"]["axis"], 2);
  EXPECT_NEAR(bodies["A"]["diameter"].get<double>(), 0.4, 1e-12);
  EXPECT_NEAR(bodies["A"]["length"].get<double>(), 0.01, 1e-9);
  EXPECT_EQ(bodies["A"]["teeth"], 48);
  EXPECT_EQ(bodies["A"]["cone"], true);
  EXPECT_EQ(bodies["G"]["teeth"], 12);
  EXPECT_EQ(bodies["G"]["axis"], 0);
  EXPECT_NEAR(bodies["G"]["diameter"].get<double>(), 0.1, 1e-12);
  EXPECT_EQ(bodies["S2"]["teeth"], 24);
  // H: mass 20, inertia 0.5 on each axis: the box of that inertia, a^2 = 6 (0.5 + 0.5 - 0.5) / 20.
  EXPECT_EQ(bodies["H"]["type"], "inertia");
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(bodies["H"]["size"][static_cast<size_t>(k)].get<double>(), std::sqrt(0.15), 1e-12);
  EXPECT_EQ(s["joints"].size(), 11u);
  EXPECT_EQ(s["gears"].size(), 5u);
  ASSERT_EQ(s["drives"].size(), 1u);
  EXPECT_EQ(s["drives"][0]["body"], "G");
  ASSERT_EQ(s["points"].size(), 2u);
  EXPECT_EQ(s["points"][0], (nlohmann::json{{"name", "Q_P1"}, {"body", "P1"}, {"at", {0.0, 0.05, 0.0}}}));

  EXPECT_TRUE(SceneData(LoadModelFile(std::string(MULTIBOND_SOURCE_DIR) + "/examples/mass_spring_damper.yaml")).is_null());
}

// A bevel gear's apex: the signed distance from its centre along its own axis (+x, +y or +z of
// its body frame, the shape's "axis") to where the mesh's axes cross at t = 0.
Eigen::Vector3d ApexPoint(const mech::Mechanism& m, const std::string& body, const nlohmann::json& shape) {
  for (const mech::Body& b : m.bodies())
    if (b.name == body) return b.position + shape["apex"].get<double>() * b.orientation.col(shape["axis"].get<int>());
  ADD_FAILURE() << "no body " << body;
  return Eigen::Vector3d::Constant(std::nan(""));
}

std::map<std::string, nlohmann::json> SceneShapes(const LoadedModel& m) {
  std::map<std::string, nlohmann::json> shapes;
  const nlohmann::json s = SceneData(m);
  if (s.is_object())
    for (const auto& b : s["bodies"]) shapes[b["name"]] = b["shape"];
  return shapes;
}

TEST(PlotWebTest, BevelGearsOfTheDifferentialShareTheirConesApex) {
  const LoadedModel m = LoadModelFile(std::string(MULTIBOND_SOURCE_DIR) + "/examples/differential.yaml");
  ASSERT_TRUE(m.mechanism);
  std::map<std::string, nlohmann::json> shapes = SceneShapes(m);
  int bevel = 0;
  for (const auto& [name, shape] : shapes) {
    if (shape["type"] != "gear") continue;
    EXPECT_EQ(shape["cone"], true) << name;
    EXPECT_TRUE(shape.contains("apex") && shape["apex"].is_number()) << name << ": " << shape.dump();
    ++bevel;
  }
  EXPECT_EQ(bevel, 6);  // G, A, P1, P2, S1, S2
  // Each mesh's two pitch cones have one apex, where the axes cross.
  for (const mech::GearMesh& g : m.mechanism->gears()) {
    const Eigen::Vector3d a = ApexPoint(*m.mechanism, g.body_a, shapes[g.body_a]);
    const Eigen::Vector3d b = ApexPoint(*m.mechanism, g.body_b, shapes[g.body_b]);
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(a[k], b[k], 1e-12) << g.name << " component " << k;
  }
  // The crown wheel A (centre H + (0, 0, -0.1), axis z) and the pinion G (centre H + (-0.2, 0,
  // -0.05), axis x) meet at H + (0, 0, -0.05): 0.05 along A's +z, 0.2 along G's +x, cone
  // half-angles atan(0.2 / 0.05) + atan(0.05 / 0.2) = 90 deg. The planets (axis x of A, P2 turned
  // half a turn about z) and the suns (z) meet at H: 0.1 inwards along each planet's own +x.
  EXPECT_NEAR(shapes["A"]["apex"].get<double>(), 0.05, 1e-12);
  EXPECT_NEAR(shapes["G"]["apex"].get<double>(), 0.2, 1e-12);
  EXPECT_NEAR(shapes["P1"]["apex"].get<double>(), -0.1, 1e-12);
  EXPECT_NEAR(shapes["P2"]["apex"].get<double>(), -0.1, 1e-12);
  EXPECT_NEAR(shapes["S1"]["apex"].get<double>(), 0.05, 1e-12);
  EXPECT_NEAR(shapes["S2"]["apex"].get<double>(), -0.05, 1e-12);
  const Eigen::Vector3d H = m.mechanism->bodies()[0].position;
  ASSERT_EQ(m.mechanism->bodies()[0].name, "H");
  const Eigen::Vector3d crossing = ApexPoint(*m.mechanism, "G", shapes["G"]) - H;
  EXPECT_NEAR(crossing.x(), 0.0, 1e-12);
  EXPECT_NEAR(crossing.y(), 0.0, 1e-12);
  EXPECT_NEAR(crossing.z(), -0.05, 1e-12);
}

TEST(PlotWebTest, BevelApexInTheCarriersFrameAndNoneWhenTheAxesDoNotCross) {
  // Parallel axes (a spur pair): a gear, no cone, no apex.
  std::map<std::string, nlohmann::json> spur =
      SceneShapes(LoadModelFile(std::string(MULTIBOND_SOURCE_DIR) + "/examples/gears/spur_pair.yaml"));
  for (const char* name : {"pinion", "wheel"}) {
    EXPECT_EQ(spur[name]["type"], "gear") << name;
    EXPECT_EQ(spur[name]["cone"], false) << name;
    EXPECT_FALSE(spur[name].contains("apex")) << name;
  }
  // A crown wheel and pinion on a carrier turned a quarter turn about x: the mesh's axes are in
  // its frame (its z is the world's -y), the bodies turned with it. The axes cross at (0, -0.05, 0).
  const auto pair = [](const std::string& pinion_at, const std::string& pinion_axis, const std::string& mesh_axis) {
    return LoadModelString(R"(model: bevel
bodies:
  C: {mass: 1.0, inertia: [0.1, 0.1, 0.1], position: [0, 0, 0], orientation: {axis: x, degrees: 90}}
  A: {shape: {disc: {diameter: 0.4, thickness: 0.01, axis: z}}, density: 2700, position: [0, 0, 0], orientation: {axis: x, degrees: 90}}
  G: {shape: {disc: {diameter: 0.1, thickness: 0.01, axis: )" + pinion_axis + R"(}}, density: 2700, position: )" + pinion_at + R"(,
      orientation: {axis: x, degrees: 90}}
joints:
  hold: {parent: ground, child: C, translation: {K: 1000, R: 1}, rotation: {axes: [x, y, z], frame: world, K: 1000, R: 1}}
gears:
  mesh: {carrier: C, a: {body: A, axis: z, teeth: 48}, b: {body: G, axis: )" + mesh_axis + R"(, teeth: 12}, K: 1000, R: 1}
)");
  };
  const LoadedModel turned = pair("[-0.2, -0.05, 0]", "x", "x");
  std::map<std::string, nlohmann::json> s = SceneShapes(turned);
  ASSERT_TRUE(s["A"].contains("apex")) << s["A"].dump();
  ASSERT_TRUE(s["G"].contains("apex")) << s["G"].dump();
  EXPECT_NEAR(s["A"]["apex"].get<double>(), 0.05, 1e-12);  // along A's +z, the world's -y
  EXPECT_NEAR(s["G"]["apex"].get<double>(), 0.2, 1e-12);
  const Eigen::Vector3d at = ApexPoint(*turned.mechanism, "A", s["A"]);
  EXPECT_NEAR(at.x(), 0.0, 1e-12);
  EXPECT_NEAR(at.y(), -0.05, 1e-12);
  EXPECT_NEAR(at.z(), 0.0, 1e-12);
  const Eigen::Vector3d at_g = ApexPoint(*turned.mechanism, "G", s["G"]);
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(at[k], at_g[k], 1e-12);

  // Skew (a hypoid's offset): the pinion's axis 0.03 beside the crown's. A bevel gear as before, no apex.
  s = SceneShapes(pair("[-0.2, -0.05, 0.03]", "x", "x"));
  for (const char* name : {"A", "G"}) {
    EXPECT_EQ(s[name]["type"], "gear") << name;
    EXPECT_EQ(s[name]["cone"], true) << name;
    EXPECT_FALSE(s[name].contains("apex")) << name << ": " << s[name].dump();
  }
  // The mesh's axis of G (x) is not the axis its disc is drawn about (y): no apex for G.
  s = SceneShapes(pair("[-0.2, -0.05, 0]", "y", "x"));
  EXPECT_EQ(s["G"]["cone"], true);
  EXPECT_FALSE(s["G"].contains("apex")) << s["G"].dump();
  EXPECT_TRUE(s["A"].contains("apex")) << s["A"].dump();
}

TEST(PlotWebTest, ShapesFromTheirMassProperties) {
  const LoadedModel m = LoadModelString(R"(model: shapes
parameters: {d: 0.1}
bodies:
  B: {shape: {box: {size: [0.1, 0.2, 0.3]}}, density: 1000, position: [0, 0, 0]}
  S: {shape: {sphere: {diameter: 0.2}}, density: 1000, position: [1, 0, 0]}
  C: {shape: {cylinder: {diameter: d, length: 0.5, axis: y}}, density: 1000, position: [2, 0, 0]}
  M: {mass: 2.0, inertia: [0.3, 0.4, 0.5], position: [3, 0, 0]}
joints:
  hold: {parent: ground, child: B, translation: {K: 1000, R: 1}}
)");
  std::map<std::string, nlohmann::json> shape;
  const nlohmann::json scene = SceneData(m);
  for (const auto& b : scene["bodies"]) shape[b["name"]] = b["shape"];
  EXPECT_EQ(shape["B"]["type"], "box");
  EXPECT_NEAR(shape["B"]["size"][0].get<double>(), 0.1, 1e-12);
  EXPECT_NEAR(shape["B"]["size"][1].get<double>(), 0.2, 1e-12);
  EXPECT_NEAR(shape["B"]["size"][2].get<double>(), 0.3, 1e-12);
  EXPECT_EQ(shape["S"]["type"], "sphere");
  EXPECT_NEAR(shape["S"]["diameter"].get<double>(), 0.2, 1e-12);
  EXPECT_EQ(shape["C"]["type"], "cylinder");  // a parameter's value: read from the mass properties
  EXPECT_EQ(shape["C"]["axis"], 1);
  EXPECT_NEAR(shape["C"]["diameter"].get<double>(), 0.1, 1e-12);
  EXPECT_NEAR(shape["C"]["length"].get<double>(), 0.5, 1e-12);
  // M: a^2 = 6 (Iyy + Izz - Ixx) / m = 1.8, b^2 = 1.2, c^2 = 0.6.
  EXPECT_EQ(shape["M"]["type"], "inertia");
  EXPECT_NEAR(shape["M"]["size"][0].get<double>(), std::sqrt(1.8), 1e-12);
  EXPECT_NEAR(shape["M"]["size"][1].get<double>(), std::sqrt(1.2), 1e-12);
  EXPECT_NEAR(shape["M"]["size"][2].get<double>(), std::sqrt(0.6), 1e-12);
}

TEST(PlotWebTest, GraphDrawingKeepsOnlyCheckedOperations) {
  const LoadedModel m = LoadModelFile(std::string(MULTIBOND_SOURCE_DIR) + "/examples/mass_spring_damper.yaml");
  const std::string long_text(500, 'x');
  const nlohmann::json layout = {
      {"bb", "0,0,200,100"},
      {"objects",
       {{{"name", "cluster_x"}, {"_draw_", {{{"op", "p"}, {"points", {{0, 0}, {10, 0}, {10, 10}}}}}}},
        {{"name", "e1"},
         {"pos", "50,40"},
         {"width", "0.5"},
         {"height", "0.25"},
         {"_ldraw_",
          {{{"op", "c"}, {"color", "url(javascript:alert(1))"}},
           {{"op", "c"}, {"color", "#ff0000"}},
           {{"op", "T"}, {"pt", {1, 2}}, {"align", "evil"}, {"text", long_text}},
           {{"op", "I"}, {"rect", {0, 0, 1, 1}}, {"name", "/etc/passwd"}},
           {{"op", "b"}, {"points", {{0, 0}, {"a", 1}}}},
           {{"op", "e"}, {"rect", {1, 2, 3, 4}}}}}},
        {{"name", "e99"}, {"pos", "1,1"}},
        {{"name", "e2"}, {"pos", "nan,1"}}}},
      {"edges", {{{"_draw_", {{{"op", "L"}, {"points", {{1, 1}, {2, 2}}}}, {{"op", "S"}, {"style", "bold;x"}}}}}}}};
  const nlohmann::json g = GraphDrawing(layout, m.graph);
  EXPECT_EQ(g["bb"], (nlohmann::json{200.0, 100.0}));
  ASSERT_EQ(g["nodes"].size(), 1u);  // e99 is no element, e2 has no position
  const nlohmann::json& n = g["nodes"][0];
  EXPECT_EQ(n["element"], m.graph.element(1).name);
  EXPECT_EQ(n["box"], (nlohmann::json{50.0, 40.0, 36.0, 18.0}));
  const nlohmann::json& ops = n["draw"];
  ASSERT_EQ(ops.size(), 4u) << ops.dump();  // the image and the bad curve are dropped
  EXPECT_EQ(ops[0]["color"], "#000000");
  EXPECT_EQ(ops[1]["color"], "#ff0000");
  EXPECT_EQ(ops[2]["align"], "c");
  EXPECT_EQ(ops[2]["text"].get<std::string>().size(), 200u);
  EXPECT_EQ(ops[3]["op"], "e");
  ASSERT_EQ(g["clusters"].size(), 1u);
  ASSERT_EQ(g["edges"].size(), 1u);
  EXPECT_EQ(g["edges"][0]["draw"][1]["style"], "solid");

  EXPECT_THROW(GraphDrawing(nlohmann::json{{"bb", "0,0,-1,5"}}, m.graph), std::runtime_error);
  EXPECT_THROW(GraphDrawing(nlohmann::json::array(), m.graph), std::runtime_error);
}

TEST(PlotWebTest, PreparePageLaysOutTheGraphAndCopiesTheFilesWithoutFollowingLinks) {
  const multibond::testing::TempDir d("multibond-plot-web");
  const fs::path dir = d.path() / "results", assets = d.path() / "assets";
  fs::create_directories(dir);
  fs::create_directories(assets);
  std::ofstream(assets / kPageScript) << "/* script */";
  std::ofstream(assets / kPageStyle) << "/* style */";
  std::ofstream(d.path() / "victim") << "precious";
  fs::create_symlink(d.path() / "victim", dir / kPageScript);
  const PlotTable t = TableOf(dir, "time [s],spring.q [m]\n0,0\n1,1\n");
  const ResultsFolder folder(dir.string());
  const PageApp app = PreparePage(folder, t, {}, PlotModel::Read(std::string(MULTIBOND_SOURCE_DIR) + "/examples/mass_spring_damper.yaml", {}), "",
                                    assets.string());
  EXPECT_TRUE(app.assets);
  EXPECT_EQ(ReadFile(d.path() / "victim"), "precious");
  EXPECT_TRUE(fs::is_regular_file(fs::symlink_status(dir / kPageScript)));
  EXPECT_EQ(ReadFile(dir / kPageScript), "/* script */");
  EXPECT_EQ(ReadFile(dir / kPageStyle), "/* style */");
  const nlohmann::json data = nlohmann::json::parse(app.data_json);
  std::set<std::string> elements;
  for (const auto& n : data["graph"]["nodes"]) elements.insert(n["element"]);
  EXPECT_EQ(elements, (std::set<std::string>{"force", "mass", "spring", "damper", "j"}));
  EXPECT_TRUE(data["scene"].is_null());
  for (const auto& e : fs::directory_iterator(dir)) EXPECT_NE(e.path().filename().string().rfind(".multibond-plot-", 0), 0u) << e.path();

  // No assets: the page says so, and has no script.
  const PageApp bare = PreparePage(folder, t, {}, PlotModel{}, "", "");
  EXPECT_FALSE(bare.assets);
  ASSERT_FALSE(bare.notes.empty());
  const std::string html = ResultsPageHtml(t, nlohmann::json::object(), FigureList{}, {}, -1, {}, &bare);
  EXPECT_EQ(html.find("<script"), std::string::npos);
  EXPECT_THAT(html, HasSubstr("not installed"));
  const std::string with = ResultsPageHtml(t, nlohmann::json::object(), FigureList{}, {}, -1, {}, &app);
  EXPECT_THAT(with, HasSubstr("<script type=\"application/json\" id=\"mb-data\">" + app.data_json + "</script>"));
  EXPECT_THAT(with, HasSubstr("<script src=\"multibond-page.js\"></script>"));
  EXPECT_THAT(with, HasSubstr("<link rel=\"stylesheet\" href=\"multibond-page.css\">"));
}

TEST(PlotWebTest, ARunTooLargeForThePageKeepsTheGalleryWithANote) {
  const multibond::testing::TempDir d("multibond-plot-web");
  const PlotTable t = TableOf(d.path(), "time [s],x [m]\n0,1\n1,2\n2,3\n");  // 6 values
  const PageApp at = PreparePage(ResultsFolder(d.path().string()), t, {}, PlotModel{}, "", "", 6);
  EXPECT_FALSE(at.data_json.empty());
  const PageApp over = PreparePage(ResultsFolder(d.path().string()), t, {}, PlotModel{}, "", "", 5);
  EXPECT_TRUE(over.data_json.empty());
  ASSERT_EQ(over.notes.size(), 1u);
  EXPECT_THAT(over.notes[0], HasSubstr("3 rows of 2 columns, more than the page holds (5 values)"));
  const std::string html = ResultsPageHtml(t, nlohmann::json::object(), FigureList{}, {}, -1, {}, &over);
  EXPECT_EQ(html.find("<script"), std::string::npos);
}

}  // namespace
}  // namespace multibond
