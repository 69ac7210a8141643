// The pass over YAML events that bounds a model file as its tree is built (io/yaml_bounds.h).
// Each of these inputs crashed or hung the loader before the pass existed (see also
// model_loader_test.cc, HostileYaml*).

#include <chrono>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <fmt/format.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include "multibond/io/yaml_bounds.h"

namespace multibond {
namespace {

using ::testing::HasSubstr;

/// The one diagnostic CheckYamlBounds gives for `text` (fails the test if it gives none).
Diagnostic Refusal(const std::string& text, const InputLimits& limits = {}) {
  DiagnosticSink sink;
  EXPECT_FALSE(CheckYamlBounds(text, "f.yaml", limits, sink)) << text.substr(0, 200);
  EXPECT_EQ(sink.diagnostics().size(), 1u);
  return sink.diagnostics().empty() ? Diagnostic{} : sink.diagnostics().front();
}

TEST(YamlBounds, AcceptsOrdinaryYamlWithAliases) {
  DiagnosticSink sink;
  EXPECT_TRUE(CheckYamlBounds("a: &k [1, 2]\nb: *k\nc: {d: *k, e: &s x, f: *s}\n---\ng: 1\n", "f.yaml", {}, sink));
  EXPECT_TRUE(sink.diagnostics().empty());
}

TEST(YamlBounds, RefusesAnAliasInsideItsOwnAnchor) {
  const Diagnostic d = Refusal("a: 1\nb: &x [1, *x]\n");
  EXPECT_EQ(d.code, "yaml.self_alias");
  EXPECT_EQ(d.where.line, 2);
  EXPECT_EQ(d.where.column, 11);
  EXPECT_THAT(d.message, HasSubstr("'*x'"));
  EXPECT_THAT(d.message, HasSubstr("f.yaml:2:4"));
  EXPECT_EQ(Refusal("m: &e\n  k: {v: *e}\n").code, "yaml.self_alias");
}

TEST(YamlBounds, CountsAliasesAsWhatTheyStandFor) {
  // The root mapping 1, key a 1, the list a 1 + 3, key b 1, the list b 1 + 3 x 4 (each alias the
  // 4 nodes of a): 20 nodes.
  const std::string text = "a: &a [1, 2, 3]\nb: [*a, *a, *a]\n";
  InputLimits limits;
  limits.yaml_nodes = 20;
  DiagnosticSink ok;
  EXPECT_TRUE(CheckYamlBounds(text, "f.yaml", limits, ok));
  limits.yaml_nodes = 19;
  const Diagnostic d = Refusal(text, limits);
  EXPECT_EQ(d.code, "limit.yaml-nodes");
  EXPECT_EQ(d.where.line, 2);
  EXPECT_EQ(d.where.column, 13);  // the third alias
}

TEST(YamlBounds, RefusesBillionLaughsAtTheLimit) {
  std::string text = "l0: &l0 [lol, lol, lol, lol, lol, lol, lol, lol, lol]\n";
  for (int i = 1; i <= 12; ++i) {
    // fmt::format, not "literal" + std::string: GCC 12 reports a false -Wrestrict on the latter.
    text += fmt::format("l{0}: &l{0} [", i);
    for (int k = 0; k < 9; ++k) text += fmt::format("{}*l{}", k ? ", " : "", i - 1);
    text += "]\n";
  }
  const auto start = std::chrono::steady_clock::now();
  const Diagnostic d = Refusal(text);
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(2));
  EXPECT_EQ(d.code, "limit.yaml-nodes");
  EXPECT_THAT(d.message, HasSubstr("limit 'yaml-nodes' exceeded: the file holds more than 1000000 YAML nodes"));
  EXPECT_THAT(d.hint, HasSubstr("--limit yaml-nodes=N (now 1000000)"));
  EXPECT_GT(d.where.line, 1);
}

TEST(YamlBounds, RefusesDeepNestingBeforeTheParserRecursesDeeper) {
  const std::string flow = "a: " + std::string(100000, '[') + std::string(100000, ']') + "\n";
  Diagnostic d = Refusal(flow);
  EXPECT_EQ(d.code, "limit.depth");
  EXPECT_THAT(d.message, HasSubstr("nested more than 64 deep"));
  EXPECT_THAT(d.hint, HasSubstr("--limit depth=N (now 64)"));
  InputLimits limits;
  limits.depth = 3;
  d = Refusal("a:\n  b:\n    c:\n      d: 1\n", limits);
  EXPECT_EQ(d.code, "limit.depth");
  EXPECT_EQ(d.where.line, 4);
  DiagnosticSink sink;
  EXPECT_TRUE(CheckYamlBounds("a:\n  b:\n    c: 1\n", "f.yaml", limits, sink));
}

TEST(YamlBounds, LeavesSyntaxErrorsToYamlCpp) {
  DiagnosticSink sink;
  EXPECT_THROW(CheckYamlBounds("a: [1, 2\nb: 3\n", "f.yaml", {}, sink), YAML::Exception);
  EXPECT_THROW(CheckYamlBounds("a: *nowhere\n", "f.yaml", {}, sink), YAML::Exception);
}

}  // namespace
}  // namespace multibond

