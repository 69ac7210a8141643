// The flagship differential with its meshes through the pitch points (examples/differential_pitch.yaml,
// docs/mechanisms.md "Tooth forces"): it runs to the flagship's end with its energy balanced and
// its tooth forces bounded, turns at the spin model's speeds, and its planet bearings carry the
// tooth loads that statics gives for the 10 N m on the side gear S2.

#include <cmath>
#include <cstring>
#include <numbers>
#include <random>
#include <string>

#include <gtest/gtest.h>

#include "support/example_runner.h"
#include "support/text_edit.h"

#include "multibond/io/model_loader.h"

namespace multibond {
namespace {

using std::numbers::pi;
using testing::ExamplePath;
using testing::ExampleText;
using testing::ReplacedAll;

const double kLoad = 10.0;                         // N m on S2 from t = 1 s
const double kSunRadius = 0.1, kCrownRadius = 0.2;  // pitch radii [m]
const double kTan20 = std::tan(20 * pi / 180);
const double kPlanetCone = std::atan(12.0 / 24.0);  // the planets' pitch cone angle
const double kPlanetMass = 2700 * pi * 0.05 * 0.05 * 0.01;
const double kCarrierSpeed = 12.5;
const double kTurn = 2 * pi / kCarrierSpeed;  // one turn of the carrier [s]

/// Runs a loaded model with its file's simulation settings (all of which it must give).
RecordingObserver RunLoaded(const LoadedModel& lm) {
  const auto model = CompiledModel::Compile(lm.graph, lm.compile);
  return testing::RunCompiled(*model, *lm.simulation.t_end, *lm.simulation.dt, ParseMethod(*lm.simulation.solver), *lm.simulation.rtol,
                              *lm.simulation.atol);
}

class DifferentialPitchTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    const std::string text = ExampleText("differential_pitch.yaml");
    pitch_ = new RecordingObserver(RunLoaded(LoadModelString(text, "differential_pitch.yaml")));
    // The same model with the paper's torque-only meshes.
    std::string spin = ReplacedAll(text, "contact: pitch, pressure_angle_deg: 20, ", "contact: spin, ");
    spin = ReplacedAll(spin, "flank: coast, ", "");
    spin_ = new RecordingObserver(RunLoaded(LoadModelString(spin, "differential_spin.yaml")));
  }
  static void TearDownTestSuite() {
    delete pitch_;
    delete spin_;
  }

  // The mean of a column over the last two turns of the carrier (the load sharing varies once a turn).
  static double Mean(const RecordingObserver& rec, const std::string& name) {
    const int k = rec.Index(name);
    const double from = rec.rows().back()[0] - 2 * kTurn;
    double sum = 0;
    int n = 0;
    for (const auto& row : rec.rows())
      if (row[0] >= from) sum += row[k], ++n;
    return sum / n;
  }

  static RecordingObserver* pitch_;
  static RecordingObserver* spin_;
};

RecordingObserver* DifferentialPitchTest::pitch_ = nullptr;
RecordingObserver* DifferentialPitchTest::spin_ = nullptr;

// The run reaches the flagship's t_end with work in = stored + dissipated (the flagship's check:
// |residual| <= 1e-6 after 0.5 s), and from 2 s on its tooth forces stay at the load's size: the
// contact with arms fixed in the carrier let them grow past 1e4 N within 2 s.
TEST_F(DifferentialPitchTest, RunsToTheEndBalancedAndBounded) {
  ASSERT_EQ(pitch_->summary().status, RunStatus::kOk) << pitch_->summary().message;
  const LoadedModel flagship = LoadModelFile(ExamplePath("differential.yaml"));
  EXPECT_DOUBLE_EQ(pitch_->rows().back()[0], *flagship.simulation.t_end);
  const int res = pitch_->Index("energy.residual");
  double worst = 0, worst_force = 0;
  for (const auto& row : pitch_->rows()) {
    if (row[0] >= 0.5) worst = std::max(worst, std::abs(row[res]));
    if (row[0] < 2.0) continue;  // the start and the load's step ring down first
    for (const char* m : {"mesh_GA", "mesh_P1S1", "mesh_P1S2", "mesh_P2S1", "mesh_P2S2"})
      worst_force = std::max(worst_force, std::abs(row[pitch_->Index(std::string(m) + ".F_t")]));
  }
  EXPECT_LT(worst, 1e-6);
  EXPECT_LT(std::abs(pitch_->Last("energy.residual")), 1e-6);
  EXPECT_LT(worst_force, 1.5 * 2 * kLoad / kCrownRadius);  // 150 N: the most a mesh carries in statics is 100 N
}

