// Joint coordinates (sim/joint_coordinates.h): a change of variables of the model's ODE. The map
// from joint coordinates y to the model's state x and the derivative map back must agree with the
// model's own right-hand side, and a run in joint coordinates must give the run in inertial
// coordinates.

#include "multibond/sim/joint_coordinates.h"

#include <cmath>
#include <random>

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
  const double h = 1e-5;
  const Eigen::VectorXd yp = y + h * ydot, ym = y - h * ydot;
  jc.ToModel(yp.data(), xp.data());
  jc.ToModel(ym.data(), xm.data());
  const Eigen::VectorXd fd = (xp - xm) / (2 * h);
  for (int i = 0; i < nx; ++i)
    EXPECT_NEAR(fd[i], xdot[i], 1e-6 * (1.0 + std::abs(xdot[i]))) << f.model->state_names()[i];
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
