// The state layout on its own (compile/state_layout.h): built from hand-made graphs and slot
// classes (support/hand_layout.h), it must lay out the states in the documented order with their
// names, units and initial values, read each block's derivative from the right slot with the
// right sign, and find variables by name in the documented order of precedence.

#include "multibond/compile/state_layout.h"

#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "support/hand_layout.h"

namespace multibond {
namespace {

using ::testing::ElementsAre;
using testing::HandSlots;
using testing::StructureOf;
using Kind = StateBlock::Kind;

SourceValue Value(double v) { return SourceValue{{TimeFunction::Constant(v)}}; }

/// Se force -> 1 j; mass -> j (the bond points out of the I: sigma = -1); j -> spring (a named
/// bond); damper -> j; the damper's bond is named "mass" and j's first bond "j", names that
/// elements hide.
BondGraph MassSpringDamper() {
  BondGraph g("msd");
  g.AddSe("force", Value(3.0));
  g.AddJunction("j", ElementKind::kOne);
  g.AddI("mass", Param::Scalar(2.0));
  g.AddC("spring", Param::Scalar(100.0));
  g.AddR("damper", Param::Scalar(0.5));
  g.element(g.Find("mass")).initial = Eigen::VectorXd::Constant(1, 0.4);
  g.element(g.Find("spring")).initial = Eigen::VectorXd::Constant(1, 0.05);
  g.Connect("force", "j", 0, "j");
  g.Connect("mass", "j");
  g.Connect("j", "spring", 0, "spring_bond");
  g.Connect("damper", "j", 0, "mass");
  return g;
}

TEST(StateLayout, StorageThenAuxiliaryThenEnergyStatesWithNamesUnitsAndInitialValues) {
  const BondGraph g = MassSpringDamper();
  const Structure s = StructureOf(g);
  const HandSlots slots(g, s);
  const StateLayout layout(slots.Input(g, s));

  EXPECT_THAT(layout.state_names(), ElementsAre("mass.p", "spring.q", "force.work", "damper.dissipated"));
  EXPECT_THAT(layout.state_units(), ElementsAre("N s", "m", "J", "J"));
  ASSERT_EQ(layout.num_states(), 4);
  EXPECT_EQ(layout.x0(), (Eigen::Vector4d(0.4, 0.05, 0.0, 0.0)).eval());
  ASSERT_EQ(layout.blocks().size(), 4u);
  const std::vector<Kind> kinds = {Kind::kMomentum, Kind::kDisplacement, Kind::kWork, Kind::kDissipation};
  const std::vector<std::string> owners = {"mass", "spring", "force", "damper"};
  for (int k = 0; k < 4; ++k) {
    EXPECT_EQ(layout.blocks()[k].kind, kinds[k]);
    EXPECT_EQ(g.element(layout.blocks()[k].owner).name, owners[k]);
    EXPECT_EQ(layout.blocks()[k].offset, k);
    EXPECT_EQ(layout.blocks()[k].size, 1);
  }
  EXPECT_EQ(layout.element_block(g.Find("mass")), 0);
  EXPECT_EQ(layout.element_block(g.Find("spring")), 1);
  EXPECT_EQ(layout.element_block(g.Find("force")), -1);  // its work state is the energy account's
  EXPECT_EQ(layout.element_block(g.Find("j")), -1);

  // Without the energy account: the storage states only.
  const StateLayout bare(slots.Input(g, s, /*energy_account=*/false));
  EXPECT_THAT(bare.state_names(), ElementsAre("mass.p", "spring.q"));
}

TEST(StateLayout, EachDerivativeReadsItsSlotWithThePowerSign) {
  const BondGraph g = MassSpringDamper();
  const Structure s = StructureOf(g);
  const HandSlots slots(g, s);
  const StateLayout layout(slots.Input(g, s));
  const int b_force = 0, b_mass = 1, b_spring = 2, b_damper = 3;
  const std::vector<StateBlock>& blk = layout.blocks();
  const std::vector<StateGather>& gt = layout.gathers();
  ASSERT_EQ(gt.size(), blk.size());

  // I: dp/dt = sigma e, with the bond pointing out of the mass.
  EXPECT_EQ(layout.derivative_source(blk[0]), slots.effort_class[b_mass]);
  EXPECT_EQ(layout.derivative_sign(blk[0]), -1.0);
  EXPECT_EQ(gt[0].effort, slots.OffsetOf(slots.effort_class[b_mass]));
  EXPECT_EQ(gt[0].sign, -1.0);
  // C: dq/dt = f (the gather copies the slot it names `effort`, unsigned).
  EXPECT_EQ(layout.derivative_source(blk[1]), slots.flow_class[b_spring]);
  EXPECT_EQ(layout.derivative_sign(blk[1]), 1.0);
  EXPECT_EQ(gt[1].effort, slots.OffsetOf(slots.flow_class[b_spring]));
  EXPECT_EQ(gt[1].sign, 1.0);
  // Work: -sigma e f of the source (its bond points out: +e f); dissipation: sigma e f (its bond
  // points out of the damper: -e f).
  EXPECT_EQ(gt[2].effort, slots.OffsetOf(slots.effort_class[b_force]));
  EXPECT_EQ(gt[2].flow, slots.OffsetOf(slots.flow_class[b_force]));
  EXPECT_EQ(gt[2].sign, 1.0);
  EXPECT_EQ(gt[3].effort, slots.OffsetOf(slots.effort_class[b_damper]));
  EXPECT_EQ(gt[3].flow, slots.OffsetOf(slots.flow_class[b_damper]));
  EXPECT_EQ(gt[3].sign, -1.0);
  for (size_t k = 0; k < gt.size(); ++k) {
    EXPECT_EQ(gt[k].kind, blk[k].kind);
    EXPECT_EQ(gt[k].state, blk[k].offset);
    EXPECT_EQ(gt[k].size, 1);
  }
}

TEST(StateLayout, FindsSignalsStatesElementsAndNamedBondsInOrder) {
  const BondGraph g = MassSpringDamper();
  const Structure s = StructureOf(g);
  HandSlots slots(g, s);
  const int u = slots.AddSignal("u", "V");
  const int shadow = slots.AddSignal("spring.q", "-");  // a signal hides a state of its name
  const StateLayout layout(slots.Input(g, s));
  const int b_force = 0, b_mass = 1, b_spring = 2, b_damper = 3;

  const auto p = layout.FindVariable("mass.p");
  ASSERT_TRUE(p);
  EXPECT_EQ(p->in, VariableRef::In::kState);
  EXPECT_EQ(p->offset, 0);
  EXPECT_EQ(p->unit, "N s");
  EXPECT_TRUE(p->components.empty());

  const auto sig = layout.FindVariable("u");
  ASSERT_TRUE(sig);
  EXPECT_EQ(sig->in, VariableRef::In::kSlot);
  EXPECT_EQ(sig->offset, slots.OffsetOf(u));
  EXPECT_EQ(sig->unit, "V");
  const auto q = layout.FindVariable("spring.q");
  ASSERT_TRUE(q);
  EXPECT_EQ(q->in, VariableRef::In::kSlot);
  EXPECT_EQ(q->offset, slots.OffsetOf(shadow));

  // Elements: a one-port's e and f; a 1-junction's common flow (its first bond's) but no effort.
  auto slot_of = [&](const std::string& name) {
    const auto v = layout.FindVariable(name);
    EXPECT_TRUE(v) << name;
    if (v) {
      EXPECT_EQ(v->in, VariableRef::In::kSlot) << name;
    }
    return v ? v->offset : -1;
  };
  EXPECT_EQ(slot_of("mass.e"), slots.OffsetOf(slots.effort_class[b_mass]));
  EXPECT_EQ(slot_of("mass.f"), slots.OffsetOf(slots.flow_class[b_mass]));
  EXPECT_EQ(slot_of("damper.f"), slots.OffsetOf(slots.flow_class[b_damper]));
  EXPECT_EQ(slot_of("j.f"), slots.OffsetOf(slots.flow_class[b_force]));
  EXPECT_EQ(layout.FindVariable("mass.f")->unit, "m/s");
  EXPECT_FALSE(layout.FindVariable("j.e"));  // and the bond named "j" is hidden by the junction
  // A named bond; the bond named "mass" is hidden by the element.
  EXPECT_EQ(slot_of("spring_bond.e"), slots.OffsetOf(slots.effort_class[b_spring]));
  EXPECT_EQ(slot_of("spring_bond.f"), slots.OffsetOf(slots.flow_class[b_spring]));
  EXPECT_EQ(layout.FindVariable("spring_bond.e")->unit, "N");
  EXPECT_FALSE(layout.FindVariable("spring_bond.p"));
  EXPECT_EQ(slot_of("mass.e"), slots.OffsetOf(slots.effort_class[b_mass]));
  // Not variables.
  EXPECT_FALSE(layout.FindVariable("mass"));
  EXPECT_FALSE(layout.FindVariable("mass.e1"));
  EXPECT_FALSE(layout.FindVariable("nothing.e"));
  EXPECT_FALSE(layout.FindVariable(""));

  // Read: from the state or from the slots.
  const std::vector<double> x = {0.4, 0.05, 7.0, 8.0};
  std::vector<double> w(slots.num_slots);
  for (int k = 0; k < slots.num_slots; ++k) w[k] = 10.0 + k;
  double out = 0.0;
  StateLayout::Read(*layout.FindVariable("spring.q"), x.data(), w.data(), &out);  // the signal
  EXPECT_EQ(out, w[slots.OffsetOf(shadow)]);
  StateLayout::Read(*layout.FindVariable("damper.dissipated"), x.data(), w.data(), &out);
  EXPECT_EQ(out, 8.0);
}

/// A rigid body: its angular momentum B.h (3 components, inertia Ib in the body frame, rotated
/// by B.R) on the rotational 1-junction w, its momentum B.p on the translational 1-junction v
/// (components named u, v, w), its orientation B.R of w and its position B.r of v.
BondGraph Body(const Eigen::Matrix3d& r0) {
  BondGraph g("body");
  g.AddJunction("w", ElementKind::kOne, 3);
  g.element(g.Find("w")).domain = "rotation";
  g.AddJunction("v", ElementKind::kOne, 3);
  Eigen::Matrix3d ib;
  ib << 2.0, 0.1, 0.0, 0.1, 3.0, 0.2, 0.0, 0.2, 4.0;
  const int h = g.AddI("B", Param::Matrix(ib), 3);
  g.element(h).rotation = "B.R";
  g.element(h).state_name = "B.h";
  const int m = g.AddI("Bm", Param::Scalar(5.0), 3);
  g.element(m).state_name = "B.p";
  g.element(m).components = {"u", "v", "w"};
  g.Connect("w", "B");
  g.Connect("v", "Bm");
  AuxState rot;
  rot.name = "B.R";
  rot.kind = AuxState::Kind::kOrientation;
  rot.of = "w";
  rot.initial = r0;
  rot.stabilization = 0.5;
  g.AddAux(rot);
  AuxState pos;
  pos.name = "B.r";
  pos.kind = AuxState::Kind::kIntegral;
  pos.of = "v";
  pos.initial = Eigen::Vector3d(1.0, 2.0, 3.0);
  g.AddAux(pos);
  return g;
}

TEST(StateLayout, ABodysVectorsOrientationAndPosition) {
  const Eigen::Matrix3d r0 = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1.0, 2.0, 3.0).normalized()).toRotationMatrix();
  const BondGraph g = Body(r0);
  const Structure s = StructureOf(g);
  const HandSlots slots(g, s);
  const StateLayout layout(slots.Input(g, s));

