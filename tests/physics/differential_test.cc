// The paper's differential: every validation of docs/differential.md at the
// default settings, the energy balance falling with the tolerance, generated code against the
// interpreter, and bit-identical reruns.

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>

#include "differential_checks.h"
#include "multibond/compile/generated_rhs.h"
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
  const auto model = CompiledModel::Compile(lm.graph, lm.compile);
  RunOptions o;
  if (generate_code) o.code = GeneratedRhs::Start(model);
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
  // The process id keeps two suites running at once (optimised and sanitized) apart.
  const fs::path d = fs::temp_directory_path() / ("multibond_differential_" + tag + "_" + std::to_string(getpid()));
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
  const LoadedModel lm = LoadModelFile(kModel);
  const auto generated = CompiledModel::Compile(lm.graph, lm.compile), interpreted = CompiledModel::Compile(lm.graph, lm.compile);
  const auto code = GeneratedRhs::Start(generated);
  ASSERT_TRUE(code->ready()) << code->engine();
  // 1. The right-hand sides agree to rounding at states along the start transient, through both
  //    entry points of the generated code.
  const fs::path a = TempDir("generated");
  ASSERT_EQ(RunInto(a, 0, 0, true, 0.5).status, RunStatus::kOk);
  const ResultsTable ta = ReadResults((a / "results.csv").string());
  Workspace wg = generated->MakeWorkspace(code.get()), wi = interpreted->MakeWorkspace();
  const int n = generated->num_states();
  Eigen::VectorXd x(n), dg(n), dg_fast(n), di(n);
  double worst_rhs = 0, worst_slot = 0;
  for (size_t row = 0; row < ta.rows.size(); row += 25) {
    for (int i = 0; i < n; ++i) x[i] = ta.At(row, generated->state_names()[i]);
    const double t = ta.rows[row][0];
    generated->CalcDerivatives(t, x.data(), dg.data(), wg);
    generated->CalcStateDerivatives(t, x.data(), dg_fast.data(), wg);
    interpreted->CalcDerivatives(t, x.data(), di.data(), wi);
    for (int i = 0; i < n; ++i) {
      const double scale = 1.0 + std::abs(di[i]);
      worst_rhs = std::max({worst_rhs, std::abs(dg[i] - di[i]) / scale, std::abs(dg_fast[i] - di[i]) / scale});
    }
    for (size_t k = 0; k < wg.slots.size(); ++k)
      worst_slot = std::max(worst_slot, std::abs(wg.slots[k] - wi.slots[k]) / (1.0 + std::abs(wi.slots[k])));
  }
  EXPECT_LT(worst_rhs, 1e-12);
  EXPECT_LT(worst_slot, 1e-12);
  // 2. Whole trajectories differ only by how the integrator amplifies those rounding
  //    differences: within the run's tolerance (rtol 1e-8).
  const fs::path b = TempDir("interpreted");
  ASSERT_EQ(RunInto(b, 0, 0, false, 0.5).status, RunStatus::kOk);
  const ResultsTable tb = ReadResults((b / "results.csv").string());
  ASSERT_EQ(ta.rows.size(), tb.rows.size());
  double worst = 0;
  for (size_t r = 0; r < ta.rows.size(); ++r)
    for (size_t c = 0; c < ta.names.size(); ++c)
      worst = std::max(worst, std::abs(ta.rows[r][c] - tb.rows[r][c]) / (1.0 + std::abs(tb.rows[r][c])));
  EXPECT_LT(worst, 1e-8);
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