namespace multibond {
namespace {

// Found by the fuzzer: yaml-cpp, given this malformed flow collection, produces null nodes without
// reading on; only the yaml-nodes limit (a million) stopped it, which took 14 s under the
// sanitizers. A file's written nodes are now bounded by its length (two per character).
TEST(YamlBounds, AParserThatProducesNodesWithoutReadingIsStoppedAtOnce) {
  std::ifstream in(MULTIBOND_SOURCE_DIR "/tests/models/fuzz/yaml_parser_runaway.yaml", std::ios::binary);
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  ASSERT_FALSE(text.empty());
  const Diagnostic d = Refusal(text);
  EXPECT_EQ(d.code, "yaml.syntax");
  EXPECT_THAT(d.message, HasSubstr("more nodes than the file has characters"));
  EXPECT_GT(d.where.line, 0);
  // A file that is mostly nulls is still accepted: "a:" is two nodes in two characters.
  std::string nulls;
  for (int i = 0; i < 1000; ++i) nulls += fmt::format("k{}:\n", i);
  DiagnosticSink sink;
  EXPECT_TRUE(CheckYamlBounds(nulls + "l: [,]\nm: {a, b}\n", "f.yaml", {}, sink));
}

}  // namespace
}  // namespace multibond

namespace multibond {
namespace {

/// Fails the test where `built` differs from `loaded` (YAML::LoadAll's): type, tag, style, mark,
/// scalar, the items and keys in order; an alias is the very node of its anchor in both.
void ExpectSameTree(const YAML::Node& built, const YAML::Node& loaded, const std::string& at) {
  SCOPED_TRACE(at);
  ASSERT_EQ(built.IsDefined(), loaded.IsDefined());
  if (!loaded.IsDefined()) return;
  ASSERT_EQ(built.Type(), loaded.Type());
  EXPECT_EQ(built.Tag(), loaded.Tag());
  EXPECT_EQ(built.Style(), loaded.Style());
  EXPECT_EQ(built.Mark().pos, loaded.Mark().pos);
  EXPECT_EQ(built.Mark().line, loaded.Mark().line);
  EXPECT_EQ(built.Mark().column, loaded.Mark().column);
  if (loaded.IsScalar()) {
    EXPECT_EQ(built.Scalar(), loaded.Scalar());
  }
  if (!loaded.IsSequence() && !loaded.IsMap()) return;
  ASSERT_EQ(built.size(), loaded.size());
  auto b = built.begin();
  int i = 0;
  for (auto l = loaded.begin(); l != loaded.end(); ++l, ++b, ++i) {
    if (loaded.IsSequence()) {
      ExpectSameTree(*b, *l, fmt::format("{}[{}]", at, i));
    } else {
      ExpectSameTree(b->first, l->first, fmt::format("{} key {}", at, i));
      ExpectSameTree(b->second, l->second, fmt::format("{}.{}", at, l->first.IsScalar() ? l->first.Scalar() : "?"));
    }
  }
}

void ExpectLoadsAsLoadAll(const std::string& text, const std::string& name) {
  SCOPED_TRACE(name);
  DiagnosticSink sink;
  const std::optional<std::vector<YAML::Node>> built = LoadYamlBounded(text, "f.yaml", {}, sink);
  ASSERT_TRUE(built.has_value());
  EXPECT_TRUE(sink.diagnostics().empty());
  const std::vector<YAML::Node> loaded = YAML::LoadAll(text);
  ASSERT_EQ(built->size(), loaded.size());
  for (size_t d = 0; d < loaded.size(); ++d) ExpectSameTree((*built)[d], loaded[d], fmt::format("document {}", d));
}

TEST(LoadYamlBounded, BuildsTheTreesYamlLoadAllBuilds) {
  ExpectLoadsAsLoadAll("", "empty");
  ExpectLoadsAsLoadAll("# only a comment\n", "comment");
  ExpectLoadsAsLoadAll("---\n", "an empty document");
  ExpectLoadsAsLoadAll("a: &k [1, 2]\nb: *k\nc: {d: *k, e: &s x, f: *s}\n---\ng: 1\n", "anchors, two documents");
  ExpectLoadsAsLoadAll("!!map {? [a, b] : c, ? {d: e} : ~, null: , 'q': \"w\"}\n", "complex keys, tags, quotes, nulls");
  ExpectLoadsAsLoadAll("- a\n- - b\n  - c\n- k: !custom v\n  l: |\n    text\n    more\n- >\n  folded\n", "block styles");
  ExpectLoadsAsLoadAll("x: 1\n", "one key");
}

TEST(LoadYamlBounded, BuildsEveryExampleAndTestModelAsYamlLoadAll) {
  int files = 0;
  for (const char* folder : {"/examples", "/tests/models"})
    for (const auto& entry : std::filesystem::recursive_directory_iterator(std::string(MULTIBOND_SOURCE_DIR) + folder)) {
      if (entry.path().extension() != ".yaml") continue;
      std::ifstream in(entry.path(), std::ios::binary);
      const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
      // Only what both read: a file out of bounds (checked first: yaml-cpp alone would not stop on
      // some of them), or that yaml-cpp refuses, is not compared.
      try {
        DiagnosticSink sink;
        if (!CheckYamlBounds(text, "f.yaml", {}, sink)) continue;
        (void)YAML::LoadAll(text);
      } catch (const YAML::Exception&) {
        continue;
      }
      ExpectLoadsAsLoadAll(text, entry.path().string());
      ++files;
    }
  EXPECT_GT(files, 100);
}

TEST(LoadYamlBounded, AnAliasIsTheNodeOfItsAnchor) {
  DiagnosticSink sink;
  const auto built = LoadYamlBounded("a: &k [1, 2]\nb: *k\n", "f.yaml", {}, sink);
  ASSERT_TRUE(built && built->size() == 1);
  EXPECT_TRUE((*built)[0]["a"].is((*built)[0]["b"]));
}

TEST(LoadYamlBounded, RefusesWhatCheckYamlBoundsRefusesWithTheSameDiagnostic) {
  std::string laughs = "l0: &l0 [lol, lol, lol, lol, lol, lol, lol, lol, lol]\n";
  for (int i = 1; i <= 12; ++i) {
    laughs += fmt::format("l{0}: &l{0} [", i);
    for (int k = 0; k < 9; ++k) laughs += fmt::format("{}*l{}", k ? ", " : "", i - 1);
    laughs += "]\n";
  }
  std::ifstream in(MULTIBOND_SOURCE_DIR "/tests/models/fuzz/yaml_parser_runaway.yaml", std::ios::binary);
  const std::string runaway((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  InputLimits shallow;
  shallow.depth = 3;
  InputLimits few;
  few.yaml_nodes = 19;
  const std::vector<std::pair<std::string, InputLimits>> cases = {
      {"a: 1\nb: &x [1, *x]\n", {}},
      {"m: &e\n  k: {v: *e}\n", {}},
      {"a: &a [1, 2, 3]\nb: [*a, *a, *a]\n", few},
      {laughs, {}},
      {"a: " + std::string(100000, '[') + std::string(100000, ']') + "\n", {}},
      {"a:\n  b:\n    c:\n      d: 1\n", shallow},
      {runaway, {}},
      {"a: 1\n---\nb: &x [*x]\n", {}},  // in a second document
  };
  for (const auto& [text, limits] : cases) {
    SCOPED_TRACE(text.substr(0, 60));
    DiagnosticSink checked, built;
    EXPECT_FALSE(CheckYamlBounds(text, "f.yaml", limits, checked));
    EXPECT_FALSE(LoadYamlBounded(text, "f.yaml", limits, built).has_value());
    ASSERT_EQ(built.diagnostics().size(), 1u);
    ASSERT_EQ(checked.diagnostics().size(), 1u);
    const Diagnostic& a = built.diagnostics().front();
    const Diagnostic& b = checked.diagnostics().front();
    EXPECT_EQ(a.code, b.code);
    EXPECT_EQ(a.where.ToString(), b.where.ToString());
    EXPECT_EQ(a.message, b.message);
    EXPECT_EQ(a.hint, b.hint);
  }
}

TEST(LoadYamlBounded, ThrowsTheSyntaxErrorsOfYamlLoadAll) {
  for (const std::string text : {"a: [1, 2\nb: 3\n", "a: *nowhere\n", "a: b: c\n", "a: 1\n- b\n", "a: [1, 2}\n", "a: 1\n  b: 2\n"}) {
    SCOPED_TRACE(text);
    YAML::Mark expected;
    try {
      (void)YAML::LoadAll(text);
      ADD_FAILURE() << "YAML::LoadAll accepts it";
    } catch (const YAML::Exception& e) {
      expected = e.mark;
    }
    DiagnosticSink sink;
    try {
      (void)LoadYamlBounded(text, "f.yaml", {}, sink);
      ADD_FAILURE() << "LoadYamlBounded accepts it";
    } catch (const YAML::Exception& e) {
      EXPECT_EQ(e.mark.line, expected.line);
      EXPECT_EQ(e.mark.column, expected.column);
    }
  }
}

}  // namespace
}  // namespace multibond
