// The model loader: what a good file becomes, and what every kind of bad input is told.

#include <fstream>
#include <iterator>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "multibond/io/model_loader.h"
#include "multibond/sim/simulator.h"

namespace multibond {
namespace {

using ::testing::HasSubstr;

/// Loads `yaml` expecting a ModelError; returns its diagnostics.
std::vector<Diagnostic> Errors(const std::string& yaml) {
  try {
    LoadedModel lm = LoadModelString(yaml, "m.yaml");
    CompiledModel::Compile(lm.graph, lm.compile);
  } catch (const ModelError& e) {
    return e.diagnostics();
  }
  ADD_FAILURE() << "expected a ModelError for:\n" << yaml;
  return {};
}

const char* kMsd = R"(model: msd
domain: translation
elements:
  force:  {type: Se, effort: {step: {value: 1.0, at: 0}}}
  mass:   {type: I, inertia: 1.0}
  spring: {type: C, stiffness: 100.0}
  damper: {type: R, resistance: 2.0}
  j:      {type: "1"}
bonds:
  - force -> j
  - [j, mass]
  - {from: j, to: spring}
  - j -> damper
)";

TEST(ModelLoader, ReadsElementsBondsAndLocations) {
  const LoadedModel lm = LoadModelString(kMsd, "m.yaml");
  const BondGraph& g = lm.graph;
  EXPECT_EQ(g.name(), "msd");
  EXPECT_EQ(g.num_elements(), 5);
  EXPECT_EQ(g.num_bonds(), 4);
  EXPECT_EQ(lm.compile.default_domain, "translation");
  const Element& spring = g.element(g.Find("spring"));
  EXPECT_EQ(spring.kind, ElementKind::kC);
  EXPECT_DOUBLE_EQ(spring.param.scalar, 100.0);
  EXPECT_EQ(spring.where.file, "m.yaml");
  EXPECT_EQ(spring.where.line, 6);
  EXPECT_EQ(spring.where.column, 3);
  EXPECT_EQ(g.bond(1).from, g.Find("j"));
  EXPECT_EQ(g.bond(1).to, g.Find("mass"));
}

TEST(ModelLoader, YamlSyntaxErrorHasLineAndColumnAndNamesBothBrackets) {
  // A '[' closed by '}': yaml-cpp's message, where it stopped, and which bracket was left open.
  const auto ds = Errors("elements:\n  a: {type: I, inertia: [1, 2}\n");
  ASSERT_EQ(ds.size(), 1u);
  EXPECT_THAT(ds[0].message, HasSubstr("YAML syntax error"));
  EXPECT_EQ(ds[0].where.line, 2);
  EXPECT_EQ(ds[0].where.column, 30);
  ASSERT_EQ(ds[0].details.size(), 1u);
  EXPECT_THAT(ds[0].details[0], HasSubstr("the '[' opened at m.yaml:2:25 is closed here by '}'"));
  EXPECT_THAT(ds[0].hint, HasSubstr("']'"));
}

TEST(ModelLoader, UnclosedBracketIsReportedWhereItOpens) {
  // yaml-cpp notices the missing '}' at the next key (3:4); the error points at the '{'.
  const auto ds = Errors("elements:\n  s: {type: Se, effort: 1\n  k: {type: C, stiffness: 1}\nbonds: [s -> k]\n");
  ASSERT_EQ(ds.size(), 1u);
  EXPECT_THAT(ds[0].message, HasSubstr("YAML syntax error"));
  EXPECT_EQ(ds[0].where.line, 2);
  EXPECT_EQ(ds[0].where.column, 6);
  ASSERT_EQ(ds[0].details.size(), 1u);
  EXPECT_THAT(ds[0].details[0], HasSubstr("'{' opened here is not closed"));
  EXPECT_THAT(ds[0].details[0], HasSubstr("m.yaml:3:"));
  // A brace inside plain text opens nothing.
  const auto text = Errors("description: uses {braces\nelements:\n  s: {type: Se, effort: 1\n  k: {type: C, stiffness: 1}\nbonds: [s -> k]\n");
  ASSERT_EQ(text.size(), 1u);
  EXPECT_EQ(text[0].where.line, 3);
  EXPECT_EQ(text[0].where.column, 6);
}

TEST(ModelLoader, OverIndentedLineIsNamed) {
  // Line 3 is indented by 3 spaces among entries indented by 2: yaml-cpp says "end of map not
  // found"; the error says which line and why.
  const auto ds = Errors("elements:\n  s: {type: Se, effort: 1}\n   k: {type: C, stiffness: 1}\nbonds: [s -> k]\n");
  ASSERT_EQ(ds.size(), 1u);
  EXPECT_EQ(ds[0].where.line, 3);
  EXPECT_EQ(ds[0].where.column, 4);
  ASSERT_EQ(ds[0].details.size(), 1u);
  EXPECT_THAT(ds[0].details[0], HasSubstr("indented by 3 spaces, the one before it (line 2) by 2"));
}

TEST(ModelLoader, BrokenBracketsAndIndentationOfEveryExampleGiveModelErrors) {
  // The syntax-error explanation scans the text around yaml-cpp's mark: every damaged copy of
  // every example (a bracket dropped, doubled or swapped, a line indented one more) must give a
  // ModelError or load, nothing else (run under ASan and UBSan in CI).
  const std::vector<std::string> names = {"differential.yaml", "differential_ideal.yaml", "rigid_gear_pair.yaml", "algebraic_loop.yaml"};
  int errors = 0, cases = 0;
  for (const std::string& name : names) {
    std::ifstream in(std::string(MULTIBOND_SOURCE_DIR) + "/examples/" + name);
    const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    ASSERT_FALSE(text.empty()) << name;
    std::vector<size_t> brackets, lines;
    for (size_t i = 0; i < text.size(); ++i) {
      if (std::string("{}[]").find(text[i]) != std::string::npos) brackets.push_back(i);
      if (text[i] == '\n' && i + 1 < text.size()) lines.push_back(i + 1);
    }
    std::vector<std::string> damaged;
    for (size_t k = 0; k < brackets.size(); k += 7) {
      const size_t i = brackets[k];
      damaged.push_back(text.substr(0, i) + text.substr(i + 1));                      // dropped
      damaged.push_back(text.substr(0, i) + text[i] + text.substr(i));                // doubled
      damaged.push_back(text.substr(0, i) + (text[i] == '{' ? '[' : text[i] == '[' ? '{' : text[i] == '}' ? ']' : '}') +
                        text.substr(i + 1));                                         // swapped
    }
    for (size_t k = 0; k < lines.size(); k += 5) damaged.push_back(text.substr(0, lines[k]) + " " + text.substr(lines[k]));
    for (const std::string& t : damaged) {
      ++cases;
      try {
        LoadModelString(t, name);
      } catch (const ModelError& e) {
        ++errors;
        for (const Diagnostic& d : e.diagnostics()) EXPECT_GE(d.where.line, 0) << d.ToString();
      }
    }
  }
  EXPECT_GT(cases, 100);
  EXPECT_GT(errors, cases / 2);
}

TEST(ModelLoader, UnknownKeySuggestsTheClosestOne) {
  const auto ds = Errors(R"(elements:
  m: {type: I, inertai: 1.0}
  s: {type: Se, effort: 1}
bonds: [s -> m]
)");
  ASSERT_GE(ds.size(), 1u);
  bool found = false;
  for (const auto& d : ds) {
    if (d.message.find("unknown key 'inertai'") == std::string::npos) continue;
    found = true;
    EXPECT_EQ(d.element, "m");
    EXPECT_EQ(d.where.line, 2);
    EXPECT_EQ(d.hint, "did you mean 'inertia'?");
  }
  EXPECT_TRUE(found);
}

TEST(ModelLoader, CollectsEveryErrorNotJustTheFirst) {
  const auto ds = Errors(R"(elements:
  m: {type: I, inertia: -1.0}
  k: {type: C, stiffness: .nan}
  r: {type: R, resistance: abc}
  x: {type: Q}
  s: {type: Se}
bonds: [s -> m, s -> nowhere]
)");
  std::string all;
  for (const auto& d : ds) all += d.ToString() + "\n";
  EXPECT_THAT(all, HasSubstr("m.yaml:3:"));
  EXPECT_THAT(all, HasSubstr("'.nan' is not a finite number"));
  EXPECT_THAT(all, HasSubstr("expected a number, got 'abc'"));
  EXPECT_THAT(all, HasSubstr("unknown element type 'Q'"));
  EXPECT_THAT(all, HasSubstr("Se needs 'effort'"));
  EXPECT_THAT(all, HasSubstr("nowhere: bond refers to an element that does not exist"));
  EXPECT_GE(ds.size(), 6u);
}

TEST(ModelLoader, NegativeMassAndIndefiniteMatrixAreRejectedWithElementName) {
  auto ds = Errors(R"(elements:
  s: {type: Se, effort: 1}
  m: {type: I, inertia: -2}
bonds: [s -> m]
)");
  ASSERT_EQ(ds.size(), 1u);
  EXPECT_EQ(ds[0].element, "m");
  EXPECT_THAT(ds[0].message, HasSubstr("inertia must be > 0 (got -2)"));
  EXPECT_EQ(ds[0].where.line, 3);
  ds = Errors(R"(elements:
  s: {type: Se, effort: [1, 1]}
  m: {type: I, inertia: [[1, 2], [2, 1]]}
bonds: [s -> m]
)");
  ASSERT_EQ(ds.size(), 1u);
  EXPECT_THAT(ds[0].message, HasSubstr("symmetric positive definite"));
}

TEST(ModelLoader, DuplicateNamesPointAtBothPlaces) {
  const auto ds = Errors(R"(elements:
  m: {type: I, inertia: 1}
  m: {type: C, stiffness: 1}
bonds: []
)");
  ASSERT_GE(ds.size(), 1u);
  EXPECT_THAT(ds[0].message, HasSubstr("duplicate element name"));
  EXPECT_EQ(ds[0].where.line, 3);
  ASSERT_EQ(ds[0].details.size(), 1u);
  EXPECT_THAT(ds[0].details[0], HasSubstr("m.yaml:2:3"));
}

TEST(ModelLoader, DuplicateKeysAreAnErrorNotASilentChoice) {
  // yaml-cpp keeps both entries of a repeated key and looks up the first: the second value
  // (stiffness 2, and t_end 9) would be dropped without a word.
  const auto ds = Errors(R"(elements:
  s: {type: Se, effort: 1}
  k: {type: C, stiffness: 1, stiffness: 2}
bonds: [s -> k]
simulation:
  t_end: 1
  dt: 0.1
  t_end: 9
)");
  ASSERT_EQ(ds.size(), 2u);
  EXPECT_EQ(ds[0].code, "yaml.duplicate_key");
  EXPECT_THAT(ds[0].message, HasSubstr("duplicate key 'stiffness'"));
  EXPECT_EQ(ds[0].element, "elements.k.stiffness");
  EXPECT_EQ(ds[0].where.line, 3);
  ASSERT_EQ(ds[0].details.size(), 1u);
  EXPECT_THAT(ds[0].details[0], HasSubstr("m.yaml:3:"));
  EXPECT_THAT(ds[1].message, HasSubstr("duplicate key 't_end'"));
  EXPECT_EQ(ds[1].where.line, 8);
  EXPECT_THAT(ds[1].details[0], HasSubstr("m.yaml:6:3"));
  // Repeated keys in different mappings are fine.
  EXPECT_NO_THROW(LoadModelString(R"(elements:
  s: {type: Se, effort: 1}
  k: {type: C, stiffness: 1}
bonds: [s -> k]
)", "m.yaml"));
}

TEST(ModelLoader, DanglingElementAndDimensionMismatch) {
  auto ds = Errors(R"(elements:
  s: {type: Se, effort: 1}
  m: {type: I, inertia: 1}
  lonely: {type: C, stiffness: 1}
bonds: [s -> m]
)");
  ASSERT_EQ(ds.size(), 1u);
  EXPECT_EQ(ds[0].element, "lonely");
  EXPECT_THAT(ds[0].message, HasSubstr("dangling"));
  ds = Errors(R"(elements:
  s: {type: Se, effort: [1, 2, 3]}
  j: {type: "1"}
  m: {type: I, inertia: [[1, 0], [0, 1]]}
bonds: [s -> j, j -> m]
)");
  ASSERT_GE(ds.size(), 1u);
  EXPECT_THAT(ds[0].message, HasSubstr("bond dimension mismatch"));
}

TEST(ModelLoader, TimeFunctions) {
  const LoadedModel lm = LoadModelString(R"(elements:
  a: {type: Se, effort: {ramp: {slope: 2, start: 1}}}
  b: {type: Se, effort: {sine: {amplitude: 2, frequency: 0.25}}}
  c: {type: Se, effort: {table: [[0, 0], [1, 10], [3, 30]]}}
  d: {type: Se, effort: {step: {value: 5, at: 2, before: 1}}}
  j: {type: "0"}
  k: {type: C, stiffness: 1}
bonds: [a -> j, b -> j, c -> j, d -> j, j -> k]
)");
  auto fn = [&](const char* n) { return lm.graph.element(lm.graph.Find(n)).source.components.at(0); };
  EXPECT_DOUBLE_EQ(fn("a")(0.5), 0.0);
  EXPECT_DOUBLE_EQ(fn("a")(3.0), 4.0);
  EXPECT_NEAR(fn("b")(1.0), 2.0, 1e-15);  // sin(pi/2)
  EXPECT_DOUBLE_EQ(fn("c")(2.0), 20.0);
  EXPECT_DOUBLE_EQ(fn("c")(9.0), 30.0);
  EXPECT_DOUBLE_EQ(fn("d")(1.999), 1.0);
  EXPECT_DOUBLE_EQ(fn("d")(2.0), 5.0);
}

TEST(ModelLoader, SubmodelsExpandWithParametersAndPorts) {
  // Two masses, each a submodel instance with its own parameters, joined by a spring.
  const char* yaml = R"(model: two_carts
domain: translation
submodels:
  cart:
    parameters: {m: 1.0, c: 0.0}
    ports: [v]
    elements:
      v: {type: "1"}
      mass: {type: I, inertia: $m}
      friction: {type: R, resistance: $c}
    bonds: [v -> mass, v -> friction]
elements:
  push: {type: Se, effort: {step: 1}}
  a: {type: cart, m: 2.0, c: 0.5}
  b: {type: cart, m: 3.0}
  link: {type: "0"}
  spring: {type: C, stiffness: 50}
bonds:
  - push -> a.v
  - a.v -> link
  - link -> b.v
  - link -> spring
simulation: {t_end: 200}
)";
  const LoadedModel lm = LoadModelString(yaml);
  const BondGraph& g = lm.graph;
  ASSERT_GE(g.Find("a.mass"), 0);
  ASSERT_GE(g.Find("b.friction"), 0);
  EXPECT_DOUBLE_EQ(g.element(g.Find("a.mass")).param.scalar, 2.0);
  EXPECT_DOUBLE_EQ(g.element(g.Find("b.mass")).param.scalar, 3.0);
  EXPECT_DOUBLE_EQ(g.element(g.Find("b.friction")).param.scalar, 0.0);  // the default
  // Physics: a constant push against friction 0.5 on cart a: terminal speed 1 / 0.5 = 2 m/s for both.
  const auto model = CompiledModel::Compile(lm.graph, lm.compile);
  RunOptions o;
  o.t_end = 200;
  o.dt = 0.5;
  RecordingObserver rec;
  Simulate(*model, o, rec);
  EXPECT_NEAR(rec.Last("a.mass.p") / 2.0, 2.0, 1e-5);
  EXPECT_NEAR(rec.Last("b.mass.p") / 3.0, 2.0, 1e-5);

  // Reaching inside an instance through something that is not a port is an error.
  std::string bad = yaml;
  bad.replace(bad.find("  - link -> spring"), 18, "  - b.mass -> spring");
  const auto ds = Errors(bad);
  ASSERT_GE(ds.size(), 1u);
  EXPECT_THAT(ds[0].message, HasSubstr("'mass' is not a port of submodel instance 'b'"));
  EXPECT_THAT(ds[0].hint, HasSubstr("v"));
}

TEST(ModelLoader, UnknownParameterInSubmodel) {
  const auto ds = Errors(R"(submodels:
  s:
    elements: {k: {type: C, stiffness: $kk}}
    bonds: []
elements:
  x: {type: s}
bonds: []
)");
  ASSERT_GE(ds.size(), 1u);
  EXPECT_THAT(ds[0].message, HasSubstr("unknown parameter '$kk'"));
}

TEST(ModelLoader, MissingFileIsAModelError) {
  try {
    LoadModelFile("/nonexistent/model.yaml");
    FAIL();
  } catch (const ModelError& e) {
    EXPECT_THAT(e.what(), HasSubstr("cannot open the model file"));
  }
}

TEST(DidYouMean, FindsCloseWords) {
  EXPECT_EQ(DidYouMean("stifness", {"stiffness", "compliance"}), "stiffness");
  EXPECT_EQ(DidYouMean("xyz", {"stiffness", "compliance"}), "");
}

}  // namespace
}  // namespace multibond

