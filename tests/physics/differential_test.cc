// The paper's differential (issue 4): every validation of shared/spec/differential.md at the
// default settings, the energy balance falling with the tolerance, generated code against the
// interpreter, and bit-identical reruns.

#include <filesystem>
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>

#include "differential_checks.h"
#include "multibond/io/model_loader.h"
#include "multibond/io/results_writer.h"
#include "multibond/sim/simulator.h"

namespace multibond {
namespace {

namespace fs = std::filesystem;

const std::string kModel = std::string(MULTIBOND_SOURCE_DIR) + "/examples/differential.yaml";

/// Runs the differential with the file's settings (tolerances overridden when > 0) into `dir`.
RunSummary RunInto(const fs::path& dir, double rtol = 0, double atol = 0, bool generate_code = true, double t_end = 0) {
  const LoadedModel lm = LoadModelFile(kModel);
  CompileOptions co = lm.compile;
  co.generate_code = generate_code;
  const auto model = CompiledModel::Compile(lm.graph, co);
  RunOptions o;
  o.t_end = t_end > 0 ? t_end : *lm.simulation.t_end;
  o.dt = *lm.simulation.dt;
  o.integrator.method = ParseMethod(*lm.simulation.solver);
  o.integrator.rtol = rtol > 0 ? rtol : *lm.simulation.rtol;
  o.integrator.atol = atol > 0 ? atol : *lm.simulation.atol;
  fs::create_directories(dir);
  CsvWriter csv((dir / "results.csv").string());
  return Simulate(*model, o, csv);
}

fs::path TempDir(const std::string& tag) {
  const fs::path d = fs::temp_directory_path() / ("multibond_differential_" + tag);
  fs::remove_all(d);
  return d;
}

std::string Read(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

TEST(Differential, EveryValidationHoldsAtTheDefaultSettings) {
  const fs::path dir = TempDir("default");
  const RunSummary s = RunInto(dir);
  ASSERT_EQ(s.status, RunStatus::kOk) << s.message;
  const ResultsTable t = ReadResults((dir / "results.csv").string());
  EXPECT_EQ(t.rows.size(), 5001u);  // every 1 ms over 0-5 s
  for (const char* col : {"A.omega.z", "P1.F.x", "P1.M.y", "G.R.23", "Q_P1.x", "drive.torque", "energy.residual"})
    EXPECT_TRUE(t.Has(col)) << col;
  for (const auto& c : differential::Checks(t))
    EXPECT_TRUE(c.ok()) << c.what << ": " << c.value << " " << c.unit << ", expected " << c.expected << " +- " << c.tolerance;
  fs::remove_all(dir);
}

TEST(Differential, EnergyResidualFallsWithTheTolerance) {
  const fs::path dir = TempDir("tight");
  const RunSummary s = RunInto(dir, 1e-10, 1e-12);
  ASSERT_EQ(s.status, RunStatus::kOk) << s.message;
  EXPECT_LE(std::abs(s.energy_residual), 1e-9);
  EXPECT_GT(s.energy_work, 14.0);  // the drive did its work (about 14.95 J)
  fs::remove_all(dir);
}

TEST(Differential, GeneratedCodeMatchesTheInterpreter) {
  // Half a second of the start transient: every column agrees to rounding.
  const fs::path a = TempDir("generated"), b = TempDir("interpreted");
  ASSERT_EQ(RunInto(a, 0, 0, true, 0.5).status, RunStatus::kOk);
  ASSERT_EQ(RunInto(b, 0, 0, false, 0.5).status, RunStatus::kOk);
  const ResultsTable ta = ReadResults((a / "results.csv").string()), tb = ReadResults((b / "results.csv").string());
  ASSERT_EQ(ta.rows.size(), tb.rows.size());
  double worst = 0;
  for (size_t r = 0; r < ta.rows.size(); ++r)
    for (size_t c = 0; c < ta.names.size(); ++c)
      worst = std::max(worst, std::abs(ta.rows[r][c] - tb.rows[r][c]) / (1.0 + std::abs(tb.rows[r][c])));
  EXPECT_LT(worst, 1e-9);
  fs::remove_all(a);
  fs::remove_all(b);
}

TEST(Differential, RerunsAreBitIdentical) {
  const fs::path a = TempDir("rerun_a"), b = TempDir("rerun_b");
  ASSERT_EQ(RunInto(a, 0, 0, true, 0.5).status, RunStatus::kOk);
  ASSERT_EQ(RunInto(b, 0, 0, true, 0.5).status, RunStatus::kOk);
  EXPECT_EQ(Read(a / "results.csv"), Read(b / "results.csv"));
  fs::remove_all(a);
  fs::remove_all(b);
}

}  // namespace
}  // namespace multibond
