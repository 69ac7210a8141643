// The ideal-constraint solver on its own (compile/constraint_solver.h, compile/constraint_factor.h):
// the linear algebra on hand-made B and V (a fixed-pattern sparse L D L^T against a dense solve,
// the generated factor against the interpreted one, Menabrea's split of a redundant reaction in
// closed form), and the solver on a hand-made plan of two masses joined rigidly under a force.

#include "multibond/compile/constraint_solver.h"

#include <dlfcn.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include <Eigen/Dense>
#include <gtest/gtest.h>

#include "multibond/compile/compiled_model.h"
#include "multibond/compile/jit.h"

namespace multibond {
namespace {

// --- ConstraintFactor ----------------------------------------------------------------------

/// A chain of rigid bodies (3 momentum components each, an SPD inverse mass matrix each), joined
/// by 3-vector constraints between neighbours: B's column for constraint j, component k, is e_k
/// on body j and -e_k on body j + 1, over all six rows of the two bodies (as the solver
/// compresses them); V = M^-1 B.
struct Chain {
  int bodies = 5;
  std::vector<Eigen::Matrix3d> inverse_mass;
  std::vector<int> offset, rows;
  std::vector<double> b, v;

  explicit Chain(double variant, int num_bodies = 5) : bodies(num_bodies) {
    for (int j = 0; j < bodies; ++j) {
      const Eigen::Vector3d u(1.0, 0.5 * j - 1.0, 0.3 + variant);
      Eigen::Matrix3d d = Eigen::Vector3d(1.0 + j, 2.0 + variant, 0.5 + 0.25 * j).asDiagonal();
      inverse_mass.push_back(d + 0.2 * u * u.transpose());
    }
    for (int j = 0; j + 1 < bodies; ++j)
      for (int k = 0; k < 3; ++k) {
        offset.push_back(static_cast<int>(rows.size()));
        for (int body : {j, j + 1}) {
          const double sign = body == j ? 1.0 : -1.0;
          const Eigen::Vector3d column = sign * inverse_mass[body].col(k);
          for (int r = 0; r < 3; ++r) {
            rows.push_back(3 * body + r);
            b.push_back(r == k ? sign : 0.0);
            v.push_back(column[r]);
          }
        }
      }
    offset.push_back(static_cast<int>(rows.size()));
  }
  int multipliers() const { return static_cast<int>(offset.size()) - 1; }
  /// W = B^T M^-1 B, dense.
  Eigen::MatrixXd DenseW() const {
    const int m = multipliers();
    Eigen::MatrixXd bd = Eigen::MatrixXd::Zero(3 * bodies, m), vd = bd;
    for (int i = 0; i < m; ++i)
      for (int q = offset[i]; q < offset[i + 1]; ++q) {
        bd(rows[q], i) = b[q];
        vd(rows[q], i) = v[q];
      }
    return bd.transpose() * vd;
  }
};

ConstraintScratch FilledScratch(const ConstraintFactor& f, const std::vector<double>& b, const std::vector<double>& v) {
  ConstraintScratch s;
  f.SizeScratch(s);
  s.b = b;
  s.v = v;
  return s;
}

double RelativeError(const Eigen::VectorXd& got, const Eigen::VectorXd& want) {
  return (got - want).lpNorm<Eigen::Infinity>() / want.lpNorm<Eigen::Infinity>();
}

TEST(ConstraintFactor, FixedSparsePatternSolvesLikeADenseFactorisation) {
  // The pattern is fixed with one set of numbers (the initial state) and used with another (a
  // later configuration: other mass matrices, the same sparsity).
  const Chain initial(0.0), later(0.7);
  ConstraintFactor f(initial.offset, initial.rows, {});
  const int m = f.num_multipliers();
  ASSERT_EQ(m, 12);
  ConstraintScratch s = FilledScratch(f, initial.b, initial.v);
  f.FindIndependent(s);
  EXPECT_TRUE(f.dependent().empty()) << "a chain's joints are independent";
  ASSERT_EQ(f.factor_size(), m);
  // W is block tridiagonal (3 x 3 blocks: 4 on the diagonal, 3 below it): the minimum-degree
  // order eliminates the chain from its ends and L keeps W's pattern, no fill-in.
  EXPECT_EQ(f.factor_entries(), 4 * 3 + 3 * 9);
  EXPECT_LT(f.factor_entries(), m * (m - 1) / 2);

  s = FilledScratch(f, later.b, later.v);
  Eigen::VectorXd rhs(m);
  for (int i = 0; i < m; ++i) rhs[i] = std::sin(1.0 + i) * (1.0 + 0.1 * i);
  std::copy(rhs.data(), rhs.data() + m, s.rhs.begin());
  const Eigen::MatrixXd w = later.DenseW();
  const Eigen::VectorXd want = w.ldlt().solve(rhs);
  ASSERT_TRUE(f.Factor(s));
  Eigen::VectorXd sparse(m);
  f.Solve(rhs.data(), sparse.data(), s);
  EXPECT_LT(RelativeError(sparse, want), 1e-13);
  EXPECT_LT((w * sparse - rhs).lpNorm<Eigen::Infinity>(), 1e-12 * rhs.lpNorm<Eigen::Infinity>());
  // The dense, pivoted fallback on the same system.
  f.FormFull(s);
  EXPECT_LT((Eigen::Map<const Eigen::MatrixXd>(s.w.data(), m, m) - w).cwiseAbs().maxCoeff(), 1e-14 * w.cwiseAbs().maxCoeff());
  Eigen::VectorXd pivoted(m);
  f.SolvePivoted(s, pivoted.data());
  EXPECT_EQ(s.rank, m);
  EXPECT_LT(RelativeError(pivoted, want), 1e-12);
}

TEST(ConstraintFactor, ALongChainIsFoundIndependentSparselyAndFactorisedWithoutFillIn) {
  // 120 bodies, 357 multipliers: more than the dense setup takes (kDenseSetup), so the sparse
  // L D L^T decides that all are independent, and the minimum-degree order is found without an
  // m x m matrix. The factor has W's pattern (no fill-in), so a solve costs O(m).
  const Chain initial(0.0, 120), later(0.7, 120);
  ConstraintFactor f(initial.offset, initial.rows, {});
  const int m = f.num_multipliers();
  ASSERT_EQ(m, 3 * 119);
  ConstraintScratch s = FilledScratch(f, initial.b, initial.v);
  EXPECT_TRUE(s.w.empty()) << "no dense m x m array for a large system until it is needed";
  f.FindIndependent(s);
  EXPECT_TRUE(f.dependent().empty());
  ASSERT_EQ(f.factor_size(), m);
  EXPECT_EQ(f.factor_entries(), 3 * 119 + 9 * 118);
  EXPECT_TRUE(s.w.empty()) << "found without the dense pivoted solve";

  s = FilledScratch(f, later.b, later.v);
  Eigen::VectorXd rhs(m);
  for (int i = 0; i < m; ++i) rhs[i] = std::sin(1.0 + i) * (1.0 + 0.1 * i);
  const Eigen::MatrixXd w = later.DenseW();
  const Eigen::VectorXd want = w.ldlt().solve(rhs);
  ASSERT_TRUE(f.Factor(s));
  Eigen::VectorXd sparse(m);
  f.Solve(rhs.data(), sparse.data(), s);
  EXPECT_LT(RelativeError(sparse, want), 1e-10);
  EXPECT_LT((w * sparse - rhs).lpNorm<Eigen::Infinity>(), 1e-12 * rhs.lpNorm<Eigen::Infinity>());
}

TEST(ConstraintFactor, ALongChainWithARepeatedJointFallsBackToThePivotedSearch) {
  // The same long chain with its last joint given twice: W is singular, the sparse test fails,
  // and the pivoted dense solve finds the three repeated multipliers redundant; the factor on
  // the rest still solves a consistent system exactly.
  Chain chain(0.0, 120);
  const int joint = static_cast<int>(chain.offset.size()) - 4;  // the last joint's first column
  for (int k = 0; k < 3; ++k) {
    const int begin = chain.offset[joint + k], end = chain.offset[joint + k + 1];
    std::vector<int> rows(chain.rows.begin() + begin, chain.rows.begin() + end);
    std::vector<double> b(chain.b.begin() + begin, chain.b.begin() + end), v(chain.v.begin() + begin, chain.v.begin() + end);
    chain.rows.insert(chain.rows.end(), rows.begin(), rows.end());
    chain.b.insert(chain.b.end(), b.begin(), b.end());
    chain.v.insert(chain.v.end(), v.begin(), v.end());
    chain.offset.push_back(static_cast<int>(chain.rows.size()));
  }
  ConstraintFactor f(chain.offset, chain.rows, {});
  const int m = f.num_multipliers();
  ASSERT_EQ(m, 3 * 119 + 3);
  ConstraintScratch s = FilledScratch(f, chain.b, chain.v);
  f.FindIndependent(s);
  EXPECT_EQ(f.dependent().size(), 3u);
  ASSERT_EQ(f.factor_size(), m - 3);
  EXPECT_EQ(f.factor_entries(), 3 * 119 + 9 * 118) << "the independent chain keeps W's pattern";
  const Eigen::MatrixXd w = chain.DenseW();
  Eigen::VectorXd x(m);
  for (int i = 0; i < m; ++i) x[i] = std::cos(0.3 * i);
  const Eigen::VectorXd rhs = w * x;  // consistent
  s = FilledScratch(f, chain.b, chain.v);
  ASSERT_TRUE(f.Factor(s));
  Eigen::VectorXd lambda(m);
  f.Solve(rhs.data(), lambda.data(), s);
  EXPECT_LT((w * lambda - rhs).lpNorm<Eigen::Infinity>(), 1e-11 * rhs.lpNorm<Eigen::Infinity>());
}

TEST(ConstraintFactor, GeneratedFactorAndSolveAreBitIdenticalToTheInterpreter) {
  const Chain initial(0.0), later(0.3);
  ConstraintFactor f(initial.offset, initial.rows, {});
  ConstraintScratch s = FilledScratch(f, initial.b, initial.v);
  f.FindIndependent(s);
  const int m = f.num_multipliers();
  std::vector<double> rhs(m);
  for (int i = 0; i < m; ++i) rhs[i] = std::cos(0.5 + i);

  ConstraintScratch interpreted = FilledScratch(f, later.b, later.v);
  ASSERT_TRUE(f.Factor(interpreted));
  std::vector<double> lambda_interpreted(m);
  f.Solve(rhs.data(), lambda_interpreted.data(), interpreted);

  const JitResult jit = CompileAndLoad(f.GenerateSource("chain"), "multibond_ldlt_factor");
  ASSERT_NE(jit.symbol, nullptr) << jit.description;
  void* solve = dlsym(jit.library.get(), "multibond_ldlt_solve");
  ASSERT_NE(solve, nullptr);
  ConstraintScratch s2 = FilledScratch(f, later.b, later.v);
  ASSERT_TRUE(f.Factor(s2, reinterpret_cast<ConstraintFactor::GeneratedFactor>(jit.symbol)));
  std::vector<double> lambda_generated(m);
  f.Solve(rhs.data(), lambda_generated.data(), s2, reinterpret_cast<ConstraintFactor::GeneratedSolve>(solve));
  EXPECT_EQ(s2.factor, interpreted.factor);
  EXPECT_EQ(lambda_generated, lambda_interpreted);
}

/// A rigid beam (vertical momentum and angular momentum: 2 states) on supports at positions a_i,
/// each holding the vertical velocity of its point at zero: g_i = v + a_i w, so B's column is
/// (1, a_i) and V's (1/m, a_i/J). A load F at x_F. rhs = -dg/dt at zero multipliers.
struct Beam {
  double mass = 4.0, inertia = 1.5, load = -100.0, at = 0.3;
  std::vector<double> supports;
  std::vector<int> offset, rows;
  std::vector<double> b, v, rhs;
  explicit Beam(std::vector<double> a) : supports(std::move(a)) {
    for (double ai : supports) {
      offset.push_back(static_cast<int>(rows.size()));
      rows.insert(rows.end(), {0, 1});
      b.insert(b.end(), {1.0, ai});
      v.insert(v.end(), {1.0 / mass, ai / inertia});
      rhs.push_back(-(load / mass + ai * load * at / inertia));
    }
    offset.push_back(static_cast<int>(rows.size()));
  }
};

/// Solves as the solver does (the factor on the independent set, else the pivoted solve), then
/// shares the reaction.
std::vector<double> SolveAndShare(const ConstraintFactor& f, const Beam& beam, bool factored, int rank) {
  ConstraintScratch s = FilledScratch(f, beam.b, beam.v);
  s.rhs = beam.rhs;
  std::vector<double> lambda(f.num_multipliers());
  if (factored) {
    s.factored = f.Factor(s);
    EXPECT_TRUE(s.factored);
    f.Solve(s.rhs.data(), lambda.data(), s);
  } else {
    s.factored = false;
    f.FormFull(s);
    f.SolvePivoted(s, lambda.data());
    EXPECT_EQ(s.rank, rank);
  }
  f.Share(s, lambda.data());
  return lambda;
}

ConstraintFactor BuiltFactor(const Beam& beam, std::vector<double> compliance) {
  ConstraintFactor f(beam.offset, beam.rows, std::move(compliance));
  ConstraintScratch s = FilledScratch(f, beam.b, beam.v);
  f.FindIndependent(s);
  return f;
}

TEST(ConstraintFactor, RedundantPairSharesItsLoadInverselyToItsCompliances) {
  // Two supports under the load's point: statically indeterminate once (W of rank 1). Menabrea:
  // the least c1 l1^2 + c2 l2^2 with l1 + l2 = -F gives l_i = -F (1/c_i) / (1/c1 + 1/c2).
  Beam pair({0.3, 0.3});
  const double c1 = 2e-6, c2 = 6e-6;
  const ConstraintFactor f = BuiltFactor(pair, {c1, c2});
  ASSERT_EQ(f.dependent().size(), 1u);
  EXPECT_EQ(f.factor_size(), 1);
  for (bool factored : {true, false}) {
    const std::vector<double> lambda = SolveAndShare(f, pair, factored, 1);
    EXPECT_NEAR(lambda[0], -pair.load * c2 / (c1 + c2), 1e-12 * std::abs(pair.load)) << factored;
    EXPECT_NEAR(lambda[1], -pair.load * c1 / (c1 + c2), 1e-12 * std::abs(pair.load)) << factored;
  }
  // Without compliances, W's diagonal weighs them: equal here, so the load splits in half.
  const ConstraintFactor plain = BuiltFactor(pair, {});
  for (bool factored : {true, false}) {
    const std::vector<double> lambda = SolveAndShare(plain, pair, factored, 1);
    EXPECT_NEAR(lambda[0], -0.5 * pair.load, 1e-12 * std::abs(pair.load)) << factored;
    EXPECT_NEAR(lambda[1], -0.5 * pair.load, 1e-12 * std::abs(pair.load)) << factored;
  }
}

TEST(ConstraintFactor, BeamOnThreeSupportsTakesMenabreasSplit) {
  // Equilibrium: sum l_i = -F, sum a_i l_i = -F x_F; least sum c_i l_i^2: c_i l_i = alpha + beta a_i.
  Beam beam({-1.0, 0.5, 2.0});
  const std::vector<double> c = {1e-6, 2e-6, 0.5e-6};
  Eigen::Matrix2d normal = Eigen::Matrix2d::Zero();
  for (int i = 0; i < 3; ++i) {
    const Eigen::Vector2d r(1.0, beam.supports[i]);
    normal += r * r.transpose() / c[i];
  }
  const Eigen::Vector2d ab = normal.inverse() * Eigen::Vector2d(-beam.load, -beam.load * beam.at);
  const ConstraintFactor f = BuiltFactor(beam, c);
  ASSERT_EQ(f.dependent().size(), 1u) << "two degrees of freedom, three supports";
  for (bool factored : {true, false}) {
    const std::vector<double> lambda = SolveAndShare(f, beam, factored, 2);
    for (int i = 0; i < 3; ++i)
      EXPECT_NEAR(lambda[i], (ab[0] + ab[1] * beam.supports[i]) / c[i], 1e-10 * std::abs(beam.load)) << i << " " << factored;
  }
}

// --- ConstraintSolver ----------------------------------------------------------------------

/// What the hand-written plans below share: the tables a plan's view holds, the solver built on
/// them, a workspace of `num_slots` slots, and the model's step 1 (the plan at lambda = 0 and the
/// gathers).
struct HandPlan {
  explicit HandPlan(int slots) : num_slots(slots) {}
  int num_slots;
  BondGraph graph;
  std::vector<plan::Instr> plan;
  std::vector<StateBlock> blocks;
  std::vector<StateGather> gathers;
  std::vector<expr::Program> programs;                  // no formulas
  std::vector<std::string> state_names = {"x0", "x1"};  // two states each
  std::vector<double> coef;
  std::vector<int> sum_terms;
  std::vector<double> sum_signs;
  std::vector<TimeFunction> sources;
  std::vector<plan::ModulusEval> moduli;
  ConstraintSolver solver;