  EXPECT_THAT(layout.state_names(),
              ElementsAre("B.h.x", "B.h.y", "B.h.z", "B.p.u", "B.p.v", "B.p.w", "B.R.11", "B.R.12", "B.R.13", "B.R.21",
                          "B.R.22", "B.R.23", "B.R.31", "B.R.32", "B.R.33", "B.r.x", "B.r.y", "B.r.z"));
  ASSERT_EQ(layout.num_states(), 18);
  EXPECT_EQ(layout.state_units()[0], "N m s");
  EXPECT_EQ(layout.state_units()[3], "N s");
  EXPECT_EQ(layout.state_units()[6], "-");
  EXPECT_EQ(layout.state_units()[15], "m");
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) EXPECT_EQ(layout.x0()[6 + 3 * r + c], r0(r, c));  // row-major
  EXPECT_EQ(layout.x0().tail(3), Eigen::Vector3d(1.0, 2.0, 3.0));
  EXPECT_EQ(layout.aux_block(g.FindAux("B.R")), 2);
  EXPECT_EQ(layout.aux_block(g.FindAux("B.r")), 3);

  // The orientation and the position integrate their junctions' flows; an orientation's gather
  // carries its stabilisation gain.
  const int b_w = g.element(g.Find("B")).bonds.front(), b_v = g.element(g.Find("Bm")).bonds.front();
  const StateBlock& rot = layout.blocks()[2];
  EXPECT_EQ(layout.derivative_source(rot), slots.flow_class[b_w]);
  EXPECT_EQ(layout.gathers()[2].flow, slots.OffsetOf(slots.flow_class[b_w]));
  EXPECT_EQ(layout.gathers()[2].sign, 0.5);
  EXPECT_EQ(layout.gathers()[2].size, 9);
  EXPECT_EQ(layout.derivative_source(layout.blocks()[3]), slots.flow_class[b_v]);
  EXPECT_EQ(layout.gathers()[3].flow, slots.OffsetOf(slots.flow_class[b_v]));

  // Blocks by name, with their components; slots with the element's components.
  const auto rv = layout.FindVariable("B.R");
  ASSERT_TRUE(rv);
  EXPECT_EQ(rv->in, VariableRef::In::kState);
  EXPECT_EQ(rv->offset, 6);
  EXPECT_EQ(rv->size, 9);
  EXPECT_THAT(rv->components, ElementsAre("11", "12", "13", "21", "22", "23", "31", "32", "33"));
  EXPECT_THAT(layout.FindVariable("B.h")->components, ElementsAre("x", "y", "z"));
  EXPECT_THAT(layout.FindVariable("B.p")->components, ElementsAre("u", "v", "w"));
  EXPECT_FALSE(layout.FindVariable("B.p.v"));  // a component is read through its block
  const auto f = layout.FindVariable("Bm.f");
  ASSERT_TRUE(f);
  EXPECT_EQ(f->size, 3);
  EXPECT_EQ(f->unit, "m/s");
  EXPECT_THAT(f->components, ElementsAre("u", "v", "w"));
  EXPECT_THAT(layout.FindVariable("B.e")->components, ElementsAre("x", "y", "z"));
  EXPECT_EQ(layout.FindVariable("B.e")->unit, "N m");
}

