/// \file
/// The energy account (docs/design.md, "Energy account"): each I's and C's stored energy from the
/// state, and the sources' work and the resistors' dissipation integrated as states.

#include <cmath>

#include <gsl/gsl_errno.h>
#include <gsl/gsl_integration.h>

#include "multibond/compile/compiled_model.h"

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

void CompiledModel::AccountEnergy() {
  const BondGraph& g = graph_;
  energy_matrix_.resize(g.num_elements());
  for (const StateBlock& blk : blocks_) {
    if (blk.kind != StateBlock::Kind::kMomentum && blk.kind != StateBlock::Kind::kDisplacement) continue;
    const Element& e = g.element(blk.owner);
    if (HasFormulas(e)) continue;  // its energy is a formula (AccountFormulaEnergy)
    const int n = blk.size;
    const Eigen::MatrixXd p = e.param.AsMatrix(n, n);
    energy_matrix_[blk.owner] = blk.kind == StateBlock::Kind::kMomentum ? Eigen::MatrixXd(p.inverse()) : p;
  }
  energy_term_of_element_.assign(g.num_elements(), -1);
  for (const StateBlock& blk : blocks_) {
    if (blk.kind != StateBlock::Kind::kMomentum && blk.kind != StateBlock::Kind::kDisplacement) continue;
    const Element& e = g.element(blk.owner);
    EnergyTerm et{blk.offset, blk.size, -1, static_cast<int>(energy_coef_.size()), blk.kind == StateBlock::Kind::kMomentum};
    if (e.kind == ElementKind::kI && !e.rotation.empty())
      et.rotation = blocks_[aux_block_[g.FindAux(e.rotation)]].offset;
    plan::AppendRowMajor(energy_coef_, energy_matrix_[blk.owner]);
    energy_term_of_element_.resize(g.num_elements(), -1);
    energy_term_of_element_[blk.owner] = static_cast<int>(energy_terms_.size());
    energy_terms_.push_back(et);
    if (HasFormulas(e)) AccountFormulaEnergy(blk.owner, static_cast<int>(energy_terms_.size()) - 1);  // formulas.cc
  }
}

double CompiledModel::EnergyOf(const EnergyTerm& et, const double* x) const {
  // 1/2 s^T E s with E = I^-1 or K (row-major in energy_coef_); a body's angular momentum is
  // taken to its frame first (h_b = R^T h), where its inertia is constant. No allocation: these
  // run at every output time.
  if (et.program >= 0) return expr::Run(programs_[et.program], 0.0, x, nullptr);
  if (et.law >= 0) return LawEnergy(programs_[et.law], x[et.state]);
  const double* s = x + et.state;
  double hb[3];
  if (et.rotation >= 0) {
    const double* r = x + et.rotation;
    for (int i = 0; i < 3; ++i) hb[i] = r[i] * s[0] + r[3 + i] * s[1] + r[6 + i] * s[2];
    s = hb;
  }
  const double* e = energy_coef_.data() + et.coef;
  double sum = 0.0;
  for (int i = 0; i < et.size; ++i) {
    double row = 0.0;
    for (int j = 0; j < et.size; ++j) row += e[i * et.size + j] * s[j];
    sum += s[i] * row;
  }
  return 0.5 * sum;
}

double CompiledModel::StoredEnergy(int element, const double* x) const {
  const int term = energy_term_of_element_.at(element);
  return term < 0 ? 0.0 : EnergyOf(energy_terms_[term], x);
}

CompiledModel::EnergyTotals CompiledModel::StoredEnergies(const double* x, double* per_term) const {
  EnergyTotals t;
  for (size_t k = 0; k < energy_terms_.size(); ++k) {
    const double e = EnergyOf(energy_terms_[k], x);
    per_term[k] = e;
    (energy_terms_[k].kinetic ? t.kinetic : t.potential) += e;
  }
  return t;
}

double CompiledModel::KineticEnergy(const double* x) const {
  double sum = 0.0;
  for (const EnergyTerm& et : energy_terms_)
    if (et.kinetic) sum += EnergyOf(et, x);
  return sum;
}

double CompiledModel::PotentialEnergy(const double* x) const {
  double sum = 0.0;
  for (const EnergyTerm& et : energy_terms_)
    if (!et.kinetic) sum += EnergyOf(et, x);
  return sum;
}

double CompiledModel::Work(const double* x) const {
  double sum = 0.0;
  for (const StateBlock& b : blocks_)
    if (b.kind == StateBlock::Kind::kWork) sum += x[b.offset];
  return sum;
}

double CompiledModel::Dissipated(const double* x) const {
  double sum = 0.0;
  for (const StateBlock& b : blocks_)
    if (b.kind == StateBlock::Kind::kDissipation) sum += x[b.offset];
  return sum;
}

}  // namespace multibond
