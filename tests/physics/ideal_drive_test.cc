// An ideal velocity drive (docs/mechanisms.md, "Drives"): the drive's speed is an ideal constraint
// and its torque the reaction, against the closed form of a flywheel with a viscous load.

#include <cmath>

#include <gtest/gtest.h>

#include "multibond/compile/compiled_model.h"
#include "multibond/mech/mechanism.h"
#include "support/example_runner.h"

namespace multibond::mech {
namespace {

// A steel disc on a rigid bearing about z, driven ideally at a speed that ramps from 0 to w1 in
// t1 and then stays, against a viscous drag c w about z.
constexpr double kW1 = 10.0, kT1 = 1.0, kDrag = 0.02;

BondGraph Flywheel(double* inertia) {
  Mechanism m;
  Body b;
  b.name = "wheel";
  b.mass = MassProperties::Cylinder(7800, 0.3, 0.05, 2);
  *inertia = b.mass.inertia(2, 2);
  m.AddBody(b);
  Joint bearing = MakeRevolute("bearing", kGround, "wheel", Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitZ(), 1e8, 1e3, 1e6, 10);
  bearing.translation->rigid = true;
  bearing.rotation->rigid = true;
  m.AddJoint(bearing);
  Drive d;
  d.name = "motor";
  d.body = "wheel";
  d.axis = Eigen::Vector3d::UnitZ();
  d.value = TimeFunction::Table({0.0, kT1, 10.0}, {0.0, kW1, kW1});
  d.rigid = true;
  m.AddDrive(d);
  BondGraph g = m.Build("flywheel");
  g.AddTF("drag_axis", Param::Matrix(Eigen::RowVector3d(0, 0, 1)));
  g.AddR("drag", Param::Scalar(kDrag));
  g.Connect("wheel.omega", "drag_axis");
  g.Connect("drag_axis", "drag");
  return g;
}

TEST(IdealDrive, TorqueIsInertiaTimesAccelerationPlusTheViscousLoad) {
  double inertia = 0.0;
  const RecordingObserver rec = testing::RunGraph(Flywheel(&inertia), {}, 3.0, 1e-2);
  ASSERT_EQ(rec.summary().status, RunStatus::kOk) << rec.summary().message;
  const double alpha = kW1 / kT1;
  for (double t : {0.25, 0.5, 0.9}) {
    EXPECT_NEAR(rec.At("wheel.omega.z", t), alpha * t, 1e-9 * kW1) << t;
    const double torque = inertia * alpha + kDrag * alpha * t;
    EXPECT_NEAR(rec.At("motor.torque", t), torque, 1e-9 * torque) << t;
  }
  for (double t : {1.5, 2.0, 3.0}) {
    EXPECT_NEAR(rec.At("wheel.omega.z", t), kW1, 1e-9 * kW1) << t;
    EXPECT_NEAR(rec.At("motor.torque", t), kDrag * kW1, 1e-9 * kDrag * kW1) << t;
  }
  // The drive's work is the kinetic energy plus the drag's dissipation: at t = 3,
  // 1/2 J w1^2 and c (alpha^2 t1^3 / 3 + w1^2 (3 - t1)).
  const double kinetic = 0.5 * inertia * kW1 * kW1, dissipated = kDrag * (alpha * alpha * kT1 * kT1 * kT1 / 3 + kW1 * kW1 * (3.0 - kT1));
  EXPECT_NEAR(rec.Last("energy.kinetic"), kinetic, 1e-9 * kinetic);
  EXPECT_NEAR(rec.Last("energy.dissipated"), dissipated, 1e-8 * dissipated);
  EXPECT_NEAR(rec.Last("motor.source.work"), kinetic + dissipated, 1e-8 * (kinetic + dissipated));
  EXPECT_LT(testing::MaxEnergyResidual(rec), 1e-9 * (kinetic + dissipated));
}

}  // namespace
}  // namespace multibond::mech
