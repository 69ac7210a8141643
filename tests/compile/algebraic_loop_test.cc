// Algebraic loops solved by tearing (CompileOptions::solve_algebraic_loops): the example's
// resistor network against its closed form, Kirchhoff's laws at every evaluation, a loop of
// 3-vector bonds, a nonlinear loop solved by Newton's method (a cubic resistor in series, against
// its root at every evaluation; one with no solution stops the run with the time and the loop),
// and what stays refused.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "multibond/compile/compiled_model.h"
#include "multibond/compile/equations.h"
#include "multibond/io/model_loader.h"
#include "multibond/sim/simulator.h"

namespace multibond {
namespace {

using ::testing::HasSubstr;

LoadedModel Example() { return LoadModelFile(std::string(MULTIBOND_SOURCE_DIR) + "/examples/algebraic_loop.yaml"); }

double ReadScalar(const CompiledModel& m, const std::string& name, const double* x, const Workspace& ws) {
  double v = 0.0;
  m.Read(*m.FindVariable(name), x, ws, &v);
  return v;
}

/// The model's run with BDF at rtol 1e-10 (atol 1e-14), outputs every dt; fails the test if the
/// run does not reach t_end.
RecordingObserver RunAccurately(const CompiledModel& m, double t_end, double dt, RunSummary* summary = nullptr) {
  RunOptions o;
  o.t_end = t_end;
  o.dt = dt;
  o.integrator.method = Method::kBdf;
  o.integrator.rtol = 1e-10;
  o.integrator.atol = 1e-14;
  RecordingObserver rec;
  const RunSummary s = Simulate(m, o, rec);
  EXPECT_EQ(s.status, RunStatus::kOk) << s.message;
  if (summary) *summary = s;
  return rec;
}

std::shared_ptr<const CompiledModel> CompileSolvingLoops(const BondGraph& g) {
  CompileOptions co;
  co.solve_algebraic_loops = true;
  return CompiledModel::Compile(g, co);
}

TEST(AlgebraicLoop, RefusedByDefaultWithTheWayOut) {
  try {
    CompiledModel::Compile(Example().graph, Example().compile);
    FAIL() << "compiled";
  } catch (const ModelError& e) {
    EXPECT_EQ(e.diagnostics().front().code, "causality.algebraic_loop");
    EXPECT_THAT(e.diagnostics().front().hint, HasSubstr("algebraic_loops: solve"));
  }
}

TEST(AlgebraicLoop, ResistorNetworkFollowsItsClosedFormAndKirchhoffsLaws) {
  // V = 1 V drives R1 = 10 ohm in series with R2 = 20 ohm parallel to L = 0.1 H: the inductor's
  // current is V/R1 (1 - exp(-t/tau)), tau = L / (R1 || R2) = 0.015 s.
  LoadedModel lm = Example();
  lm.compile.solve_algebraic_loops = true;
  const auto m = CompiledModel::Compile(lm.graph, lm.compile);
  ASSERT_EQ(m->algebraic_loops().size(), 1u);
  EXPECT_THAT(m->algebraic_loops().front().path, HasSubstr("R1"));
  EXPECT_THAT(m->algebraic_loops().front().path, HasSubstr("R2"));
  // No structure through the loop's solve: every column full but the energy account's integrals'
  // (the source's work, the resistors' dissipation), which nothing reads.
  const JacobianPattern* p = m->jacobian_pattern();
  ASSERT_NE(p, nullptr);
  for (int j = 0; j < p->n; ++j)
    EXPECT_EQ(p->col_start[j + 1] - p->col_start[j], m->state_names()[j].ends_with(".dissipated") || m->state_names()[j].ends_with(".work") ? 1 : p->n) << m->state_names()[j];
  // The probes rerun only what depends on the unknown (R1's effort, n0's sum, R2's flow, j1's sum),
  // not the source or the inductor's flow.
  EXPECT_EQ(m->num_loop_instructions(), 4);
  EXPECT_EQ(m->num_instructions(), 6);
  const double V = 1.0, R1 = 10.0, R2 = 20.0, L = 0.1, tau = L / (R1 * R2 / (R1 + R2));

  RunSummary s;
  const RecordingObserver rec = RunAccurately(*m, 0.1, 0.005, &s);
  Workspace ws = m->MakeWorkspace();
  Eigen::VectorXd xdot(m->num_states());
  for (const auto& row : rec.rows()) {
    const double t = row[0];
    const double* x = row.data() + 1;  // the states come first
    const double iL = V / R1 * (1.0 - std::exp(-t / tau));
    EXPECT_NEAR(x[0] / L, iL, 1e-9) << "t = " << t;
    // Kirchhoff at this state, from one evaluation: KVL around the source, KCL at the node, each
    // resistor's law.
    m->CalcDerivatives(t, x, xdot.data(), ws);
    const double e1 = ReadScalar(*m, "R1.e", x, ws), f1 = ReadScalar(*m, "R1.f", x, ws);
    const double e2 = ReadScalar(*m, "R2.e", x, ws), f2 = ReadScalar(*m, "R2.f", x, ws);
    const double fL = ReadScalar(*m, "L.f", x, ws);
    EXPECT_NEAR(e1 + e2, V, 1e-14);
    EXPECT_NEAR(f1, f2 + fL, 1e-14);
    EXPECT_NEAR(e1, R1 * f1, 1e-14);
    EXPECT_NEAR(e2, R2 * f2, 1e-14);
  }
  EXPECT_LT(std::abs(s.energy_residual), 1e-8);
}

/// The example's network built through the API (source V, R1 in series with R2 parallel to L), its
/// names prefixed (two copies make two loops), on bonds of `dim` components.
void AddNetwork(BondGraph& g, const std::string& p, Param r1, Param r2, int dim = 1,
                SourceValue v = {{TimeFunction::Constant(1.0)}}, double inductance = 0.1) {
  g.AddSe(p + "V", std::move(v), dim);
  g.AddJunction(p + "j1", ElementKind::kOne);
  g.AddR(p + "R1", std::move(r1), dim);
  g.AddJunction(p + "n0", ElementKind::kZero);
  g.AddR(p + "R2", std::move(r2), dim);
  g.AddI(p + "L", Param::Scalar(inductance), dim);
  g.Connect(p + "V", p + "j1");
  g.Connect(p + "j1", p + "R1");
  g.Connect(p + "j1", p + "n0");
  g.Connect(p + "n0", p + "R2");
  g.Connect(p + "n0", p + "L");
}

/// A source of `volts` across a linear resistor (1 ohm) and a hardening one (e = f + f^3) in
/// series, charging a capacitor (1 F) drained by a load (2 ohm): the two resistors share their
/// current with no storage between them, a loop through a formula.
std::string CubicSeries(const std::string& volts, const std::string& law = "f + f^3", const std::string& lin = "resistance: 1.0") {
  return R"(model: cubic_series
domain: electrical
algebraic_loops: solve
elements:
  source: {type: Se, effort: )" + volts + R"(}
  i:      {type: "1"}
  lin:    {type: R, )" + lin + R"(}
  cubic:  {type: R, effort: ")" + law + R"("}
  out:    {type: "0"}
  cap:    {type: C, compliance: 1.0}
  load:   {type: R, resistance: 2.0}
bonds: [source -> i, i -> lin, i -> cubic, i -> out, out -> cap, out -> load]
outputs:
  - {name: v_lin, variable: lin.e}
  - {name: v_cubic, variable: cubic.e}
)";
}

TEST(AlgebraicLoop, ANonlinearLoopIsSolvedByNewtonAtEveryEvaluation) {
  const LoadedModel lm = LoadModelString(CubicSeries("{sine: {amplitude: 3.0, frequency: 0.5}}"));
  const auto m = CompiledModel::Compile(lm.graph, lm.compile);
  ASSERT_GT(m->num_loop_instructions(), 0);
  // At a state: u = source - v = 2 f + f^3, one real root (monotonic), by bisection.
  Workspace ws = m->MakeWorkspace();
  Eigen::VectorXd x = m->MakeInitialState(), xdot(x.size());
  const int q = static_cast<int>(std::find(m->state_names().begin(), m->state_names().end(), "cap.q") - m->state_names().begin());
  for (const auto& [t, v] : std::vector<std::pair<double, double>>{{0.5, 0.3}, {0.9, -1.0}, {1.3, 2.5}, {0.0, 0.0}, {2.0, 40.0}}) {
    x[q] = v;
    m->CalcDerivatives(t, x.data(), xdot.data(), ws);
    const double u = 3.0 * std::sin(M_PI * t) - v;
    double lo = -1e3, hi = 1e3;
    for (int k = 0; k < 200; ++k) (2.0 * (0.5 * (lo + hi)) + std::pow(0.5 * (lo + hi), 3) < u ? lo : hi) = 0.5 * (lo + hi);
    const double f = 0.5 * (lo + hi);
    EXPECT_NEAR(ReadScalar(*m, "lin.f", x.data(), ws), f, 1e-13 * std::max(1.0, std::abs(f))) << "t = " << t << ", v = " << v;
    EXPECT_NEAR(ReadScalar(*m, "cubic.e", x.data(), ws), f + f * f * f, 1e-12 * std::max(1.0, std::abs(u))) << "t = " << t;
    EXPECT_NEAR(xdot[q], f - v / 2.0, 1e-12 * std::max(1.0, std::abs(f))) << "t = " << t;  // dq/dt = i - v / RL
  }
  // A run: Kirchhoff's voltage law around the loop at every output, and the energy balance.
  RunSummary summary;
  const RecordingObserver rec = RunAccurately(*m, 4.0, 0.01, &summary);
  const int ilin = rec.Index("v_lin"), icubic = rec.Index("v_cubic"), icap = rec.Index("cap.q");
  for (const auto& row : rec.rows())
    EXPECT_NEAR(row[ilin] + row[icubic] + row[icap], 3.0 * std::sin(M_PI * row[0]), 1e-12) << "t = " << row[0];
  EXPECT_LT(std::abs(summary.energy_residual), 1e-8);
}

TEST(AlgebraicLoop, EquationsShowANonlinearLoopTornAtALaw) {
  // examples/equations/diode_thermal.yaml tears its loop at the diode's voltage, the output of its
  // inverted law (no sum to tear at): the loop's equation is the law (this once divided by zero).
  const LoadedModel lm = LoadModelFile(std::string(MULTIBOND_SOURCE_DIR) + "/examples/equations/diode_thermal.yaml");
  const auto m = CompiledModel::Compile(lm.graph, lm.compile);
  ASSERT_TRUE(m->has_nonlinear_loops());
  for (const EquationFormat f : {EquationFormat::kText, EquationFormat::kLatex}) {
    const std::string text = FormatEquations(*m, f);
    EXPECT_THAT(text, HasSubstr("solved for diode.e by Newton's method at every evaluation"));
    EXPECT_THAT(text, HasSubstr("exp(e/(1*8.617333e-05*Tj))"));
  }
}

TEST(AlgebraicLoop, ANonlinearLoopWithoutASolutionStopsTheRunWithTheTimeAndTheLoop) {
  // Two saturating resistors in series: u = tanh(f)/2 + tanh(f)/2 = tanh(f) lies in (-1, 1), so
  // no current carries the 2 V the source steps to at 0.5 s.
  const LoadedModel lm = LoadModelString(CubicSeries("\"if(t < 0.5, 0, 2)\"", "0.5*tanh(f)", R"y(effort: "0.5*tanh(f)")y"));
  const auto m = CompiledModel::Compile(lm.graph, lm.compile);
  RunOptions o;
  o.t_end = 1.0;
  o.dt = 0.01;
  RecordingObserver rec;
  const RunSummary s = Simulate(*m, o, rec);
  EXPECT_EQ(s.status, RunStatus::kFailed);
  EXPECT_THAT(s.message, HasSubstr("nonlinear algebraic loop"));
  EXPECT_THAT(s.message, HasSubstr("does not converge at t = 0.5"));
  EXPECT_THAT(s.message, HasSubstr("R 'cubic'"));
  // What it computed before is kept: the rows up to the step.
  ASSERT_FALSE(rec.rows().empty());
  EXPECT_NEAR(rec.rows().back()[0], 0.5, 0.011);
}

TEST(AlgebraicLoop, TwoLoopsAreTornSeparately) {
  BondGraph g("two_loops");
  AddNetwork(g, "a_", Param::Scalar(10.0), Param::Scalar(20.0));
  AddNetwork(g, "b_", Param::Scalar(4.0), Param::Scalar(1.0));
  const auto m = CompileSolvingLoops(g);
  ASSERT_EQ(m->algebraic_loops().size(), 2u);
  const RecordingObserver rec = RunAccurately(*m, 0.05, 0.05);
  const auto& last = rec.rows().back();
  for (auto [p, r1, r2] : {std::tuple{"a_", 10.0, 20.0}, std::tuple{"b_", 4.0, 1.0}}) {
    const double tau = 0.1 / (r1 * r2 / (r1 + r2));
    const auto ref = m->FindVariable(std::string(p) + "L.p");
    ASSERT_TRUE(ref.has_value());
    EXPECT_NEAR(last[1 + ref->offset] / 0.1, 1.0 / r1 * (1.0 - std::exp(-0.05 / tau)), 1e-9) << p;
  }
}

TEST(AlgebraicLoop, VectorBondsTearAllTheirComponents) {
  // The same network on 3-vector bonds, with a full (symmetric, positive definite) R1: a loop of
  // three unknowns. At steady state the inductor carries R1^-1 V.
  Eigen::Matrix3d r1;
  r1 << 4.0, 1.0, 0.5, 1.0, 3.0, 0.2, 0.5, 0.2, 5.0;
  BondGraph g("vector_loop");
  AddNetwork(g, "", Param::Matrix(r1), Param::Scalar(7.0), 3,
             {{TimeFunction::Constant(1.0), TimeFunction::Constant(-2.0), TimeFunction::Constant(0.5)}}, 0.01);
  const auto m = CompileSolvingLoops(g);
  ASSERT_EQ(m->algebraic_loops().size(), 1u);
  const RecordingObserver rec = RunAccurately(*m, 0.5, 0.5);
  const Eigen::Vector3d v(1.0, -2.0, 0.5);
  const Eigen::Vector3d expected = r1.ldlt().solve(v);  // the inductor shorts R2 at steady state
  const double* x = rec.rows().back().data() + 1;
  const Eigen::Vector3d iL = Eigen::Map<const Eigen::Vector3d>(x) / 0.01;
  EXPECT_TRUE(iL.isApprox(expected, 1e-8)) << iL.transpose() << " vs " << expected.transpose();
  // KCL and KVL on the vectors at the last state.
  Workspace ws = m->MakeWorkspace();
  Eigen::VectorXd xdot(m->num_states());
  m->CalcDerivatives(0.5, x, xdot.data(), ws);
  Eigen::Vector3d e1, f1, e2, f2, fL;
  m->Read(*m->FindVariable("R1.e"), x, ws, e1.data());
  m->Read(*m->FindVariable("R1.f"), x, ws, f1.data());
  m->Read(*m->FindVariable("R2.e"), x, ws, e2.data());
  m->Read(*m->FindVariable("R2.f"), x, ws, f2.data());
  m->Read(*m->FindVariable("L.f"), x, ws, fL.data());
  EXPECT_LT((e1 + e2 - v).norm(), 1e-13);
  EXPECT_LT((f1 - f2 - fL).norm(), 1e-13);
  EXPECT_LT((e1 - r1 * f1).norm(), 1e-13);
}

TEST(AlgebraicLoop, EquationsNameTheUnknownAndItsLoop) {
  LoadedModel lm = Example();
  lm.compile.solve_algebraic_loops = true;
  const auto m = CompiledModel::Compile(lm.graph, lm.compile);
  const std::string text = FormatEquations(*m, EquationFormat::kText);
  // The state equation refers to the unknown; the loop's line gives the equation it solves
  // (KCL at n0 with R1's current: j1.f = (V - R1 j1.f)/R2 + L.p/L).
  EXPECT_THAT(text, HasSubstr("d(L.p)/dt = V(t) - R1.R * j1.f"));
  EXPECT_THAT(text, HasSubstr("j1.f = 1/R2.R * (V(t) - R1.R * j1.f) + L.p/L.I, solved for j1.f"));
  EXPECT_THAT(FormatEquations(*m, EquationFormat::kLatex), HasSubstr("% algebraic loop"));
}

TEST(AlgebraicLoop, NotWithIdealConstraintsYet) {
  // The example with a second inductor in series with L: in derivative causality, so an ideal
  // constraint, and the resistive loop is still there.
  const LoadedModel lm = LoadModelString(
      "domain: electrical\nconstraints: ideal\nalgebraic_loops: solve\nelements:\n"
      "  V: {type: Se, effort: 1.0}\n  j1: {type: \"1\"}\n  R1: {type: R, resistance: 10.0}\n  n0: {type: \"0\"}\n"
      "  R2: {type: R, resistance: 20.0}\n  j2: {type: \"1\"}\n  L: {type: I, inertia: 0.1}\n  L2: {type: I, inertia: 0.2}\n"
      "bonds: [V -> j1, j1 -> R1, j1 -> n0, n0 -> R2, n0 -> j2, j2 -> L, j2 -> L2]\n",
      "m.yaml");
  try {
    CompiledModel::Compile(lm.graph, lm.compile);
    FAIL() << "compiled";
  } catch (const ModelError& e) {
    EXPECT_THAT(e.what(), HasSubstr("algebraic loops are not solved in a model with ideal constraints"));
    EXPECT_THAT(e.what(), HasSubstr("loop: R 'R2' -> 0 'n0' -> R 'R1'"));
  }
}

TEST(AlgebraicLoop, TheModelFileAndItsMistakes) {
  const std::string base = "elements:\n  V: {type: Se, effort: 1}\n  R: {type: R, resistance: 1}\nbonds: [V -> R]\n";
  EXPECT_TRUE(LoadModelString(base + "algebraic_loops: solve\n", "m.yaml").compile.solve_algebraic_loops);
  EXPECT_FALSE(LoadModelString(base + "algebraic_loops: error\n", "m.yaml").compile.solve_algebraic_loops);
  try {
    LoadModelString(base + "algebraic_loops: tear\n", "m.yaml");
    FAIL() << "accepted";
  } catch (const ModelError& e) {
    EXPECT_THAT(e.what(), HasSubstr("m.yaml:5:18"));
    EXPECT_THAT(e.what(), HasSubstr("unknown algebraic_loops 'tear'"));
    EXPECT_THAT(e.what(), HasSubstr("algebraic_loops: solve"));
  }
}

}  // namespace
}  // namespace multibond
