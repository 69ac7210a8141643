#pragma once
/// \file
/// A repair assistant for bond graphs in derivative causality (`multibond check --suggest`).
///
/// Method. An inertia I_dep in derivative causality has its flow fixed by the rest of the graph
/// (another inertia through a rigid gear, a flow source, a second inertia on its 1-junction). The
/// coupling goes on the one bond that joins I_dep to the rest of the graph, J -- I_dep:
///
///        J --> I_dep          becomes          J --> 0 --> I_dep
///                                                    |
///                                                    v
///                                                    1 --> C (stiffness K)
///                                                     \--> R (damping R)
///
/// (the bond's direction is kept: for a bond I_dep --> J the chain is I_dep --> 0 --> J). The
/// 0-junction carries one effort, the coupling's force or torque, which acts on both sides; its
/// flow balance (bonds in count +, bonds out -, core/graph.h) gives the 1-junction's common flow
/// f_tail - f_head, i.e. f_J - f_I for the usual bond J --> I_dep: the deflection rate. The C
/// integrates it into the deflection and the R damps it, so I_dep gets back an independent
/// momentum (integral causality).
///
/// K and R come from a target natural frequency f and damping ratio zeta of the relative mode:
///     w = 2 pi f,   K = m_eff w^2,   R = 2 zeta sqrt(K m_eff) = 2 zeta w m_eff,
/// where m_eff is the reduced inertia of the two sides, m_eff = I_dep I_ref / (I_dep + I_ref), and
/// I_ref is the independent inertia that fixed I_dep's flow (the origin of the causal path),
/// reflected to I_dep's side. Reflection: along the path the flows are related by the
/// transformers, f_dep = T f_ref with T the product of the TF ratios passed (M going from port 1 to
/// port 2, M^-1 the other way; 1-junctions pass the flow unchanged). The kinetic energy
/// 1/2 f_ref^T I_ref f_ref = 1/2 f_dep^T (T^-T I_ref T^-1) f_dep, so the reflected inertia is
/// T^-T I_ref T^-1, which for a scalar TF of ratio n (f_dep = n f_ref) is I_ref / n^2. Matrix
/// inertias use m_eff = (I_dep^-1 + I_ref^-1)^-1, K = w^2 m_eff and R = 2 zeta w m_eff (the same
/// frequency and damping ratio in every direction). When the flow is imposed by a flow source,
/// I_ref is infinite and m_eff = I_dep. When the reflection cannot be computed (a gyrator, a
/// modulated two-port, a 0-junction on the path, an orientation-dependent inertia, a non-square
/// map), m_eff = I_dep alone, and the result says so: the coupling is then stiffer than the target
/// frequency needs (its frequency is higher).
///
/// Greedy: the coupling is inserted for the first inertia in derivative causality, causality is
/// assigned again on the modified graph, and so on until no inertia is left in derivative
/// causality. Each coupling is checked to remove at least one derivative causality (its own
/// inertia's), so the set is minimal in that sense: no coupling in it is redundant when it is
/// inserted. (It is not claimed to be the smallest possible set.) A C in derivative causality
/// needs the dual repair (a series resistor or inertia), which is not proposed.

#include <string>
#include <vector>

#include <Eigen/Dense>

#include "multibond/causality/causality.h"
#include "multibond/core/graph.h"