// The side gears turn as in the spin model: within 1e-3 of S2's 25 rad/s at every sample of the
// last second (the crown wheel, tilted on its soft bearing by the pinion's tooth force, makes the
// train wobble once a turn), within 1e-4 over the last two turns.
TEST_F(DifferentialPitchTest, SideGearSpeedsAreTheSpinModels) {
  ASSERT_EQ(spin_->summary().status, RunStatus::kOk) << spin_->summary().message;
  ASSERT_EQ(pitch_->rows().size(), spin_->rows().size());
  for (const char* col : {"S1.omega.z", "S2.omega.z", "A.omega.z"}) {
    const int a = pitch_->Index(col), b = spin_->Index(col);
    double worst = 0;
    for (size_t i = 0; i < pitch_->rows().size(); ++i)
      if (pitch_->rows()[i][0] >= 4.0) worst = std::max(worst, std::abs(pitch_->rows()[i][a] - spin_->rows()[i][b]));
    EXPECT_LT(worst, 1e-3 * 25) << col;
    EXPECT_NEAR(Mean(*pitch_, col), Mean(*spin_, col), 1e-4 * 25) << col;
  }
  EXPECT_NEAR(spin_->Last("S2.omega.z"), -25.0, 1e-5);
  EXPECT_NEAR(Mean(*pitch_, "S2.omega.z"), -25.0, 1e-4 * 25);
}

// Statics at steady load, over the last two turns: the tangential tooth forces are the torques
// over the pitch radii (S2's meshes carry the load, S1's the same held torque, the G-A mesh the
// carrier's 2 x 10 N m), the two planets sharing them; the spin model's meshes carry the same
// torques.
TEST_F(DifferentialPitchTest, ToothForcesAreTorqueOverPitchRadius) {
  const double sun = kLoad / kSunRadius;  // 100 N over the two planets
  EXPECT_NEAR(Mean(*pitch_, "mesh_P1S2.F_t") + Mean(*pitch_, "mesh_P2S2.F_t"), sun, 2e-3 * sun);
  // S1's meshes run on the coast flank: F_t < 0 (a's teeth pushed along +t).
  EXPECT_NEAR(-Mean(*pitch_, "mesh_P1S1.F_t") - Mean(*pitch_, "mesh_P2S1.F_t"), sun, 2e-3 * sun);
  EXPECT_NEAR(Mean(*pitch_, "mesh_GA.F_t"), 2 * kLoad / kCrownRadius, 2e-3 * sun);
  for (const char* m : {"mesh_P1S2", "mesh_P2S2"}) {
    EXPECT_NEAR(Mean(*pitch_, std::string(m) + ".F_t"), sun / 2, 0.05 * sun / 2) << m;  // shared to 5 %
    EXPECT_NEAR(Mean(*pitch_, std::string(m) + ".torque"), 0.05 * Mean(*pitch_, std::string(m) + ".F_t"), 1e-9) << m;
  }
  // The spin model's mesh torques (referred to the planet, r = 0.05 m) carry the same.
  EXPECT_NEAR(std::abs(Mean(*spin_, "mesh_P1S2.torque") + Mean(*spin_, "mesh_P2S2.torque")), 0.05 * sun, 2e-3 * 0.05 * sun);
}

