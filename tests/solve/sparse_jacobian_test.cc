// The sparse Newton matrix of BDF and Adams: column groups (solve/column_groups.h) and the
// coloured difference-quotient Jacobian with KLU, against a closed-form solution.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "multibond/solve/column_groups.h"
#include "multibond/solve/integrator.h"

namespace multibond {
namespace {

/// A pattern from (row, column) pairs, with the diagonal.
JacobianPattern MakePattern(int n, std::vector<std::pair<int, int>> entries) {
  for (int i = 0; i < n; ++i) entries.push_back({i, i});
  std::sort(entries.begin(), entries.end(), [](auto a, auto b) { return a.second != b.second ? a.second < b.second : a.first < b.first; });
  entries.erase(std::unique(entries.begin(), entries.end()), entries.end());
  JacobianPattern p;
  p.n = n;
  p.col_start.assign(n + 1, 0);
  for (auto [i, j] : entries) {
    ++p.col_start[j + 1];
    p.row_index.push_back(i);
  }
  for (int j = 0; j < n; ++j) p.col_start[j + 1] += p.col_start[j];
  return p;
}

/// Every column in exactly one group, and no two columns of a group sharing a row.
void ExpectValidGroups(const JacobianPattern& p, const ColumnGroups& g) {
  std::vector<int> seen(p.n, 0);
  for (int k = 0; k < g.count(); ++k) {
    std::vector<int> row_owner(p.n, -1);
    for (int c = g.start[k]; c < g.start[k + 1]; ++c) {
      const int j = g.column[c];
      ++seen[j];
      for (int e = p.col_start[j]; e < p.col_start[j + 1]; ++e) {
        const int i = p.row_index[e];
        EXPECT_EQ(row_owner[i], -1) << "columns " << row_owner[i] << " and " << j << " share row " << i << " in group " << k;
        row_owner[i] = j;
      }
    }
  }
  for (int j = 0; j < p.n; ++j) EXPECT_EQ(seen[j], 1) << "column " << j;
}

TEST(ColumnGroups, TridiagonalNeedsThreeGroups) {
  const int n = 40;
  std::vector<std::pair<int, int>> e;
  for (int i = 0; i + 1 < n; ++i) e.insert(e.end(), {{i, i + 1}, {i + 1, i}});
  const JacobianPattern p = MakePattern(n, e);
  const ColumnGroups g = GroupColumns(p);
  ExpectValidGroups(p, g);
  EXPECT_EQ(g.count(), 3);
}

TEST(ColumnGroups, DiagonalNeedsOneAndDenseNeedsAll) {
  const JacobianPattern diag = MakePattern(25, {});
  EXPECT_EQ(GroupColumns(diag).count(), 1);
  std::vector<std::pair<int, int>> all;
  for (int i = 0; i < 12; ++i)
    for (int j = 0; j < 12; ++j) all.push_back({i, j});
  const JacobianPattern dense = MakePattern(12, all);
  const ColumnGroups g = GroupColumns(dense);
  ExpectValidGroups(dense, g);
  EXPECT_EQ(g.count(), 12);
}

TEST(ColumnGroups, RandomPatternsGiveValidGroups) {
  std::mt19937 rng(7);
  for (int trial = 0; trial < 20; ++trial) {
    const int n = 30 + trial * 7;
    std::uniform_int_distribution<int> pick(0, n - 1);
    std::vector<std::pair<int, int>> e;
    for (int k = 0; k < 4 * n; ++k) e.push_back({pick(rng), pick(rng)});
    const JacobianPattern p = MakePattern(n, e);
    const ColumnGroups g = GroupColumns(p);
    ExpectValidGroups(p, g);
    // A row with r entries needs r groups; greedy colouring never needs more than the largest
    // number of columns a column conflicts with, plus one.
    int densest_row = 0;
    std::vector<int> per_row(n, 0);
    for (int i : p.row_index) densest_row = std::max(densest_row, ++per_row[i]);
    EXPECT_GE(g.count(), densest_row);
  }
}

/// The heat equation on n interior points, x' = -k L x (L the second difference, zero ends),
/// stiff for large n; its pattern is tridiagonal. Each eigenmode sin(m pi i / (n + 1)) decays
/// as exp(-k lambda_m t), lambda_m = 4 sin^2(m pi / (2 (n + 1))).
class HeatEquation final : public OdeSystem {
 public:
  HeatEquation(int n, double k, bool give_pattern) : n_(n), k_(k) {
    std::vector<std::pair<int, int>> e;
    for (int i = 0; i + 1 < n; ++i) e.insert(e.end(), {{i, i + 1}, {i + 1, i}});
    if (give_pattern) pattern_ = MakePattern(n, e);
  }
  int num_states() const override { return n_; }
  void CalcDerivatives(double, const double* x, double* xdot) override {
    ++evaluations;
    for (int i = 0; i < n_; ++i) {
      const double left = i > 0 ? x[i - 1] : 0.0, right = i + 1 < n_ ? x[i + 1] : 0.0;
      xdot[i] = k_ * (left - 2.0 * x[i] + right);
    }
  }
  const JacobianPattern* jacobian_pattern() const override { return pattern_.n > 0 ? &pattern_ : nullptr; }

