/// \file
/// The state layout (docs/design.md, "The compiled model's parts and passes"): which states,
/// their names, units and initial values, the flat state vector's blocks, what each block's
/// derivative reads (the gathers), and the lookup of named variables.

#include "multibond/compile/compiled_model.h"

namespace multibond {

std::vector<std::string> ComponentNames(int n, const std::vector<std::string>& names) {
  if (static_cast<int>(names.size()) == n) return names;
  if (n == 1) return {};
  if (n == 3) return {"x", "y", "z"};
  std::vector<std::string> out;
  for (int i = 1; i <= n; ++i) out.push_back(std::to_string(i));
  return out;
}

void CompiledModel::LayoutStates() {
  const BondGraph& g = graph_;
  const auto& dim = structure_.bond_dim;

  // --- State layout. ---
  element_block_.assign(g.num_elements(), -1);
  aux_block_.assign(g.aux_states().size(), -1);
  std::vector<double> x0;
  auto add_block = [&](StateBlock::Kind kind, int owner, int size, const std::string& base,
                       const std::vector<std::string>& comps, const std::string& unit) {
    blocks_.push_back({kind, owner, static_cast<int>(state_names_.size()), size});
    for (int k = 0; k < size; ++k) {
      state_names_.push_back(comps.empty() ? base : base + "." + comps[k]);
      state_units_.push_back(unit);
    }
    return static_cast<int>(blocks_.size()) - 1;
  };
  for (int i = 0; i < g.num_elements(); ++i) {
    const Element& e = g.element(i);
    if (!IsStorage(e.kind)) continue;
    const int b = e.bonds.front(), n = dim[b];
    const DomainUnits u = UnitsOf(structure_.bond_domain[b]);
    const bool inertia = e.kind == ElementKind::kI;
    element_block_[i] = add_block(inertia ? StateBlock::Kind::kMomentum : StateBlock::Kind::kDisplacement, i, n,
                                  e.state_name.empty() ? e.name + (inertia ? ".p" : ".q") : e.state_name,
                                  ComponentNames(n, e.components),
                                  inertia ? u.momentum : u.displacement);
    for (int k = 0; k < n; ++k) x0.push_back(e.initial.size() == n ? e.initial(k) : 0.0);
  }
  for (size_t a = 0; a < g.aux_states().size(); ++a) {
    const AuxState& s = g.aux_states()[a];
    if (s.kind == AuxState::Kind::kLag || s.kind == AuxState::Kind::kPid ||
        (s.kind == AuxState::Kind::kIntegral && s.rate.given())) {
      // A signal state: its derivative is a formula's slot (formulas.cc, AssignSignalSlots).
      auto signal_state = [&](const std::string& name, const std::string& rate, double initial) {
        const int blk = add_block(StateBlock::Kind::kIntegral, static_cast<int>(a), 1, name, {}, s.unit.empty() ? "-" : s.unit);
        blocks_[blk].rate_class = internal_class_.at(rate);
        x0.push_back(initial);
        return blk;
      };
      const double initial = s.initial.size() == 1 ? s.initial(0, 0) : 0.0;
      if (s.kind == AuxState::Kind::kPid) {
        aux_block_[a] = signal_state(s.name + ".i", s.name + ".i.rate", initial);
        if (s.pid.kd > 0.0) signal_state(s.name + ".d", s.name + ".d.rate", 0.0);
      } else {
        aux_block_[a] = signal_state(s.name, s.name + ".rate", initial);
      }
      continue;
    }
    const int of = g.Find(s.of);
    const int b = g.element(of).bonds.front(), n = dim[b];
    if (s.kind == AuxState::Kind::kOrientation) {
      aux_block_[a] = add_block(StateBlock::Kind::kOrientation, static_cast<int>(a), 9, s.name,
                                {"11", "12", "13", "21", "22", "23", "31", "32", "33"}, "-");
      const Eigen::Matrix3d r0 = s.initial.size() == 9 ? Eigen::Matrix3d(s.initial) : Eigen::Matrix3d::Identity();
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) x0.push_back(r0(r, c));
    } else {
      const std::string unit = s.unit.empty() ? UnitsOf(structure_.bond_domain[b]).displacement : s.unit;
      aux_block_[a] = add_block(StateBlock::Kind::kIntegral, static_cast<int>(a), n, s.name,
                                ComponentNames(n, s.components.empty() ? g.element(of).components : s.components), unit);
      for (int k = 0; k < n; ++k) x0.push_back(s.initial.size() == n ? s.initial(k) : 0.0);
    }
  }
  if (options_.energy_account) {
    for (int i = 0; i < g.num_elements(); ++i) {
      const Element& e = g.element(i);
      if (IsSource(e.kind)) add_block(StateBlock::Kind::kWork, i, 1, e.name + ".work", {}, "J");
      if (e.kind == ElementKind::kR) add_block(StateBlock::Kind::kDissipation, i, 1, e.name + ".dissipated", {}, "J");
      if (IsSource(e.kind) || e.kind == ElementKind::kR) x0.push_back(0.0);
    }
  }
  x0_ = Eigen::Map<Eigen::VectorXd>(x0.data(), static_cast<Eigen::Index>(x0.size()));
}

Eigen::VectorXd CompiledModel::MakeInitialState() const { return x0_; }

