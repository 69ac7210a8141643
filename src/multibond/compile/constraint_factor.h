#pragma once
/// \file
/// The linear algebra of ideal constraints (docs/design.md, "Ideal constraints"): the system
/// W lambda = rhs with W = B^T M^-1 B, given B's and V = M^-1 B's sparse columns, one per
/// multiplier. It knows nothing of the plan or the graph (the ConstraintSolver forms B and V):
///  - W's nonzeros are the pairs of columns that share a momentum row (found once);
///  - at compile time, a pivoted L D L^T of W at the initial state picks an independent set of
///    constraints (for a large system, a sparse L D L^T that finds them all independent, kDenseSetup),
///    and a minimum-degree order of it fixes the pattern of a sparse L D L^T;
///  - at run time, W on that set is factorised in its fixed pattern (Factor) and solved (Solve),
///    else (a configuration where the set is nearly dependent) the scaled, pivoted dense L D L^T
///    over all constraints solves it (FormFull, SolvePivoted);
///  - redundant constraints leave lambda free along B's null space: Share picks the split that
///    minimises the complementary energy (Menabrea's theorem).
/// Nothing here allocates after construction and FindIndependent (but for a large system, above
/// kDenseSetup multipliers, the dense arrays of the pivoted fallback, once, when it is first needed).

#include <string>
#include <utility>
#include <vector>

namespace multibond {

/// The scratch of the constraint solve, allocated once (Workspace::con; the linear algebra's
/// part is sized by ConstraintFactor::SizeScratch, the plan's by ConstraintSolver::SizeScratch).
struct ConstraintScratch {
  std::vector<double> dslots, dmoduli;  ///< time derivatives of slots and moduli (tangent pass)
  std::vector<double> lin;              ///< response of the slots to one unit multiplier
  std::vector<double> xdot;             ///< dx/dt with the multipliers at zero
  std::vector<double> zero_x;           ///< zeros, one per state (formulas' directions in B's columns)
  std::vector<double> b;                ///< per multiplier: its momentum-rate response (compressed)
  std::vector<double> v;                ///< per multiplier: the flow response M^-1 b (compressed)
  std::vector<double> w, rhs, scale;    ///< the m x m system W lambda = rhs, and its scaling
  std::vector<int> perm;
  int rank = 0;                         ///< of the last pivoted solve
  /// ConstraintFactor::Share: N's columns (m each, at most m), N^T C N and N^T C lambda, weights.
  std::vector<double> nullspace, gram, proj, weight;
  /// W on the independent constraints, factorised in place in its fixed sparse pattern
  /// (ConstraintFactor): D^-1, L, L D.
  std::vector<double> factor;
  std::vector<double> y;                ///< the solution in the factor's order
  /// The time and state at which b, v and factor were last formed, when `factored`: a solve at
  /// that very time and state reuses them (B and W depend on the orientations only, so an
  /// output time's projection, which changes momenta, leaves them right for the evaluation
  /// that follows it).
  std::vector<double> factored_at;
  double factored_t = 0.0;
  bool factored = false;
  /// Switching elements (compile/switching.h): per multiplier, 1 if its value is prescribed by
  /// its element's mode (an open contact: 0; a slipping friction: -mu_k N sign(g)) instead of
  /// solved, and that value; `any_fixed` when some is. Set before every solve from the modes.
  std::vector<unsigned char> fixed;
  std::vector<double> fixed_value;
  bool any_fixed = false;
};

/// W = B^T V for the multipliers of ideal constraints, and its solves.
class ConstraintFactor {
 public:
  ConstraintFactor() = default;
  /// B's sparsity: column i (multiplier i) has its entries at rows[offset[i] .. offset[i + 1])
  /// (state offsets, increasing within a column; offset has m + 1 entries). `compliance`: per
  /// multiplier, the compliance (1/K) of the coupling its constraint stands for, when every
  /// constraint declares one; else empty (W's diagonal then weighs Share's split).
  ConstraintFactor(std::vector<int> offset, std::vector<int> rows, std::vector<double> compliance);

  int num_multipliers() const { return m_; }
  const std::vector<int>& column_offset() const { return offset_; }
  const std::vector<int>& rows() const { return rows_; }
  /// Sizes b, v and the linear algebra's arrays of a scratch (the plan's are the solver's).
  void SizeScratch(ConstraintScratch& s) const;

  /// Compile time, with B and V at the initial state in s.b and s.v: the independent set (the
  /// first pivots of the pivoted solve, above 1e-11 of the unit diagonal), the redundant rest
  /// (dependent()), and the fixed pattern of the sparse factor in a minimum-degree order.
  void FindIndependent(ConstraintScratch& s);
  /// The multipliers outside the independent set (redundant at the initial state).
  const std::vector<int>& dependent() const { return dependent_; }
  /// The factor's size (the independent set; 0 before FindIndependent or without constraints),
  /// its strictly lower entries, and the length of ConstraintScratch::factor.
  int factor_size() const { return pattern_.size(); }
  int factor_entries() const { return pattern_.entries(); }
  int factor_values() const { return pattern_.values(); }

