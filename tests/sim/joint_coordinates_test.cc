// Joint coordinates (sim/joint_coordinates.h): a change of variables of the model's ODE. The map
// from joint coordinates y to the model's state x and the derivative map back must agree with the
// model's own right-hand side, and a run in joint coordinates must give the run in inertial
// coordinates.

#include "multibond/sim/joint_coordinates.h"

#include <cmath>
#include <cstdio>
#include <numbers>
#include <random>
#include <string>
#include <vector>

#include <fmt/format.h>

#include <gtest/gtest.h>

#include "multibond/io/model_loader.h"
#include "multibond/sim/simulator.h"
#include "support/example_runner.h"

namespace multibond {
namespace {

// A double pendulum whose hinges are off both bodies' centres of mass (the anchors matter), the
// upper one rigid and the lower one compliant, a point mass hung from the lower bar by a spring
// joint, and a free body that tumbles about no axis of any joint (it needs re-charting).
constexpr const char* kMechanism = R"(
model: chain
gravity: [0, 0, -9.81]
bodies:
  upper: {mass: 2.0, inertia: [0.02, 0.2, 0.2], position: [0.5, 0, 0]}
  lower: {mass: 1.0, inertia: [0.01, 0.1, 0.1], position: [1.5, 0, 0], omega: [0, 3, 0]}
  bob:   {mass: 0.5, position: [2.0, 0, -0.2]}
  tumbler: {mass: 1.0, inertia: [0.1, 0.2, 0.3], position: [0, 5, 0], omega: [0.6, 8.0, 0.4]}
joints:
  top:    {type: revolute, child: upper, at: [0, 0, 0], child_at: [-0.5, 0, 0], axis: y, rigid: true}
  elbow:  {type: revolute, parent: upper, child: lower, child_at: [-0.5, 0, 0], axis: y,
           translation: {K: 1.0e5, R: 20}, rotation: {K: 1.0e4, R: 5}}
  spring: {type: spherical, parent: lower, child: bob, child_at: [0, 0, 0], translation: {K: 200, R: 0.5}}
simulation: {t_end: 2.0, dt: 0.01, solver: dopri5, rtol: 1.0e-9, atol: 1.0e-11}
)";

struct Fixture {
  LoadedModel lm = LoadModelString(kMechanism, "<chain>");
  std::shared_ptr<const CompiledModel> model = CompiledModel::Compile(lm.graph, lm.compile);
  JointTree tree = lm.mechanism->MakeJointTree();
};

TEST(JointTree, FollowsTheJointsThatHoldTheMostRotation) {
  const Fixture f;
  ASSERT_EQ(f.tree.size(), 4u);
  EXPECT_EQ(f.tree[0].name, "upper");
  EXPECT_EQ(f.tree[0].parent, "");
  EXPECT_EQ(f.tree[0].joint, "top");
  EXPECT_TRUE(f.tree[0].anchor.isApprox(Eigen::Vector3d(-0.5, 0, 0)));
  EXPECT_NEAR(std::abs(f.tree[0].axis.dot(Eigen::Vector3d::UnitY())), 1.0, 1e-15);  // the hinge's free axis
  EXPECT_EQ(f.tree[1].name, "lower");
  EXPECT_EQ(f.tree[1].parent, "upper");
  EXPECT_EQ(f.tree[2].name, "bob");
  EXPECT_EQ(f.tree[2].parent, "lower");
  EXPECT_EQ(f.tree[3].name, "tumbler");  // no joint: from the ground, about its initial spin
  EXPECT_EQ(f.tree[3].parent, "");
  EXPECT_TRUE(f.tree[3].axis.isApprox(Eigen::Vector3d(0.6, 8.0, 0.4).normalized()));
}

/// A joint-coordinate state with every component nonzero (off-axis rotations included).
Eigen::VectorXd SomeState(JointCoordinateSystem& jc, const CompiledModel& model) {
  Eigen::VectorXd x = model.MakeInitialState(), y(jc.num_states());
  jc.FromModel(x.data(), y.data());
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-0.3, 0.3);
  for (int i = 0; i < y.size(); ++i) y[i] += u(rng);
  return y;
}

