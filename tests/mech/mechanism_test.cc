// The rigid-body library against closed-form answers and invariants.

#include <cmath>
#include <numbers>
#include <tuple>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "support/example_runner.h"

#include "multibond/compile/compiled_model.h"
#include "multibond/mech/mechanism.h"
#include "multibond/sim/simulator.h"

namespace multibond::mech {
namespace {

using std::numbers::pi;

RecordingObserver Simulated(const Mechanism& m, double t_end, double dt, double rtol = 1e-10, double atol = 1e-12,
                            bool project = true) {
  RecordingObserver rec =
      testing::RunGraph(m.Build("test"), {}, t_end, dt, IntegratorOptions{}.method, rtol, atol, project);
  EXPECT_EQ(rec.summary().status, RunStatus::kOk) << rec.summary().message;
  return rec;
}

Eigen::Matrix3d OrientationAt(const RecordingObserver& rec, size_t row, const std::string& body) {
  Eigen::Matrix3d r;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) r(i, j) = rec.rows()[row][rec.Index(body + ".R." + std::to_string(10 * (i + 1) + j + 1))];
  return r;
}

Eigen::Vector3d VectorAt(const RecordingObserver& rec, size_t row, const std::string& name) {
  return {rec.rows()[row][rec.Index(name + ".x")], rec.rows()[row][rec.Index(name + ".y")], rec.rows()[row][rec.Index(name + ".z")]};
}

/// Times at which `f(row)` changes sign, linearly interpolated.
template <typename F>
std::vector<double> ZeroCrossings(const RecordingObserver& rec, F f) {
  std::vector<double> out;
  double prev = f(0);
  for (size_t k = 1; k < rec.rows().size(); ++k) {
    const double cur = f(k);
    if ((prev < 0) != (cur < 0)) {
      const double t0 = rec.rows()[k - 1][0], t1 = rec.rows()[k][0];
      out.push_back(t0 + (t1 - t0) * prev / (prev - cur));
    }
    prev = cur;
  }
  return out;
}

double MaxEnergyResidual(const RecordingObserver& rec, double from_fraction = 0.1) {
  const int res = rec.Index("energy.residual");
  const double t_from = rec.rows().back()[0] * from_fraction;
  double m = 0.0;
  for (const auto& row : rec.rows())
    if (row[0] >= t_from) m = std::max(m, std::abs(row[res]));
  return m;
}

TEST(MassProperties, ShapesMatchTextbookFormulas) {
  const MassProperties disc = MassProperties::Cylinder(2700, 0.4, 0.01, 2);  // the paper's crown wheel
  const double m = 2700 * pi * 0.2 * 0.2 * 0.01;
  EXPECT_NEAR(disc.mass, m, 1e-12);
  EXPECT_NEAR(disc.inertia(2, 2), m * 0.04 / 2, 1e-15);
  EXPECT_NEAR(disc.inertia(0, 0), m * (3 * 0.04 + 1e-4) / 12, 1e-15);
  const MassProperties box = MassProperties::Box(1000, {0.1, 0.2, 0.3});
  EXPECT_NEAR(box.mass, 6.0, 1e-12);
  EXPECT_NEAR(box.inertia(0, 0), 6.0 * (0.04 + 0.09) / 12, 1e-15);
  const MassProperties ball = MassProperties::Sphere(1000, 0.2);
  EXPECT_NEAR(ball.inertia(1, 1), 0.4 * ball.mass * 0.01, 1e-15);
  EXPECT_FALSE(MassProperties::PointMass(1).has_rotation());
}

// A revolute or prismatic joint couples the two directions perpendicular to its axis: along a
// coordinate axis they are the other two, positive (their columns are named .x/.y/.z); along any
// axis, an orthonormal pair orthogonal to it.
TEST(Joints, PerpendicularDirectionsOfACoordinateAxisAreTheOtherTwoAxes) {
  for (int axis = 0; axis < 3; ++axis) {
    const Eigen::Matrix<double, 2, 3> p = Perpendicular(Eigen::Vector3d::Unit(axis));
    for (int r = 0; r < 2; ++r) {
      EXPECT_NEAR(p.row(r).maxCoeff(), 1.0, 1e-15) << "axis " << axis << ", row " << r << ": " << p.row(r);
      EXPECT_NEAR(p(r, axis), 0.0, 1e-15);
    }
  }
  const Eigen::Vector3d a = Eigen::Vector3d(1.0, -2.0, 0.5).normalized();
  const Eigen::Matrix<double, 2, 3> p = Perpendicular(a);
  EXPECT_LT((p * p.transpose() - Eigen::Matrix2d::Identity()).norm(), 1e-14);
  EXPECT_LT((p * a).norm(), 1e-14);
}

TEST(RigidBody, TorqueFreeFlipConservesEnergyAndMomentumAndHasTheEllipticPeriod) {
  // An asymmetric body (I1 < I2 < I3) spun near its intermediate axis: the Dzhanibekov flip.
  const double i1 = 1, i2 = 2, i3 = 3;
  const Eigen::Vector3d w0(0.25, 5.0, 0.25);  // body = inertial frame at t = 0
  Mechanism m;
  Body b;
  b.name = "B";
  b.mass = MassProperties::Given(1.0, Eigen::Vector3d(i1, i2, i3).asDiagonal());
  b.omega = w0;
  m.AddBody(b);
  const RecordingObserver rec = Simulated(m, 20.0, 1e-3, 1e-11, 1e-13);

  const Eigen::Vector3d iw = Eigen::Vector3d(i1, i2, i3).cwiseProduct(w0);
  const double two_e = w0.dot(iw), l2 = iw.squaredNorm();
  double max_de = 0, max_dh = 0;
  for (size_t k = 0; k < rec.rows().size(); ++k) {
    max_de = std::max(max_de, std::abs(2 * rec.rows()[k][rec.Index("energy.kinetic")] - two_e) / two_e);
    max_dh = std::max(max_dh, std::abs(VectorAt(rec, k, "B.h").squaredNorm() - l2) / l2);
  }
  EXPECT_LT(max_de, 1e-8);
  EXPECT_LT(max_dh, 1e-8);

  // Landau & Lifshitz, Mechanics, sec. 37 (L^2 > 2 E I2): the body-frame w2 ~ sn(tau, k) with
  // tau = lambda t, lambda = sqrt((I3 - I2)(L^2 - 2 E I1) / (I1 I2 I3)); sn changes sign every 2 K(k).
  ASSERT_GT(l2, two_e * i2);
  const double lambda = std::sqrt((i3 - i2) * (l2 - two_e * i1) / (i1 * i2 * i3));
  const double k2 = (i2 - i1) * (two_e * i3 - l2) / ((i3 - i2) * (l2 - two_e * i1));
  const double half_period = 2 * std::comp_ellint_1(std::sqrt(k2)) / lambda;
  const auto crossings = ZeroCrossings(rec, [&](size_t k) {
    return (OrientationAt(rec, k, "B").transpose() * VectorAt(rec, k, "B.omega"))[1];
  });
  ASSERT_GE(crossings.size(), 4u);
  const double measured = (crossings.back() - crossings.front()) / static_cast<double>(crossings.size() - 1);
  EXPECT_NEAR(measured, half_period, 1e-6 * half_period);
  EXPECT_EQ(rec.Last("energy.work"), 0.0);
}

TEST(RigidBody, OrientationStaysOrthonormalAtDefaultTolerances) {
  Mechanism m;
  Body b;
  b.name = "B";
  b.mass = MassProperties::Box(1000, {0.1, 0.2, 0.3});
  b.omega = Eigen::Vector3d(3.0, -7.0, 11.0);
  m.AddBody(b);
  auto worst_drift = [](const RecordingObserver& rec) {
    double worst = 0;
    for (const auto& row : rec.rows()) worst = std::max(worst, row[rec.Index("B.orthonormality")]);
    return worst;
  };
  // The CLI's defaults (BDF, rtol 1e-8, atol 1e-10, projection on), then the same without the
  // projection: the drift column shows what the integration alone does.
  EXPECT_LT(worst_drift(Simulated(m, 10.0, 1e-2, 1e-8, 1e-10)), 1e-9);
  EXPECT_GT(worst_drift(Simulated(m, 10.0, 1e-2, 1e-8, 1e-10, false)), 1e-7);
}

TEST(RigidBody, HorizontalGyroscopePrecessesAtMglOverIsS) {
  // A disc spinning about its horizontal symmetry axis (body x), its centre l from a spherical
  // pivot: steady precession at exactly W = m g l / (I_s s) (theta = 90 degrees).
  const double g = 9.81, l = 0.1, s = 200.0;
  const MassProperties disc = MassProperties::Cylinder(7800, 0.1, 0.02, 0);
  const double big_omega = disc.mass * g * l / (disc.inertia(0, 0) * s);
  Mechanism m;
  m.SetGravity({0, 0, -g});
  Body b;
  b.name = "rotor";
  b.mass = disc;
  b.position = {l, 0, 0};
  b.omega = {s, 0, big_omega};
  b.velocity = Eigen::Vector3d(0, 0, big_omega).cross(b.position);
  m.AddBody(b);
  Joint pivot = MakeSpherical("pivot", kGround, "rotor", Eigen::Vector3d::Zero(), 1e8, 200);
  pivot.child_point = {-l, 0, 0};
  m.AddJoint(pivot);
  const double t_end = 2.0;
  const RecordingObserver rec = Simulated(m, t_end, 1e-3);
  // Azimuth of the spin axis (the first column of R), unwrapped.
  double phi = 0, prev = 0;
  for (size_t k = 0; k < rec.rows().size(); ++k) {
    const Eigen::Matrix3d r = OrientationAt(rec, k, "rotor");
    const double a = std::atan2(r(1, 0), r(0, 0));
    if (k > 0) phi += std::remainder(a - prev, 2 * pi);
    prev = a;
  }
  EXPECT_NEAR(phi / t_end, big_omega, 1e-4 * big_omega);
  EXPECT_LT(MaxEnergyResidual(rec), 1e-8);
}

/// A uniform bar of length 1 m hanging from a stiff revolute joint about y at its top end.
Mechanism Pendulum(double theta0, double* inertia_pivot, double* mass, bool sensors = false) {
  const double len = 1.0, l = len / 2;
  const MassProperties bar = MassProperties::Box(2700, {0.02, 0.02, len});
  *inertia_pivot = bar.inertia(1, 1) + bar.mass * l * l;
  *mass = bar.mass;
  Mechanism m;
  m.SetGravity({0, 0, -9.81});
  Body b;
  b.name = "bar";
  b.mass = bar;
  b.orientation = Eigen::AngleAxisd(theta0, Eigen::Vector3d::UnitY()).toRotationMatrix();
  b.position = b.orientation * Eigen::Vector3d(0, 0, -l);
  m.AddBody(b);
  Joint j = MakeRevolute("hinge", kGround, "bar", Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitY(), 1e9, 2e3, 1e7, 20);
  j.child_point = {0, 0, l};
  j.sensors = sensors;
  m.AddJoint(j);
  return m;
}

TEST(RigidBody, CompoundPendulumSmallAmplitudePeriod) {
  double ip, mass;
  const Mechanism m = Pendulum(0.01, &ip, &mass);
  const double t0 = 2 * pi * std::sqrt(ip / (mass * 9.81 * 0.5));
  // The hinge deflects by ~1e-8 m: an absolute tolerance of 1e-15 resolves it to 1e-7, so that
  // the energy balance of this small swing (~3e-4 J) is checked at the same 1e-8 as elsewhere.
  const RecordingObserver rec = Simulated(m, 4 * t0, 1e-4, 1e-10, 1e-15);
  const auto crossings = ZeroCrossings(rec, [&](size_t k) { return rec.rows()[k][rec.Index("bar.r.x")]; });
  ASSERT_GE(crossings.size(), 6u);
  const double period = 2 * (crossings.back() - crossings.front()) / static_cast<double>(crossings.size() - 1);
  EXPECT_NEAR(period, t0, 1e-4 * t0);  // the amplitude correction theta0^2/16 is 6e-6
  EXPECT_LT(MaxEnergyResidual(rec), 1e-8);
}

TEST(RigidBody, CompoundPendulumReactionAtTheBottomOfTheSwing) {
  const double theta0 = 0.5;
  double ip, mass;
  const Mechanism m = Pendulum(theta0, &ip, &mass);
  const double t0 = 2 * pi * std::sqrt(ip / (mass * 9.81 * 0.5));
  const RecordingObserver rec = Simulated(m, 0.6 * t0, 1e-4);
  const auto crossings = ZeroCrossings(rec, [&](size_t k) { return rec.rows()[k][rec.Index("bar.r.x")]; });
  ASSERT_GE(crossings.size(), 1u);
  // At the bottom the joint carries the weight and the centripetal force: m g + m l w^2, with
  // w^2 = 2 m g l (1 - cos theta0) / I_pivot; the tangential force is zero.
  const double w2 = 2 * mass * 9.81 * 0.5 * (1 - std::cos(theta0)) / ip;
  const double expected = mass * 9.81 + mass * 0.5 * w2;
  EXPECT_NEAR(rec.At("hinge.F.z", crossings[0]), expected, 1e-4 * expected);
  EXPECT_NEAR(rec.At("hinge.F.x", crossings[0]), 0.0, 1e-4 * expected);
  EXPECT_NEAR(rec.At("bar.F.z", crossings[0]), expected, 1e-4 * expected);  // the only coupling
}

// Off by default (each is a state the integrator carries): the hinge's sensor, its junction on the
// axis and its angle, only when asked for.
TEST(JointSensors, AreOffUnlessAskedFor) {
  double ip, mass;
  const BondGraph off = Pendulum(0.5, &ip, &mass).Build("off");
  EXPECT_LT(off.Find("hinge.axial"), 0);
  EXPECT_LT(off.FindAux("hinge.angle"), 0);
  const BondGraph on = Pendulum(0.5, &ip, &mass, true).Build("on");
  EXPECT_GE(on.Find("hinge.axial"), 0);
  EXPECT_GE(on.FindAux("hinge.angle"), 0);
}

TEST(JointSensors, RevoluteAngleAndRateFollowThePendulumsOrientationAndPosition) {
  const double theta0 = 0.5;
  double ip, mass;
  Mechanism m = Pendulum(theta0, &ip, &mass, true);
  const double t0 = 2 * pi * std::sqrt(ip / (mass * 9.81 * 0.5));
  const RecordingObserver rec = Simulated(m, t0, 1e-3, 1e-12, 1e-14);
  const int angle = rec.Index("hinge.angle"), rate = rec.Index("hinge.rate"), wy = rec.Index("bar.omega.y");
  ASSERT_GE(angle, 0);
  ASSERT_GE(rate, 0);
  double max_orientation = 0.0, max_position = 0.0, max_rate = 0.0, min_angle = 0.0;
  for (size_t k = 0; k < rec.rows().size(); ++k) {
    const auto& row = rec.rows()[k];
    const Eigen::Matrix3d r = OrientationAt(rec, k, "bar");
    // About y: R = [[c, 0, s], [0, 1, 0], [-s, 0, c]]; the CoM hangs at R (0, 0, -l) = (-l s, 0, -l c).
    const double from_orientation = std::atan2(r(0, 2), r(0, 0));
    const double from_position = std::atan2(-row[rec.Index("bar.r.x")], -row[rec.Index("bar.r.z")]);
    max_orientation = std::max(max_orientation, std::abs(row[angle] + theta0 - from_orientation));
    max_position = std::max(max_position, std::abs(row[angle] + theta0 - from_position));
    max_rate = std::max(max_rate, std::abs(row[rate] - row[wy]));
    min_angle = std::min(min_angle, row[angle]);
  }
  EXPECT_LT(max_orientation, 1e-9);
  EXPECT_LT(max_position, 1e-8);  // the compliant hinge deflects by ~1e-9 m on an arm of 0.5 m (2.6e-9 rad)
  EXPECT_EQ(max_rate, 0.0);       // the same flow, projected on a fixed axis
  EXPECT_NEAR(min_angle, -2 * theta0, 1e-6);  // a full swing to the other side
}

/// A cube of 0.1 m and 1 kg (a sphere's inertia: the same about every axis).
Body Cube(const std::string& name) {
  Body b;
  b.name = name;
  b.mass = MassProperties::Box(1000, {0.1, 0.1, 0.1});
  return b;
}

TEST(JointSensors, PrismaticSlideAndSpeedAreTheDisplacementAndVelocityAlongTheAxis) {
  Mechanism m;
  Body b = Cube("slider");
  b.position = {0.3, 0.0, 0.0};
  m.AddBody(b);
  // A slider along x in a carriage turned 90 degrees about z: the joint's axis y in the
  // carriage's frame is the world's -x.
  Body c;
  c.name = "carriage";
  c.mass = MassProperties::Box(1000, {0.2, 0.2, 0.05});
  c.orientation = Eigen::AngleAxisd(pi / 2, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  m.AddBody(c);
  m.AddJoint(MakeFixed("mount", kGround, "carriage", Eigen::Vector3d::Zero(), 1e9, 1e3, 1e8, 1e2));
  Joint rail = MakePrismatic("rail", "carriage", "slider", Eigen::Vector3d(0, -0.3, 0), Eigen::Vector3d::UnitY(), 1e9, 1e3, 1e8, 1e2);
  rail.sensors = true;
  m.AddJoint(rail);
  Drive d;
  d.name = "push";
  d.kind = Drive::Kind::kForce;
  d.body = "slider";
  d.axis = Eigen::Vector3d::UnitX();
  d.value = TimeFunction::Constant(2.0);
  m.AddDrive(d);
  const RecordingObserver rec = Simulated(m, 1.0, 1e-2);
  const int slide = rec.Index("rail.slide"), speed = rec.Index("rail.speed");
  ASSERT_GE(slide, 0);
  ASSERT_GE(speed, 0);
  double max_slide = 0.0, max_speed = 0.0;
  for (const auto& row : rec.rows()) {
    max_slide = std::max(max_slide, std::abs(row[slide] + (row[rec.Index("slider.r.x")] - 0.3)));
    max_speed = std::max(max_speed, std::abs(row[speed] + row[rec.Index("slider.v.x")]));
  }
  EXPECT_LT(max_slide, 1e-9);
  EXPECT_LT(max_speed, 1e-9);
  const double accel = 2.0 / b.mass.mass;
  EXPECT_NEAR(rec.Last("rail.slide"), -accel / 2, 1e-6 * accel);  // F t^2 / 2m at t = 1 s, along -x
}

// A ball on a spherical joint at its centre, spinning freely about (0.6, 0.8, 0) at 0.5 rad/s (a
// sphere: the axis stays): after t the relative rotation is the rotation vector (0.3 t, 0.4 t, 0),
// turned about x and y at once, an angle of 0.5 t (to 2.5 rad < pi).
// The same with the joint an ideal constraint: the sensor's signals are formulas that only feed
// outputs, which a model with ideal constraints takes.
class SphericalSensor : public ::testing::TestWithParam<bool> {};

TEST_P(SphericalSensor, RotationIsTheRotationVectorOfTheRelativeOrientation) {
  Mechanism m;
  Body b = Cube("ball");
  b.omega = {0.3, 0.4, 0.0};
  b.orientation = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  m.AddBody(b);
  Joint joint = MakeSpherical("ball_joint", kGround, "ball", Eigen::Vector3d::Zero(), 1e6, 10);
  joint.sensors = true;
  if (GetParam()) MakeRigid(joint);
  m.AddJoint(joint);
  const RecordingObserver rec = Simulated(m, 5.0, 1e-2);
  ASSERT_EQ(m.joints()[0].translation->rigid, GetParam());
  for (const auto& row : rec.rows()) {
    const double t = row[0];
    EXPECT_NEAR(row[rec.Index("ball_joint.rotation.x")], 0.3 * t, 1e-8) << t;
    EXPECT_NEAR(row[rec.Index("ball_joint.rotation.y")], 0.4 * t, 1e-8) << t;
    EXPECT_NEAR(row[rec.Index("ball_joint.rotation.z")], 0.0, 1e-8) << t;
    EXPECT_NEAR(row[rec.Index("ball_joint.rotation.angle")], 0.5 * t, 1e-8) << t;
  }
}

INSTANTIATE_TEST_SUITE_P(JointSensors, SphericalSensor, ::testing::Values(false, true),
                         [](const ::testing::TestParamInfo<bool>& i) { return i.param ? std::string("Rigid") : std::string("Compliant"); });

/// Two spur gears (20 and 40 teeth) on revolute joints to `carrier`, gear a driven at 10 rad/s
/// relative to the carrier, gear b loaded by a viscous drag to the carrier.
Mechanism GearPair(bool spinning_carrier, bool sensors = false) {
  Mechanism m;
  auto disc = [](const std::string& name, double d, const Eigen::Vector3d& at) {
    Body b;
    b.name = name;
    b.mass = MassProperties::Cylinder(7800, d, 0.01, 2);
    b.position = at;
    return b;
  };
  std::string carrier = kGround;
  if (spinning_carrier) {
    carrier = "arm";
    m.AddBody(disc("arm", 0.5, {0, 0, 0}));
    m.AddJoint(MakeRevolute("arm_bearing", kGround, "arm", Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitZ(), 1e7, 100, 1e5, 10));
    Drive d;
    d.name = "arm_drive";
    d.body = "arm";
    d.axis = Eigen::Vector3d::UnitZ();
    d.value = TimeFunction::Constant(3.0);  // the carrier turns at 3 rad/s from t = 0
    d.stiffness = 1e5;
    d.damping = 50;
    m.AddDrive(d);
  }
  m.AddBody(disc("a", 0.1, {0.15, 0, 0.05}));
  m.AddBody(disc("b", 0.2, {0.0, 0, 0.05}));
  const Eigen::Vector3d pa = spinning_carrier ? Eigen::Vector3d(0.15, 0, 0.05) : Eigen::Vector3d(0.15, 0, 0.05);
  const Eigen::Vector3d pb(0.0, 0, 0.05);
  for (const auto& [name, body, at] : {std::tuple{"a_bearing", "a", pa}, std::tuple{"b_bearing", "b", pb}}) {
    Joint bearing = MakeRevolute(name, carrier, body, at, Eigen::Vector3d::UnitZ(), 1e7, 100, 1e4, 10);
    bearing.sensors = sensors;
    m.AddJoint(bearing);
  }
  GearMesh gm;
  gm.name = "mesh";
  gm.carrier = carrier;
  gm.body_a = "a";
  gm.body_b = "b";
  gm.teeth_a = 20;
  gm.teeth_b = 40;
  gm.stiffness = 1e4;
  gm.damping = 2;
  gm.sensors = sensors;
  m.AddGear(gm);
  Drive drive;
  drive.name = "motor";
  drive.body = "a";
  drive.reference = carrier;
  drive.axis = Eigen::Vector3d::UnitZ();
  drive.value = TimeFunction::Step(10.0);
  drive.stiffness = 1e3;
  drive.damping = 5;
  m.AddDrive(drive);
  return m;
}

TEST(GearMeshTest, FixedCarrierSpeedRatioIsTheTeethRatio) {
  const RecordingObserver rec = Simulated(GearPair(false, true), 3.0, 1e-3);
  // The mesh phase is a's rolling angle, its bearing's angle; b turns back by the teeth ratio up
  // to the mesh deflection, the integral of d = s_a + (40/20) s_b: q = phase + 2 angle_b.
  for (const auto& row : rec.rows()) {
    EXPECT_EQ(row[rec.Index("mesh.phase")], row[rec.Index("a_bearing.angle")]) << row[0];
    EXPECT_NEAR(row[rec.Index("mesh.phase")] + 40.0 / 20.0 * row[rec.Index("b_bearing.angle")], row[rec.Index("mesh.mesh.K.q")], 1e-9) << row[0];
  }
  EXPECT_GT(rec.Last("mesh.phase"), 25.0);  // about 10 rad/s for 3 s
  const double wa = rec.Last("a.omega.z"), wb = rec.Last("b.omega.z");
  EXPECT_NEAR(wa, 10.0, 1e-6 * 10);
  EXPECT_NEAR(wb / wa, -20.0 / 40.0, 1e-6);
  EXPECT_LT(MaxEnergyResidual(rec), 1e-8);
}

TEST(GearMeshTest, SpinningCarrierKeepsTheRelativeRatioAndBalancesEnergy) {
  const RecordingObserver rec = Simulated(GearPair(true), 3.0, 1e-3);
  const double wc = rec.Last("arm.omega.z"), wa = rec.Last("a.omega.z"), wb = rec.Last("b.omega.z");
  EXPECT_NEAR(wc, 3.0, 1e-6 * 3);
  EXPECT_NEAR(wa - wc, 10.0, 1e-6 * 10);
  EXPECT_NEAR((wb - wc) / (wa - wc), -0.5, 1e-6);
  EXPECT_LT(MaxEnergyResidual(rec), 1e-8);
  // The carrier carries the mesh reaction: its bearing moment is not zero while the gears spin
  // up, and the work of both drives balances the stored and dissipated energy.
  EXPECT_GT(rec.Last("energy.work"), 0.0);
}

}  // namespace
}  // namespace multibond::mech
