#pragma once
/// \file
/// The energy account of a compiled model (docs/design.md, "Energy account"): each I's and C's
/// stored energy as a function of the state, and the totals of the work and dissipation states
/// the layout adds (compile/state_layout.h). The stored energy of a storage element is
///   1/2 p^T I^-1 p (an I), 1/2 h_b^T Ib^-1 h_b with h_b = R^T h (a rotated I, R its orientation),
///   1/2 q^T K q (a C),
/// or, for an element given by formulas, a program of the time and the state: its `energy:`
/// formula or its law's integral from 0 in closed form, else its law integrated from 0 by
/// quadrature (GSL) at each call. A law that reads t, signals or other states (a modulated
/// storage) has its energy E(q, s) at fixed s, with the signals written out in t and the state,
/// so that it is a function of (t, x) too; the work of its modulation is a state of the layout
/// (`<element>.modulation_work`, a kWork block) and counts in Work(). The account knows
/// programs, not formulas: whoever builds it compiles them (Input::formula_energy; the compiled
/// model's is compile/formulas.cc's StoredEnergyFormula).
///
/// Built once from the layout and the graph; it holds every table it evaluates from. Evaluation
/// allocates nothing (the quadrature's workspace aside: a law's energy, at output times only).

#include <functional>
#include <optional>
#include <vector>

#include "multibond/compile/expr_program.h"
#include "multibond/compile/state_layout.h"
#include "multibond/core/graph.h"

namespace multibond {

class EnergyAccount {
 public:
  /// The stored energy of a storage element given by formulas, compiled: a program of the time
  /// and the state (Run(program, t, x, nullptr): it reads no slot), or with `law` the element's
  /// law as a program of x[0] alone, integrated from 0 to the element's state.
  struct FormulaEnergy {
    expr::Program program;
    bool law = false;
  };
  /// What the account is built from: the graph (the I's and C's parameters, a body's
  /// orientation), the layout (their blocks), and the energies of the elements given by
  /// formulas: called with each storage element and the offset of its state, in layout order;
  /// nullopt (or no function) for an element whose parameter gives its energy.
  struct Input {
    const BondGraph& graph;
    const StateLayout& layout;
    std::function<std::optional<FormulaEnergy>(int element, int state)> formula_energy = {};
  };

  EnergyAccount() = default;
  explicit EnergyAccount(const Input& in);

  /// An I's or C's stored energy at (t, x); 0 for any other element. The time matters only to a
  /// storage law that reads it (directly or through a signal).
  double StoredEnergy(int element, double t, const double* x) const;
  /// Every I's and C's stored energy in one pass (what an output row needs): per_term receives
  /// num_terms() values, in the order term(element) gives; returns the sums.
  struct Totals {
    double kinetic = 0.0, potential = 0.0;
  };
  Totals StoredEnergies(double t, const double* x, double* per_term) const;
  int num_terms() const { return static_cast<int>(terms_.size()); }
  int term(int element) const { return term_of_element_.at(element); }  ///< or -1
  double Kinetic(double t, const double* x) const;    ///< every I's
  double Potential(double t, const double* x) const;  ///< every C's, and minus the work of the potential_work sources (gravity)
  /// Total work so far: of all sources (their work states) but the potential_work ones, and of
  /// every modulated storage element's modulation (its modulation_work state).
  double Work(const double* x) const;
  double Dissipated(const double* x) const;  ///< total dissipated in all resistors so far

 private:
  /// The stored energy of each I and C, ready for output times (no lookups, no allocation).
  struct Term {
    int state, size;
    int rotation;  ///< state offset of the body's orientation (rotated inertia), or -1
    int coef;      ///< offset in coef_ of the size x size matrix (row-major): I^-1, Ib^-1 or K
    bool kinetic;
    int program = -1;  ///< a formula's energy: its program in programs_ (then coef is unused)
    int law = -1;      ///< a law without a closed-form energy: its program of x[0] (quadrature)
  };
  double EnergyOf(const Term& et, double t, const double* x) const;

  std::vector<Term> terms_;
  std::vector<int> potential_work_;  ///< work states of the sources whose work is a potential energy (gravity)
  std::vector<double> coef_;
  std::vector<int> term_of_element_;  ///< index in terms_, or -1
  std::vector<expr::Program> programs_;
  std::vector<int> work_, dissipated_;  ///< the work (sources', modulations') and dissipation states, in layout order
};

}  // namespace multibond