// ToModel(FromModel(x)) = x: charting anew at any state changes the coordinates, not the motion.
TEST(JointCoordinates, ChartingAgainKeepsTheState) {
  Fixture f;
  ModelSystem system(*f.model);
  JointCoordinateSystem jc(*f.model, f.tree, &system);
  const Eigen::VectorXd y = SomeState(jc, *f.model);
  Eigen::VectorXd x1(f.model->num_states()), x2(f.model->num_states()), y2(jc.num_states());
  jc.ToModel(y.data(), x1.data());
  jc.FromModel(x1.data(), y2.data());
  jc.ToModel(y2.data(), x2.data());
  EXPECT_LT((x2 - x1).cwiseAbs().maxCoeff(), 1e-13);
}

// The chain rule: x(t) = ToModel(y(t)) with dy/dt from the system must move as the model's own
// right-hand side says, in every state (orientations and positions: the kinematics; momenta: the
// model's forces and constraint reactions, mapped to joint accelerations and back). Central
// differences along dy/dt, at a state where nothing is at rest.
TEST(JointCoordinates, DerivativesAreTheModelsThroughTheChainRule) {
  Fixture f;
  ModelSystem system(*f.model);
  JointCoordinateSystem jc(*f.model, f.tree, &system);
  const Eigen::VectorXd y = SomeState(jc, *f.model);
  const int nx = f.model->num_states();
  Eigen::VectorXd ydot(jc.num_states()), x(nx), xdot(nx), xp(nx), xm(nx);
  const double t = 0.1;
  jc.CalcDerivatives(t, y.data(), ydot.data());
  jc.ToModel(y.data(), x.data());
  Workspace ws = f.model->MakeWorkspace();
  f.model->CalcDerivatives(t, x.data(), xdot.data(), ws);
  const double h = 3e-7;  // central differences' own error, h^2 x''': 2.4e-3 of bob.p at 1e-5 with the momenta stored
  const Eigen::VectorXd yp = y + h * ydot, ym = y - h * ydot;
  jc.ToModel(yp.data(), xp.data());
  jc.ToModel(ym.data(), xm.data());
  const Eigen::VectorXd fd = (xp - xm) / (2 * h);
  for (int i = 0; i < nx; ++i)
    EXPECT_NEAR(fd[i], xdot[i], 1e-6 * (1.0 + std::abs(xdot[i]))) << f.model->state_names()[i];
}

// The Jacobian pattern (BuildPattern) holds every entry that can be nonzero: a difference
// quotient of every column, at a state off the start (every coordinate nudged), moves only rows
// the pattern has, in the test mechanism and the shipped models. It is also tight enough to
// matter: the compliant differential's 154 states have 5.6k entries (the true Jacobian 3.6k)
// where every body state coupled to every other made 17k, so its Newton matrices are sparse.
TEST(JointCoordinates, JacobianPatternHoldsEveryDependence) {
  struct Case {
    std::string name;
    LoadedModel lm;
  };
  std::vector<Case> cases;
  cases.push_back({"test mechanism", LoadModelString(kMechanism, "<chain>")});
  for (const char* e : {"differential.yaml", "mechanisms/four_bar.yaml", "gyroscope.yaml", "spinning_top.yaml"})
    cases.push_back({e, LoadModelFile(testing::ExamplePath(e))});
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    const auto model = CompiledModel::Compile(c.lm.graph, c.lm.compile);
    ModelSystem system(*model);
    JointCoordinateSystem jc(*model, c.lm.mechanism->MakeJointTree(), &system);
    const JacobianPattern* pattern = jc.jacobian_pattern();
    ASSERT_NE(pattern, nullptr);
    const int n = jc.num_states();
    Eigen::VectorXd y(n), f0(n), f1(n);
    const Eigen::VectorXd x = model->MakeInitialState();
    jc.FromModel(x.data(), y.data());
    for (int i = 0; i < n; ++i) y[i] += 1e-3 * std::sin(1.0 + i);
    jc.CalcDerivatives(0.1, y.data(), f0.data());
    int missing = 0, nonzero = 0;
    for (int j = 0; j < n; ++j) {
      Eigen::VectorXd yp = y;
      yp[j] += 1e-6 * std::max(1.0, std::abs(y[j]));
      jc.CalcDerivatives(0.1, yp.data(), f1.data());
      for (int i = 0; i < n; ++i) {
        if (!(std::abs(f1[i] - f0[i]) > 1e-13 * (1.0 + std::abs(f0[i])))) continue;  // not moved, or by rounding only
        ++nonzero;
        if (!pattern->Contains(i, j) && ++missing <= 5) {
          ADD_FAILURE() << "d " << jc.state_names()[i] << "' / d " << jc.state_names()[j] << " is not in the pattern";
        }
      }
    }
    EXPECT_EQ(missing, 0);
    EXPECT_LE(nonzero, pattern->nonzeros());
    std::printf("%s: %d states, %d entries in the pattern, %d moved by a difference quotient\n", c.name.c_str(), n,
                pattern->nonzeros(), nonzero);
    if (c.name == "differential.yaml") {
      EXPECT_LT(pattern->nonzeros(), kSparseMaxDensity * n * n);  // so its Newton matrices are sparse
    }
  }
}

