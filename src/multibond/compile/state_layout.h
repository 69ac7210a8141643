#pragma once
/// \file
/// The state layout of a compiled model (docs/design.md, "The compiled model's parts and
/// passes"): the flat state vector's blocks (I momenta, C displacements, orientations, integrals
/// and signal states, the energy account's work and dissipation), their names, units and initial
/// values, what each block's derivative reads from the slots (the gathers), and the lookup of
/// named variables (FindVariable: signals, states, elements' and named bonds' efforts and flows).
///
/// Built once from the graph, its structure and the slot classes (Input, named below); it holds
/// every table it answers from, so it can be built and tested on its own. CompiledModel holds one
/// and forwards its public methods to it.

#include <optional>
#include <string>
#include <unordered_map>
#include <vector>

#include <Eigen/Dense>

#include "multibond/core/graph.h"
#include "multibond/core/structure.h"

namespace multibond {

/// The name of the internal slot class that holds the power a modulated C or I (a storage law
/// that reads t, signals or other states) takes from its modulation; its integral is the state
/// `<element>.modulation_work` of the energy account (compile/modulated_storage.cc).
inline std::string ModulationPowerName(const std::string& element) { return element + ".modulation_power"; }

/// A named, contiguous group of states (I momenta, C displacements, auxiliary states, energy).
/// A kWork block is a source's work, or (owner a C or I, rate_class set) the work of a storage
/// element's modulation.
struct StateBlock {
  enum class Kind { kMomentum, kDisplacement, kOrientation, kIntegral, kWork, kDissipation };
  Kind kind;
  int owner;   ///< element index (I, C, source, R) or aux index (orientation, integral)
  int offset;  ///< first entry in the state vector
  int size;
  /// Signal states (a rate formula, a lag, a PID): the slot class their derivative copies; -1 =
  /// by kind (derivative_source).
  int rate_class = -1;
};

/// How one state block's derivative is read from the slots (CompiledModel::EvalGather): the
/// effort (momenta, displacements) or flow (orientations, integrals) it reads, or both (work,
/// dissipation), and a sign (an orientation's: its stabilisation gain, 0 = none).
struct StateGather {
  StateBlock::Kind kind;
  int state, size, effort, flow, rotation;
  double sign;
};

/// Where a named variable lives and how to read it.
struct VariableRef {
  enum class In { kState, kSlot };
  In in = In::kSlot;
  int offset = 0;
  int size = 1;
  std::string unit;
  std::vector<std::string> components;  ///< suffixes ("x", "y", "z", "11", ...), empty for scalars
};

/// Component suffixes for a bond of dimension n: none for 1, x y z for 3, 1..n otherwise,
/// unless `names` gives them.
std::vector<std::string> ComponentNames(int n, const std::vector<std::string>& names = {});

class StateLayout {
 public:
  /// What the layout is built from: the graph (storage elements, auxiliary states, bonds' names
  /// and power signs), its structure (bond dimensions and domains, two-ports' bonds), and the slot
  /// classes (the efforts and flows that share a workspace slot, compile/plan_builder.cc
  /// AssignSlots; signals and signal states' rates, compile/formulas.cc AssignSignalSlots).
  struct Input {
    const BondGraph& graph;
    const Structure& structure;
    const std::vector<int>& effort_class;  ///< per bond: its effort's slot class
    const std::vector<int>& flow_class;    ///< per bond: its flow's slot class
    const std::vector<int>& class_offset;  ///< per slot class: its first slot
    const std::vector<int>& class_size;
    const std::vector<std::string>& class_units;
    /// Signals by name ("u", "pid.u") -> their slot class (FindVariable finds them first).
    const std::unordered_map<std::string, int>& signal_class;
    /// The signal states' rates ("lag.rate", "pid.i.rate") -> their slot class (StateBlock::rate_class).
    const std::unordered_map<std::string, int>& internal_class;
    /// The signal states' units by state name ("pid.i", "lag"), where known; a PID's own `unit`
    /// is its output's, so its states without an entry have none ("-").
    const std::unordered_map<std::string, std::string>& signal_state_units;
      /// Add a work state per source and a dissipation state per resistor (the energy account),
    /// and a modulation work state per storage element with a modulation power class
    /// (ModulationPowerName, among internal_class).
    bool energy_account = true;
  };

  StateLayout() = default;
  /// Lays out the states in order: each I's and C's block (element order), each auxiliary
  /// state's (orientations, integrals, signal states; a PID's i and, with kd > 0, d), then the
  /// energy account's work, dissipation and modulation work (element order); then the gathers
  /// and the name index.
  explicit StateLayout(const Input& in);

  int num_states() const { return static_cast<int>(state_names_.size()); }
  const std::vector<StateBlock>& blocks() const { return blocks_; }
  const std::vector<std::string>& state_names() const { return state_names_; }
  const std::vector<std::string>& state_units() const { return state_units_; }
  const Eigen::VectorXd& x0() const { return x0_; }
  /// Per element: its state block (I, C) or -1; per auxiliary state: its first block (a PID's d
  /// is the next one).
  int element_block(int element) const { return element_block_[element]; }
  int aux_block(int aux) const { return aux_block_[aux]; }
  /// One per block (parallel to blocks()).
  const std::vector<StateGather>& gathers() const { return gathers_; }
  /// The slot class a block's derivative reads (e for I, f for C and integrals, the rate class of
  /// a signal state; f for work and dissipation), and its sign (sigma for I, else 1). `b` is one
  /// of blocks().
  int derivative_source(const StateBlock& b) const { return derivative_class_[IndexOf(b)]; }
  double derivative_sign(const StateBlock& b) const { return derivative_sign_[IndexOf(b)]; }

  /// Looks up, in this order: a signal ("u", "pid.u"); a state block by the name of its state, or
  /// of its states' common part ("mass.p", "A.R", "A.r"); "<element>.e|f|e1|f1|e2|f2" (a
  /// 0-junction has no f, a 1-junction no e); "<bond>.e|f" for a named bond that no element's
  /// name hides.
  std::optional<VariableRef> FindVariable(const std::string& name) const;
  /// Copies a variable from the state x or the workspace's slots.
  static void Read(const VariableRef& v, const double* x, const double* slots, double* out);

 private:
  int IndexOf(const StateBlock& b) const;
  /// Lays out the blocks (the constructor's first step).
  void LayOut(const Input& in);
  void BuildGathers(const Input& in);
  void IndexNames(const Input& in);

  std::vector<StateBlock> blocks_;
  std::vector<std::string> state_names_, state_units_;
  Eigen::VectorXd x0_;
  std::vector<int> element_block_;  ///< per element: its state block (I, C) or -1
  std::vector<int> aux_block_;      ///< per aux state
  std::vector<StateGather> gathers_;
  std::vector<int> derivative_class_;    ///< per block
  std::vector<double> derivative_sign_;  ///< per block
  /// The name index: every name FindVariable answers, resolved when the layout is built (a
  /// search per lookup made laying out the columns of a 5,000-body model quadratic).
  struct Named {
    VariableRef::In in;
    int offset, size;
    int unit;        ///< kSlot: index in units_ (a state's unit is state_units_'s)
    int components;  ///< index in components_ (an element's own names), -1: ComponentNames(size)
  };
  std::unordered_map<std::string, Named> names_;
  std::vector<std::string> units_;                    ///< the slots' units, each once
  std::vector<std::vector<std::string>> components_;  ///< elements' component names (the few given)
};

}  // namespace multibond