TEST(StateLayout, SignalStatesCopyTheirRateClasses) {
  BondGraph g("signals");
  AuxState lag;
  lag.name = "lag";
  lag.kind = AuxState::Kind::kLag;
  lag.unit = "V";
  lag.initial = Eigen::MatrixXd::Constant(1, 1, 0.2);
  g.AddAux(lag);
  AuxState pid;
  pid.name = "pid";
  pid.kind = AuxState::Kind::kPid;
  pid.pid.kd = 0.1;
  pid.pid.tf = 0.01;
  pid.initial = Eigen::MatrixXd::Constant(1, 1, 0.1);
  g.AddAux(pid);
  AuxState acc;
  acc.name = "acc";
  acc.kind = AuxState::Kind::kIntegral;
  acc.rate.root = expr::Name("u");
  g.AddAux(acc);
  const Structure s = StructureOf(g);
  HandSlots slots(g, s);
  const int lag_rate = slots.AddRate("lag.rate"), i_rate = slots.AddRate("pid.i.rate"),
            d_rate = slots.AddRate("pid.d.rate"), acc_rate = slots.AddRate("acc.rate");
  const StateLayout layout(slots.Input(g, s));

  EXPECT_THAT(layout.state_names(), ElementsAre("lag", "pid.i", "pid.d", "acc"));
  EXPECT_THAT(layout.state_units(), ElementsAre("V", "-", "-", "-"));
  EXPECT_EQ(layout.x0(), (Eigen::Vector4d(0.2, 0.1, 0.0, 0.0)).eval());
  EXPECT_EQ(layout.aux_block(g.FindAux("pid")), 1);  // its d is the next block
  EXPECT_EQ(layout.aux_block(g.FindAux("acc")), 3);
  const std::vector<int> rates = {lag_rate, i_rate, d_rate, acc_rate};
  for (int k = 0; k < 4; ++k) {
    const StateBlock& b = layout.blocks()[k];
    EXPECT_EQ(b.kind, Kind::kIntegral);
    EXPECT_EQ(b.rate_class, rates[k]);
    EXPECT_EQ(layout.derivative_source(b), rates[k]);
    EXPECT_EQ(layout.gathers()[k].flow, slots.OffsetOf(rates[k]));
    EXPECT_EQ(layout.gathers()[k].sign, 1.0);
  }
  EXPECT_EQ(layout.FindVariable("pid.d")->offset, 2);
  EXPECT_FALSE(layout.FindVariable("pid.i.rate"));  // a rate is internal, not a signal
}

}  // namespace
}  // namespace multibond
