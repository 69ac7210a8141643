// The physics of models repaired by `multibond check --suggest --write`: the coupling it inserts
// must behave like the rigid connection it replaces, up to a deviation its stiffness sets.

#include <cmath>
#include <numbers>

#include <gtest/gtest.h>

#include "multibond/causality/repair.h"
#include "multibond/io/model_loader.h"
#include "multibond/io/model_repair.h"
#include "support/example_runner.h"

namespace multibond {
namespace {

struct Repaired {
  LoadedModel original;
  RepairResult repair;
  LoadedModel repaired;  ///< the file RepairModelText wrote, loaded again
};

Repaired Repair(const std::string& path, const CouplingTarget& target = {}) {
  LoadedModel original = LoadModelFile(path);
  RepairResult repair = SuggestCouplings(original.graph, original.compile.default_domain, target);
  LoadedModel repaired = LoadModelString(RepairModelText(original.text, original.file, repair, target).text, "<repaired>");
  return {std::move(original), std::move(repair), std::move(repaired)};
}

RecordingObserver Simulated(const LoadedModel& lm, double t_end, double dt) {
  RecordingObserver rec = testing::RunModel(lm, t_end, dt);
  EXPECT_EQ(rec.summary().status, RunStatus::kOk) << rec.summary().message;
  return rec;
}

double Param(const LoadedModel& lm, const std::string& name) { return lm.graph.element(lm.graph.Find(name)).param.scalar; }

TEST(RepairedRigidGearPair, KeepsTheGearRatioAndTheRigidAccelerationOnceTheCouplingHasSettled) {
  const Repaired r = Repair(testing::ExamplePath("rigid_gear_pair.yaml"));
  ASSERT_EQ(r.repair.couplings.size(), 1u);
  const SuggestedCoupling& c = r.repair.couplings[0];
  const double j1 = Param(r.original, "J1"), j2 = Param(r.original, "J2"), n = Param(r.original, "gear");
  const double torque = 1.0;  // the example's constant torque on the pinion
  // Rigid: the pinion accelerates the pinion and the reflected wheel, alpha1 = T / (J1 + n^2 J2).
  const double alpha1 = torque / (j1 + n * n * j2), alpha2 = n * alpha1;
  // The coupling: w = 2 pi f, zeta = 0.7, its relative mode decays as exp(-zeta w t). It carries
  // the wheel's torque J2 alpha2 at a steady deflection J2 alpha2 / K; the speed mismatch of the
  // transient is of the order of that deflection times w.
  const double w = 2 * std::numbers::pi * 100.0, k = c.stiffness(0, 0), zeta = 0.7;
  const double deflection = j2 * alpha2 / k, mismatch_scale = deflection * w;
  const double settled = 20.0 / (zeta * w);  // e^-20 of the transient is left
  const RecordingObserver rec = Simulated(r.repaired, 0.5, 1e-3);
  const int p1 = rec.Index("J1.p"), p2 = rec.Index("J2.p"), q = rec.Index("J2_K.q");
  double max_mismatch = 0.0, settled_mismatch = 0.0;
  for (const auto& row : rec.rows()) {
    const double t = row[0], w1 = row[p1] / j1, w2 = row[p2] / j2;
    const double mismatch = std::abs(w2 - n * w1);
    max_mismatch = std::max(max_mismatch, mismatch);
    if (t >= settled) {
      settled_mismatch = std::max(settled_mismatch, mismatch);
      EXPECT_NEAR(w1, alpha1 * t, 1e-7 * alpha1 * t + 1e-9) << "t = " << t;  // J1 w1 + n J2 w2 = T t exactly
      EXPECT_NEAR(row[q], deflection, 1e-6 * deflection) << "t = " << t;
    }
  }
  EXPECT_LT(max_mismatch, 2.0 * mismatch_scale);  // the coupling is stiff: the gear ratio holds throughout
  EXPECT_GT(max_mismatch, 0.05 * mismatch_scale);  // and it is a coupling (not rigid) during the transient
  EXPECT_LT(settled_mismatch, 1e-6 * mismatch_scale + 1e-9 * alpha2 * 0.5);
  EXPECT_NEAR(rec.Last("J2.p") / j2, n * alpha1 * 0.5, 1e-7 * n * alpha1 * 0.5);
  // Energy: the torque's work = kinetic + spring energy + the damper's dissipation.
  EXPECT_LT(testing::MaxEnergyResidual(rec), 1e-7);
  EXPECT_GT(rec.Last("J2_R.dissipated"), 0.0);
}

TEST(RepairedRigidGearTrain, BothCouplingsHoldTheirRatiosAndTheEnergyBalances) {
  const Repaired r = Repair(std::string(MULTIBOND_SOURCE_DIR) + "/tests/models/rigid_gear_train.yaml");
  ASSERT_EQ(r.repair.couplings.size(), 2u);
  const double j1 = Param(r.original, "J1"), j2 = Param(r.original, "J2"), j3 = Param(r.original, "J3");
  const double n12 = Param(r.original, "mesh12"), n23 = Param(r.original, "mesh23");
  const RecordingObserver rec = Simulated(r.repaired, 1.0, 1e-3);
  for (const auto& row : rec.rows()) {
    if (row[0] < 0.1) continue;
    const double w1 = row[rec.Index("J1.p")] / j1, w2 = row[rec.Index("J2.p")] / j2, w3 = row[rec.Index("J3.p")] / j3;
    EXPECT_NEAR(w2, n12 * w1, 1e-3 * std::abs(n12 * w1)) << "t = " << row[0];
    EXPECT_NEAR(w3, n12 * n23 * w1, 1e-3 * std::abs(n12 * n23 * w1)) << "t = " << row[0];
  }
  EXPECT_LT(testing::MaxEnergyResidual(rec), 1e-7);
}

}  // namespace
}  // namespace multibond