void CompiledModel::BuildGathers() {
  const BondGraph& g = graph_;
  const auto& dim = structure_.bond_dim;
  for (const StateBlock& blk : blocks_) {
    Gather gt{blk.kind, blk.offset, blk.size, -1, -1, -1, 1.0};
    switch (blk.kind) {
      case StateBlock::Kind::kMomentum:
      case StateBlock::Kind::kDisplacement:
        gt.effort = class_offset_[derivative_source(blk)];
        gt.sign = derivative_sign(blk);
        break;
      case StateBlock::Kind::kOrientation:
      case StateBlock::Kind::kIntegral:
        gt.flow = class_offset_[derivative_source(blk)];
        // For an orientation, `sign` carries the stabilisation gain (0 = none).
        gt.sign = blk.kind == StateBlock::Kind::kOrientation ? g.aux_states()[blk.owner].stabilization : 1.0;
        break;
      case StateBlock::Kind::kWork:
      case StateBlock::Kind::kDissipation: {
        const int b = g.element(blk.owner).bonds.front();
        gt.effort = class_offset_[effort_class_[b]];
        gt.flow = class_offset_[flow_class_[b]];
        gt.size = dim[b];
        const double sigma = g.PowerSign(b, blk.owner);
        gt.sign = blk.kind == StateBlock::Kind::kWork ? -sigma : sigma;
        break;
      }
    }
    gathers_.push_back(gt);
  }
}

int CompiledModel::derivative_source(const StateBlock& b) const {
  if (b.rate_class >= 0) return b.rate_class;
  switch (b.kind) {
    case StateBlock::Kind::kMomentum:
      return effort_class_[graph_.element(b.owner).bonds.front()];
    case StateBlock::Kind::kOrientation:
    case StateBlock::Kind::kIntegral:  // owner is an aux state: the flow of what it integrates
      return flow_class_[graph_.element(graph_.Find(graph_.aux_states()[b.owner].of)).bonds.front()];
    default:
      return flow_class_[graph_.element(b.owner).bonds.front()];
  }
}

double CompiledModel::derivative_sign(const StateBlock& b) const {
  // I: dp/dt = sigma e; C: dq/dt = f.
  if (b.kind != StateBlock::Kind::kMomentum) return 1.0;
  return graph_.PowerSign(graph_.element(b.owner).bonds.front(), b.owner);
}

/// The name a state block is found by: its state's name, or for a vector or an orientation the
/// common part before the last '.' ("A.R" for A.R.11 ... A.R.33).
static std::string BlockName(const StateBlock& b, const std::vector<std::string>& state_names) {
  const std::string& first = state_names[b.offset];
  return b.size > 1 || b.kind == StateBlock::Kind::kOrientation ? first.substr(0, first.rfind('.')) : first;
}

void CompiledModel::IndexVariables() {
  block_by_name_.clear();
  bond_by_name_.clear();
  for (int i = 0; i < static_cast<int>(blocks_.size()); ++i) block_by_name_.emplace(BlockName(blocks_[i], state_names_), i);  // the first kept
  for (int b = 0; b < graph_.num_bonds(); ++b)
    if (!graph_.bond(b).name.empty()) bond_by_name_.emplace(graph_.bond(b).name, b);
}

std::optional<VariableRef> CompiledModel::FindVariable(const std::string& name) const {
  // Signals ("u", "pid.u"): a slot of their own.
  if (const auto it = signal_class_.find(name); it != signal_class_.end())
    return VariableRef{VariableRef::In::kSlot, class_offset_[it->second], 1, class_units_[it->second], {}};
  // States by full name of their block ("mass.p", "A.R", "A.r").
  if (const auto it = block_by_name_.find(name); it != block_by_name_.end()) {
    const StateBlock& b = blocks_[it->second];
    VariableRef v{VariableRef::In::kState, b.offset, b.size, state_units_[b.offset], {}};
    for (int k = 0; k < b.size; ++k)
      if (state_names_[b.offset + k] != name) v.components.push_back(state_names_[b.offset + k].substr(name.size() + 1));
    return v;
  }
  const auto dot = name.rfind('.');
  if (dot == std::string::npos) return std::nullopt;
  const std::string owner = name.substr(0, dot), var = name.substr(dot + 1);
  const int e = graph_.Find(owner);
  if (e < 0) {
    // A named bond: "<bond>.e" or "<bond>.f".
    const auto it = bond_by_name_.find(owner);
    if (it == bond_by_name_.end() || (var != "e" && var != "f")) return std::nullopt;
    const int b = it->second;
    const int cls = var == "e" ? effort_class_[b] : flow_class_[b];
    return VariableRef{VariableRef::In::kSlot, class_offset_[cls], class_size_[cls], class_units_[cls], ComponentNames(class_size_[cls])};
  }
  const Element& el = graph_.element(e);
  int cls = -1;
  if (IsTwoPort(el.kind)) {
    const int b1 = structure_.port_in[e], b2 = structure_.port_out[e];
    if (var == "e1") cls = effort_class_[b1];
    if (var == "f1") cls = flow_class_[b1];
    if (var == "e2") cls = effort_class_[b2];
    if (var == "f2") cls = flow_class_[b2];
  } else if (!el.bonds.empty()) {
    // A 0-junction has one effort, a 1-junction one flow; their other variable differs per bond.
    if (var == "e" && el.kind != ElementKind::kOne) cls = effort_class_[el.bonds.front()];
    if (var == "f" && el.kind != ElementKind::kZero) cls = flow_class_[el.bonds.front()];
  }
  if (cls < 0) return std::nullopt;
  return VariableRef{VariableRef::In::kSlot, class_offset_[cls], class_size_[cls], class_units_[cls],
                     ComponentNames(class_size_[cls], el.components)};
}

void CompiledModel::Read(const VariableRef& v, const double* x, const Workspace& ws, double* out) const {
  const double* from = v.in == VariableRef::In::kState ? x + v.offset : ws.slots.data() + v.offset;
  std::copy(from, from + v.size, out);
}

}  // namespace multibond
