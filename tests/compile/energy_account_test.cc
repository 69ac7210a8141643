// The energy account on its own (compile/energy_account.h): built from a hand-made layout
// (support/hand_layout.h), each stored energy against its closed form: 1/2 p^2/m and 1/2 k q^2,
// 1/2 p^T M^-1 p and 1/2 q^T K q, a rotated body's 1/2 h^T (R Ib^-1 R^T) h, a formula's energy,
// and a law without a closed-form integral integrated by quadrature; and the totals of the work
// and dissipation states.

#include "multibond/compile/energy_account.h"

#include <cmath>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "support/hand_layout.h"

namespace multibond {
namespace {

using testing::HandSlots;
using testing::StructureOf;

SourceValue Value(double v) { return SourceValue{{TimeFunction::Constant(v)}}; }

/// |got - want| <= tol |want|.
void ExpectRelative(double got, double want, double tol) { EXPECT_NEAR(got, want, tol * std::abs(want)) << "want " << want; }

/// Two sources and two resistors on a 1-junction with an I (mass m) and a C (stiffness k),
/// scalar or n-dimensional (then the parameters are matrices).
BondGraph Oscillator(const Param& mass, const Param& stiffness, int n) {
  BondGraph g("oscillator");
  g.AddSe("force", Value(1.0), n);
  g.AddSf("drive", Value(0.5), n);
  g.AddJunction("j", ElementKind::kOne, n);
  g.AddJunction("z", ElementKind::kZero, n);
  g.AddI("mass", mass, n);
  g.AddC("spring", stiffness, n);
  g.AddR("damper", Param::Scalar(0.3), n);
  g.AddR("leak", Param::Scalar(2.0), n);
  g.Connect("force", "j");
  g.Connect("j", "mass");
  g.Connect("j", "spring");
  g.Connect("j", "damper");
  g.Connect("drive", "z");
  g.Connect("z", "leak");
  g.Connect("z", "j");
  return g;
}

/// The layout and account of a graph, the energies of formulas given by `formula_energy`.
struct Built {
  BondGraph graph;
  Structure structure;
  StateLayout layout;
  EnergyAccount account;
  Built(BondGraph g, std::function<std::optional<EnergyAccount::FormulaEnergy>(int, int)> formula_energy = {})
      : graph(std::move(g)), structure(StructureOf(graph)) {
    const HandSlots slots(graph, structure);
    layout = StateLayout(slots.Input(graph, structure));
    account = EnergyAccount({graph, layout, std::move(formula_energy)});
  }
  int Offset(const std::string& state) const { return layout.FindVariable(state)->offset; }
};

TEST(EnergyAccount, AMassAndASpringStoreTheirClosedForms) {
  const double m = 2.0, k = 100.0, p = 0.4, q = 0.05;
  const Built b(Oscillator(Param::Scalar(m), Param::Scalar(k), 1));
  const BondGraph& g = b.graph;
  std::vector<double> x(b.layout.num_states(), 0.0);
  x[b.Offset("mass.p")] = p;
  x[b.Offset("spring.q")] = q;
  x[b.Offset("force.work")] = 1.25;
  x[b.Offset("drive.work")] = -0.25;
  x[b.Offset("damper.dissipated")] = 0.5;
  x[b.Offset("leak.dissipated")] = 0.125;

  EXPECT_DOUBLE_EQ(b.account.StoredEnergy(g.Find("mass"), 0.0, x.data()), 0.5 * p * p / m);
  EXPECT_DOUBLE_EQ(b.account.StoredEnergy(g.Find("spring"), 0.0, x.data()), 0.5 * k * q * q);
  EXPECT_EQ(b.account.StoredEnergy(g.Find("damper"), 0.0, x.data()), 0.0);
  EXPECT_EQ(b.account.term(g.Find("damper")), -1);
  ASSERT_EQ(b.account.num_terms(), 2);

  // One pass over the terms, in the order term(element) gives.
  double per_term[2];
  const EnergyAccount::Totals t = b.account.StoredEnergies(0.0, x.data(), per_term);
  EXPECT_EQ(per_term[b.account.term(g.Find("mass"))], b.account.StoredEnergy(g.Find("mass"), 0.0, x.data()));
  EXPECT_EQ(per_term[b.account.term(g.Find("spring"))], b.account.StoredEnergy(g.Find("spring"), 0.0, x.data()));
  EXPECT_EQ(t.kinetic, b.account.Kinetic(0.0, x.data()));
  EXPECT_EQ(t.potential, b.account.Potential(0.0, x.data()));
  EXPECT_DOUBLE_EQ(t.kinetic, 0.5 * p * p / m);
  EXPECT_DOUBLE_EQ(t.potential, 0.5 * k * q * q);
  EXPECT_EQ(b.account.Work(x.data()), 1.0);
  EXPECT_EQ(b.account.Dissipated(x.data()), 0.625);
}

TEST(EnergyAccount, MatrixInertiaAndStiffness) {
  Eigen::Matrix3d mm, kk;
  mm << 2.0, 0.5, 0.1, 0.5, 1.0, 0.2, 0.1, 0.2, 3.0;
  kk << 30.0, 10.0, 0.0, 10.0, 20.0, 5.0, 0.0, 5.0, 40.0;
  const Built b(Oscillator(Param::Matrix(mm), Param::Matrix(kk), 3));
  const Eigen::Vector3d p(0.4, -1.1, 0.7), q(0.02, 0.05, -0.03);
  std::vector<double> x(b.layout.num_states(), 0.0);
  for (int i = 0; i < 3; ++i) {
    x[b.Offset("mass.p") + i] = p[i];
    x[b.Offset("spring.q") + i] = q[i];
  }
  ExpectRelative(b.account.StoredEnergy(b.graph.Find("mass"), 0.0, x.data()), 0.5 * p.dot(mm.ldlt().solve(p)), 1e-14);
  ExpectRelative(b.account.StoredEnergy(b.graph.Find("spring"), 0.0, x.data()), 0.5 * q.dot(kk * q), 1e-14);
}

TEST(EnergyAccount, ARotatedBodyStoresItsEnergyInItsFrame) {
  // 1/2 h^T (R Ib^-1 R^T) h: the inertia in the inertial frame is R Ib R^T.
  Eigen::Matrix3d ib;
  ib << 1.0, 0.1, 0.0, 0.1, 4.0, 0.2, 0.0, 0.2, 10.0;
  BondGraph g("body");
  g.AddJunction("w", ElementKind::kOne, 3);
  g.element(g.Find("w")).domain = "rotation";
  const int body = g.AddI("B", Param::Matrix(ib), 3);
  g.element(body).rotation = "B.R";
  g.Connect("w", "B");
  AuxState rot;
  rot.name = "B.R";
  rot.kind = AuxState::Kind::kOrientation;
  rot.of = "w";
  g.AddAux(rot);
  const Built b(std::move(g));

  const Eigen::Matrix3d r = Eigen::AngleAxisd(1.2, Eigen::Vector3d(1.0, 2.0, 3.0).normalized()).toRotationMatrix();
  const Eigen::Vector3d h(0.3, -1.2, 0.8);
  std::vector<double> x(b.layout.num_states(), 0.0);
  for (int i = 0; i < 3; ++i) x[b.Offset("B.p") + i] = h[i];
  const int at = b.Offset("B.R");
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) x[at + 3 * i + j] = r(i, j);  // row-major, as the layout keeps R
  const double want = 0.5 * h.dot(r * ib.inverse() * r.transpose() * h);
  ExpectRelative(b.account.StoredEnergy(body, 0.0, x.data()), want, 1e-14);
  ExpectRelative(b.account.Kinetic(0.0, x.data()), want, 1e-14);
  // Unrotated, the same h stores a different energy: the account does read R.
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) x[at + 3 * i + j] = i == j ? 1.0 : 0.0;
  ExpectRelative(b.account.StoredEnergy(body, 0.0, x.data()), 0.5 * h.dot(ib.inverse() * h), 1e-14);
  EXPECT_GT(std::abs(b.account.StoredEnergy(body, 0.0, x.data()) - want), 0.1 * want);
}

