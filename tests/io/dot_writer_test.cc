// MakeDot and RenderWithGraphviz: bonds as half-arrows with causal strokes, clusters, derivative
// causality in red, escaping, and that Graphviz accepts what we write.
#include "support/temp_dir.h"
#include "multibond/io/dot_writer.h"

#include <gtest/gtest.h>

#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include <fmt/format.h>

namespace multibond {
namespace {

namespace fs = std::filesystem;

SourceValue Value(double v) { return SourceValue{{TimeFunction::Constant(v)}}; }

BondGraph MassSpringDamper() {
  BondGraph g("msd");
  g.AddSe("force", Value(1.0));
  g.AddJunction("j", ElementKind::kOne);
  g.AddI("mass", Param::Scalar(2.0));
  g.AddC("spring", Param::Scalar(100.0));
  g.AddR("damper", Param::Scalar(0.5));
  g.Connect("force", "j");
  g.Connect("j", "mass");
  g.Connect("j", "spring");
  g.Connect("j", "damper");
  return g;
}

/// Drive -> 1 j1 (I J1) -> TF gear (ratio 2) -> 1 j2 (I J2): J2 is rigidly tied to J1, so it
/// ends in derivative causality.
BondGraph RigidGear() {
  BondGraph g("rigid gear");
  g.AddSe("drive", Value(1.0));
  g.AddJunction("j1", ElementKind::kOne);
  g.AddI("J1", Param::Scalar(0.1));
  g.AddTF("gear", Param::Scalar(2.0));
  g.AddJunction("j2", ElementKind::kOne);
  g.AddI("J2", Param::Scalar(0.4));
  g.Connect("drive", "j1");
  g.Connect("j1", "J1");
  g.Connect("j1", "gear");
  g.Connect("gear", "j2");
  g.Connect("j2", "J2");
  return g;
}

struct Analysed {
  Structure structure;
  CausalAssignment causality;
};

Analysed Analyse(const BondGraph& g) {
  DiagnosticSink sink;
  Analysed a;
  a.structure = AnalyzeStructure(g, "", sink);
  EXPECT_FALSE(sink.has_errors());
  a.causality = AssignCausality(g, a.structure);
  return a;
}

/// The edge statements ("e0 -> e1 [...]"), in order.
std::vector<std::string> Edges(const std::string& dot) {
  std::vector<std::string> out;
  static const std::regex edge(R"(^\s*e\d+ -> e\d+ \[.*\];$)");
  std::istringstream in(dot);
  for (std::string line; std::getline(in, line);)
    if (std::regex_match(line, edge)) out.push_back(line);
  return out;
}

/// The statement of element `index`'s node.
std::string NodeLine(const std::string& dot, int index) {
  std::istringstream in(dot);
  const std::string head = fmt::format("e{} [", index);
  for (std::string line; std::getline(in, line);) {
    const auto at = line.find_first_not_of(' ');
    if (at != std::string::npos && line.compare(at, head.size(), head) == 0) return line;
  }
  return "";
}

/// Shared helpers (tests/support/temp_dir.h); the folder keeps this file's prefix.
struct TempDir : multibond::testing::TempDir {
  TempDir() : multibond::testing::TempDir("multibond-dot-test") {}
};
using multibond::testing::ReadFile;

/// Writes `dot` and renders it to SVG; returns the SVG text ("" on failure, with a test failure).
std::string RenderSvg(const std::string& dot, const TempDir& dir, const std::string& stem = "graph") {
  const fs::path dot_path = dir.path() / (stem + ".dot"), svg_path = dir.path() / (stem + ".svg");
  std::ofstream(dot_path) << dot;
  std::string error;
  EXPECT_TRUE(RenderWithGraphviz(dot_path.string(), svg_path.string(), "svg", &error)) << error << "\n" << dot;
  if (!fs::exists(svg_path)) return "";
  return ReadFile(svg_path);
}

TEST(DotWriterTest, OneEdgePerBondWithStrokes) {
  const BondGraph g = MassSpringDamper();
  const Analysed a = Analyse(g);
  const std::string dot = MakeDot(g, &a.structure, &a.causality);
  EXPECT_EQ(dot.rfind("digraph \"msd\" {", 0), 0u) << dot;
  const std::vector<std::string> edges = Edges(dot);
  ASSERT_EQ(static_cast<int>(edges.size()), g.num_bonds()) << dot;
  for (int b = 0; b < g.num_bonds(); ++b) {
    const std::string& e = edges[b];
    EXPECT_EQ(e.find(fmt::format("e{} -> e{} ", g.bond(b).from, g.bond(b).to)), e.find_first_not_of(' ')) << e;
    EXPECT_NE(e.find("tee"), std::string::npos) << e;
    EXPECT_NE(e.find("lvee"), std::string::npos) << e;
    // The stroke at the head is drawn with the half-arrow, at the tail on its own.
    if (a.causality.stroke_at_head[b]) {
      EXPECT_NE(e.find("arrowhead=teelvee"), std::string::npos) << e;
      EXPECT_EQ(e.find("arrowtail"), std::string::npos) << e;
    } else {
      EXPECT_NE(e.find("dir=both"), std::string::npos) << e;
      EXPECT_NE(e.find("arrowtail=tee"), std::string::npos) << e;
    }
    // Default bond names are not labels, and scalar bonds have no dimension label.
    EXPECT_EQ(e.find("label="), std::string::npos) << e;
  }
  // Source -> junction: the source imposes the effort (stroke at the junction, the head).
  EXPECT_NE(edges[0].find("arrowhead=teelvee"), std::string::npos);
  // The C imposes its effort on the junction: the stroke is at the tail (j).
  EXPECT_NE(edges[2].find("arrowtail=tee"), std::string::npos);
  // Plain-text nodes, labelled by kind and name; junctions with the name in small type.
  EXPECT_NE(dot.find("shape=plaintext"), std::string::npos);
  EXPECT_NE(NodeLine(dot, 2).find("label=\"I: mass\""), std::string::npos) << dot;
  EXPECT_NE(NodeLine(dot, 1).find("label=<1<BR/><FONT POINT-SIZE=\"8\">j</FONT>>"), std::string::npos) << dot;
  EXPECT_EQ(dot.find("red"), std::string::npos);
  EXPECT_EQ(dot.find("cluster"), std::string::npos);
}

TEST(DotWriterTest, WithoutCausalityOrStructure) {
  const BondGraph g = MassSpringDamper();
  const std::string dot = MakeDot(g, nullptr, nullptr);
  const std::vector<std::string> edges = Edges(dot);
  ASSERT_EQ(static_cast<int>(edges.size()), g.num_bonds()) << dot;
  EXPECT_EQ(dot.find("tee"), std::string::npos) << dot;
  for (const std::string& e : edges) EXPECT_NE(e.find("arrowhead=lvee"), std::string::npos) << e;
}

TEST(DotWriterTest, DerivativeCausalityIsRed) {
  const BondGraph g = RigidGear();
  const Analysed a = Analyse(g);
  ASSERT_EQ(a.causality.derivative, std::vector<int>{g.Find("J2")});
  const std::string dot = MakeDot(g, &a.structure, &a.causality);
  const std::string j2 = NodeLine(dot, g.Find("J2"));
  EXPECT_NE(j2.find("color=red"), std::string::npos) << dot;
  EXPECT_NE(j2.find("tooltip=\"derivative causality at I 'J2'"), std::string::npos) << j2;
  EXPECT_EQ(NodeLine(dot, g.Find("J1")).find("red"), std::string::npos) << dot;
  const std::vector<std::string> edges = Edges(dot);
  ASSERT_EQ(static_cast<int>(edges.size()), g.num_bonds());
  for (const std::string& e : edges) EXPECT_NE(e.find("tee"), std::string::npos) << e;

  TempDir dir;
  const std::string svg = RenderSvg(dot, dir);
  EXPECT_NE(svg.find("<svg"), std::string::npos) << svg.substr(0, 200);
  EXPECT_NE(svg.find("I: J2"), std::string::npos);
}

TEST(DotWriterTest, ClustersByDottedPrefix) {
  BondGraph g("two bodies");
  g.AddSe("drive", Value(1.0));
  g.AddJunction("A.w", ElementKind::kOne);
  g.AddI("A.J", Param::Scalar(1.0));
  g.AddJunction("B.w", ElementKind::kOne);
  g.AddI("B.J", Param::Scalar(1.0));
  g.AddC("B.arm.k", Param::Scalar(1.0));
  g.AddR("B.arm.c", Param::Scalar(1.0));
  g.AddJunction("link", ElementKind::kZero);
  g.AddC("solo.k", Param::Scalar(1.0));  // a prefix of its own: no cluster
  g.Connect("drive", "A.w");
  g.Connect("A.w", "A.J");
  g.Connect("A.w", "link");
  g.Connect("link", "B.w");
  g.Connect("link", "solo.k");
  g.Connect("B.w", "B.J");
  g.Connect("B.w", "B.arm.k");
  g.Connect("B.w", "B.arm.c");
  const Analysed a = Analyse(g);
  const std::string dot = MakeDot(g, &a.structure, &a.causality);
  EXPECT_NE(dot.find("subgraph cluster_A {"), std::string::npos) << dot;
  EXPECT_NE(dot.find("subgraph cluster_B {"), std::string::npos) << dot;
  EXPECT_NE(dot.find("subgraph \"cluster_B.arm\" {"), std::string::npos) << dot;
  EXPECT_EQ(dot.find("cluster_solo"), std::string::npos) << dot;
  // A.J is inside cluster A; B.arm is nested in B.
  const size_t a_open = dot.find("subgraph cluster_A {"), b_open = dot.find("subgraph cluster_B {");
  const size_t arm_open = dot.find("subgraph \"cluster_B.arm\" {");
  EXPECT_LT(a_open, dot.find("label=\"I: A.J\""));
  EXPECT_LT(b_open, arm_open);
  EXPECT_LT(arm_open, dot.find("label=\"C: B.arm.k\""));
  EXPECT_EQ(static_cast<int>(Edges(dot).size()), g.num_bonds());

  DotOptions flat;
  flat.group_by_prefix = false;
  EXPECT_EQ(MakeDot(g, &a.structure, &a.causality, flat).find("cluster"), std::string::npos);

  TempDir dir;
  EXPECT_NE(RenderSvg(dot, dir).find("<svg"), std::string::npos);
}

TEST(DotWriterTest, NestsClustersOnRequest) {
  BondGraph g("joint between links");
  g.AddSe("drive", Value(1.0));
  g.AddJunction("A.w", ElementKind::kOne);
  g.AddI("A.J", Param::Scalar(1.0));
  g.AddJunction("B.w", ElementKind::kOne);
  g.AddI("B.J", Param::Scalar(1.0));
  g.AddJunction("AB.rel", ElementKind::kZero);
  g.AddC("AB.k", Param::Scalar(1.0));
  g.Connect("drive", "A.w");
  g.Connect("A.w", "A.J");
  g.Connect("A.w", "AB.rel", 0, "AB.in");
  g.Connect("AB.rel", "B.w");
  g.Connect("AB.rel", "AB.k");
  g.Connect("B.w", "B.J");
  const Analysed a = Analyse(g);
  DotOptions o;
  o.nest = {{"AB", "B"}, {"B", "AB"}, {"nothing", "A"}, {"A", "A"}};  // the cycle and the unknowns are ignored
  const std::string dot = MakeDot(g, &a.structure, &a.causality, o);
  const size_t b_open = dot.find("subgraph cluster_B {"), ab_open = dot.find("subgraph cluster_AB {");
  ASSERT_NE(b_open, std::string::npos) << dot;
  ASSERT_NE(ab_open, std::string::npos) << dot;
  EXPECT_LT(b_open, ab_open) << dot;  // AB inside B
  EXPECT_EQ(dot.find("cluster_nothing"), std::string::npos);
  EXPECT_NE(dot.find("subgraph cluster_A {"), std::string::npos);
  // B closes after AB: AB's nodes are indented one level deeper than B's.
  EXPECT_NE(dot.find("\n      e6 [label=\"C: AB.k\""), std::string::npos) << dot;
  EXPECT_NE(dot.find("label=\"AB.in\""), std::string::npos) << dot;
  EXPECT_EQ(static_cast<int>(Edges(dot).size()), g.num_bonds());

  o.bond_names = false;  // names go, the tooltip keeps them
  const std::string plain = MakeDot(g, &a.structure, &a.causality, o);
  EXPECT_EQ(plain.find("label=\"AB.in\""), std::string::npos) << plain;
  EXPECT_NE(plain.find("tooltip=\"bond 'AB.in'"), std::string::npos) << plain;

  TempDir dir;
  EXPECT_NE(RenderSvg(dot, dir).find("<svg"), std::string::npos);
}

TEST(DotWriterTest, LabelsShowDimensionAndGivenNames) {
  BondGraph g("spatial");
  g.AddSe("torque", Value(1.0), 3);
  g.AddJunction("w", ElementKind::kOne, 3);
  g.AddI("J", Param::Scalar(1.0), 3);
  g.AddR("b", Param::Scalar(0.1), 3);
  g.Connect("torque", "w");
  g.Connect("w", "J", 0, "spin");
  g.Connect("b", "w");
  const Analysed a = Analyse(g);
  const std::vector<std::string> edges = Edges(MakeDot(g, &a.structure, &a.causality));
  ASSERT_EQ(edges.size(), 3u);
  EXPECT_NE(edges[0].find("label=\"3\""), std::string::npos) << edges[0];
  EXPECT_NE(edges[1].find("label=\"spin\\n3\""), std::string::npos) << edges[1];
  EXPECT_EQ(edges[2].find("b->w\\n"), std::string::npos) << edges[2];
  // Dimensions are unknown without the structure.
  const std::vector<std::string> bare = Edges(MakeDot(g, nullptr, nullptr));
  EXPECT_EQ(bare[0].find("label="), std::string::npos) << bare[0];
  EXPECT_NE(bare[1].find("label=\"spin\""), std::string::npos) << bare[1];
}

TEST(DotWriterTest, EscapesNames) {
  BondGraph g("say \"hi\"");
  g.AddSe("src \"1\"", Value(1.0));
  g.AddJunction("a<b>&c", ElementKind::kOne);
  g.AddI("back\\slash", Param::Scalar(1.0));
  g.Connect("src \"1\"", "a<b>&c", 0, "the \"bond\"");
  g.Connect("a<b>&c", "back\\slash");
  const Analysed a = Analyse(g);
  const std::string dot = MakeDot(g, &a.structure, &a.causality);
  EXPECT_NE(dot.find("digraph \"say \\\"hi\\\"\""), std::string::npos) << dot;
  EXPECT_NE(dot.find("label=\"Se: src \\\"1\\\"\""), std::string::npos) << dot;
  EXPECT_NE(dot.find("label=\"I: back\\\\slash\""), std::string::npos) << dot;
  EXPECT_NE(dot.find("a&lt;b&gt;&amp;c"), std::string::npos) << dot;
  EXPECT_NE(dot.find("label=\"the \\\"bond\\\"\""), std::string::npos) << dot;
  TempDir dir;
  const std::string svg = RenderSvg(dot, dir);
  EXPECT_NE(svg.find("<svg"), std::string::npos);
  EXPECT_NE(svg.find("back\\slash"), std::string::npos);
}

TEST(DotWriterTest, HostileNamesStayInsideTheirStrings) {
  // Names as a hand-made graph (or a loader that lets them through) may hold them: control
  // characters, bytes that are not UTF-8, quotes and brackets that would end a string or a node
  // statement and add attributes (image= makes dot read a file), HTML that would end a label.
  const std::vector<std::string> names = {
      "ctl\x01\x1b[2J\x7f",
      "bad\xff\xfe\xc3",
      "q\"]; e9 [image=\"/etc/passwd\"]; x [label=\"",
      "j<b>&amp;</b></FONT>]>, image=\"/etc/passwd\" x=<",
      "back\\\"slash\\",
      "line\nbreak\r",
  };
  BondGraph g(names[2]);
  g.AddSe(names[0], Value(1.0));
  g.AddJunction(names[3], ElementKind::kOne);
  g.AddI(names[1], Param::Scalar(1.0));
  g.AddC(names[4], Param::Scalar(1.0));
  g.AddR(names[5], Param::Scalar(1.0));
  g.AddI("grp." + names[2], Param::Scalar(1.0));
  g.AddI("grp." + names[0], Param::Scalar(1.0));
  g.Connect(names[0], names[3], 0, names[2]);
  for (int e = 2; e <= 6; ++e) g.Connect(names[3], g.element(e).name, 0, names[e % names.size()]);
  const Analysed a = Analyse(g);
  const std::string dot = MakeDot(g, &a.structure, &a.causality);

  // Valid UTF-8, no control character but the line breaks between statements.
  for (size_t i = 0; i < dot.size(); ++i) {
    const unsigned char c = static_cast<unsigned char>(dot[i]);
    ASSERT_FALSE((c < 0x20 && c != '\n') || c == 0x7f) << "control character " << int(c) << " at " << i << "\n" << dot;
    if (c >= 0x80) {
      const int n = (c & 0xe0) == 0xc0 ? 1 : (c & 0xf0) == 0xe0 ? 2 : (c & 0xf8) == 0xf0 ? 3 : -1;
      ASSERT_GT(n, 0) << "not UTF-8 at " << i << "\n" << dot;
      for (int k = 1; k <= n; ++k)
        ASSERT_EQ(static_cast<unsigned char>(dot[i + k]) & 0xc0, 0x80) << "not UTF-8 at " << i << "\n" << dot;
      i += n;
    }
  }
  // One statement per element and per bond, each with the attributes we write and no other.
  std::istringstream in(dot);
  int nodes = 0, edges = 0;
  static const std::regex quoted(R"re("(\\.|[^"\\])*")re");
  static const std::regex html(R"re(<[^<>]*<BR/><FONT POINT-SIZE="8">[^<>]*</FONT>>)re");
  for (std::string line; std::getline(in, line);) {
    const std::string bare = std::regex_replace(std::regex_replace(line, html, "H"), quoted, "Q");
    EXPECT_EQ(bare.find("image"), std::string::npos) << line;
    if (std::regex_match(bare, std::regex(R"(\s*e\d+ \[label=[QH], (fontcolor=red, color=red, )?tooltip=Q\];)"))) ++nodes;
    if (std::regex_match(bare, std::regex(R"(\s*e\d+ -> e\d+ \[[a-z=, ]*(, label=Q)?, tooltip=Q\];)"))) ++edges;
  }
  EXPECT_EQ(nodes, g.num_elements()) << dot;
  EXPECT_EQ(edges, g.num_bonds()) << dot;
  TempDir dir;
  const std::string svg = RenderSvg(dot, dir);
  EXPECT_NE(svg.find("</svg>"), std::string::npos);
  EXPECT_EQ(svg.find('\x01'), std::string::npos);
  EXPECT_EQ(svg.find("/etc/passwd\"/>"), std::string::npos);
}

TEST(DotWriterTest, Deterministic) {
  const BondGraph g = RigidGear();
  const Analysed a = Analyse(g);
  const Analysed b = Analyse(g);
  EXPECT_EQ(MakeDot(g, &a.structure, &a.causality), MakeDot(g, &b.structure, &b.causality));
}

TEST(DotWriterTest, RenderSvgAndPng) {
  const BondGraph g = MassSpringDamper();
  const Analysed a = Analyse(g);
  TempDir dir;
  // A path with a space and a quote goes through untouched (no shell).
  const fs::path dot_path = dir.path() / "my \"model\".dot";
  std::ofstream(dot_path) << MakeDot(g, &a.structure, &a.causality);
  const fs::path svg = dir.path() / "out file.svg", png = dir.path() / "out.png";
  std::string error;
  ASSERT_TRUE(RenderWithGraphviz(dot_path.string(), svg.string(), "svg", &error)) << error;
  const std::string text = ReadFile(svg);
  EXPECT_TRUE(text.rfind("<?xml", 0) == 0 || text.find("<svg") != std::string::npos) << text.substr(0, 200);
  ASSERT_TRUE(RenderWithGraphviz(dot_path.string(), png.string(), "png", &error)) << error;
  EXPECT_EQ(ReadFile(png).substr(1, 3), "PNG");
}

TEST(DotWriterTest, RenderReportsFailures) {
  TempDir dir;
  std::string error;
  EXPECT_FALSE(RenderWithGraphviz((dir.path() / "missing.dot").string(), (dir.path() / "x.svg").string(), "svg", &error));
  EXPECT_NE(error.find("failed"), std::string::npos) << error;

  const fs::path bad = dir.path() / "bad.dot";
  std::ofstream(bad) << "digraph { this is not dot ";
  error.clear();
  EXPECT_FALSE(RenderWithGraphviz(bad.string(), (dir.path() / "bad.svg").string(), "svg", &error));
  EXPECT_NE(error.find("syntax error"), std::string::npos) << error;

  error.clear();
  EXPECT_FALSE(RenderWithGraphviz(bad.string(), (dir.path() / "x.svg").string(), "svg; rm -rf /", &error));
  EXPECT_NE(error.find("invalid Graphviz output format"), std::string::npos) << error;

  // No `dot` on the PATH.
  const char* old = std::getenv("PATH");
  const std::string saved = old ? old : "";
  setenv("PATH", dir.path().c_str(), 1);
  error.clear();
  const bool ok = RenderWithGraphviz(bad.string(), (dir.path() / "x.svg").string(), "svg", &error);
  setenv("PATH", saved.c_str(), 1);
  EXPECT_FALSE(ok);
  EXPECT_NE(error.find("Graphviz is not installed"), std::string::npos) << error;
}

}  // namespace
}  // namespace multibond
