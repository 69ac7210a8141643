// The model loader: what a good file becomes, and what every kind of bad input is told.

#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <iterator>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include "multibond/io/model_loader.h"
#include "multibond/io/yaml_document.h"
#include "support/mechanism_chain.h"
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
  EXPECT_THAT(all, HasSubstr("m.yaml:4:28: error: r: unknown parameter 'abc'"));  // a word is read as a formula of parameters
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

// --- hostile input (issue 21): every one of these crashed, hung, or was accepted before --------

/// The diagnostic with `code` among those of loading `yaml` (with `limits`); fails if there is none.
Diagnostic WithCode(const std::string& yaml, const std::string& code, const InputLimits& limits = {}) {
  try {
    (void)LoadModelString(yaml, "m.yaml", limits);
  } catch (const ModelError& e) {
    for (const Diagnostic& d : e.diagnostics())
      if (d.code == code) return d;
    ADD_FAILURE() << "no diagnostic '" << code << "'; first: " << e.diagnostics().front().ToString();
    return {};
  }
  ADD_FAILURE() << "expected a ModelError (" << code << ") for:\n" << yaml.substr(0, 400);
  return {};
}

/// A temporary folder of the test, removed at the end.
struct TempDir {
  std::filesystem::path path;
  TempDir() {
    std::string p = (std::filesystem::temp_directory_path() / "mb_loader_XXXXXX").string();
    path = ::mkdtemp(p.data());
  }
  ~TempDir() { std::filesystem::remove_all(path); }
};

TEST(ModelLoaderHostile, RefusesWhatIsNotARegularFile) {
  TempDir dir;
  const std::string fifo = (dir.path / "fifo.yaml").string();
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  for (const std::string& path : {std::string("/dev/zero"), std::string("/dev/urandom"), dir.path.string(), fifo}) {
    try {
      (void)LoadModelFile(path);
      ADD_FAILURE() << path << " was loaded";
    } catch (const ModelError& e) {
      EXPECT_EQ(e.diagnostics().front().code, "io.not_regular") << path;  // the CLI exits 74
      EXPECT_THAT(e.diagnostics().front().message, HasSubstr("cannot read the model file: it is a")) << path;
    }
  }
  try {
    (void)LoadModelFile((dir.path / "missing.yaml").string());
    ADD_FAILURE();
  } catch (const ModelError& e) {
    EXPECT_EQ(e.diagnostics().front().code, "io.unreadable");
  }
}

TEST(ModelLoaderHostile, RefusesAFileLargerThanTheLimit) {
  TempDir dir;
  const std::string path = (dir.path / "big.yaml").string();
  std::ofstream(path) << kMsd << "# " << std::string(2000, 'x') << "\n";
  InputLimits limits;
  limits.file_bytes = 1000;
  try {
    (void)LoadModelFile(path, limits);
    ADD_FAILURE();
  } catch (const ModelError& e) {
    const Diagnostic& d = e.diagnostics().front();
    EXPECT_EQ(d.code, "limit.file-size");
    EXPECT_EQ(d.where.ToString(), path + ":1:1");
    EXPECT_THAT(d.message, HasSubstr("limit 'file-size' exceeded: the model is " + std::to_string(std::filesystem::file_size(path)) +
                                     " bytes long (at most 1000)"));
    EXPECT_THAT(d.hint, HasSubstr("--limit file-size=N (now 1000)"));
  }
  limits.file_bytes = 100000;
  EXPECT_EQ(LoadModelFile(path, limits).graph.num_elements(), 5);
  limits.file_bytes = 1000;
  EXPECT_EQ(WithCode(std::string(kMsd) + "#" + std::string(1000, 'x'), "limit.file-size", limits).where.line, 1);
}

TEST(ModelLoaderHostile, SelfReferencingAliasIsALocatedError) {
  const Diagnostic d = WithCode(std::string(kMsd) + "outputs: &x [*x]\n", "yaml.self_alias");
  EXPECT_EQ(d.where.ToString(), "m.yaml:14:14");
  EXPECT_EQ(WithCode("model: m\nelements: &e\n  a: {type: I, inertia: 1, p0: *e}\nbonds: []\n", "yaml.self_alias").where.line, 3);
}

TEST(ModelLoaderHostile, AliasExpansionIsBounded) {
  std::string yaml = std::string(kMsd) + "description: &l0 [lol, lol, lol, lol, lol, lol, lol, lol, lol, lol]\nstates:\n";
  for (int i = 1; i <= 9; ++i) {
    yaml += "  l" + std::to_string(i) + ": &l" + std::to_string(i) + " [";
    for (int k = 0; k < 10; ++k) yaml += (k ? ", *l" : "*l") + std::to_string(i - 1);
    yaml += "]\n";
  }
  const auto start = std::chrono::steady_clock::now();
  const Diagnostic d = WithCode(yaml, "limit.yaml-nodes");
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(5));
  EXPECT_THAT(d.message, HasSubstr("more than 1000000 YAML nodes"));
}

