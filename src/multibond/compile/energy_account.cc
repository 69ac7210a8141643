/// \file
/// The energy account (compile/energy_account.h; docs/design.md, "Energy account"): each I's and
/// C's stored energy from the time and the state, and the totals of the sources' and the
/// modulations' work and the resistors' dissipation, integrated as states.

#include "multibond/compile/energy_account.h"

#include <cmath>

#include <gsl/gsl_errno.h>
#include <gsl/gsl_integration.h>

#include "multibond/compile/operations.h"

namespace multibond {
namespace {

/// The integral of a law from 0 to q (GSL's adaptive 41-point Gauss-Kronrod to a relative 1e-13):
/// the stored energy of an element whose law has no closed-form integral. Output times only.
double LawEnergy(const expr::Program& law, double q) {
  static const bool quiet = [] {
    gsl_set_error_handler_off();  // a result at the limit of rounding is still the best there is
    return true;
  }();
  (void)quiet;
  gsl_function fn{[](double s, void* p) { return expr::Run(*static_cast<const expr::Program*>(p), 0.0, &s, nullptr); },
                  const_cast<expr::Program*>(&law)};
  constexpr size_t kIntervals = 256;
  gsl_integration_workspace* ws = gsl_integration_workspace_alloc(kIntervals);
  double result = 0.0, error = 0.0;
  gsl_integration_qag(&fn, 0.0, q, 0.0, 1e-13, kIntervals, GSL_INTEG_GAUSS41, ws, &result, &error);
  gsl_integration_workspace_free(ws);
  return result;
}

}  // namespace

EnergyAccount::EnergyAccount(const Input& in) {
  const BondGraph& g = in.graph;
  const StateLayout& layout = in.layout;
  term_of_element_.assign(g.num_elements(), -1);
  for (const StateBlock& blk : layout.blocks()) {
    if (blk.kind == StateBlock::Kind::kWork) (g.element(blk.owner).potential_work ? potential_work_ : work_).push_back(blk.offset);
    if (blk.kind == StateBlock::Kind::kDissipation) dissipated_.push_back(blk.offset);
    if (blk.kind != StateBlock::Kind::kMomentum && blk.kind != StateBlock::Kind::kDisplacement) continue;
    const Element& e = g.element(blk.owner);
    Term et{blk.offset, blk.size, -1, static_cast<int>(coef_.size()), blk.kind == StateBlock::Kind::kMomentum};
    if (e.kind == ElementKind::kI && !e.rotation.empty())
      et.rotation = layout.blocks()[layout.aux_block(g.FindAux(e.rotation))].offset;
    std::optional<FormulaEnergy> formula;
    if (in.formula_energy) formula = in.formula_energy(blk.owner, blk.offset);
    if (formula) {
      (formula->law ? et.law : et.program) = static_cast<int>(programs_.size());
      programs_.push_back(std::move(formula->program));
    } else {
      const int n = blk.size;
      const Eigen::MatrixXd p = e.param.AsMatrix(n, n);
      plan::AppendRowMajor(coef_, blk.kind == StateBlock::Kind::kMomentum ? Eigen::MatrixXd(p.inverse()) : p);
    }
    term_of_element_[blk.owner] = static_cast<int>(terms_.size());
    terms_.push_back(et);
  }
}

double EnergyAccount::EnergyOf(const Term& et, double t, const double* x) const {
  // 1/2 s^T E s with E = I^-1 or K (row-major in coef_); a body's angular momentum is
  // taken to its frame first (h_b = R^T h), where its inertia is constant. No allocation: these
  // run at every output time.
  if (et.program >= 0) return expr::Run(programs_[et.program], t, x, nullptr);
  if (et.law >= 0) return LawEnergy(programs_[et.law], x[et.state]);
  const double* s = x + et.state;
  double hb[3];
  if (et.rotation >= 0) {
    const double* r = x + et.rotation;
    for (int i = 0; i < 3; ++i) hb[i] = r[i] * s[0] + r[3 + i] * s[1] + r[6 + i] * s[2];
    s = hb;
  }
  const double* e = coef_.data() + et.coef;
  double sum = 0.0;
  for (int i = 0; i < et.size; ++i) {
    double row = 0.0;
    for (int j = 0; j < et.size; ++j) row += e[i * et.size + j] * s[j];
    sum += s[i] * row;
  }
  return 0.5 * sum;
}

double EnergyAccount::StoredEnergy(int element, double t, const double* x) const {
  const int term = term_of_element_.at(element);
  return term < 0 ? 0.0 : EnergyOf(terms_[term], t, x);
}

EnergyAccount::Totals EnergyAccount::StoredEnergies(double t, const double* x, double* per_term) const {
  Totals sums;
  for (size_t k = 0; k < terms_.size(); ++k) {
    const double e = EnergyOf(terms_[k], t, x);
    per_term[k] = e;
    (terms_[k].kinetic ? sums.kinetic : sums.potential) += e;
  }
  for (int offset : potential_work_) sums.potential -= x[offset];
  return sums;
}

double EnergyAccount::Kinetic(double t, const double* x) const {
  double sum = 0.0;
  for (const Term& et : terms_)
    if (et.kinetic) sum += EnergyOf(et, t, x);
  return sum;
}

double EnergyAccount::Potential(double t, const double* x) const {
  double sum = 0.0;
  for (const Term& et : terms_)
    if (!et.kinetic) sum += EnergyOf(et, t, x);
  for (int offset : potential_work_) sum -= x[offset];
  return sum;
}

double EnergyAccount::Work(const double* x) const {
  double sum = 0.0;
  for (int offset : work_) sum += x[offset];
  return sum;
}

double EnergyAccount::Dissipated(const double* x) const {
  double sum = 0.0;
  for (int offset : dissipated_) sum += x[offset];
  return sum;
}

}  // namespace multibond
