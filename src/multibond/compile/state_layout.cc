/// \file
/// The state layout (compile/state_layout.h; docs/design.md, "The compiled model's parts and
/// passes"): which states, their names, units and initial values, the flat state vector's blocks,
/// what each block's derivative reads (the gathers), and the lookup of named variables.

#include "multibond/compile/state_layout.h"

#include <algorithm>

#include "multibond/core/error.h"

namespace multibond {

std::vector<std::string> ComponentNames(int n, const std::vector<std::string>& names) {
  if (static_cast<int>(names.size()) == n) return names;
  if (n == 1) return {};
  if (n == 3) return {"x", "y", "z"};
  std::vector<std::string> out;
  for (int i = 1; i <= n; ++i) out.push_back(std::to_string(i));
  return out;
}

StateLayout::StateLayout(const Input& in) {
  LayOut(in);
  BuildGathers(in);
  IndexNames(in);
}

void StateLayout::LayOut(const Input& in) {
  const BondGraph& g = in.graph;
  const auto& dim = in.structure.bond_dim;

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
    const DomainUnits u = UnitsOf(in.structure.bond_domain[b]);
    const bool inertia = e.kind == ElementKind::kI;
    element_block_[i] = add_block(inertia ? StateBlock::Kind::kMomentum : StateBlock::Kind::kDisplacement, i, n,
                                  e.state_name.empty() ? e.name + (inertia ? ".p" : ".q") : e.state_name,
                                  ComponentNames(n, e.components),
                                  inertia ? u.momentum : u.displacement);
    if (static_cast<int>(e.state_units.size()) == n)  // `units:`, one per component (checked by the loader)
      for (int k = 0; k < n; ++k) state_units_[blocks_[element_block_[i]].offset + k] = e.state_units[k];
    for (int k = 0; k < n; ++k) x0.push_back(e.initial.size() == n ? e.initial(k) : 0.0);
  }
  for (size_t a = 0; a < g.aux_states().size(); ++a) {
    const AuxState& s = g.aux_states()[a];
    if (s.kind == AuxState::Kind::kLag || s.kind == AuxState::Kind::kPid ||
        (s.kind == AuxState::Kind::kIntegral && s.rate.given())) {
      // A signal state: its derivative is a formula's slot (formulas.cc, AssignSignalSlots).
      auto signal_state = [&](const std::string& name, const std::string& rate, double initial) {
        const auto known = in.signal_state_units.find(name);
        const std::string unit = known != in.signal_state_units.end() && !known->second.empty() ? known->second
                                 : s.kind != AuxState::Kind::kPid && !s.unit.empty()                ? s.unit
                                                                                                    : "-";
        const int blk = add_block(StateBlock::Kind::kIntegral, static_cast<int>(a), 1, name, {}, unit);
        blocks_[blk].rate_class = in.internal_class.at(rate);
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
      const std::string unit = s.unit.empty() ? UnitsOf(in.structure.bond_domain[b]).displacement : s.unit;
      aux_block_[a] = add_block(StateBlock::Kind::kIntegral, static_cast<int>(a), n, s.name,
                                ComponentNames(n, s.components.empty() ? g.element(of).components : s.components), unit);
      for (int k = 0; k < n; ++k) x0.push_back(s.initial.size() == n ? s.initial(k) : 0.0);
    }
  }
  if (in.energy_account) {
    for (int i = 0; i < g.num_elements(); ++i) {
      const Element& e = g.element(i);
      // A switching element (a contact, a friction) is a source that only ever takes energy out:
      // what it delivers is counted as dissipated (docs/events.md), impacts included.
      if (IsSource(e.kind) && e.switching.kind == Switching::Kind::kNone) add_block(StateBlock::Kind::kWork, i, 1, e.name + ".work", {}, "J");
      if (IsSource(e.kind) && e.switching.kind != Switching::Kind::kNone)
        add_block(StateBlock::Kind::kDissipation, i, 1, e.name + ".dissipated", {}, "J");
      if (e.kind == ElementKind::kR) add_block(StateBlock::Kind::kDissipation, i, 1, e.name + ".dissipated", {}, "J");
      if (IsSource(e.kind) || e.kind == ElementKind::kR) x0.push_back(0.0);
      // A storage element whose law reads t, signals or other states: the work its modulation
      // does, the integral of its power (a formula's slot, compile/modulated_storage.cc).
      if (const auto it = in.internal_class.find(ModulationPowerName(e.name)); IsStorage(e.kind) && it != in.internal_class.end()) {
        const int blk = add_block(StateBlock::Kind::kWork, i, 1, e.name + ".modulation_work", {}, "J");
        blocks_[blk].rate_class = it->second;
        x0.push_back(0.0);
      }
    }
  }
  x0_ = Eigen::Map<Eigen::VectorXd>(x0.data(), static_cast<Eigen::Index>(x0.size()));
}

void StateLayout::BuildGathers(const Input& in) {
  const BondGraph& g = in.graph;
  const auto& dim = in.structure.bond_dim;
  for (const StateBlock& blk : blocks_) {
    // The slot class the block's derivative reads: I: dp/dt = sigma e; C: dq/dt = f; an
    // orientation or integral (owner: an aux state) the flow of what it integrates.
    int source = blk.rate_class;
    double sign = 1.0;
    if (source < 0) {
      switch (blk.kind) {
        case StateBlock::Kind::kMomentum:
          source = in.effort_class[g.element(blk.owner).bonds.front()];
          sign = g.PowerSign(g.element(blk.owner).bonds.front(), blk.owner);
          break;
        case StateBlock::Kind::kOrientation:
        case StateBlock::Kind::kIntegral:
          source = in.flow_class[g.element(g.Find(g.aux_states()[blk.owner].of)).bonds.front()];
          break;
        default:
          source = in.flow_class[g.element(blk.owner).bonds.front()];
      }
    }
    derivative_class_.push_back(source);
    derivative_sign_.push_back(sign);

    StateGather gt{blk.kind, blk.offset, blk.size, -1, -1, -1, 1.0};
    if (blk.kind == StateBlock::Kind::kWork && blk.rate_class >= 0) {
      // A modulation's work: its derivative copies the power's slot, as a signal state's does.
      gt.kind = StateBlock::Kind::kIntegral;
      gt.flow = in.class_offset[source];
      gathers_.push_back(gt);
      continue;
    }
    switch (blk.kind) {
      case StateBlock::Kind::kMomentum:
      case StateBlock::Kind::kDisplacement:
        gt.effort = in.class_offset[source];
        gt.sign = sign;
        break;
      case StateBlock::Kind::kOrientation:
      case StateBlock::Kind::kIntegral:
        gt.flow = in.class_offset[source];
        // For an orientation, `sign` carries the stabilisation gain (0 = none).
        gt.sign = blk.kind == StateBlock::Kind::kOrientation ? g.aux_states()[blk.owner].stabilization : 1.0;
        break;
      case StateBlock::Kind::kWork:
      case StateBlock::Kind::kDissipation: {
        const int b = g.element(blk.owner).bonds.front();
        gt.effort = in.class_offset[in.effort_class[b]];
        gt.flow = in.class_offset[in.flow_class[b]];
        gt.size = dim[b];
        const double sigma = g.PowerSign(b, blk.owner);
        gt.sign = blk.kind == StateBlock::Kind::kWork ? -sigma : sigma;
        break;
      }
    }
    gathers_.push_back(gt);
  }
}

int StateLayout::IndexOf(const StateBlock& b) const {
  // The blocks lie in the state vector in order, none empty.
  const auto it = std::lower_bound(blocks_.begin(), blocks_.end(), b.offset,
                                   [](const StateBlock& a, int offset) { return a.offset < offset; });
  MB_ASSERT(it != blocks_.end() && it->offset == b.offset && it->kind == b.kind, "a block of this layout");
  return static_cast<int>(it - blocks_.begin());
}

/// The name a state block is found by: its state's name, or for a vector or an orientation the
/// common part before the last '.' ("A.R" for A.R.11 ... A.R.33).
static std::string BlockName(const StateBlock& b, const std::vector<std::string>& state_names) {
  const std::string& first = state_names[b.offset];
  return b.size > 1 || b.kind == StateBlock::Kind::kOrientation ? first.substr(0, first.rfind('.')) : first;
}

void StateLayout::IndexNames(const Input& in) {
  const BondGraph& g = in.graph;
  std::unordered_map<std::string, int> unit_index;
  auto unit_of = [&](int cls) {
    // try_emplace: a unit already indexed (nearly every call) makes no node to throw away.
    const auto [it, added] = unit_index.try_emplace(in.class_units[cls], static_cast<int>(units_.size()));
    if (added) units_.push_back(in.class_units[cls]);
    return it->second;
  };
  // A name already taken is kept: what FindVariable looks up first is indexed first.
  auto add_slot = [&](std::string name, int cls, int size, int components) {
    const auto [it, added] = names_.try_emplace(std::move(name));  // one look-up, not two; the name moved in
    if (added) it->second = Named{VariableRef::In::kSlot, in.class_offset[cls], size, unit_of(cls), components};
  };
  // Room for every name at once (up to four per element, two per named bond): no rehashing.
  names_.reserve(in.signal_class.size() + blocks_.size() + 4 * static_cast<size_t>(g.num_elements()) + 2 * static_cast<size_t>(g.num_bonds()));
  // Signals: a slot of their own.
  for (const auto& [name, cls] : in.signal_class) add_slot(name, cls, 1, -1);
  // States by full name of their block; of blocks of one name, the first.
  for (const StateBlock& b : blocks_) names_.emplace(BlockName(b, state_names_), Named{VariableRef::In::kState, b.offset, b.size, -1, -1});
  // Elements' efforts and flows: a two-port's e1 f1 e2 f2; a 0-junction has one effort, a
  // 1-junction one flow (their other variable differs per bond).
  for (int e = 0; e < g.num_elements(); ++e) {
    const Element& el = g.element(e);
    int components = -1;
    if (!el.components.empty()) {
      components = static_cast<int>(components_.size());
      components_.push_back(el.components);
    }
    auto add = [&](const std::string& var, int cls) { add_slot(el.name + "." + var, cls, in.class_size[cls], components); };
    if (IsTwoPort(el.kind)) {
      const int b1 = in.structure.port_in[e], b2 = in.structure.port_out[e];
      if (b1 < 0 || b2 < 0) continue;
      add("e1", in.effort_class[b1]);
      add("f1", in.flow_class[b1]);
      add("e2", in.effort_class[b2]);
      add("f2", in.flow_class[b2]);
    } else if (!el.bonds.empty()) {
      if (el.kind != ElementKind::kOne) add("e", in.effort_class[el.bonds.front()]);
      if (el.kind != ElementKind::kZero) add("f", in.flow_class[el.bonds.front()]);
    }
  }
  // Named bonds: "<bond>.e" or "<bond>.f", unless an element has the bond's name.
  for (int b = 0; b < g.num_bonds(); ++b) {
    const std::string& name = g.bond(b).name;
    if (name.empty() || g.Find(name) >= 0) continue;
    add_slot(name + ".e", in.effort_class[b], in.class_size[in.effort_class[b]], -1);
    add_slot(name + ".f", in.flow_class[b], in.class_size[in.flow_class[b]], -1);
  }
}

std::optional<VariableRef> StateLayout::FindVariable(const std::string& name) const {
  const auto it = names_.find(name);
  if (it == names_.end()) return std::nullopt;
  const Named& n = it->second;
  if (n.in == VariableRef::In::kState) {
    VariableRef v{VariableRef::In::kState, n.offset, n.size, state_units_[n.offset], {}};
    for (int k = 0; k < n.size; ++k)
      if (state_names_[n.offset + k] != name) v.components.push_back(state_names_[n.offset + k].substr(name.size() + 1));
    return v;
  }
  return VariableRef{VariableRef::In::kSlot, n.offset, n.size, units_[n.unit],
                     n.components >= 0 ? ComponentNames(n.size, components_[n.components]) : ComponentNames(n.size)};
}

void StateLayout::Read(const VariableRef& v, const double* x, const double* slots, double* out) {
  const double* from = v.in == VariableRef::In::kState ? x + v.offset : slots + v.offset;
  std::copy(from, from + v.size, out);
}

}  // namespace multibond
