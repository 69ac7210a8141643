// examples/differential_ideal.yaml: the paper's differential with every joint and mesh
// rigid and the housing fixed, against the closed-form solution of the rigid mechanism: one
// equivalent inertia J on the drive coupling (docs/differential.md, "The ideal mechanism").

#include <algorithm>
#include <cmath>
#include <numbers>

#include <gtest/gtest.h>

#include "support/example_runner.h"

namespace multibond {
namespace {

using testing::MaxEnergyResidual;
using testing::RunExample;

struct Disc {
  double m, axial, diametral;
};
Disc MakeDisc(double d) {
  const double rho = 2700.0, t = 0.01, r = d / 2;
  const double m = rho * std::numbers::pi * r * r * t;
  return {m, m * r * r / 2, m * (3 * r * r + t * t) / 12};
}

/// The rigid mechanism: theta_G driven through K, R from 50 t (a step in speed at t = 0). The
/// deflection e = 50 t - theta obeys J e'' + R e' + K e = 0, e(0) = 0, e'(0) = 50.
struct ClosedForm {
  double j, k = 1000.0, r = 5.0, s1, s2;
  ClosedForm() {
    const Disc g = MakeDisc(0.1), a = MakeDisc(0.4), p = MakeDisc(0.1), s = MakeDisc(0.2);
    const double rho = 0.1;  // planet centres from A's axis
    // Referred to G: A turns at w/4, the planets orbit at w/4 and spin at w/2, S2 at w/2.
    j = g.axial + a.axial / 16 + 2 * (p.diametral + p.m * rho * rho) / 16 + 2 * p.axial / 4 + s.axial / 4;
    const double disc = std::sqrt(r * r - 4 * j * k);  // overdamped: R^2 > 4 J K
    s1 = (-r + disc) / (2 * j);
    s2 = (-r - disc) / (2 * j);
  }
  double e(double t) const { return 50 * (std::exp(s1 * t) - std::exp(s2 * t)) / (s1 - s2); }
  double de(double t) const { return 50 * (s1 * std::exp(s1 * t) - s2 * std::exp(s2 * t)) / (s1 - s2); }
  double omega_g(double t) const { return 50 - de(t); }
  double torque(double t) const { return k * e(t) + r * de(t); }
};

// One run for every check (ctest runs each TEST in its own process; under the sanitizers a run
// takes over a minute).
void SteadySpeedsAreExact(const RecordingObserver& r) {
  EXPECT_NEAR(r.Last("G.omega.x"), 50.0, 50.0 * 1e-9);
  EXPECT_NEAR(r.Last("A.omega.z"), -12.5, 12.5 * 1e-9);
  EXPECT_NEAR(r.Last("S1.omega.z"), 0.0, 1e-9);
  EXPECT_NEAR(r.Last("S2.omega.z"), -25.0, 25.0 * 1e-9);
  EXPECT_NEAR(r.Last("S1.omega.z") + r.Last("S2.omega.z"), 2 * r.Last("A.omega.z"), 1e-9);
  // The kinematic identities hold at every sample, not only in the steady state.
  for (const auto& row : r.rows()) {
    const double wg = row[r.Index("G.omega.x")], wa = row[r.Index("A.omega.z")], ws2 = row[r.Index("S2.omega.z")];
    ASSERT_NEAR(wa, -wg / 4, 1e-9 * (1 + std::abs(wg))) << row[0];
    ASSERT_NEAR(ws2, 2 * wa, 1e-9 * (1 + std::abs(wg))) << row[0];
  }
}

void PlanetBearingsCarryTheCentripetalForceAndGyroscopicMoment(const RecordingObserver& r) {
  const Disc p = MakeDisc(0.1);
  const double wa = 12.5, s = 25.0, rho = 0.1;
  for (const char* b : {"P1_bearing", "P2_bearing"}) {
    const std::string n = b;
    const double f = std::hypot(r.Last(n + ".F.x"), r.Last(n + ".F.y"), r.Last(n + ".F.z"));
    const double m = std::hypot(r.Last(n + ".M.x"), r.Last(n + ".M.y"), r.Last(n + ".M.z"));
    EXPECT_NEAR(f, p.m * wa * wa * rho, 1e-6 * p.m * wa * wa * rho) << b;
    EXPECT_NEAR(m, p.axial * s * wa, 1e-6 * p.axial * s * wa) << b;
  }
}

void TransientMatchesTheEquivalentInertia(const RecordingObserver& r) {
  const ClosedForm cf;
  double worst_w = 0.0, worst_tau = 0.0;
  for (const auto& row : r.rows()) {
    const double t = row[0];
    worst_w = std::max(worst_w, std::abs(row[r.Index("A.omega.z")] - (-cf.omega_g(t) / 4)));
    worst_tau = std::max(worst_tau, std::abs(row[r.Index("drive.torque")] - cf.torque(t)));
  }
  // Relative to the scales of the run: w_A 12.5 rad/s, the drive torque's 250 N m at the start.
  EXPECT_LT(worst_w / 12.5, 1e-5);
  EXPECT_LT(worst_tau / 250.0, 1e-5);
}

void EnergyIsConservedAndOrientationsStayRotations(const RecordingObserver& r) {
  EXPECT_LT(MaxEnergyResidual(r), 1e-6);
  for (const char* b : {"G", "A", "P1", "P2", "S1", "S2", "H"}) {
    const int c = r.Index(std::string(b) + ".orthonormality");
    double worst = 0.0;
    for (const auto& row : r.rows()) worst = std::max(worst, row[c]);
    EXPECT_LT(worst, 1e-9) << b;
  }
}

// Four planet-sun meshes for two planets: one of them is redundant, and the split of the mesh
// torques is the compliant meshes' (equal stiffnesses): by symmetry both planets carry the same
// torque on each sun, at every sample. (With the independent set's split, P1S1 carried nothing
// and P2S1 all of it.)
void RedundantMeshesShareTheTorqueSymmetrically(const RecordingObserver& r) {
  double worst = 0.0, largest = 0.0;
  for (const auto& row : r.rows())
    for (const char* sun : {"S1", "S2"}) {
      const double p1 = row[r.Index(std::string("mesh_P1") + sun + ".torque")], p2 = row[r.Index(std::string("mesh_P2") + sun + ".torque")];
      worst = std::max(worst, std::abs(p1 - p2));
      largest = std::max(largest, std::abs(p1));
    }
  EXPECT_GT(largest, 1e-2);  // the start transient loads the meshes
  EXPECT_LT(worst, 1e-9 * largest);
}

void Validate(const RecordingObserver& rec) {
  ASSERT_EQ(rec.summary().status, RunStatus::kOk) << rec.summary().message;
  ASSERT_DOUBLE_EQ(rec.rows().back()[0], 5.0);
  {
    SCOPED_TRACE("steady speeds");
    SteadySpeedsAreExact(rec);
  }
  {
    SCOPED_TRACE("planet bearings");
    PlanetBearingsCarryTheCentripetalForceAndGyroscopicMoment(rec);
  }
  {
    SCOPED_TRACE("transient");
    TransientMatchesTheEquivalentInertia(rec);
  }
  {
    SCOPED_TRACE("energy and orientations");
    EnergyIsConservedAndOrientationsStayRotations(rec);
  }
  {
    SCOPED_TRACE("redundant meshes");
    RedundantMeshesShareTheTorqueSymmetrically(rec);
  }
}

// As the example runs (BDF in joint coordinates), with generated code for the plan's constraint
// columns and W's factorisation, as the CLI runs it (--jit auto);
// GeneratedConstraintCodeMatchesTheInterpreter holds the two paths together.
TEST(IdealDifferential, ValidatesAgainstTheRigidMechanism) {
  Validate(RunExample("differential_ideal.yaml", 0, 0, Method::kBdf, /*generate_code=*/true));
}

// The model's own inertial-frame states (--coordinates inertial) meet the same closed forms, with
// Dormand-Prince (whose steps there are held by accuracy, far inside its stability limit).
TEST(IdealDifferential, ValidatesInInertialCoordinates) {
  Validate(RunExample("differential_ideal.yaml", 0, 0, Method::kDormandPrince, true, "inertial"));
}

/// The generated constraint code (the plan at zero multipliers, its tangent, B's columns, W's
/// L D L^T and what the multipliers reach) gives the interpreter's constraint efforts, state
/// derivatives and reactions to rounding, at states along the start transient and in the steady
/// rotation, and the same projection onto the constraints. (Checked to fail when the generated
/// tangent's product rule is off by 1e-6, or when one body's momentum rate is left at its value
/// without the multipliers.)
TEST(IdealDifferential, GeneratedConstraintCodeMatchesTheInterpreter) {
  const LoadedModel lm = LoadModelFile(testing::ExamplePath("differential_ideal.yaml"));
  // One model, two engines: its workspaces with and without the generated code.
  const auto generated = CompiledModel::Compile(lm.graph, lm.compile), interpreted = generated;
  const auto code = GeneratedRhs::Start(generated);
  ASSERT_TRUE(code->ready()) << code->engine();
  const RecordingObserver rec = RunExample("differential_ideal.yaml", 0.4, 0, Method::kDormandPrince);
  ASSERT_EQ(rec.summary().status, RunStatus::kOk);
  Workspace wg = generated->MakeWorkspace(code.get()), wi = interpreted->MakeWorkspace();
  const int n = generated->num_states();
  Eigen::VectorXd x(n), dg(n), di(n);
  double worst_rhs = 0.0, worst_lambda = 0.0, worst_slot = 0.0, worst_projection = 0.0, largest_lambda = 0.0;
  int samples = 0;
  for (size_t row = 0; row < rec.rows().size(); row += 20, ++samples) {
    for (int i = 0; i < n; ++i) x[i] = rec.rows()[row][rec.Index(generated->state_names()[i])];
    const double t = rec.rows()[row][0];
    generated->CalcStateDerivatives(t, x.data(), dg.data(), wg);
    interpreted->CalcStateDerivatives(t, x.data(), di.data(), wi);
    for (int i = 0; i < n; ++i) worst_rhs = std::max(worst_rhs, std::abs(dg[i] - di[i]) / (1.0 + std::abs(di[i])));
    for (size_t k = 0; k < wi.lambda.size(); ++k) {
      worst_lambda = std::max(worst_lambda, std::abs(wg.lambda[k] - wi.lambda[k]) / (1.0 + std::abs(wi.lambda[k])));
      largest_lambda = std::max(largest_lambda, std::abs(wi.lambda[k]));
    }
    for (size_t k = 0; k < wi.slots.size(); ++k)
      worst_slot = std::max(worst_slot, std::abs(wg.slots[k] - wi.slots[k]) / (1.0 + std::abs(wi.slots[k])));
    // A state off the constraints (momenta disturbed): both projections land on the same point.
    Eigen::VectorXd pg = x, pi = x;
    for (int i = 0; i < n; ++i) {
      pg[i] += 1e-6 * ((i * 7) % 11 - 5);
      pi[i] = pg[i];
    }
    generated->Project(t, pg.data(), wg);
    interpreted->Project(t, pi.data(), wi);
    for (int i = 0; i < n; ++i) worst_projection = std::max(worst_projection, std::abs(pg[i] - pi[i]) / (1.0 + std::abs(pi[i])));
  }
  EXPECT_GE(samples, 10);
  EXPECT_GT(largest_lambda, 1.0);  // the reactions are not trivially zero
  EXPECT_LT(worst_rhs, 1e-11);
  EXPECT_LT(worst_lambda, 1e-11);
  EXPECT_LT(worst_slot, 1e-11);
  EXPECT_LT(worst_projection, 1e-14);
}

/// At an output time the state is projected and then evaluated; the evaluation reuses B and the
/// factor of W that the projection formed (only momenta moved in between, and B and W depend on
/// the orientations only). It must give exactly the numbers of an evaluation that forms them anew.
TEST(IdealDifferential, EvaluationAfterAProjectionReusesItsFactorExactly) {
  for (const bool generate : {true, false}) {
    const LoadedModel lm = LoadModelFile(testing::ExamplePath("differential_ideal.yaml"));
    const auto model = CompiledModel::Compile(lm.graph, lm.compile);
    const auto code = generate ? GeneratedRhs::Start(model) : nullptr;
    ASSERT_TRUE(!generate || code->ready()) << code->engine();
    const int n = model->num_states();
    Eigen::VectorXd x = model->MakeInitialState();
    for (int i = 0; i < n; ++i) x[i] += 1e-6 * ((i * 7) % 11 - 5);  // off the constraints
    const double t = 0.25;
    Workspace reused = model->MakeWorkspace(code.get()), fresh = model->MakeWorkspace(code.get());
    model->Project(t, x.data(), reused);
    ASSERT_TRUE(reused.con.factored) << "the projection left no factor to reuse";
    Eigen::VectorXd with(n), without(n);
    model->CalcDerivatives(t, x.data(), with.data(), reused);
    model->CalcDerivatives(t, x.data(), without.data(), fresh);
    for (int i = 0; i < n; ++i) EXPECT_EQ(with[i], without[i]) << model->state_names()[i] << (generate ? " (generated)" : "");
    for (size_t k = 0; k < fresh.lambda.size(); ++k) EXPECT_EQ(reused.lambda[k], fresh.lambda[k]) << k;
    for (size_t k = 0; k < fresh.slots.size(); ++k) EXPECT_EQ(reused.slots[k], fresh.slots[k]) << k;
    // A state that differs in one orientation entry is evaluated with B formed anew.
    x[model->FindVariable("G.R")->offset] += 1e-9;
    Workspace unused = model->MakeWorkspace(code.get());
    model->CalcDerivatives(t, x.data(), with.data(), reused);
    model->CalcDerivatives(t, x.data(), without.data(), unused);
    for (int i = 0; i < n; ++i) EXPECT_EQ(with[i], without[i]) << model->state_names()[i];
  }
}

}  // namespace
}  // namespace multibond