  double Mode(int m, int i) const { return std::sin(m * M_PI * (i + 1) / (n_ + 1)); }
  double Rate(int m) const {
    const double s = std::sin(m * M_PI / (2.0 * (n_ + 1)));
    return k_ * 4.0 * s * s;
  }
  long evaluations = 0;

 private:
  int n_;
  double k_;
  JacobianPattern pattern_;
};

struct HeatRun {
  double max_error = 0.0;
  IntegratorStats stats;
};

IntegratorOptions Options(Method method, JacobianKind kind, double rtol, double atol) {
  IntegratorOptions o;
  o.method = method;
  o.rtol = rtol;
  o.atol = atol;
  o.jacobian = kind;
  return o;
}

HeatRun RunHeat(HeatEquation& sys, int n, JacobianKind kind, Method method = Method::kBdf) {
  auto integ = MakeIntegrator(sys, Options(method, kind, 1e-9, 1e-12));
  std::vector<double> x(n);
  for (int i = 0; i < n; ++i) x[i] = sys.Mode(1, i) + 0.5 * sys.Mode(7, i);
  integ->Reset(0.0, x.data());
  HeatRun r;
  for (double t : {0.01, 0.05, 0.2, 1.0}) {
    integ->AdvanceTo(t, x.data());
    for (int i = 0; i < n; ++i) {
      const double exact = std::exp(-sys.Rate(1) * t) * sys.Mode(1, i) + 0.5 * std::exp(-sys.Rate(7) * t) * sys.Mode(7, i);
      r.max_error = std::max(r.max_error, std::abs(x[i] - exact));
    }
  }
  r.stats = integ->stats();
  return r;
}

TEST(SparseJacobian, BdfMatchesTheHeatEquationsModesWithThreeEvaluationsPerJacobian) {
  const int n = 80;  // stiffness ratio about 2,600
  HeatEquation sparse_sys(n, 1.0, true), dense_sys(n, 1.0, true);
  const HeatRun sparse = RunHeat(sparse_sys, n, JacobianKind::kAuto);  // 80 states, 3 % dense: sparse
  const HeatRun dense = RunHeat(dense_sys, n, JacobianKind::kDense);
  EXPECT_TRUE(sparse.stats.sparse_jacobian);
  EXPECT_FALSE(dense.stats.sparse_jacobian);
  EXPECT_EQ(sparse.stats.evals_per_jacobian, 3);
  EXPECT_EQ(dense.stats.evals_per_jacobian, n);
  EXPECT_GT(sparse.stats.jac_evals, 0);
  EXPECT_LT(sparse.max_error, 1e-7);
  EXPECT_LT(dense.max_error, 1e-7);
  // Same quotients, column by column: the two runs take the same path to rounding.
  EXPECT_NEAR(sparse.stats.steps, dense.stats.steps, 0.02 * dense.stats.steps);
  // Every evaluation is counted, the Jacobians' included.
  EXPECT_EQ(sparse.stats.rhs_evals, sparse_sys.evaluations);
  EXPECT_EQ(dense.stats.rhs_evals, dense_sys.evaluations);
  EXPECT_LT(sparse.stats.rhs_evals, dense.stats.rhs_evals);
}

/// A mass on a spring under a large constant force, from rest: p' = F - k q, q' = p / m
/// (F = 1e5 N, m = 10 kg, k = 100 N/m); q = F/k (1 - cos w t), p = F/w sin w t, w = sqrt(k/m).
/// From y = 0 with atol 1e-10, the first step is about 1e-15 s, and the difference quotients'
/// increments (proportional to h) move f by less than its rounding.
class ForcedSpring final : public OdeSystem {
 public:
  explicit ForcedSpring(bool give_pattern) {
    if (give_pattern) pattern_ = MakePattern(2, {{0, 1}, {1, 0}});
  }
  int num_states() const override { return 2; }
  void CalcDerivatives(double, const double* x, double* xdot) override {
    ++evaluations;
    xdot[0] = kF - kK * x[1];
    xdot[1] = x[0] / kM;
  }
  const JacobianPattern* jacobian_pattern() const override { return pattern_.n > 0 ? &pattern_ : nullptr; }
  static constexpr double kF = 1e5, kM = 10.0, kK = 100.0;
  long evaluations = 0;