namespace multibond {

/// The target of every coupling's relative mode.
struct CouplingTarget {
  double frequency_hz = 100.0;  ///< natural frequency f [Hz]
  double damping_ratio = 0.7;   ///< zeta
};

/// One compliant coupling to insert.
struct SuggestedCoupling {
  std::string storage;       ///< the inertia in derivative causality (I_dep)
  std::string other_end;     ///< the element at the other end of its bond (J)
  std::string bond;          ///< the bond's name
  std::string tail, head;    ///< the bond's ends (tail -> head), names in the graph
  SourceLocation where;      ///< where the bond was written
  int original_bond = -1;    ///< the bond's index in the graph given to SuggestCouplings
  std::string path;          ///< the causal path that fixed I_dep's flow
  /// The inserted elements: the 0-junction on the bond, the 1-junction of the deflection rate, and
  /// the C and R on it.
  std::string zero, one, spring, damper;
  int dim = 1;               ///< the bond's dimension
  std::string domain;        ///< the bond's domain ("" = generic)
  Eigen::MatrixXd m_eff;     ///< reduced inertia (dim x dim)
  Eigen::MatrixXd stiffness; ///< K = m_eff w^2
  Eigen::MatrixXd damping;   ///< R = 2 zeta w m_eff
  bool reflected = false;    ///< m_eff includes the reference inertia I_ref (or a flow source)
  std::string reference;     ///< "I 'J1'" or "Sf 'drive'": what fixed I_dep's flow ("" if unknown)
  /// How m_eff was obtained, one sentence: "I_dep I_ref / (I_dep + I_ref) with I_dep = I 'J2'
  /// (0.04) and I_ref = I 'J1' (0.01) reflected through TF 'gear' (...): 0.04", or "I 'J2' alone: why".
  std::string m_eff_note;
  int removed = 0;           ///< derivative causalities this coupling removed (>= 1)
};

struct RepairResult {
  std::vector<SuggestedCoupling> couplings;  ///< in the order of insertion
  BondGraph repaired;                        ///< the graph with every coupling inserted
  CausalAssignment causality;                ///< the causality of `repaired`
  /// `repaired` has no storage element in derivative causality (other causality problems, e.g.
  /// conflicts or algebraic loops, are not the assistant's business; see causality.has_errors()).
  bool integral = false;
  /// Storage elements in derivative causality left as they are, each with the reason.
  std::vector<std::string> not_repaired;
};

/// The graph as the compiler assigns its causality: an Sf marked `constraint` (a rigid joint or
/// mesh, an explicit ideal constraint) is an effort source of unknown effort, its reaction, which
/// the compiled model solves for (compile/constraints.cc). Elements and bonds keep their indices,
/// so the causality of the view applies to `g` as written. Taken by value: a caller that no
/// longer needs `g` moves it in, and the view costs no copy of the graph.
BondGraph CausalView(BondGraph g);

/// CausalView in place, for a scope: `g` is the view while this object lives (its constraint Sf
/// are Se) and as it was after, without a copy of the graph (a copy of a large model's graph
/// costs as much as its causality). The graph must not gain or lose elements meanwhile.
class InCausalView {
 public:
  explicit InCausalView(BondGraph& g);
  ~InCausalView();
  InCausalView(const InCausalView&) = delete;
  InCausalView& operator=(const InCausalView&) = delete;
  const BondGraph& graph() const { return g_; }

 private:
  BondGraph& g_;
  std::vector<int> turned_;  ///< the constraint Sf made Se, to be made Sf again
};

/// Proposes compliant couplings that remove all derivative causality of inertias in `g` (see the
/// method above). Throws ModelError if the graph's structure is wrong (as CompiledModel does).
/// Causality is that of CausalView (rigid joints are not derivative causality: they are solved).
RepairResult SuggestCouplings(const BondGraph& g, const std::string& default_domain, const CouplingTarget& target = {});

/// A copy of `g` with `c` inserted on bond `bond` (c.zero, c.one, c.spring, c.damper are added at
/// the end, with c.stiffness and c.damping). The two bonds that replace `bond` take its place in
/// the bond order; the one at the storage element keeps a user-given bond name.
BondGraph InsertCoupling(const BondGraph& g, int bond, const SuggestedCoupling& c);

/// Units of an inertia, a stiffness and a resistance in a domain ("-" for generic ones).
struct CouplingUnits {
  std::string inertia, stiffness, resistance;
};
CouplingUnits CouplingUnitsOf(const std::string& domain);

/// A parameter for a dim x dim matrix: a scalar when it is a multiple of the identity, else the
/// matrix (diagonal or full).
Param ParamOf(const Eigen::MatrixXd& m);
/// The matrix as a model file writes a parameter: "0.04" for a multiple of the identity, else
/// "[0.1, 0.2]" (diagonal) or "[[..], [..]]"; 6 significant digits, or every digit.
std::string MatrixText(const Eigen::MatrixXd& m, bool full_precision);

}  // namespace multibond