// The same motion in both coordinates: every output column agrees to the tolerance, over 2 s of
// swinging (the rigid hinge's reactions, the compliant elbow's deflection, the tumbler re-charted
// as its rotation leaves its initial axis).
TEST(JointCoordinates, RunAgreesWithInertialCoordinates) {
  Fixture f;
  RunOptions o;
  o.t_end = 2.0;
  o.dt = 0.01;
  o.integrator.method = Method::kDormandPrince;
  o.integrator.rtol = 1e-10;
  o.integrator.atol = 1e-12;
  RecordingObserver inertial, joint;
  Simulate(*f.model, o, inertial);
  o.joint_coordinates = f.tree;
  Simulate(*f.model, o, joint);
  ASSERT_EQ(inertial.summary().status, RunStatus::kOk);
  ASSERT_EQ(joint.summary().status, RunStatus::kOk) << joint.summary().message;
  ASSERT_EQ(inertial.columns().size(), joint.columns().size());
  ASSERT_EQ(inertial.rows().size(), joint.rows().size());
  for (size_t c = 0; c < inertial.columns().size(); ++c) {
    const std::string& name = inertial.columns()[c].name;
    ASSERT_EQ(name, joint.columns()[c].name);
    double scale = 1.0, worst = 0.0;
    for (size_t k = 0; k < inertial.rows().size(); ++k) {
      scale = std::max(scale, std::abs(inertial.rows()[k][c]));
      worst = std::max(worst, std::abs(inertial.rows()[k][c] - joint.rows()[k][c]));
    }
    EXPECT_LT(worst / scale, 1e-6) << name;
  }
  EXPECT_LT(testing::MaxEnergyResidual(joint), 1e-8);
  EXPECT_GT(joint.summary().recharts, 0);  // the tumbler: about its intermediate axis, unstable
  for (const char* b : {"upper", "lower", "tumbler"})
    EXPECT_LT(joint.Last(std::string(b) + ".orthonormality"), 1e-12) << b;
}

/// The azimuth of a body axis (column `col` of the body's R: 1, 2 or 3) at every row, unwrapped.
std::vector<double> Azimuth(const RecordingObserver& rec, const std::string& body, int col) {
  const int x = rec.Index(fmt::format("{}.R.1{}", body, col)), y = rec.Index(fmt::format("{}.R.2{}", body, col));
  std::vector<double> out;
  double prev = 0.0, phi = 0.0;
  for (const auto& row : rec.rows()) {
    const double a = std::atan2(row[y], row[x]);
    if (!out.empty()) phi += std::remainder(a - prev, 2 * std::numbers::pi);
    prev = a;
    out.push_back(phi);
  }
  return out;
}

