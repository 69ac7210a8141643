// Keeps docs/model-format.md true: every ```yaml block in it is a model that loads, compiles
// (integrally causal) and simulates with a closed energy balance, unless it is marked
//   # doc: fragment              (a snippet: skipped), or
//   # doc: expect-error <code>   (a deliberately bad model: loading + compiling must fail with a
//                                 diagnostic of that code).
// Together the blocks must show every element kind.

#include <algorithm>
#include <cmath>
#include <fstream>
#include <memory>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "multibond/io/model_loader.h"
#include "multibond/sim/simulator.h"

namespace multibond {
namespace {

constexpr const char* kDoc = MULTIBOND_SOURCE_DIR "/docs/model-format.md";

struct YamlBlock {
  int line = 0;  ///< line of the opening fence in the document (1-based)
  std::string text;
  std::string first_line;
};

std::string Trim(const std::string& s) {
  const auto a = s.find_first_not_of(" \t\r"), z = s.find_last_not_of(" \t\r");
  return a == std::string::npos ? std::string() : s.substr(a, z - a + 1);
}

std::vector<YamlBlock> ReadYamlBlocks() {
  std::ifstream in(kDoc);
  EXPECT_TRUE(in) << "cannot open " << kDoc;
  std::vector<YamlBlock> blocks;
  std::string line;
  int n = 0;
  bool inside = false;
  YamlBlock cur;
  while (std::getline(in, line)) {
    ++n;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (!inside) {
      if (line.rfind("```", 0) == 0 && Trim(line.substr(3)) == "yaml") {
        inside = true;
        cur = YamlBlock{n, {}, {}};
      }
      continue;
    }
    if (line.rfind("```", 0) == 0) {
      inside = false;
      std::istringstream ss(cur.text);
      std::getline(ss, cur.first_line);
      cur.first_line = Trim(cur.first_line);
      blocks.push_back(cur);
      continue;
    }
    cur.text += line + "\n";
  }
  EXPECT_FALSE(inside) << "unterminated ```yaml block opened at line " << cur.line;
  return blocks;
}

/// For SCOPED_TRACE: the block's place in the document.
std::string Where(const YamlBlock& b) { return fmt::format("docs/model-format.md:{}", b.line); }
/// The file name the loader puts in front of its positions (line:col within the block).
std::string FileName(const YamlBlock& b) { return fmt::format("<yaml block at docs/model-format.md:{}>", b.line); }

/// Loads and compiles; on a ModelError, ok is false and the diagnostics are kept.
struct CompileResult {
  bool ok = false;
  std::vector<Diagnostic> diagnostics;
  std::string what;
};

CompileResult TryCompile(const std::string& text, const std::string& file, LoadedModel* loaded = nullptr,
                         std::shared_ptr<const CompiledModel>* model = nullptr) {
  CompileResult r;
  try {
    LoadedModel lm = LoadModelString(text, file);
    auto m = CompiledModel::Compile(lm.graph, lm.compile);
    if (loaded) *loaded = std::move(lm);
    if (model) *model = std::move(m);
    r.ok = true;
  } catch (const ModelError& e) {
    r.diagnostics = e.diagnostics();
    r.what = e.what();
  }
  return r;
}

TEST(ModelFormatDoc, HasYamlBlocks) {
  const auto blocks = ReadYamlBlocks();
  EXPECT_GE(blocks.size(), 12u);
}

TEST(ModelFormatDoc, EveryYamlBlockLoadsCompilesAndSimulates) {
  const auto blocks = ReadYamlBlocks();
  for (const YamlBlock& b : blocks) {
    SCOPED_TRACE(Where(b));
    if (b.first_line == "# doc: fragment") continue;

    const std::string kExpect = "# doc: expect-error";
    if (b.first_line.rfind(kExpect, 0) == 0) {
      const std::string code = Trim(b.first_line.substr(kExpect.size()));
      if (code.empty()) {
        ADD_FAILURE() << "expect-error needs a diagnostic code";
        continue;
      }
      const CompileResult r = TryCompile(b.text, FileName(b));
      EXPECT_FALSE(r.ok) << "the model loaded and compiled, but an error '" << code << "' was expected";
      const bool found = std::any_of(r.diagnostics.begin(), r.diagnostics.end(), [&](const Diagnostic& d) { return d.code == code; });
      EXPECT_TRUE(r.ok || found) << "expected a diagnostic with code '" << code << "', got:\n" << r.what;
      continue;
    }

    LoadedModel lm;
    std::shared_ptr<const CompiledModel> model;
    const CompileResult r = TryCompile(b.text, FileName(b), &lm, &model);
    if (!r.ok) {
      ADD_FAILURE() << "the model does not load and compile:\n" << r.what;
      continue;
    }
    if (model->num_states() >= 200) continue;

    const SimulationDefaults& d = lm.simulation;
    RunOptions o;
    o.t_end = std::min(d.t_end.value_or(1.0), 0.1);
    o.dt = std::min(d.dt.value_or(1e-3), o.t_end);
    o.integrator.method = ParseMethod(d.solver.value_or("bdf"));
    o.integrator.rtol = d.rtol.value_or(1e-8);
    o.integrator.atol = d.atol.value_or(1e-10);
    o.integrator.fixed_step = d.step.value_or(0.0);
    o.integrator.max_step = d.max_step.value_or(0.0);
    RecordingObserver rec;
    RunSummary s;
    try {
      s = Simulate(*model, o, rec);
    } catch (const std::exception& e) {
      ADD_FAILURE() << "the simulation threw: " << e.what();
      continue;
    }
    EXPECT_EQ(s.status, RunStatus::kOk) << s.message;
    if (rec.rows().empty()) {
      ADD_FAILURE() << "no samples";
      continue;
    }
    EXPECT_NEAR(rec.rows().back().at(0), o.t_end, 1e-12);
    const double work = rec.Last("energy.work");
    const auto& first = rec.rows().front();
    const double stored0 = first.at(rec.Index("energy.kinetic")) + first.at(rec.Index("energy.potential"));
    if (std::abs(work) > 1e-12 || stored0 > 1e-12) {
      EXPECT_LT(std::abs(rec.Last("energy.residual")), 1e-6) << "work " << work << " J, stored at start " << stored0 << " J";
    }
  }
}

TEST(ModelFormatDoc, ShowsEveryElementKind) {
  std::set<std::string> kinds;
  for (const YamlBlock& b : ReadYamlBlocks()) {
    if (b.first_line.rfind("# doc:", 0) == 0) continue;
    try {
      const LoadedModel lm = LoadModelString(b.text, FileName(b));
      for (const Element& e : lm.graph.elements()) kinds.insert(KindName(e.kind));
    } catch (const ModelError&) {
      // Reported by EveryYamlBlockLoadsCompilesAndSimulates.
    }
  }
  for (const char* k : {"Se", "Sf", "I", "C", "R", "TF", "GY", "MTF", "MGY", "0", "1"})
    EXPECT_TRUE(kinds.count(k)) << "no complete model in the document has an element of type " << k;
}

}  // namespace
}  // namespace multibond