 private:
  JacobianPattern pattern_;
};

// Both Newton matrices, dense and sparse, with both methods, from rest with increments that move
// f by less than its rounding (physics/examples_test.cc has the model that CVODE's own dense
// quotients got wrong).
TEST(DifferenceQuotientJacobian, ForcedSpringFromRestFollowsTheClosedForm) {
  const double w = std::sqrt(ForcedSpring::kK / ForcedSpring::kM);
  for (const Method method : {Method::kBdf, Method::kAdams})
    for (const JacobianKind kind : {JacobianKind::kDense, JacobianKind::kSparse}) {
      ForcedSpring sys(kind == JacobianKind::kSparse);
      auto integ = MakeIntegrator(sys, Options(method, kind, 1e-8, 1e-10));
      double x[2] = {0.0, 0.0};
      integ->Reset(0.0, x);
      double max_p = 0.0, max_q = 0.0;
      for (int k = 1; k <= 20; ++k) {
        const double t = 0.1 * k;
        integ->AdvanceTo(t, x);
        max_p = std::max(max_p, std::abs(x[0] - ForcedSpring::kF / w * std::sin(w * t)));
        max_q = std::max(max_q, std::abs(x[1] - ForcedSpring::kF / ForcedSpring::kK * (1.0 - std::cos(w * t))));
      }
      const std::string what = std::string(MethodName(method)) + (kind == JacobianKind::kSparse ? ", sparse" : ", dense");
      // Global errors within 1e-6 of the amplitudes (F/w = 3.2e4 N s, 2 F/k = 2e3 m) at rtol 1e-8;
      // measured: BDF 2.3e-7 and 1.5e-7, Adams 7e-8 and 3e-8.
      EXPECT_LT(max_p, 1e-6 * ForcedSpring::kF / w) << what;
      EXPECT_LT(max_q, 1e-6 * 2.0 * ForcedSpring::kF / ForcedSpring::kK) << what;
      EXPECT_EQ(integ->stats().sparse_jacobian, kind == JacobianKind::kSparse) << what;
      EXPECT_EQ(integ->stats().rhs_evals, sys.evaluations) << what;  // the repeated quotients are counted
    }
}

TEST(SparseJacobian, ARestartCountsItsOwnEvaluations) {
  const int n = 60;
  HeatEquation sys(n, 1.0, true);
  IntegratorOptions o;
  o.method = Method::kBdf;
  auto integ = MakeIntegrator(sys, o);
  std::vector<double> x(n);
  for (int run = 0; run < 2; ++run) {
    for (int i = 0; i < n; ++i) x[i] = sys.Mode(2, i);
    sys.evaluations = 0;
    integ->Reset(0.0, x.data());
    integ->AdvanceTo(0.5, x.data());
    EXPECT_TRUE(integ->stats().sparse_jacobian);
    EXPECT_EQ(integ->stats().rhs_evals, sys.evaluations) << "run " << run;
  }
}

TEST(SparseJacobian, AdamsUsesItToo) {
  const int n = 60;
  HeatEquation sys(n, 0.2, true);
  const HeatRun r = RunHeat(sys, n, JacobianKind::kSparse, Method::kAdams);
  EXPECT_TRUE(r.stats.sparse_jacobian);
  EXPECT_LT(r.max_error, 1e-7);
}

TEST(SparseJacobian, SmallOrPatternlessSystemsStayDense) {
  HeatEquation small(20, 1.0, true), patternless(80, 1.0, false);
  EXPECT_FALSE(RunHeat(small, 20, JacobianKind::kAuto).stats.sparse_jacobian);
  EXPECT_FALSE(RunHeat(patternless, 80, JacobianKind::kAuto).stats.sparse_jacobian);
  // Asked for explicitly, a small system gets it.
  HeatEquation small_sparse(20, 1.0, true);
  EXPECT_TRUE(RunHeat(small_sparse, 20, JacobianKind::kSparse).stats.sparse_jacobian);
}

TEST(SparseJacobian, AskingForItWithoutAPatternIsAnError) {
  HeatEquation sys(80, 1.0, false);
  IntegratorOptions o;
  o.method = Method::kBdf;
  o.jacobian = JacobianKind::kSparse;
  EXPECT_THROW(MakeIntegrator(sys, o), std::invalid_argument);
  o.method = Method::kDormandPrince;  // explicit methods have no Newton matrix: nothing to refuse
  EXPECT_NO_THROW(MakeIntegrator(sys, o));
}

TEST(SparseJacobian, KindNamesRoundTrip) {
  for (JacobianKind k : {JacobianKind::kAuto, JacobianKind::kDense, JacobianKind::kSparse})
    EXPECT_EQ(ParseJacobianKind(JacobianKindName(k)), k);
  EXPECT_THROW(ParseJacobianKind("banded"), std::invalid_argument);
}

}  // namespace
}  // namespace multibond