// Each planet bearing carries the vector sum of its two meshes' tooth forces (and the planet's
// m a): at every sample of the last second in the carrier's frame, from the meshes' reported F_t,
// F_r, F_a and their directions (t, the radial direction, the planet's axis); on average 2 F_t along
// the planet's path, the meshes' thrust 2 F_t tan 20deg sin(cone) and the centripetal m w^2 rho
// along its axis, nothing along the carrier's axis (the radial forces cancel).
TEST_F(DifferentialPitchTest, PlanetBearingCarriesItsMeshesToothForces) {
  struct Planet {
    const char* name;
    const char* s1;
    const char* s2;
    double out;  // the planet's axis along A's x: +1 (P1 at +x), -1 (P2 at -x)
  };
  for (const Planet& p : {Planet{"P1", "mesh_P1S1", "mesh_P1S2", 1.0}, Planet{"P2", "mesh_P2S1", "mesh_P2S2", -1.0}}) {
    const std::string P = p.name;
    // In A's frame: the planet's axis a = out x, the path (the way it travels, A turning about -z)
    // -out y; mesh with S1 at its -z side: radial -z, t = a x radial = out y; with S2: +z, -out y.
    const Eigen::Vector3d a(p.out, 0, 0), path(0, -p.out, 0);
    double worst = 0;
    for (size_t i = 0; i < pitch_->rows().size(); ++i) {
      const auto& row = pitch_->rows()[i];
      if (row[0] < 4.0) continue;
      auto at = [&](const std::string& c) { return row[pitch_->Index(c)]; };
      Eigen::Matrix3d ra;
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) ra(r, c) = at("A.R." + std::to_string(10 * (r + 1) + c + 1));
      // The force on the planet (gear a) from a mesh: -F_t t - F_r radial + F_a a.
      auto mesh = [&](const std::string& m, const Eigen::Vector3d& radial) {
        return Eigen::Vector3d(-at(m + ".F_t") * a.cross(radial) - at(m + ".F_r") * radial + at(m + ".F_a") * a);
      };
      const Eigen::Vector3d teeth = mesh(p.s1, {0, 0, -1}) + mesh(p.s2, {0, 0, 1});
      const Eigen::Vector3d bearing = ra.transpose() * Eigen::Vector3d(at(P + "_bearing.F.x"), at(P + "_bearing.F.y"), at(P + "_bearing.F.z"));
      const Eigen::Vector3d ma = ra.transpose() * Eigen::Vector3d(at(P + ".F.x"), at(P + ".F.y"), at(P + ".F.z"));
      worst = std::max(worst, (bearing + teeth - ma).norm());
      // The example's signals: the same bearing force along the path, the axis and A's z.
      EXPECT_NEAR(at(P + "_bearing_tangential"), bearing.dot(path), 1e-9) << P << " at t = " << row[0];
      EXPECT_NEAR(at(P + "_bearing_axial"), bearing.dot(a), 1e-9) << P;
      EXPECT_NEAR(at(P + "_bearing_normal"), bearing.z(), 1e-9) << P;
    }
    EXPECT_LT(worst, 1e-9 * kLoad / kSunRadius) << P;
    const double ft = std::abs(Mean(*pitch_, std::string(p.s1) + ".F_t")) + std::abs(Mean(*pitch_, std::string(p.s2) + ".F_t"));
    EXPECT_NEAR(Mean(*pitch_, P + "_bearing_tangential"), ft, 2e-3 * ft) << P;
    const double thrust = ft * kTan20 * std::sin(kPlanetCone), centripetal = kPlanetMass * kCarrierSpeed * kCarrierSpeed * 0.1;
    EXPECT_NEAR(Mean(*pitch_, P + "_bearing_axial"), -(thrust + centripetal), 2e-3 * (thrust + centripetal)) << P;
    EXPECT_NEAR(Mean(*pitch_, P + "_bearing_normal"), 0.0, 1e-3 * ft) << P;
  }
}

// The contact's state-dependent moduli (formulas of B.r and B.R) give the interpreter's bits in
// the generated code: every state derivative at the initial state and at states nearby.
TEST(DifferentialPitchEngines, InterpreterAndGeneratedCodeGiveTheSameBits) {
  const LoadedModel lm = LoadModelFile(ExamplePath("differential_pitch.yaml"));
  const auto interpreter = CompiledModel::Compile(lm.graph, lm.compile), generated = interpreter;  // one model, two engines
  const auto code = GeneratedRhs::Start(generated);
  if (!code->Wait()) GTEST_SKIP() << code->engine();
  ASSERT_TRUE(code->ready()) << code->engine();
  Workspace wi = interpreter->MakeWorkspace(), wg = generated->MakeWorkspace(code.get());
  const Eigen::VectorXd x0 = interpreter->MakeInitialState();
  const int n = static_cast<int>(x0.size());
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int trial = 0; trial < 4; ++trial) {
    Eigen::VectorXd x = x0, di(n), dg(n);
    if (trial > 0)
      for (int i = 0; i < n; ++i) x[i] += std::ldexp(u(rng), -4 * (4 - trial)) * (1.0 + std::abs(x[i]));
    interpreter->CalcDerivatives(1.5, x.data(), di.data(), wi);
    generated->CalcDerivatives(1.5, x.data(), dg.data(), wg);
    int differ = 0;
    for (int i = 0; i < n; ++i) differ += std::memcmp(&di[i], &dg[i], sizeof(double)) != 0;
    EXPECT_EQ(differ, 0) << "trial " << trial;
  }
}

}  // namespace
}  // namespace multibond