/// Submodels s1 ... s`levels`, each with `fan` instances of the one before; the model holds one s`levels`.
std::string NestedSubmodels(int levels, int fan) {
  std::string y = "model: m\nsubmodels:\n  s0:\n    ports: [j]\n    elements:\n      j: {type: \"1\"}\n      m: {type: I, inertia: 1.0}\n    bonds: [j -> m]\n";
  for (int i = 1; i <= levels; ++i) {
    y += "  s" + std::to_string(i) + ":\n    ports: [j]\n    elements:\n      j: {type: \"1\"}\n";
    for (int k = 0; k < fan; ++k) y += "      c" + std::to_string(k) + ": {type: s" + std::to_string(i - 1) + "}\n";
    y += "    bonds: [";
    for (int k = 0; k < fan; ++k) y += (k ? ", j -> c" : "j -> c") + std::to_string(k) + ".j";
    y += "]\n";
  }
  return y + "elements:\n  f: {type: Se, effort: 1.0}\n  top: {type: s" + std::to_string(levels) + "}\nbonds:\n  - f -> top.j\n";
}

TEST(ModelLoaderHostile, ExponentialSubmodelsAreRefusedBeforeExpanding) {
  const auto start = std::chrono::steady_clock::now();
  const Diagnostic d = WithCode(NestedSubmodels(30, 10), "limit.instances");  // 10^30 instances
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(1));
  const std::string yaml = NestedSubmodels(30, 10);
  // At the model's 'elements' (its first entry, the line after the key).
  EXPECT_EQ(d.where.line, std::count(yaml.begin(), yaml.begin() + static_cast<long>(yaml.find("\nelements:")), '\n') + 3);
  EXPECT_THAT(d.message, HasSubstr("limit 'instances' exceeded: more than 100000 submodel instances, nested ones included"));
  EXPECT_THAT(d.hint, HasSubstr("--limit instances=N (now 100000)"));
  // Counted exactly: 3 levels of 4 give 4 + 16 + 64 = 84 instances and the top one: 85.
  InputLimits limits;
  limits.instances = 84;
  EXPECT_THAT(WithCode(NestedSubmodels(3, 4), "limit.instances", limits).message, HasSubstr("85 submodel instances"));
  limits.instances = 85;
  EXPECT_NO_THROW((void)LoadModelString(NestedSubmodels(3, 4), "m.yaml", limits));
}

TEST(ModelLoaderHostile, SubmodelDepthAndGraphSizeAreBounded) {
  InputLimits limits;
  limits.depth = 5;  // the YAML of NestedSubmodels nests 5 deep
  EXPECT_THAT(WithCode(NestedSubmodels(6, 1), "limit.depth", limits).message,
              HasSubstr("limit 'depth' exceeded: 7 submodels nested in submodels (at most 5)"));
  EXPECT_NO_THROW((void)LoadModelString(NestedSubmodels(4, 1), "m.yaml", limits));
  limits = {};
  limits.elements = 10;
  EXPECT_THAT(WithCode(NestedSubmodels(2, 2), "limit.elements", limits).message,  // f + (j + 2 (j + 2 (j, m))) = 12
              HasSubstr("limit 'elements' exceeded: 12 elements once the submodels are expanded (at most 10)"));
  limits = {};
  limits.bonds = 3;
  EXPECT_THAT(WithCode(kMsd, "limit.bonds", limits).message, HasSubstr("limit 'bonds' exceeded: 4 bonds in the expanded bond graph (at most 3)"));
  limits = {};
  limits.elements = 4;
  EXPECT_EQ(WithCode(kMsd, "limit.elements", limits).where.line, 4);  // the first element
}