namespace multibond {
namespace {

TEST(ModelLoaderRegression, ConstantModulusKeepsItsRowSelection) {
  // rows [y, z] of diag(1, 10, 100) applied to (1, 2, 3) must give (20, 300).
  const LoadedModel lm = LoadModelString(R"(elements:
  w: {type: Sf, flow: [1, 2, 3]}
  pick: {type: MTF, modulus: {matrix: [[1, 0, 0], [0, 10, 0], [0, 0, 100]], rows: [y, z]}}
  out: {type: "1"}
  r: {type: R, resistance: 1}
bonds: [w -> pick, pick -> out, out -> r]
)");
  const auto model = CompiledModel::Compile(lm.graph, lm.compile);
  Workspace ws = model->MakeWorkspace();
  Eigen::VectorXd x = model->MakeInitialState(), xdot(x.size());
  model->CalcDerivatives(0.0, x.data(), xdot.data(), ws);
  Eigen::Vector2d f;
  model->Read(*model->FindVariable("r.f"), x.data(), ws, f.data());
  EXPECT_DOUBLE_EQ(f[0], 20.0);
  EXPECT_DOUBLE_EQ(f[1], 300.0);
}

TEST(ModelLoaderRegression, RotationMustNameAnOrientationState) {
  const auto ds = Errors(R"(elements:
  s: {type: Se, effort: [0, 0, 1]}
  w: {type: "1"}
  J: {type: I, inertia: [1, 2, 3], rotation: pos}
bonds: [s -> w, w -> J]
states:
  pos: {kind: integral, of: w}
)");
  ASSERT_GE(ds.size(), 1u);
  EXPECT_EQ(ds[0].code, "param.range");
  EXPECT_THAT(ds[0].message, HasSubstr("rotation 'pos' is not an orientation state"));
}

TEST(ModelLoaderRegression, OtherJunctionVariableIsNotAVariable) {
  const LoadedModel lm = LoadModelString(kMsd, "m.yaml");
  const auto model = CompiledModel::Compile(lm.graph, lm.compile);
  EXPECT_TRUE(model->FindVariable("j.f").has_value());
  EXPECT_FALSE(model->FindVariable("j.e").has_value());  // each bond of a 1-junction has its own effort
}

TEST(ModelLoaderRegression, Rk4WithoutStepIsAModelError) {
  const auto ds = Errors(std::string(kMsd) + "simulation: {solver: rk4}\n");
  ASSERT_GE(ds.size(), 1u);
  EXPECT_THAT(ds[0].message, HasSubstr("rk4 is a fixed-step method and needs 'step'"));
}

}  // namespace
}  // namespace multibond
