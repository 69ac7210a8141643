// The small mechanism models of docs/mechanisms/ (drawn in docs/mechanisms.md) load, compile and
// run, and keep their energy balance.

#include <filesystem>

#include <gtest/gtest.h>

#include "multibond/io/model_loader.h"
#include "multibond/sim/simulator.h"

namespace multibond {
namespace {

TEST(DocsMechanisms, EveryModelRunsWithBalancedEnergy) {
  int n = 0;
  for (const auto& entry : std::filesystem::directory_iterator(std::string(MULTIBOND_SOURCE_DIR) + "/docs/mechanisms")) {
    if (entry.path().extension() != ".yaml") continue;
    SCOPED_TRACE(entry.path().string());
    ++n;
    const LoadedModel lm = LoadModelFile(entry.path().string());
    EXPECT_TRUE(lm.warnings.empty());
    const auto model = CompiledModel::Compile(lm.graph, lm.compile);
    RunOptions o;
    o.t_end = *lm.simulation.t_end;
    o.dt = *lm.simulation.dt;
    o.integrator.method = lm.simulation.solver ? ParseMethod(*lm.simulation.solver) : Method::kBdf;
    o.integrator.rtol = 1e-10;
    o.integrator.atol = 1e-12;
    RecordingObserver rec;
    const RunSummary s = Simulate(*model, o, rec);
    ASSERT_EQ(s.status, RunStatus::kOk) << s.message;
    EXPECT_LT(std::abs(s.energy_residual), 1e-7);
  }
  EXPECT_GE(n, 3);
}

}  // namespace
}  // namespace multibond
