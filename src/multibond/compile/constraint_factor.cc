// The linear algebra of ideal constraints (constraint_factor.h; docs/design.md, "Ideal
// constraints"): W = B^T V from B's and V's compressed columns, the independent set and the
// fixed pattern of its sparse L D L^T, the pivoted fallback, and the split of a statically
// indeterminate reaction (Menabrea).

#include "multibond/compile/constraint_factor.h"

#include <algorithm>
#include <cmath>
#include <iterator>
#include <set>

#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>
#include <fmt/format.h>

#include "multibond/compile/code_text.h"
#include "multibond/compile/exact_sum.h"
#include "multibond/core/error.h"

namespace multibond {

using code::Chain;
using code::CommentText;
using code::Fma;
using code::Neg;


ConstraintFactor::ConstraintFactor(std::vector<int> offset, std::vector<int> rows, std::vector<double> compliance)
    : m_(static_cast<int>(offset.size()) - 1), offset_(std::move(offset)), rows_(std::move(rows)), compliance_(std::move(compliance)) {
  // The nonzeros of W = B^T M^-1 B: the pairs of columns that share momentum rows, with the
  // positions of the shared rows in their compressed columns (rows are sorted within a column).
  // The candidates j <= i of column i are the columns of its rows (each row's columns listed
  // once): a constraint touches one or two bodies, so this is linear in the number of
  // constraints, not quadratic.
  int num_rows = 0;
  for (int r : rows_) num_rows = std::max(num_rows, r + 1);
  std::vector<int> row_start(num_rows + 1, 0), row_columns(rows_.size());
  for (int r : rows_) ++row_start[r + 1];
  for (int r = 0; r < num_rows; ++r) row_start[r + 1] += row_start[r];
  std::vector<int> fill(row_start.begin(), row_start.end() - 1);
  for (int i = 0; i < m_; ++i)
    for (int p = offset_[i]; p < offset_[i + 1]; ++p) row_columns[fill[rows_[p]]++] = i;  // increasing i within a row
  std::vector<int> candidates, seen(m_, -1);
  for (int i = 0; i < m_; ++i) {
    candidates.clear();
    for (int p = offset_[i]; p < offset_[i + 1]; ++p)
      for (int k = row_start[rows_[p]]; k < row_start[rows_[p] + 1] && row_columns[k] <= i; ++k)
        if (seen[row_columns[k]] != i) {
          seen[row_columns[k]] = i;
          candidates.push_back(row_columns[k]);
        }
    std::sort(candidates.begin(), candidates.end());
    for (int j : candidates) {
      const int first = static_cast<int>(w_terms_.size());
      int p = offset_[i], q = offset_[j];
      while (p < offset_[i + 1] && q < offset_[j + 1]) {
        if (rows_[p] < rows_[q]) ++p;
        else if (rows_[p] > rows_[q]) ++q;
        else w_terms_.push_back({p++, q++});
      }
      if (static_cast<int>(w_terms_.size()) > first) w_pairs_.push_back({i, j, first, static_cast<int>(w_terms_.size())});
    }
  }
}

void ConstraintFactor::SizeScratch(ConstraintScratch& s) const {
  const int m = m_;
  s.b.assign(rows_.size(), 0.0);
  s.v.assign(rows_.size(), 0.0);
  s.rhs.assign(m, 0.0);
  s.scale.assign(m, 0.0);
  s.perm.assign(m, 0);
  // The dense arrays (m x m) of the pivoted solve and of Share: sized now for a small system;
  // for a large one (above kDenseSetup multipliers) only when first needed, a configuration
  // where the independent set stops being independent or a redundant one (EnsureDense).
  s.w.clear();
  s.nullspace.clear();
  s.gram.clear();
  if (m <= kDenseSetup) EnsureDense(s);
  s.proj.assign(m, 0.0);
  s.weight.assign(m, 0.0);
  s.factor.assign(pattern_.values(), 0.0);
  s.y.assign(pattern_.size(), 0.0);
}

void ConstraintFactor::FormFull(ConstraintScratch& s) const {
  // W = B^T M^-1 B over the rows the two columns share (precomputed pairs).
  EnsureDense(s);
  const int m = m_;
  const double* b = s.b.data();
  const double* v = s.v.data();
  double* wm = s.w.data();
  std::fill(s.w.begin(), s.w.end(), 0.0);
  for (const WPair& pr : w_pairs_) wm[pr.i * m + pr.j] = wm[pr.j * m + pr.i] = WEntry(pr, b, v);
}

double ConstraintFactor::WEntry(const WPair& pr, const double* b, const double* v) const {
  double sum = 0.0;
  for (int k = pr.begin; k < pr.end; ++k) sum += b[w_terms_[k].first] * v[w_terms_[k].second];
  return sum;
}

bool ConstraintFactor::Factor(ConstraintScratch& s, GeneratedFactor generated) const {
  // The constraints found independent at t = 0 (redundant ones get zero effort): W restricted to
  // them is positive definite, and L D L^T solves it without pivoting, in the sparse pattern fixed
  // at compile time (FindIndependent). A configuration where they stop being independent (a
  // pivot below 1e-10 of W's diagonal entry: the square of the 1e-5 that Cholesky's diagonal
  // would be checked against) falls back to the pivoted solve.
  if (generated) return generated(s.b.data(), s.v.data(), s.factor.data()) != 0;
  const IndependentFactor& f = pattern_;
  const int n = f.size(), ne = f.entries();
  const double* b = s.b.data();
  const double* v = s.v.data();
  double* d = s.factor.data();  // W's diagonal, then D^-1 (row by row); then L; then L D
  double* l = d + n;
  double* ld = l + ne;
  // W's nonzeros straight into their places in the factor; fill-in starts at zero.
  std::fill(s.factor.begin(), s.factor.end(), 0.0);
  for (const IndependentFactor::Dot& e : f.w3)
    d[e.target] += Dot3(b[e.a], v[e.b], b[e.a + 1], v[e.b + 1], b[e.a + 2], v[e.b + 2]);
  for (const IndependentFactor::Dot& e : f.w1) d[e.target] = MulAdd(b[e.a], v[e.b], d[e.target]);
  // Crout's L D L^T, row by row: (L D)(i, j) = W(i, j) - sum_{k < j} L(i, k) (L D)(j, k), then
  // L(i, j) = (L D)(i, j) / d_j and d_i = W(i, i) - sum_{k < i} L(i, k) (L D)(i, k). Each entry is
  // a dot product accumulated in a register over the precomputed common columns (the
  // column-by-column form scatters its updates into a work vector, which chains them through
  // memory: measured slower here). Sums of products are chains as everywhere (exact_sum.h), in
  // the order of the generated factorisation (GenerateSource).
  for (int i = 0; i < n; ++i) {
    double di = d[i];
    for (int e = f.row_offset[i]; e < f.row_offset[i + 1]; ++e) {
      double c = l[e];
      for (int t = f.l3_offset[e]; t < f.l3_offset[e + 1]; ++t) {
        const IndependentFactor::Dot& u = f.l3[t];
        c -= Dot3(l[u.a], ld[u.b], l[u.a + 1], ld[u.b + 1], l[u.a + 2], ld[u.b + 2]);
      }
      for (int t = f.l1_offset[e]; t < f.l1_offset[e + 1]; ++t) c = MulAdd(-l[f.l1[t].a], ld[f.l1[t].b], c);
      ld[e] = c;
      l[e] = c * d[f.cols[e]];  // the next entries wait for this one: a product, not a division
      di = MulAdd(-l[e], c, di);
    }
    if (!(di > 1e-10 * d[i])) return false;  // not positive definite here, or nearly dependent
    d[i] = 1.0 / di;  // from here on, d holds D^-1
  }
  return true;
}

void ConstraintFactor::Solve(const double* rhs, double* out, ConstraintScratch& s, GeneratedSolve generated) const {
  if (generated) {
    generated(rhs, out, s.factor.data(), s.y.data());
    return;
  }
  // L D L^T y = rhs (in the factor's order), then back to the multipliers.
  const IndependentFactor& f = pattern_;
  const int n = f.size();
  const double* d = s.factor.data();
  const double* l = d + n;
  double* y = s.y.data();
  for (int i = 0; i < n; ++i) {
    double sum = rhs[f.multiplier[i]];
    for (int e = f.row_offset[i]; e < f.row_offset[i + 1]; ++e) sum = MulAdd(-l[e], y[f.cols[e]], sum);
    y[i] = sum;
  }
  for (int i = 0; i < n; ++i) y[i] *= d[i];
  for (int i = n - 1; i >= 0; --i)
    for (int e = f.row_offset[i]; e < f.row_offset[i + 1]; ++e) y[f.cols[e]] = MulAdd(-l[e], y[i], y[f.cols[e]]);
  std::fill(out, out + m_, 0.0);
  for (int i = 0; i < n; ++i) out[f.multiplier[i]] = y[i];
}

void ConstraintFactor::Share(ConstraintScratch& s, double* lambda) const {
  if (dependent_.empty() && (s.factored || s.rank == m_)) return;  // nothing redundant: no null space
  EnsureDense(s);
  const int m = m_;
  double* nsp = s.nullspace.data();  // column k: nsp[k * m ..]
  double* c = s.weight.data();
  int d = 0;  // null vectors found
  if (s.factored) {
    // The independent set of t = 0 (pattern_): each redundant multiplier j has b_j = B_I c_j with
    // W_II c_j = W_Ij (the factor solves it), so n_j = e_j - c_j moves nothing (B n_j = 0).
    if (dependent_.empty()) return;
    const double* b = s.b.data();
    const double* v = s.v.data();
    double* wm = s.w.data();  // only the redundant multipliers' rows are used here
    for (int j : dependent_) std::fill(wm + static_cast<size_t>(j) * m, wm + static_cast<size_t>(j + 1) * m, 0.0);
    std::fill(c, c + m, 0.0);
    for (int k : share_pairs_) {
      const WPair& pr = w_pairs_[k];
      const double sum = WEntry(pr, b, v);
      wm[pr.i * m + pr.j] = wm[pr.j * m + pr.i] = sum;
      if (pr.i == pr.j) c[pr.i] = sum;  // W_ii
    }
    for (int j : dependent_) {
      if (!(c[j] > 0.0)) continue;  // a constraint that acts on nothing: its effort stays 0
      double* n = nsp + static_cast<size_t>(d) * m;
      Solve(wm + static_cast<size_t>(j) * m, n, s);  // W's row j = its column j
      // Redundant here too? b_j's part outside span(B_I) is W_jj - W_jI c_j (a Schur complement);
      // if it is not ~0, n_j would move something: the split is then left as the solve made it.
      double schur = c[j];
      for (int i = 0; i < m; ++i) schur -= wm[static_cast<size_t>(j) * m + i] * n[i];
      if (schur > 1e-8 * c[j]) continue;
      for (int i = 0; i < m; ++i) n[i] = -n[i];
      n[j] = 1.0;
      ++d;
    }
  } else {
    // After SolvePivoted: w holds L D L^T of the scaled, permuted W, whose first `rank` pivots
    // are independent. For a redundant position r, W_II c = W_Ir gives (in scaled form)
    // c = L_II^-T L_rI^T: one back substitution on L's row r. Unscaled: n = S (e_r - c).
    const int rank = s.rank;
    if (rank == m) return;
    const double* a = s.w.data();
    const double* sc = s.scale.data();
    const int* perm = s.perm.data();
    for (int i = 0; i < m; ++i) c[i] = sc[i] > 0.0 ? 1.0 / (sc[i] * sc[i]) : 0.0;  // W_ii
    for (int r = rank; r < m; ++r) {
      if (!(sc[perm[r]] > 0.0)) continue;  // a constraint that acts on nothing: its effort stays 0
      double* n = nsp + static_cast<size_t>(d) * m;
      std::fill(n, n + m, 0.0);
      double* y = s.proj.data();  // c in the factor's order, positions 0..rank
      for (int k = rank - 1; k >= 0; --k) {
        double sum = a[r * m + k];
        for (int i = k + 1; i < rank; ++i) sum -= a[i * m + k] * y[i];
        y[k] = sum;
      }
      for (int k = 0; k < rank; ++k) n[perm[k]] = -y[k] * sc[perm[k]];
      n[perm[r]] = sc[perm[r]];
      ++d;
    }
  }
  if (d == 0) return;
  if (!compliance_.empty()) std::copy(compliance_.begin(), compliance_.end(), c);
  // min over alpha of sum_i c_i (lambda + N alpha)_i^2: (N^T C N) alpha = -N^T C lambda, by
  // Cholesky (N's columns are independent: each has a 1 where the others have 0).
  double* g = s.gram.data();
  double* rhs = s.proj.data();
  const double* lam = lambda;
  for (int p = 0; p < d; ++p) {
    const double* np = nsp + static_cast<size_t>(p) * m;
    double r = 0.0;
    for (int i = 0; i < m; ++i) r -= c[i] * np[i] * lam[i];
    rhs[p] = r;
    for (int q = 0; q <= p; ++q) {
      const double* nq = nsp + static_cast<size_t>(q) * m;
      double sum = 0.0;
      for (int i = 0; i < m; ++i) sum += c[i] * np[i] * nq[i];
      g[p * d + q] = sum;
    }
  }
  for (int p = 0; p < d; ++p) {
    for (int q = 0; q < p; ++q) {
      double sum = g[p * d + q];
      for (int k = 0; k < q; ++k) sum -= g[p * d + k] * g[q * d + k];
      g[p * d + q] = sum / g[q * d + q];
    }
    double diag = g[p * d + p];
    for (int k = 0; k < p; ++k) diag -= g[p * d + k] * g[p * d + k];
    if (!(diag > 0.0)) return;  // cannot happen with positive weights; keep the solve's own split
    g[p * d + p] = std::sqrt(diag);
  }
  for (int p = 0; p < d; ++p) {
    for (int k = 0; k < p; ++k) rhs[p] -= g[p * d + k] * rhs[k];
    rhs[p] /= g[p * d + p];
  }
  for (int p = d - 1; p >= 0; --p) {
    for (int k = p + 1; k < d; ++k) rhs[p] -= g[k * d + p] * rhs[k];
    rhs[p] /= g[p * d + p];
  }
  for (int p = 0; p < d; ++p) {
    const double* np = nsp + static_cast<size_t>(p) * m;
    for (int i = 0; i < m; ++i) lambda[i] += rhs[p] * np[i];
  }
}

void ConstraintFactor::SolvePivoted(ConstraintScratch& s, double* lambda) const {
  const int m = m_;
  double* a = s.w.data();
  double* y = s.rhs.data();
  double* sc = s.scale.data();
  int* perm = s.perm.data();
  // Jacobi scaling: unit diagonal, so that force and moment constraints compare.
  for (int i = 0; i < m; ++i) sc[i] = a[i * m + i] > 0.0 ? 1.0 / std::sqrt(a[i * m + i]) : 0.0;
  for (int i = 0; i < m; ++i) {
    for (int j = 0; j < m; ++j) a[i * m + j] *= sc[i] * sc[j];
    y[i] *= sc[i];
    perm[i] = i;
  }
  // LDL^T with diagonal pivoting (W is symmetric positive semi-definite). Pivots below 1e-11 of
  // the unit diagonal belong to redundant constraints: their multipliers are set to zero.
  constexpr double kTol = 1e-11;
  int rank = 0;
  for (int k = 0; k < m; ++k) {
    int p = k;
    for (int i = k + 1; i < m; ++i)
      if (a[i * m + i] > a[p * m + p]) p = i;
    if (!(a[p * m + p] > kTol)) break;
    if (p != k) {
      for (int j = 0; j < m; ++j) std::swap(a[k * m + j], a[p * m + j]);
      for (int i = 0; i < m; ++i) std::swap(a[i * m + k], a[i * m + p]);
      std::swap(perm[k], perm[p]);
      std::swap(y[k], y[p]);
    }
    const double dk = a[k * m + k];
    // The trailing block is kept whole (both triangles) so that later symmetric swaps stay exact.
    for (int i = k + 1; i < m; ++i) {
      const double lik = a[i * m + k] / dk;
      if (lik == 0.0) continue;
      for (int j = k + 1; j < m; ++j) a[i * m + j] -= lik * a[k * m + j];
    }
    for (int i = k + 1; i < m; ++i) a[i * m + k] /= dk;
    ++rank;
  }
  // Solve L D L^T z = y on the first `rank` (pivoted) unknowns; the rest are zero.
  for (int i = 0; i < rank; ++i)
    for (int j = 0; j < i; ++j) y[i] -= a[i * m + j] * y[j];
  for (int i = 0; i < rank; ++i) y[i] /= a[i * m + i];
  for (int i = rank - 1; i >= 0; --i)
    for (int j = i + 1; j < rank; ++j) y[i] -= a[j * m + i] * y[j];
  for (int i = rank; i < m; ++i) y[i] = 0.0;
  // Undo the permutation and the scaling.
  for (int i = 0; i < m; ++i) lambda[perm[i]] = y[i] * sc[perm[i]];
  s.rank = rank;
}

void ConstraintFactor::EnsureDense(ConstraintScratch& s) const {
  const size_t mm = static_cast<size_t>(m_) * m_;
  if (s.w.size() == mm) return;
  s.w.assign(mm, 0.0);
  s.nullspace.assign(mm, 0.0);
  s.gram.assign(mm, 0.0);
}

void ConstraintFactor::MinimumDegree(const std::vector<int>& position, int n, std::vector<int>& order,
                                    std::vector<std::vector<int>>& lower) const {
  // W's graph on the independent constraints: constraints sharing a body's momentum are adjacent.
  std::vector<std::vector<int>> adjacent(n);  // sorted; only vertices not yet eliminated
  for (const WPair& pr : w_pairs_) {
    const int i = pr.i < static_cast<int>(position.size()) ? position[pr.i] : -1;
    const int j = pr.j < static_cast<int>(position.size()) ? position[pr.j] : -1;
    if (i < 0 || j < 0 || i == j) continue;
    adjacent[i].push_back(j);
    adjacent[j].push_back(i);
  }
  std::set<std::pair<int, int>> by_degree;  // (degree, vertex): the first is the next pivot
  for (int u = 0; u < n; ++u) {
    std::sort(adjacent[u].begin(), adjacent[u].end());
    adjacent[u].erase(std::unique(adjacent[u].begin(), adjacent[u].end()), adjacent[u].end());
    by_degree.insert({static_cast<int>(adjacent[u].size()), u});
  }
  // Eliminating a vertex joins its remaining neighbours (the fill-in); they are the rows of L's
  // column at its position.
  std::vector<std::vector<int>> columns(n);  // per vertex: the positions of its L row's columns
  std::vector<int> joined;
  order.clear();
  while (!by_degree.empty()) {
    const int best = by_degree.begin()->second;
    by_degree.erase(by_degree.begin());
    const int pos = static_cast<int>(order.size());
    order.push_back(best);
    const std::vector<int> neighbours = std::move(adjacent[best]);
    for (int a : neighbours) {
      by_degree.erase({static_cast<int>(adjacent[a].size()), a});
      columns[a].push_back(pos);
      joined.clear();  // a's neighbours and best's other ones, without best
      std::set_union(adjacent[a].begin(), adjacent[a].end(), neighbours.begin(), neighbours.end(), std::back_inserter(joined));
      joined.erase(std::remove_if(joined.begin(), joined.end(), [&](int u) { return u == a || u == best; }), joined.end());
      adjacent[a].swap(joined);
      by_degree.insert({static_cast<int>(adjacent[a].size()), a});
    }
  }
  lower.assign(n, {});
  for (int p = 0; p < n; ++p) lower[p] = std::move(columns[order[p]]);
}

bool ConstraintFactor::SparseFullRank(ConstraintScratch& s, const std::vector<int>& order) const {
  // W scaled to a unit diagonal, as the pivoted solve scales it, in the factor's order (lower
  // triangle), factorised by Eigen's simplicial L D L^T in that order (no fill-in beyond the
  // pattern MinimumDegree found).
  std::vector<double> scale(m_, 0.0);
  for (const WPair& pr : w_pairs_)
    if (pr.i == pr.j) {
      const double wii = WEntry(pr, s.b.data(), s.v.data());
      scale[pr.i] = wii > 0.0 ? 1.0 / std::sqrt(wii) : 0.0;
    }
  if (std::find(scale.begin(), scale.end(), 0.0) != scale.end()) return false;  // a constraint on nothing
  std::vector<int> pos_of(m_);
  for (int p = 0; p < m_; ++p) pos_of[order[p]] = p;
  std::vector<Eigen::Triplet<double, int>> entries;
  entries.reserve(w_pairs_.size());
  for (const WPair& pr : w_pairs_)
    entries.emplace_back(std::max(pos_of[pr.i], pos_of[pr.j]), std::min(pos_of[pr.i], pos_of[pr.j]),
                         WEntry(pr, s.b.data(), s.v.data()) * scale[pr.i] * scale[pr.j]);
  Eigen::SparseMatrix<double, Eigen::ColMajor, int> w(m_, m_);
  w.setFromTriplets(entries.begin(), entries.end());
  const Eigen::SimplicialLDLT<Eigen::SparseMatrix<double, Eigen::ColMajor, int>, Eigen::Lower, Eigen::NaturalOrdering<int>> ldlt(w);
  return ldlt.info() == Eigen::Success && ldlt.vectorD().minCoeff() > 1e-8;
}

void ConstraintFactor::FindIndependent(ConstraintScratch& s) {
  pattern_ = IndependentFactor{};
  dependent_.clear();
  share_pairs_.clear();
  if (m_ == 0) return;
  // Which constraints are independent at the initial state. A large system is first factorised
  // sparse (Eigen's simplicial L D L^T in the factor's order) with W scaled to a unit diagonal:
  // when every pivot is above 1e-8 (three decades above the dense test's 1e-11), all are
  // independent, found in time linear in a chain's or a tree's size. Otherwise, and for small
  // systems (where it is as fast and decides as it always has), the pivoted dense
  // factorisation's first `rank` pivots are an independent set.
  // The factor's order (order[pos] = index in independent) and the pattern of L, row by row:
  // lower[pos] = its columns, sorted.
  std::vector<int> independent, order;
  std::vector<std::vector<int>> lower;
  if (m_ > kDenseSetup) {
    std::vector<int> all(m_);
    for (int j = 0; j < m_; ++j) all[j] = j;
    MinimumDegree(all, m_, order, lower);
    if (SparseFullRank(s, order)) independent = std::move(all);
  }
  if (independent.empty()) {
    FormFull(s);
    std::fill(s.rhs.begin(), s.rhs.end(), 0.0);
    std::vector<double> lambda(m_, 0.0);
    SolvePivoted(s, lambda.data());
    independent.assign(s.perm.begin(), s.perm.begin() + s.rank);
    std::sort(independent.begin(), independent.end());
    order.clear();
  }
  for (int j = 0, k = 0; j < m_; ++j) {
    if (k < static_cast<int>(independent.size()) && independent[k] == j) ++k;
    else dependent_.push_back(j);
  }
  for (size_t k = 0; k < w_pairs_.size(); ++k) {
    const WPair& pr = w_pairs_[k];
    if (pr.i == pr.j || std::binary_search(dependent_.begin(), dependent_.end(), pr.i) ||
        std::binary_search(dependent_.begin(), dependent_.end(), pr.j))
      share_pairs_.push_back(static_cast<int>(k));
  }
  const int n = static_cast<int>(independent.size());
  std::vector<int> position(m_, -1);
  for (int k = 0; k < n; ++k) position[independent[k]] = k;
  if (order.empty()) MinimumDegree(position, n, order, lower);
  IndependentFactor& f = pattern_;
  std::vector<int> pos_of(n);
  for (int p = 0; p < n; ++p) {
    pos_of[order[p]] = p;
    f.multiplier.push_back(independent[order[p]]);
  }
  f.row_offset.push_back(0);
  for (int i = 0; i < n; ++i) {
    f.cols.insert(f.cols.end(), lower[i].begin(), lower[i].end());
    f.row_offset.push_back(f.entries());
  }
  // The entry of L at (i, j), j < i, in the pattern.
  auto index_of = [&f](int i, int j) {
    const auto begin = f.cols.begin() + f.row_offset[i], end = f.cols.begin() + f.row_offset[i + 1];
    const auto it = std::lower_bound(begin, end, j);
    return it != end && *it == j ? static_cast<int>(it - f.cols.begin()) : -1;
  };
  // Runs of three consecutive positions on both sides become one Dot3, the rest Dot1s.
  auto cut = [](const std::vector<std::pair<int, int>>& terms, int target, std::vector<IndependentFactor::Dot>& dot3,
                std::vector<IndependentFactor::Dot>& dot1) {
    for (size_t k = 0; k < terms.size();) {
      const auto [a, b] = terms[k];
      if (k + 2 < terms.size() && terms[k + 2].first == a + 2 && terms[k + 2].second == b + 2) {
        dot3.push_back({target, a, b});  // positions are increasing: k + 1 is (a + 1, b + 1)
        k += 3;
      } else {
        dot1.push_back({target, a, b});
        k += 1;
      }
    }
  };
  // Each entry's update terms: the columns k < j that rows i and j share.
  f.l3_offset.push_back(0);
  f.l1_offset.push_back(0);
  for (int i = 0; i < n; ++i)
    for (int e = f.row_offset[i]; e < f.row_offset[i + 1]; ++e) {
      const int j = f.cols[e];
      // The columns k < j that rows i and j share: a merge of their sorted columns.
      std::vector<std::pair<int, int>> terms;
      for (int p = f.row_offset[i], q = f.row_offset[j]; p < f.row_offset[i + 1] && q < f.row_offset[j + 1];) {
        if (f.cols[p] >= j || f.cols[q] >= j) break;
        if (f.cols[p] < f.cols[q]) ++p;
        else if (f.cols[p] > f.cols[q]) ++q;
        else terms.push_back({p++, q++});
      }
      cut(terms, e, f.l3, f.l1);
      f.l3_offset.push_back(static_cast<int>(f.l3.size()));
      f.l1_offset.push_back(static_cast<int>(f.l1.size()));
    }
  // Where each nonzero of W goes in ConstraintScratch::factor (D first, then L's entries).
  for (const WPair& pr : w_pairs_) {
    if (position[pr.i] < 0 || position[pr.j] < 0) continue;
    const int i = std::max(pos_of[position[pr.i]], pos_of[position[pr.j]]);
    const int j = std::min(pos_of[position[pr.i]], pos_of[position[pr.j]]);
    cut(std::vector<std::pair<int, int>>(w_terms_.begin() + pr.begin, w_terms_.begin() + pr.end),
        i == j ? i : n + index_of(i, j), f.w3, f.w1);
  }
}

std::string ConstraintFactor::GenerateSource(const std::string& model_name) const {
  // Factor and Solve written out for the pattern fixed at compile time: the same operations in
  // the same order, every index a literal, no loops over index lists. Cut into functions of a
  // few hundred statements: GCC's time grows faster than linearly with the size of one
  // straight-line function (the differential's factorisation in one piece took 6-12 s to
  // compile, in pieces about a second).
  const IndependentFactor& f = pattern_;
  const int n = f.size(), ne = f.entries();
  auto B = [](int k) { return fmt::format("b[{}]", k); };
  auto V = [](int k) { return fmt::format("v[{}]", k); };
  auto L = [](int k) { return fmt::format("l[{}]", k); };
  auto Ld = [](int k) { return fmt::format("ld[{}]", k); };
  constexpr int kStatementsPerPart = 200;
  std::string parts, body;
  std::string part;
  int part_statements = 0, num_parts = 0;
  bool checked = true;
  auto flush = [&]() {
    if (part.empty()) return;
    parts += fmt::format("static __attribute__((noinline)) int mb_ldlt_part{}(double* __restrict d, double* __restrict l,\n"
                         "    double* __restrict ld, double* __restrict y, const double* __restrict b, const double* __restrict v,\n"
                         "    const double* __restrict rhs) {{\n  (void)d; (void)l; (void)ld; (void)y; (void)b; (void)v; (void)rhs;\n",
                         num_parts);
    parts += part + "  return 1;\n}\n";
    // A part returns 0 only from the factorisation's definiteness test.
    body += checked ? fmt::format("  if (!mb_ldlt_part{}(d, d + {}, d + {}, y, b, v, rhs)) return 0;\n", num_parts, n, n + ne)
                    : fmt::format("  (void)mb_ldlt_part{}(d, d + {}, d + {}, y, b, v, rhs);\n", num_parts, n, n + ne);
    ++num_parts;
    part.clear();
    part_statements = 0;
  };
  // Appends a group of statements that must stay together (a row of L keeps di in a local).
  auto add = [&](const std::string& code, int statements) {
    if (part_statements > 0 && part_statements + statements > kStatementsPerPart) flush();
    part += code;
    part_statements += statements;
  };
  // d: W's diagonal, then D^-1; then L; then L D (as in the interpreter's ConstraintScratch::factor).
  auto function = [&](const std::string& signature, const std::string& locals, const std::string& ret) {
    flush();
    std::string o = signature + " {\n" + locals + body + ret + "}\n";
    body.clear();
    return o;
  };
  add(fmt::format("  for (int k = 0; k < {}; ++k) d[k] = 0.0;\n", f.values()), 1);
  for (const IndependentFactor::Dot& e : f.w3)
    add(fmt::format("  d[{}] += {};\n", e.target, Chain({{B(e.a), V(e.b)}, {B(e.a + 1), V(e.b + 1)}, {B(e.a + 2), V(e.b + 2)}})), 1);
  for (const IndependentFactor::Dot& e : f.w1) add(fmt::format("  d[{}] = {};\n", e.target, Fma(B(e.a), V(e.b), fmt::format("d[{}]", e.target))), 1);
  for (int i = 0; i < n; ++i) {
    std::string row = fmt::format("  {{\n    double di = d[{}];\n", i);
    int statements = 3;
    for (int e = f.row_offset[i]; e < f.row_offset[i + 1]; ++e) {
      row += fmt::format("    {{ double c = l[{}];\n", e);
      for (int t = f.l3_offset[e]; t < f.l3_offset[e + 1]; ++t) {
        const IndependentFactor::Dot& u = f.l3[t];
        row += fmt::format("      c -= {};\n", Chain({{L(u.a), Ld(u.b)}, {L(u.a + 1), Ld(u.b + 1)}, {L(u.a + 2), Ld(u.b + 2)}}));
      }
      for (int t = f.l1_offset[e]; t < f.l1_offset[e + 1]; ++t) row += fmt::format("      c = {};\n", Fma(Neg(L(f.l1[t].a)), Ld(f.l1[t].b), "c"));
      row += fmt::format("      ld[{}] = c; l[{}] = c * d[{}]; di = {}; }}\n", e, e, f.cols[e], Fma(Neg(L(e)), "c", "di"));
      statements += 2 + (f.l3_offset[e + 1] - f.l3_offset[e]) + (f.l1_offset[e + 1] - f.l1_offset[e]);
    }
    row += fmt::format("    if (!(di > 1e-10 * d[{}])) return 0;\n    d[{}] = 1.0 / di;\n  }}\n", i, i);
    add(row, statements);
  }
  std::string o = "// Generated by multibond from the constraint factorisation of model '" + CommentText(model_name) + "'. Do not edit.\n";
  const std::string factor = function("extern \"C\" int multibond_ldlt_factor(const double* __restrict b, const double* __restrict v,\n"
                                      "                                       double* __restrict d)",
                                      "  double* y = nullptr;\n  const double* rhs = nullptr;\n", "  return 1;\n");
  // L D L^T y = rhs: the interpreter subtracts one term at a time (s = rhs; s = s - l y; ...), the
  // same chain as here (exact_sum.h).
  checked = false;
  for (int i = 0; i < n; ++i) {
    std::string e = fmt::format("rhs[{}]", f.multiplier[i]);
    for (int k = f.row_offset[i]; k < f.row_offset[i + 1]; ++k) e = Fma(Neg(L(k)), fmt::format("y[{}]", f.cols[k]), e);
    add(fmt::format("  y[{}] = {};\n", i, e), 1 + f.row_offset[i + 1] - f.row_offset[i]);
  }
  for (int i = 0; i < n; ++i) add(fmt::format("  y[{}] *= d[{}];\n", i, i), 1);
  for (int i = n - 1; i >= 0; --i)
    for (int e = f.row_offset[i]; e < f.row_offset[i + 1]; ++e) {
      const std::string y = fmt::format("y[{}]", f.cols[e]);
      add(fmt::format("  {} = {};\n", y, Fma(Neg(L(e)), fmt::format("y[{}]", i), y)), 1);
    }
  std::string scatter = fmt::format("  for (int k = 0; k < {}; ++k) lambda[k] = 0.0;\n", m_);
  for (int i = 0; i < n; ++i) scatter += fmt::format("  lambda[{}] = y[{}];\n", f.multiplier[i], i);
  const std::string solve = function("extern \"C\" void multibond_ldlt_solve(const double* __restrict rhs, double* __restrict lambda,\n"
                                     "                                      double* __restrict d, double* __restrict y)",
                                     "  const double* b = nullptr;\n  const double* v = nullptr;\n", scatter);
  return o + parts + factor + solve;
}

}  // namespace multibond