TEST(ModelLoaderHostile, NamesFollowTheIdentifierGrammarWithLocations) {
  struct Case {
    std::string yaml;
    int line, column;
  };
  const std::string se = "  f: {type: Se, effort: 1.0}\n";
  for (const Case& c : {
           Case{"elements:\n" + se + "  spring.q: {type: C, stiffness: 1}\nbonds: [f -> spring.q]\n", 3, 3},
           Case{"elements:\n" + se + "  \"a->b\": {type: C, stiffness: 1}\nbonds: []\n", 3, 3},
           Case{"elements:\n" + se + "  m: {type: I, inertia: 1}\nbonds:\n  - {from: f, to: m, name: m.p}\n", 5, 28},
           Case{"elements:\n" + se + "  m: {type: I, inertia: 1}\nbonds: [f -> m]\noutputs:\n  - {name: f.e, variable: m.p}\n", 6, 12},
           Case{"elements:\n" + se + "  j: {type: \"1\"}\nbonds: [f -> j]\nstates:\n  x.y: {kind: integral, of: j}\n", 6, 3},
           Case{"submodels:\n  a.b: {elements: {m: {type: I, inertia: 1}}}\nelements:\n" + se + "bonds: []\n", 2, 3},
           Case{"submodels:\n  s: {parameters: {k.1: 1}, elements: {m: {type: I, inertia: 1}}}\nelements:\n" + se + "bonds: []\n", 2, 20},
           Case{"bodies:\n  G.x: {mass: 1}\n", 2, 3},
           Case{"model: \"m x\"\nelements:\n" + se + "bonds: []\n", 1, 8},
       }) {
    const Diagnostic d = WithCode(c.yaml, "name.invalid");
    EXPECT_EQ(d.where.line, c.line) << c.yaml;
    EXPECT_EQ(d.where.column, c.column) << c.yaml;
    EXPECT_THAT(d.hint, HasSubstr("a name is a letter or '_', then letters, digits and '_'")) << c.yaml;
  }
  EXPECT_THAT(WithCode("elements:\n" + se + "  spring.q: {type: C, stiffness: 1}\nbonds: []\n", "name.invalid").message,
              HasSubstr("an element's name holds '.' (it separates the parts of result column names, as in spring.q)"));
  EXPECT_THAT(WithCode("elements:\n" + se + "  spring.q: {type: C, stiffness: 1}\nbonds: []\n", "name.invalid").hint, HasSubstr("'spring_q'"));
  EXPECT_EQ(WithCode("elements:\n" + se + "  x: {type: C, stiffness: 1, components: [\"a`id`\"]}\nbonds: []\n", "name.invalid").where.line, 3);
}

const char* kIntegral = R"(model: m
domain: rotation
elements:
  f: {type: Se, effort: 1.0}
  j: {type: "1"}
  J: {type: I, inertia: 1.0}
bonds: [f -> j, j -> J]
states:
  angle: {kind: integral, of: j, unit: UNIT}
)";

std::string WithUnit(const std::string& unit) {
  std::string y = kIntegral;
  return y.replace(y.find("UNIT"), 4, unit);
}

TEST(ModelLoaderHostile, UnitsFollowTheUnitGrammar) {
  for (const char* unit : {"rad", "\"N m\"", "rad/s", "\"kg m^2\"", "\"-\"", "\"m s^-2\""}) {
    const LoadedModel lm = LoadModelString(WithUnit(unit), "m.yaml");
    EXPECT_EQ(lm.graph.aux_states().at(0).unit, YAML::Load(unit).as<std::string>()) << unit;
  }
  for (const char* unit : {"\"m`touch /tmp/pwned`\"", "\"m\\\"\\nsystem(\\\"id\\\")\\n#\"", "furlong", "\"<b>\""}) {
    const Diagnostic d = WithCode(WithUnit(unit), "unit.invalid");
    EXPECT_EQ(d.where.ToString(), "m.yaml:9:40") << unit;
    EXPECT_THAT(d.message, HasSubstr("the unit '")) << unit;
    EXPECT_THAT(d.message, ::testing::Not(HasSubstr("\n"))) << unit;
    EXPECT_THAT(d.hint, HasSubstr("kg m^2, rad/s")) << unit;
  }
}

TEST(ModelLoaderHostile, BytesThatAreNotUtf8AreALocatedError) {
  std::string yaml = kMsd;
  yaml.replace(yaml.find("mass:"), 4, "m\xe4ss");
  const Diagnostic d = WithCode(yaml, "text.encoding");
  EXPECT_EQ(d.where.ToString(), "m.yaml:5:4");
  EXPECT_THAT(d.message, HasSubstr("byte 0xe4 is not part of valid UTF-8"));
  EXPECT_EQ(WithCode(std::string(kMsd) + "# \xff\n", "text.encoding").where.line, 14);
  EXPECT_EQ(WithCode(std::string(kMsd) + "description: \"a\x1b[2J\"\n", "text.encoding").where.line, 14);
  EXPECT_NO_THROW((void)LoadModelString(std::string(kMsd) + "description: \"caf\xc3\xa9 \xe2\x86\x92 ok\"\n"));
}