// examples/gyroscope.yaml: a rotor spinning at 200 rad/s in gimbals, released without
// precession. Under every solver (the CLI's rtol 1e-8, atol 1e-10; rk4 at a fixed 1 ms), in
// joint coordinates, to its end: the energy conserved, and the rotor's axis, the rings' angles
// and every body's angular velocity those of a reference run in inertial coordinates (dopri5,
// rtol 1e-10). The rotor's own phase is left out: at rtol 1e-8 it is good to rtol times the
// 2,000 rad it turns through, in either coordinates. Measured: at most 8.5e-6 of the column's
// scale (bs3; inertial coordinates under the same settings: up to 2.9e-6 with BDF, 3.8e-3 with
// Adams, which cannot project, and 1.6e-3 with rk4), energy residuals below 7e-9. The axis
// precesses on average at m g l / (I_s s) (a fast gyroscope: within the nutation's share, a few
// percent).
TEST(Gyroscope, RunsToItsEndUnderEverySolverWithTheInertialMotion) {
  const RecordingObserver ref = testing::RunExampleWith("gyroscope.yaml", Method::kDormandPrince, false, 1e-10, 1e-12);
  ASSERT_EQ(ref.summary().status, RunStatus::kOk) << ref.summary().message;
  const double t_end = ref.rows().back()[0];
  ASSERT_DOUBLE_EQ(t_end, 10.0);
  std::vector<std::string> compared;
  for (const char* c : {"1", "2", "3"}) compared.push_back(fmt::format("rotor.R.{}2", c));  // the spin axis
  for (const char* c : {"11", "21", "22", "33"}) compared.push_back(fmt::format("outer.R.{}", c));
  for (const char* c : {"22", "32", "23", "33"}) compared.push_back(fmt::format("inner.R.{}", c));
  for (const char* b : {"outer", "inner", "rotor"})
    for (const char* c : {"x", "y", "z"}) compared.push_back(fmt::format("{}.omega.{}", b, c));
  for (const Method m : {Method::kBdf, Method::kAdams, Method::kDormandPrince, Method::kBogackiShampine, Method::kStabilizedRk3,
                         Method::kRk4}) {
    SCOPED_TRACE(MethodName(m));
    const RecordingObserver run = testing::RunExampleWith("gyroscope.yaml", m, true);
    ASSERT_EQ(run.summary().status, RunStatus::kOk) << run.summary().message;
    ASSERT_EQ(run.rows().size(), ref.rows().size());
    EXPECT_DOUBLE_EQ(run.rows().back()[0], t_end);
    EXPECT_LT(testing::MaxEnergyResidual(run), 1e-7);
    for (const std::string& name : compared) {
      const int c = run.Index(name);
      double worst = 0.0, scale = 1.0;
      for (size_t k = 0; k < ref.rows().size(); ++k) {
        scale = std::max(scale, std::abs(ref.rows()[k][c]));
        worst = std::max(worst, std::abs(run.rows()[k][c] - ref.rows()[k][c]));
      }
      EXPECT_LT(worst / scale, 2e-5) << name;
    }
  }
  const double g = 9.81, l = 0.05, s = 200.0, m = 7800 * std::numbers::pi * 0.05 * 0.05 * 0.02, i_s = m * 0.05 * 0.05 / 2;
  const double mean_rate = Azimuth(ref, "rotor", 2).back() / t_end;
  EXPECT_NEAR(mean_rate, m * g * l / (i_s * s), 0.05 * m * g * l / (i_s * s));
}