  static plan::Instr Instr(plan::Op op, int dst, int coef, int element) {
    plan::Instr in{op};
    in.dst = dst, in.coef = coef, in.element = element;
    return in;
  }
  static void Gather(const StateGather& gt, const double*, const double* w, double* xdot) {
    xdot[gt.state] = gt.sign * w[gt.effort];
  }
  ConstraintSolver::PlanView View() const {
    return {plan, {coef.data(), sum_terms.data(), sum_signs.data(), sources.data()}, moduli, gathers, &Gather, nullptr, 2};
  }
  Workspace MakeWorkspace() const {
    Workspace ws;
    ws.slots.assign(num_slots, 0.0);
    solver.SizeScratch(ws, num_slots, 0, 2);
    return ws;
  }
  void EvalPlan(double t, const double* x, double* xdot, Workspace& ws) const {
    std::fill(ws.lambda.begin(), ws.lambda.end(), 0.0);
    const ConstraintSolver::PlanView view = View();
    for (const plan::Instr& in : plan)
      plan::Exec(in, plan::ExecArgs{t, x, ws.slots.data(), ws.slots.data(), nullptr, ws.lambda.data(), view.tables});
    for (const StateGather& gt : gathers) Gather(gt, x, ws.slots.data(), xdot);
  }
};

/// Two masses m1, m2 on a line, a force F on the first, the second joined to it by an ideal
/// constraint whose flow is v2 - v1 (the power lambda (v2 - v1) it delivers: -lambda on the
/// first, +lambda on the second), prescribed as `rate` t. The plan is written by hand as the
/// model's passes would make it (one slot per class):
///   slot 0 F; 1 lambda; 2 v1 = p1/m1; 3 v2 = p2/m2; 4 dp1/dt = F - lambda; 5 dp2/dt = lambda;
///   6 the constraint's flow v2 - v1.
struct TwoMasses : HandPlan {
  double m1 = 2.0, m2 = 3.0, force = 12.0, rate = 0.0;
  std::vector<std::vector<int>> reads = {{}, {}, {}, {}, {0, 1}, {1}, {2, 3}};
  std::vector<int> writes = {0, 1, 2, 3, 4, 5, 6};
  std::vector<int> class_offset = {0, 1, 2, 3, 4, 5, 6}, class_size = std::vector<int>(7, 1);
  std::vector<std::string> class_names = {"F.e", "joint.e", "m1.f", "m2.f", "m1.e", "m2.e", "joint.f"};
  std::vector<int> flow_class = {6};    // bond 0: the joint's
  std::vector<int> effort_class = {1};  // (its effort is the multiplier's)

