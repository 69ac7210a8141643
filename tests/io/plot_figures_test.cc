// ParseFigureList / ReadFigureList: the figure list format of docs/plots.md, and its errors, each
// located with a hint (did you mean?), as for a model file.
#include "multibond/io/plot_figures.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <string>

#include "multibond/core/error.h"

namespace multibond {
namespace {

using ::testing::HasSubstr;

/// Every diagnostic of the ModelError that parsing `text` throws, one a line ("" if none).
std::string Errors(const std::string& text, const InputLimits& limits = {}) {
  try {
    ParseFigureList(text, "list.yaml", limits);
  } catch (const ModelError& e) {
    std::string out;
    for (const Diagnostic& d : e.diagnostics()) out += d.ToString() + " [" + d.code + "]\n";
    return out;
  }
  return "";
}

TEST(PlotFiguresTest, ReadsTheFormat) {
  const FigureList list = ParseFigureList(R"(title: My run
intro: the x_{1} story
sections:
  - title: Masses
    figures:
      - name: mass-position
        label: Fig. 1
        caption: Position of the mass
        shows: "ends at {{last mass.q}}"
        panels:
          - {title: "(a) q", quantity: position, curves: [{column: mass.q, title: q, color: "#123456", from_start: true, scale: 1000}], zoom: true}
          - {kind: path, title: path, curves: [{vector: body.r, title: C}]}
          - {kind: orientation, title: R, body: body}
figures:
  - name: loose
    panels: [{curves: [{vector: body.F, title: F}]}]
checks:
  - {quantity: "|F|", norm: body.F, value: 1.5, tolerance: 0.01, unit: N}
)");
  EXPECT_EQ(list.title, "My run");
  ASSERT_EQ(list.sections.size(), 1u);
  ASSERT_EQ(list.figures.size(), 2u);
  EXPECT_EQ(FigureNames(list), (std::vector<std::string>{"loose", "mass-position"}));
  const Figure& f = list.figures[1];
  EXPECT_EQ(f.Title(), "Fig. 1. Position of the mass");
  EXPECT_EQ(f.section, 0);
  EXPECT_EQ(list.figures[0].section, -1);
  ASSERT_EQ(f.panels.size(), 3u);
  EXPECT_EQ(f.panels[0].id, "a");
  EXPECT_TRUE(f.panels[0].zoom);
  EXPECT_EQ(f.panels[0].curves[0].color, "#123456");
  EXPECT_TRUE(f.panels[0].curves[0].from_start);
  EXPECT_EQ(f.panels[0].curves[0].scale, 1000);
  EXPECT_EQ(f.panels[1].kind, PanelKind::kPath);
  EXPECT_EQ(f.panels[1].curves[0].columns, (std::vector<std::string>{"body.r.x", "body.r.y", "body.r.z"}));
  EXPECT_EQ(f.panels[2].kind, PanelKind::kOrientation);
  ASSERT_EQ(f.panels[2].curves.size(), 3u);
  EXPECT_EQ(f.panels[2].curves[1].columns, (std::vector<std::string>{"body.R.12", "body.R.22", "body.R.32"}));
  // A vector in a time panel: three curves, legends F_{x} ...
  const Panel& loose = list.figures[0].panels[0];
  ASSERT_EQ(loose.curves.size(), 3u);
  EXPECT_EQ(loose.curves[2].columns[0], "body.F.z");
  EXPECT_EQ(loose.curves[2].title, "F_{z}");
  ASSERT_EQ(list.checks.size(), 1u);
  EXPECT_TRUE(list.checks[0].norm);
  EXPECT_EQ(list.checks[0].value, 1.5);
}

TEST(PlotFiguresTest, UnknownKeysAreLocatedWithDidYouMean) {
  const std::string e = Errors("figures:\n  - name: a\n    captoin: x\n    panels: [{curves: [{colum: q}]}]\n");
  EXPECT_THAT(e, HasSubstr("list.yaml:3:5"));
  EXPECT_THAT(e, HasSubstr("unknown key 'captoin'"));
  EXPECT_THAT(e, HasSubstr("did you mean 'caption'?"));
  EXPECT_THAT(e, HasSubstr("unknown key 'colum'"));
  EXPECT_THAT(e, HasSubstr("did you mean 'column'?"));
  EXPECT_THAT(Errors("figures:\n  - name: a\n    panels: [{kind: tme, curves: [{column: q}]}]\n"), HasSubstr("did you mean 'time'?"));
  EXPECT_THAT(Errors("figurs: []\n"), HasSubstr("did you mean 'figures'?"));
}

TEST(PlotFiguresTest, NamesColoursAndShapesAreChecked) {
  EXPECT_THAT(Errors("figures:\n  - name: ../../etc/x\n    panels: [{curves: [{column: q}]}]\n"), HasSubstr("is not a figure name"));
  EXPECT_THAT(Errors("figures:\n  - name: a\n    panels: [{curves: [{column: q}]}]\n  - name: a\n    panels: [{curves: [{column: q}]}]\n"),
              HasSubstr("a second figure named 'a'"));
  EXPECT_THAT(Errors("figures:\n  - name: a\n    panels: [{curves: [{column: q, color: 'red\" lw 9'}]}]\n"), HasSubstr("is not a colour"));
  EXPECT_THAT(Errors("figures:\n  - name: a\n    panels: [{kind: path, curves: [{columns: [x, y]}]}]\n"), HasSubstr("three columns"));
  EXPECT_THAT(Errors("figures:\n  - name: a\n    panels: [{curves: [{column: q, vector: v}]}]\n"), HasSubstr("exactly one of"));
  EXPECT_THAT(Errors("figures:\n  - name: a\n    panels: [{kind: orientation}]\n"), HasSubstr("needs 'body'"));
  EXPECT_THAT(Errors("figures:\n  - name: a\n"), HasSubstr("needs 'panels'"));
  EXPECT_THAT(Errors("figures:\n  - name: a\n    caption: c\n    caption: d\n    panels: [{curves: [{column: q}]}]\n"),
              HasSubstr("duplicate key 'caption'"));
  EXPECT_THAT(Errors("figures:\n  - name: a\n    panels: [{curves: [{column: q, scale: x}]}]\n"), HasSubstr("expected a finite number"));
  EXPECT_THAT(Errors("checks: [{column: q}]\nfigures: []\n"), HasSubstr("needs 'value'"));
  EXPECT_THAT(Errors("- a\n- b\n"), HasSubstr("must be a YAML mapping"));
  EXPECT_THAT(Errors("title: x\n"), HasSubstr("neither 'figures' nor 'sections'"));
}

TEST(PlotFiguresTest, BoundedLikeAModelFile) {
  EXPECT_THAT(Errors("figures: [\n"), HasSubstr("[yaml.syntax]"));
  EXPECT_THAT(Errors("title: \"\xff\"\nfigures: []\n"), HasSubstr("[text.encoding]"));
  InputLimits few;
  few.yaml_nodes = 10000;
  EXPECT_THAT(Errors("a: &a [x, x, x, x, x, x, x, x, x, x]\nb: &b [*a, *a, *a, *a, *a, *a, *a, *a, *a, *a]\n"
                     "c: &c [*b, *b, *b, *b, *b, *b, *b, *b, *b, *b]\nd: &d [*c, *c, *c, *c, *c, *c, *c, *c, *c, *c]\n"
                     "e: [*d, *d, *d, *d, *d, *d, *d, *d, *d, *d]\n",
                     few),
              HasSubstr("[limit.yaml-nodes]"));
  InputLimits small;
  small.file_bytes = 10;
  EXPECT_THAT(Errors("figures: []  # a comment\n", small), HasSubstr("[limit.file-size]"));
  EXPECT_THAT(Errors("figures: []\n---\nfigures: []\n"), HasSubstr("2 YAML documents"));
}

// Every diagnostic of the parse, to the letter (location, message, hint, code), for each way the
// YAML pass can refuse a list, and for the first of two problems: the list is read in one pass
// that bounds its events as it builds the tree, and says what the separate check said.
TEST(PlotFiguresTest, TheYamlPassSaysWhatItSaid) {
  InputLimits shallow;
  shallow.depth = 3;
  InputLimits few;
  few.yaml_nodes = 20;
  const struct {
    const char* text;
    InputLimits limits;
    const char* errors;
  } cases[] = {
      {"figures: [\n", {},
       "list.yaml:2:1: error: YAML syntax error: end of sequence flow not found\n"
       "  hint: check indentation, colons and brackets near this place [yaml.syntax]\n"},
      {"figures: [[[[1]]]]\n", shallow,
       "list.yaml:1:12: error: limit 'depth' exceeded: YAML lists and mappings nested more than 3 deep\n"
       "  hint: if the input is meant to be this large, raise the limit with --limit depth=N (now 3) [limit.depth]\n"},
      {"a: &x [*x]\nfigures: []\n", {},
       "list.yaml:1:8: error: the alias '*x' stands for the node anchored '&x' (at list.yaml:1:4), which contains this alias: the node would contain itself without end\n"
       "  hint: an alias may only refer to a node that is complete before it [yaml.self_alias]\n"},
      {"a: &a [x, x, x, x, x, x, x, x, x, x]\nb: [*a, *a, *a]\nfigures: [\n", few,
       "list.yaml:2:5: error: limit 'yaml-nodes' exceeded: the file holds more than 20 YAML nodes (each alias counted as the nodes it stands for)\n"
       "  hint: if the input is meant to be this large, raise the limit with --limit yaml-nodes=N (now 20) [limit.yaml-nodes]\n"},
      {"figures: [\na: [[[[1]]]]\n", shallow,
       "list.yaml:2:4: error: limit 'depth' exceeded: YAML lists and mappings nested more than 3 deep\n"
       "  hint: if the input is meant to be this large, raise the limit with --limit depth=N (now 3) [limit.depth]\n"},
      {"figures: []\n---\nfigures: [\n", {},
       "list.yaml:4:1: error: YAML syntax error: end of sequence flow not found\n"
       "  hint: check indentation, colons and brackets near this place [yaml.syntax]\n"},
      {"figures: []\n---\nfigures: []\n", {},
       "list.yaml: error: the file holds 2 YAML documents; a figure list is one\n"
       "  hint: remove the '---' line [plot.list]\n"},
      {"", {},
       "list.yaml: error: a figure list must be a YAML mapping with 'figures' or 'sections'\n"
       "  hint: see docs/plots.md, or examples/differential/figures.yaml [plot.list]\n"},
      // An aliased figure is the same node: its name is given twice.
      {"figures:\n  - &f {name: a, panels: [{curves: [{column: q}]}]}\n  - *f\n", {},
       "list.yaml:2:15: error: a: a second figure named 'a'\n"
       "  hint: give each figure its own name [plot.name]\n"},
  };
  for (const auto& c : cases) EXPECT_EQ(Errors(c.text, c.limits), c.errors) << c.text;
}

TEST(PlotFiguresTest, ReadsAFile) {
  EXPECT_THROW(ReadFigureList("/nonexistent/list.yaml"), ModelError);
  EXPECT_THROW(ReadFigureList("/"), ModelError);
  const FigureList paper = ReadFigureList(std::string(MULTIBOND_SOURCE_DIR) + "/examples/differential/figures.yaml");
  EXPECT_EQ(paper.figures.size(), 32u);
  EXPECT_TRUE(paper.figures.front().bond_graph);
  EXPECT_FALSE(paper.checks.empty());
}

TEST(PlotFiguresTest, FigureNames) {
  EXPECT_TRUE(IsFigureName("fig03-G-orientation"));
  EXPECT_TRUE(IsFigureName("a.b_c"));
  EXPECT_FALSE(IsFigureName(""));
  EXPECT_FALSE(IsFigureName(".hidden"));
  EXPECT_FALSE(IsFigureName("a/b"));
  EXPECT_FALSE(IsFigureName("a b"));
  EXPECT_FALSE(IsFigureName(std::string(101, 'a')));
}

}  // namespace
}  // namespace multibond
