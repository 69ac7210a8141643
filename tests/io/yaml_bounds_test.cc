// The pass over YAML events that bounds a model file before a tree is built (io/yaml_bounds.h).
// Each of these inputs crashed or hung the loader before the pass existed (see also
// model_loader_test.cc, HostileYaml*).

#include <chrono>
#include <fstream>
#include <iterator>
#include <string>

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