  explicit TwoMasses(double prescribed_rate) : HandPlan(7), rate(prescribed_rate) {
    coef = {1.0 / m1, 1.0 / m2};
    sum_terms = {0, 1, 1, 3, 2};
    sum_signs = {1.0, -1.0, 1.0, 1.0, -1.0};
    sources = {TimeFunction::Constant(force)};
    graph.AddSe("F", SourceValue{{TimeFunction::Constant(force)}});
    graph.AddI("m1", Param::Scalar(m1));
    graph.AddI("m2", Param::Scalar(m2));
    const int joint = graph.AddSf("joint", SourceValue{{TimeFunction::Ramp(rate)}});
    graph.element(joint).constraint = true;
    plan.push_back(Instr(plan::Op::kSource, 0, 0, 0));
    plan.push_back(Instr(plan::Op::kMultiplier, 1, 0, joint));
    plan.push_back(Instr(plan::Op::kStateScale, 2, 0, 1));
    plan.back().src = 0;
    plan.push_back(Instr(plan::Op::kStateScale, 3, 1, 2));
    plan.back().src = 1;
    plan.push_back(Instr(plan::Op::kSum1, 4, 0, -1));
    plan.back().count = 2;
    plan.push_back(Instr(plan::Op::kSum1, 5, 2, -1));
    plan.back().count = 1;
    plan.push_back(Instr(plan::Op::kSum1, 6, 3, -1));
    plan.back().count = 2;
    blocks = {{StateBlock::Kind::kMomentum, 1, 0, 1}, {StateBlock::Kind::kMomentum, 2, 1, 1}};
    gathers = {{StateBlock::Kind::kMomentum, 0, 1, 4, -1, -1, 1.0}, {StateBlock::Kind::kMomentum, 1, 1, 5, -1, -1, 1.0}};
    // As the compiled model declares, numbers and builds it (bond 0, pointing away from the Sf).
    solver.Add("joint.rigid", joint, {{0, 1.0, 0}});
    solver.AssignMultipliers({1});
    solver.Build({graph, plan, reads, writes, blocks, gathers, class_offset, class_size, class_names, flow_class, effort_class, num_slots,
                  programs, state_names, 2});
  }
};

TEST(ConstraintSolver, BuildsItsTablesFromThePlan) {
  const TwoMasses model(0.0);
  const ConstraintSolver& s = model.solver;
  EXPECT_EQ(s.num_multipliers(), 1);
  EXPECT_EQ(s.names(), std::vector<std::string>{"joint.rigid"});
  ASSERT_EQ(s.groups().size(), 1u);
  EXPECT_EQ(s.groups()[0].starts, std::vector<int>{1});
  EXPECT_EQ(s.groups()[0].closure, (std::vector<int>{4, 5}));   // both momentum rates
  EXPECT_EQ(s.groups()[0].momenta, (std::vector<int>{0, 1}));
  EXPECT_EQ(s.groups()[0].members[0].slot, 6);                  // the bond's flow slot
  EXPECT_EQ(s.tangent_plan(), (std::vector<int>{2, 3, 6}));     // what the joint's flow depends on
  EXPECT_EQ(s.reaction_plan(), (std::vector<int>{1, 4, 5}));
  EXPECT_EQ(s.reaction_gathers(), (std::vector<int>{0, 1}));
  EXPECT_EQ(s.flow_instr_of_block(), (std::vector<int>{2, 3}));
  EXPECT_EQ(s.factor().rows(), (std::vector<int>{0, 1}));       // B's one column: both momenta
  EXPECT_EQ(s.MultiplierOf(0), 0);
}

TEST(ConstraintSolver, TwoMassesJoinedRigidlyShareTheForceByTheirMasses) {
  // Both accelerate at F / (m1 + m2); the joint pulls the second with m2 F / (m1 + m2). With a
  // prescribed relative velocity r t: lambda/m2 - (F - lambda)/m1 = r, lambda = m2 (F + r m1) / (m1 + m2).
  for (double rate : {0.0, 1.5}) {
    TwoMasses model(rate);
    Workspace ws = model.MakeWorkspace();
    const double x0[2] = {0.0, 0.0};
    std::vector<double> xdot(2);
    model.EvalPlan(0.0, x0, xdot.data(), ws);
    model.solver.FindIndependent(model.View(), x0, ws);
    ws = model.MakeWorkspace();  // now with the factor's arrays

    const double x[2] = {4.0, 6.0 + 3.0 * rate * 0.25};  // v1 = v2 - r t at t = 0.25: on the constraint
    model.EvalPlan(0.25, x, xdot.data(), ws);
    model.solver.Solve(model.View(), 0.25, x, xdot.data(), ws, /*share=*/true);
    const double m1 = model.m1, m2 = model.m2, f = model.force;
    EXPECT_TRUE(ws.con.factored);
    EXPECT_NEAR(ws.lambda[0], m2 * (f + rate * m1) / (m1 + m2), 1e-14 * f) << rate;
    EXPECT_EQ(ws.slots[1], ws.lambda[0]) << "the multiplier's slot, again with lambda";
    EXPECT_NEAR(xdot[0], m1 * (f - rate * m2) / (m1 + m2), 1e-14 * f) << rate;
    EXPECT_NEAR(xdot[1] / m2 - xdot[0] / m1, rate, 1e-14 * f) << "the constraint's acceleration";
    EXPECT_NEAR(xdot[0] + xdot[1], f, 1e-14 * f) << "the joint's forces cancel";
  }
}

TEST(ConstraintSolver, ProjectionPutsTheMomentaOnTheJointAndKeepsTheirSum) {
  // p += B mu by the kinetic-energy metric: both masses end at the common velocity
  // (p1 + p2) / (m1 + m2), and the total momentum is unchanged (B = (-1, 1)).
  TwoMasses model(0.0);
  Workspace ws = model.MakeWorkspace();
  double x[2] = {0.0, 0.0};
  std::vector<double> xdot(2);
  model.EvalPlan(0.0, x, xdot.data(), ws);
  model.solver.FindIndependent(model.View(), x, ws);
  ws = model.MakeWorkspace();

  x[0] = 5.0, x[1] = -1.0;  // v1 = 2.5, v2 = -1/3
  model.EvalPlan(0.0, x, xdot.data(), ws);
  EXPECT_NEAR(model.solver.Residual(0.0, ws), 2.5 + 1.0 / 3.0, 1e-15);
  model.EvalPlan(0.0, x, xdot.data(), ws);
  model.solver.ProjectMomenta(model.View(), 0.0, x, ws);
  const double v = 4.0 / (model.m1 + model.m2);
  EXPECT_NEAR(x[0] / model.m1, v, 1e-15);
  EXPECT_NEAR(x[1] / model.m2, v, 1e-15);
  EXPECT_NEAR(x[0] + x[1], 4.0, 1e-15);
  EXPECT_EQ(ws.lambda[0], 0.0) << "the projection leaves no multiplier behind";
  model.EvalPlan(0.0, x, xdot.data(), ws);
  EXPECT_LT(model.solver.Residual(0.0, ws), 1e-15);
}


/// The dual: a flow multiplier. A flow source F fills a 0-junction z holding two springs k1, k2
/// (one force: k1 q1 = k2 q2); k2's bond is cut into two flow sources sharing mu, the constraint
/// being that their efforts agree (k2's effort and z's). By hand, one slot per class:
///   slot 0 F; 1 mu (k2's side); 2 mu (z's side); 3 e_z = k1 q1; 4 k2's effort sigma k2 q2;
///   5 dq1/dt = F - mu (z's flow balance).
/// `k2_into`: k2's bond points into k2 (sigma = 1), else away from it (sigma = -1: its kernel
/// gives -k2 q2, and V = H B = +k2 B must undo that sign).
struct SpringPair : HandPlan {
  double k1 = 30.0, k2 = 70.0, flow = 4.0;
  std::vector<std::vector<int>> reads = {{}, {}, {}, {}, {}, {0, 2}};
  std::vector<int> writes = {0, 1, 2, 3, 4, 5};
  std::vector<int> class_offset = {0, 1, 2, 3, 4, 5}, class_size = std::vector<int>(6, 1);
  std::vector<std::string> class_names = {"F.f", "k2.cut.f", "k2.cut.rest.f", "z.e", "k2.e", "k1.f"};
  std::vector<int> flow_class = {0, 5, 1, 2};    // bonds F -> z, z -> k1, k2's, z -> k2.cut.rest
  std::vector<int> effort_class = {3, 3, 4, 3};