/// A tree's program whose own name (`own`) reads the state x[state].
expr::Program ProgramOf(const std::string& text, const std::string& own, int state) {
  const expr::ParseResult parsed = expr::Parse(text);
  EXPECT_FALSE(parsed.error) << text;
  return expr::CompileProgram(*parsed.root, [&](const expr::Node& n) -> expr::Input {
    EXPECT_EQ(n.name, own);
    return {expr::Input::In::kState, state, 0.0};
  });
}

TEST(EnergyAccount, FormulaEnergiesArePrograms) {
  // A Duffing spring's energy 1/2 k1 q^2 + 1/4 k3 q^4 and a mass's p^2/(2 m), given as formulas;
  // the parameters of the other elements give theirs.
  const double k1 = 2.0, k3 = 10.0, m = 4.0, q = 0.6, p = -0.9;
  std::vector<std::pair<int, int>> asked;
  BondGraph g = Oscillator(Param::Scalar(1.0), Param::Scalar(1.0), 1);
  const int spring = g.Find("spring"), mass = g.Find("mass");
  const Built b(std::move(g), [&](int element, int state) -> std::optional<EnergyAccount::FormulaEnergy> {
    asked.emplace_back(element, state);
    if (element == spring) return EnergyAccount::FormulaEnergy{ProgramOf("1/2*2*q^2 + 1/4*10*q^4", "q", state)};
    if (element == mass) return EnergyAccount::FormulaEnergy{ProgramOf("p^2/(2*4)", "p", state)};
    return std::nullopt;
  });
  // Asked for every storage element, with its state, in layout order.
  ASSERT_EQ(asked.size(), 2u);
  EXPECT_EQ(asked[0], std::make_pair(mass, b.Offset("mass.p")));
  EXPECT_EQ(asked[1], std::make_pair(spring, b.Offset("spring.q")));

  std::vector<double> x(b.layout.num_states(), 0.0);
  x[b.Offset("mass.p")] = p;
  x[b.Offset("spring.q")] = q;
  ExpectRelative(b.account.StoredEnergy(spring, 0.0, x.data()), 0.5 * k1 * q * q + 0.25 * k3 * std::pow(q, 4), 1e-15);
  ExpectRelative(b.account.StoredEnergy(mass, 0.0, x.data()), p * p / (2.0 * m), 1e-15);
  ExpectRelative(b.account.Kinetic(0.0, x.data()), p * p / (2.0 * m), 1e-15);
  ExpectRelative(b.account.Potential(0.0, x.data()), 0.5 * k1 * q * q + 0.25 * k3 * std::pow(q, 4), 1e-15);
}