// examples/spinning_top.yaml: a fast top started in steady precession. Its axis keeps its 30
// degrees from the vertical and turns about it at the slower root W of
// I1p W^2 cos(theta) - I3 w3 W + m g l = 0, close to the fast-top rate m g l / (I3 w3) (by the
// ratio of the first term to the last, 1.2 % here), in joint coordinates as in inertial ones.
TEST(SpinningTop, PrecessesAtTheClosedFormRate) {
  const double m = 1.0, i1 = 0.004, i3 = 0.002, l = 0.1, g = 9.81, w3 = 500.0, theta = std::numbers::pi / 6;
  const double i1p = i1 + m * l * l, c = std::cos(theta);
  const double w = (i3 * w3 - std::sqrt(i3 * w3 * i3 * w3 - 4 * i1p * c * m * g * l)) / (2 * i1p * c);
  for (const bool joint : {true, false}) {
    SCOPED_TRACE(joint ? "joint coordinates" : "inertial coordinates");
    const RecordingObserver rec = testing::RunExampleWith("spinning_top.yaml", Method::kBdf, joint);
    ASSERT_EQ(rec.summary().status, RunStatus::kOk) << rec.summary().message;
    const std::vector<double> phi = Azimuth(rec, "top", 3);
    for (size_t k = 0; k < rec.rows().size(); k += 50) {
      const double t = rec.rows()[k][0];
      EXPECT_NEAR(phi[k], w * t, 1e-6 * std::max(1.0, w * t)) << "t = " << t;
      EXPECT_NEAR(rec.rows()[k][rec.Index("top.R.33")], c, 1e-6) << "t = " << t;  // the tilt
    }
    EXPECT_NEAR(phi.back() / rec.rows().back()[0], m * g * l / (i3 * w3), 0.015 * w);
    EXPECT_LT(testing::MaxEnergyResidual(rec), 1e-7);
  }
}

// A disc spinning at 200 rad/s about its horizontal symmetry axis, its centre l = 0.1 m from a
// rigid spherical pivot, started in steady precession: W = m g l / (I_s s) exactly (the axis
// horizontal), its angular velocity off the symmetry axis by W / s = 0.02 rad. In joint
// coordinates the axis turns a full circle about the vertical in 1.6 s: re-charted as it
// leaves each chart, about the disc's own axis each time, and the azimuth still turns at W.
TEST(JointCoordinates, GyroscopeOnAPivotPrecessesAtMglOverIsSAcrossRecharts) {
  const double g = 9.81, l = 0.1, s = 200.0, m = 7800 * std::numbers::pi * 0.05 * 0.05 * 0.02, i_s = m * 0.05 * 0.05 / 2;
  const double w = m * g * l / (i_s * s);
  const std::string yaml = fmt::format(R"(
model: gyroscope_on_a_pivot
gravity: [0, 0, -{}]
bodies:
  rotor: {{shape: {{disc: {{diameter: 0.1, thickness: 0.02, axis: x}}}}, density: 7800, position: [{}, 0, 0],
          omega: [{}, 0, {:.17g}], velocity: [0, {:.17g}, 0]}}
joints:
  pivot: {{type: spherical, child: rotor, at: [0, 0, 0], child_at: [-{}, 0, 0], rigid: true}}
)", g, l, s, w, w * l, l);
  const LoadedModel lm = LoadModelString(yaml, "<gyroscope>");
  const auto model = CompiledModel::Compile(lm.graph, lm.compile);
  RunOptions o;
  o.t_end = 2.0;
  o.dt = 0.01;
  o.joint_coordinates = lm.mechanism->MakeJointTree();
  RecordingObserver rec;
  Simulate(*model, o, rec);
  ASSERT_EQ(rec.summary().status, RunStatus::kOk) << rec.summary().message;
  EXPECT_GE(rec.summary().recharts, 4);
  const std::vector<double> phi = Azimuth(rec, "rotor", 1);
  for (size_t k = 0; k < rec.rows().size(); k += 20)
    EXPECT_NEAR(phi[k], w * rec.rows()[k][0], 1e-6 * std::max(1.0, w * rec.rows()[k][0])) << "t = " << rec.rows()[k][0];
  EXPECT_LT(testing::MaxEnergyResidual(rec), 1e-6);  // 3.2e-7: BDF at rtol 1e-8, restarted at each re-chart
}

TEST(JointCoordinates, RefusesATreeThatDoesNotFitTheModel) {
  Fixture f;
  JointTree bad = f.tree;
  bad[1].parent = "bob";  // a parent after its child
  EXPECT_THROW(JointCoordinateSystem(*f.model, bad), std::invalid_argument);
  bad = f.tree;
  bad[2].name = "nobody";
  EXPECT_THROW(JointCoordinateSystem(*f.model, bad), std::invalid_argument);
  bad = f.tree;
  bad.push_back(bad[0]);
  EXPECT_THROW(JointCoordinateSystem(*f.model, bad), std::invalid_argument);
}

}  // namespace
}  // namespace multibond