  explicit SpringPair(bool k2_into) : HandPlan(6) {
    sum_terms = {0, 2};
    sum_signs = {1.0, -1.0};
    const double sigma = k2_into ? 1.0 : -1.0;
    coef = {k1, sigma * k2};
    sources = {TimeFunction::Constant(flow)};
    graph.AddSf("F", SourceValue{{TimeFunction::Constant(flow)}});
    graph.AddJunction("z", ElementKind::kZero);
    graph.AddC("k1", Param::Scalar(k1));
    const int spring = graph.AddC("k2", Param::Scalar(k2));
    const int cut = graph.AddSf("k2.cut", SourceValue{{TimeFunction::Constant(0.0)}});
    const int rest = graph.AddSf("k2.cut.rest", SourceValue{{TimeFunction::Constant(0.0)}});
    graph.element(cut).constraint = graph.element(rest).constraint = true;
    graph.Connect("F", "z");
    graph.Connect("z", "k1");
    if (k2_into) graph.Connect("k2.cut", "k2");
    else graph.Connect("k2", "k2.cut");
    graph.Connect("z", "k2.cut.rest");
    plan.push_back(Instr(plan::Op::kSource, 0, 0, 0));
    plan.push_back(Instr(plan::Op::kMultiplier, 1, 0, cut));
    plan.push_back(Instr(plan::Op::kMultiplier, 2, 0, rest));
    plan.push_back(Instr(plan::Op::kStateScale, 3, 0, 2));
    plan.back().src = 0;
    plan.push_back(Instr(plan::Op::kStateScale, 4, 1, spring));
    plan.back().src = 1;
    plan.push_back(Instr(plan::Op::kSum1, 5, 0, 1));
    plan.back().count = 2;
    blocks = {{StateBlock::Kind::kDisplacement, 2, 0, 1}, {StateBlock::Kind::kDisplacement, spring, 1, 1}};
    gathers = {{StateBlock::Kind::kDisplacement, 0, 1, 5, -1, -1, 1.0}, {StateBlock::Kind::kDisplacement, 1, 1, 1, -1, -1, 1.0}};
    // Members as the graph pass declares them: the bond at each source, +1 when it leaves it.
    solver.Add("k2.cut", spring, {{2, k2_into ? 1.0 : -1.0, -1}, {3, -1.0, -1}}, /*imposes_flow=*/true);
    solver.AssignMultipliers({1, 1, 1, 1});
    solver.Build({graph, plan, reads, writes, blocks, gathers, class_offset, class_size, class_names, flow_class, effort_class, num_slots,
                  programs, state_names, 2});
  }
  /// Compile-time set-up at x = 0, then a fresh workspace with the factor's arrays.
  Workspace Ready() {
    Workspace ws = MakeWorkspace();
    const double x0[2] = {0.0, 0.0};
    std::vector<double> xdot(2);
    EvalPlan(0.0, x0, xdot.data(), ws);
    solver.FindIndependent(View(), x0, ws);
    return MakeWorkspace();
  }
};

TEST(ConstraintSolver, AFlowMultiplierConstrainsEfforts) {
  const SpringPair model(true);
  const ConstraintSolver& s = model.solver;
  ASSERT_EQ(s.groups().size(), 1u);
  EXPECT_TRUE(s.groups()[0].imposes_flow);
  EXPECT_EQ(s.groups()[0].starts, (std::vector<int>{1, 2}));
  EXPECT_EQ(s.groups()[0].closure, std::vector<int>{5});        // z's flow balance
  EXPECT_EQ(s.groups()[0].momenta, (std::vector<int>{0, 1}));   // both displacements: B's rows
  EXPECT_EQ(s.groups()[0].members[0].slot, 4);                  // k2's effort
  EXPECT_EQ(s.groups()[0].members[1].slot, 3);                  // z's effort
  EXPECT_EQ(s.tangent_plan(), (std::vector<int>{3, 4}));        // what the two efforts depend on
  EXPECT_EQ(s.flow_instr_of_block(), (std::vector<int>{3, 4})); // each spring's effort kernel: V = K B
  EXPECT_EQ(s.factor().rows(), (std::vector<int>{0, 1}));
}

TEST(ConstraintSolver, AFlowMultiplierSplitsTheFlowByTheSprings) {
  // k2 mu = k1 (F - mu): mu = k1 F / (k1 + k2), whichever way k2's bond points.
  for (const bool into : {true, false}) {
    SpringPair model(into);
    Workspace ws = model.Ready();
    const double x[2] = {0.7, 0.3};  // on the constraint: 30 * 0.7 = 70 * 0.3
    std::vector<double> xdot(2);
    model.EvalPlan(0.5, x, xdot.data(), ws);
    model.solver.Solve(model.View(), 0.5, x, xdot.data(), ws, /*share=*/true);
    const double mu = model.k1 * model.flow / (model.k1 + model.k2);
    EXPECT_NEAR(ws.lambda[0], mu, 1e-14 * model.flow) << into;
    EXPECT_NEAR(xdot[0], model.flow - mu, 1e-14 * model.flow) << into;
    EXPECT_NEAR(xdot[1], mu, 1e-14 * model.flow) << into;
    EXPECT_NEAR(model.k1 * xdot[0], model.k2 * xdot[1], 1e-13 * model.flow) << "the forces keep equal";
  }
}

TEST(ConstraintSolver, ProjectionPutsTheDisplacementsOnTheCutAndKeepsTheirSum) {
  // x += B mu with B = (-1, 1) by the potential-energy metric: q1 + q2 (the pair's total
  // deflection) is kept, and the force becomes k q_total with k = k1 k2 / (k1 + k2).
  for (const bool into : {true, false}) {
    SpringPair model(into);
    Workspace ws = model.Ready();
    double x[2] = {0.2, 0.0};
    std::vector<double> xdot(2);
    model.EvalPlan(0.0, x, xdot.data(), ws);
    EXPECT_NEAR(model.solver.Residual(0.0, ws), 6.0, 1e-14);
    model.EvalPlan(0.0, x, xdot.data(), ws);
    model.solver.ProjectMomenta(model.View(), 0.0, x, ws);
    EXPECT_NEAR(x[0], 0.14, 1e-15) << into;
    EXPECT_NEAR(x[1], 0.06, 1e-15) << into;
    model.EvalPlan(0.0, x, xdot.data(), ws);
    EXPECT_LT(model.solver.Residual(0.0, ws), 1e-14) << into;
  }
}

}  // namespace
}  // namespace multibond