TEST(EnergyAccount, ALawWithoutAClosedFormIsIntegratedByQuadrature) {
  // A spring whose law is e = k atan(q): its energy, the integral from 0, is
  // k (q atan q - ln(1 + q^2) / 2), even in q.
  const double k = 4.0;
  BondGraph g = Oscillator(Param::Scalar(1.0), Param::Scalar(1.0), 1);
  const int spring = g.Find("spring");
  const Built b(std::move(g), [&](int element, int) -> std::optional<EnergyAccount::FormulaEnergy> {
    if (element != spring) return std::nullopt;
    return EnergyAccount::FormulaEnergy{ProgramOf("4*atan(q)", "q", 0), /*law=*/true};  // a program of x[0]
  });
  std::vector<double> x(b.layout.num_states(), 0.0);
  for (const double q : {1.5, -0.7, 1e-3, 25.0}) {
    x[b.Offset("spring.q")] = q;
    const double want = k * (q * std::atan(q) - 0.5 * std::log1p(q * q));
    ExpectRelative(b.account.StoredEnergy(spring, 0.0, x.data()), want, 1e-12);
    ExpectRelative(b.account.Potential(0.0, x.data()), want, 1e-12);
  }
  x[b.Offset("spring.q")] = 0.0;
  EXPECT_EQ(b.account.StoredEnergy(spring, 0.0, x.data()), 0.0);
}

TEST(EnergyAccount, AModulatedSpringsEnergyReadsTimeAndItsModulationWorkIsWork) {
  // A spring whose stiffness doubles over time, E = 1/2 k0 (1 + t) q^2: a program of t and x; the
  // layout gives it the state spring.modulation_work (its power's class among the internal
  // ones), whose derivative copies that class's slot and which counts in Work().
  BondGraph g = Oscillator(Param::Scalar(1.0), Param::Scalar(1.0), 1);
  const int spring = g.Find("spring");
  const Structure s = StructureOf(g);
  HandSlots slots(g, s);
  const int power = slots.AddRate(ModulationPowerName("spring"));
  const StateLayout layout(slots.Input(g, s));
  const auto v = layout.FindVariable("spring.modulation_work");
  ASSERT_TRUE(v);
  const int q_at = layout.FindVariable("spring.q")->offset;
  const EnergyAccount account({g, layout, [&](int element, int state) -> std::optional<EnergyAccount::FormulaEnergy> {
                                 if (element != spring) return std::nullopt;
                                 const expr::ParseResult parsed = expr::Parse("1/2*3*(1 + t)*q^2");
                                 return EnergyAccount::FormulaEnergy{expr::CompileProgram(*parsed.root, [&](const expr::Node& n) {
                                   return n.name == "t" ? expr::Input{expr::Input::In::kTime, 0, 0.0}
                                                        : expr::Input{expr::Input::In::kState, state, 0.0};
                                 })};
                               }});
  std::vector<double> x(layout.num_states(), 0.0);
  x[q_at] = 0.2;
  x[v->offset] = 0.125;
  x[layout.FindVariable("force.work")->offset] = 1.0;
  EXPECT_DOUBLE_EQ(account.StoredEnergy(spring, 0.0, x.data()), 0.5 * 3 * 0.04);
  EXPECT_DOUBLE_EQ(account.StoredEnergy(spring, 2.0, x.data()), 0.5 * 3 * 3 * 0.04);
  EXPECT_DOUBLE_EQ(account.Work(x.data()), 1.125);
  // Its gather copies the power's slot.
  const std::vector<StateBlock>& blocks = layout.blocks();
  for (size_t k = 0; k < blocks.size(); ++k)
    if (blocks[k].offset == v->offset) {
      EXPECT_EQ(blocks[k].kind, StateBlock::Kind::kWork);
      EXPECT_EQ(blocks[k].owner, spring);
      EXPECT_EQ(layout.gathers()[k].kind, StateBlock::Kind::kIntegral);
      EXPECT_EQ(layout.gathers()[k].flow, slots.OffsetOf(power));
    }
}

}  // namespace
}  // namespace multibond