TEST(ModelLoaderHostile, SubnormalNumbersAreRefusedWhereverANumberIsRead) {
  for (const char* tail : {"simulation: {dt: 4.9e-324}\n", "simulation: {t_end: 1e-310}\n", "simulation: {rtol: 1e-320, atol: 1e-9}\n"}) {
    const auto ds = Errors(std::string(kMsd) + tail);
    ASSERT_EQ(ds.size(), 1u) << tail;  // said once, not again as "must be > 0"
    EXPECT_EQ(ds[0].where.line, 14) << tail;
    EXPECT_THAT(ds[0].message, HasSubstr("is too small to compute with (a subnormal number")) << tail;
  }
  std::string yaml = kMsd;
  yaml.replace(yaml.find("100.0"), 5, "1e-315");
  EXPECT_THAT(Errors(yaml)[0].message, HasSubstr("'1e-315' is too small"));
  EXPECT_EQ(Errors(yaml)[0].where.line, 6);
}

std::string GearPair(const std::string& teeth_a) {
  return R"(model: gears
bodies:
  A: {mass: 1.0, inertia: [1.0, 1.0, 1.0]}
  B: {mass: 1.0, inertia: [1.0, 1.0, 1.0], position: [0.1, 0, 0]}
joints:
  a_bearing: {type: revolute, child: A, axis: z, rigid: true}
  b_bearing: {type: revolute, child: B, axis: z, rigid: true}
gears:
  mesh: {a: {body: A, axis: z, teeth: )" + teeth_a + R"(}, b: {body: B, axis: -z, teeth: 24}, K: 1.0e6, R: 10}
drives:
  motor: {type: torque, body: A, axis: z, value: 1.0}
)";
}

TEST(ModelLoaderHostile, ToothCountsAreWholeNumbersOfASaneSize) {
  EXPECT_NO_THROW((void)LoadModelString(GearPair("12")));
  for (const char* teeth : {"12.5", "0.5", "1e300", "100001"}) {
    const auto ds = Errors(GearPair(teeth));
    ASSERT_EQ(ds.size(), 1u) << teeth;
    EXPECT_EQ(ds[0].code, "param.range") << teeth;
    EXPECT_EQ(ds[0].where.line, 9) << teeth;
    EXPECT_THAT(ds[0].message, HasSubstr("teeth: a tooth count is a whole number from 1 to 100000")) << teeth;
  }
  EXPECT_THAT(Errors(GearPair("4.9e-324"))[0].message, HasSubstr("too small to compute with"));
}

TEST(ModelLoader, LoadsAChainOf5000Bodies) {
  // Every name (bodies, joints, the elements they expand to) is found through a hash index: the
  // load takes well under a second (bench/loader_bench.cc times it).
  const LoadedModel lm = LoadModelString(testing::MechanismChainText(5000), "chain.yaml");
  ASSERT_NE(lm.mechanism, nullptr);
  EXPECT_EQ(lm.mechanism->bodies().size(), 5000u);
  EXPECT_EQ(lm.mechanism->joints().size(), 5000u);
  EXPECT_EQ(lm.mechanism->joints().back().parent, "b4998");
  EXPECT_GE(lm.graph.Find("b4999.v"), 0);
  EXPECT_GE(lm.graph.Find("j4999.r.K"), 0) << "the last joint's rotational spring";
  EXPECT_TRUE(lm.warnings.empty());
}

// A model parsed once loads again and again with other parameter values (a sweep's runs), each
// load the same graph as loading the text anew with those values: the loader does not change the
// parsed document (setting a parameter once nulled the file's value in it).
TEST(ParsedModel, LoadsLikeTheTextForEveryParameterValue) {
  const std::string file = std::string(MULTIBOND_SOURCE_DIR) + "/examples/differential.yaml";
  const std::string text = ReadModelText(file, {});
  const ParsedModel parsed(text, file, {});
  for (const char* k : {"3000", "1000", "2.5e4", "3000"}) {
    const std::vector<ParameterOverride> set = {{"mesh_K", k}};
    const LoadedModel a = parsed.Load(set), b = LoadModelString(text, file, {}, set);
    ASSERT_EQ(a.graph.num_elements(), b.graph.num_elements());
    int meshes = 0;
    for (int i = 0; i < a.graph.num_elements(); ++i) {
      const Element &x = a.graph.element(i), &y = b.graph.element(i);
      ASSERT_EQ(x.name, y.name);
      EXPECT_EQ(x.param.is_scalar, y.param.is_scalar) << x.name;
      EXPECT_EQ(x.param.scalar, y.param.scalar) << x.name;
      EXPECT_EQ(x.param.matrix, y.param.matrix) << x.name;
      if (x.name == "mesh_GA.mesh.K") {
        EXPECT_EQ(x.param.scalar, std::stod(k));
        ++meshes;
      }
    }
    EXPECT_EQ(meshes, 1);
    ASSERT_EQ(a.parameters.size(), b.parameters.size());
    EXPECT_EQ(a.parameters.front().value, b.parameters.front().value);
  }
}

}  // namespace
}  // namespace multibond