  /// Factor and Solve as generated code (GenerateSource; null: interpreted), passed per call: the
  /// same operations on the same arrays, so that either may follow the other.
  using GeneratedFactor = int (*)(const double*, const double*, double*);
  using GeneratedSolve = void (*)(const double*, double*, double*, double*);
  /// L D L^T of W on the independent set, from s.b and s.v into s.factor, in the fixed pattern;
  /// false when W is not positive definite there (or the set nearly dependent: a pivot below
  /// 1e-10 of W's diagonal entry), for the pivoted fallback.
  bool Factor(ConstraintScratch& s, GeneratedFactor generated = nullptr) const;
  /// out (m, zero off the independent set) from the factor in s and rhs (m; read on the
  /// independent set).
  void Solve(const double* rhs, double* out, ConstraintScratch& s, GeneratedSolve generated = nullptr) const;
  /// W (m x m, dense) from s.b and s.v into s.w.
  void FormFull(ConstraintScratch& s) const;
  /// W lambda = s.rhs by a Jacobi-scaled, pivoted L D L^T of s.w (overwritten): pivots below a
  /// relative 1e-11 are redundant constraints and get a zero multiplier; s.rank the rank found.
  void SolvePivoted(ConstraintScratch& s, double* lambda) const;
  /// After a solve (the factored one when s.factored, else the pivoted one): moves lambda along
  /// B's null space N (which moves nothing) to lambda + N alpha minimising the complementary
  /// energy sum_j c_j lambda_j^2 (Menabrea): c_j the compliance, or W_jj when none is declared
  /// (units agree: effort times flow rate). The result does not depend on which set was chosen
  /// independent.
  void Share(ConstraintScratch& s, double* lambda) const;

  /// Factor and Solve as C++ for the fixed pattern (`multibond_ldlt_factor(b, v, factor)`, 1 on
  /// success, and `multibond_ldlt_solve(rhs, lambda, factor, y)`): the same operations in the
  /// same order, every index a literal.
  std::string GenerateSource(const std::string& model_name) const;

 private:
  struct WPair {
    int i, j, begin, end;
  };  ///< a nonzero of W and its range in w_terms_
  /// W's entry for `pr`: the products of B's and V's entries over the rows its columns share.
  double WEntry(const WPair& pr, const double* b, const double* v) const;
  /// Up to this many multipliers, the independent set is found by the pivoted dense solve, and
  /// the dense arrays are sized with the scratch; above, a sparse L D L^T (Eigen) decides first.
  static constexpr int kDenseSetup = 256;
  /// The m x m arrays of the pivoted solve and of Share, sized if they are not.
  void EnsureDense(ConstraintScratch& s) const;
  /// The minimum-degree order (ties to the lowest index, so it is reproducible) of W's graph on
  /// the n constraints of the independent set (position: multiplier -> its index there, or -1):
  /// order[pos] = index; and the pattern of L in it, lower[pos] = its columns (sorted). Each
  /// elimination joins the pivot's remaining neighbours: the cost follows the fill-in (linear
  /// for a chain or a tree of joints), not the square of n.
  void MinimumDegree(const std::vector<int>& position, int n, std::vector<int>& order, std::vector<std::vector<int>>& lower) const;
  /// True when the L D L^T of W (scaled to a unit diagonal, at s.b and s.v) in `order` (a
  /// minimum-degree order of every constraint) has every pivot above 1e-8: all are independent.
  bool SparseFullRank(ConstraintScratch& s, const std::vector<int>& order) const;

  int m_ = 0;
  std::vector<int> offset_, rows_;  ///< B's compressed columns
  std::vector<WPair> w_pairs_;
  std::vector<std::pair<int, int>> w_terms_;  ///< (position in column i, position in column j)
  /// Per multiplier: the compliance of the coupling it replaces, or empty.
  std::vector<double> compliance_;
  /// Redundancy at the initial state (FindIndependent): the multipliers outside the factor's
  /// independent set, and the w_pairs_ that Share needs on the factored path (W's diagonal and
  /// every entry in a redundant multiplier's row or column).
  std::vector<int> dependent_;
  std::vector<int> share_pairs_;
  /// W on the multipliers of the independent set (all, if none is redundant) is factorised as
  /// L D L^T with a pattern fixed at compile time (constraints touch one or two bodies, so W and
  /// L are sparse). Positions are the factor's order (minimum degree). ConstraintScratch::factor
  /// holds D^-1 (one per position), then L's strict lower triangle row by row (CSR), then the
  /// same entries times their column's pivot (L D, Crout's form).
  struct IndependentFactor {
    /// factor[target] += x[a] y[b] + x[a + 1] y[b + 1] + x[a + 2] y[b + 2] (Dot3) or x[a] y[b]
    /// (Dot1): sparse dot products cut into runs of three consecutive positions (a 3-vector
    /// constraint or momentum) and single ones, so that the loops have fixed trip counts.
    struct Dot {
      int target, a, b;
    };
    std::vector<int> multiplier;  ///< per position: the multiplier (one of the independent set)
    std::vector<int> row_offset;  ///< per row of L: its range in cols (size + 1)
    std::vector<int> cols;        ///< columns of L's strict lower triangle, sorted within a row
    std::vector<Dot> w3, w1;      ///< W = B^T V: a = position in b, b = position in v; target in factor
    /// Per entry e of L: sum_k L(i, k) (L D)(j, k) over its rows' common columns k < j, in
    /// l3[l3_offset[e]..] and l1[l1_offset[e]..] (a, b: entries of L; target unused).
    std::vector<int> l3_offset, l1_offset;
    std::vector<Dot> l3, l1;
    int size() const { return static_cast<int>(multiplier.size()); }
    int entries() const { return static_cast<int>(cols.size()); }
    int values() const { return size() + 2 * entries(); }  ///< length of ConstraintScratch::factor
  } pattern_;
};

}  // namespace multibond
