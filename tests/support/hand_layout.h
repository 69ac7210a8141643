#pragma once
// Test helper: the inputs of a StateLayout (compile/state_layout.h) for a graph built by hand,
// with slot classes made by hand: each bond's effort, then its flow, a class of its own (no
// junction shares one), then the signals and signal states' rates a test adds.

#include <string>
#include <unordered_map>
#include <vector>

#include "multibond/compile/state_layout.h"
#include "multibond/core/structure.h"

namespace multibond::testing {

/// The graph's structure (dimensions, domains; `translation` where none is given); throws on errors.
inline Structure StructureOf(const BondGraph& g) {
  DiagnosticSink sink;
  Structure s = AnalyzeStructure(g, "translation", sink);
  sink.ThrowIfErrors();
  return s;
}

struct HandSlots {
  std::vector<int> effort_class, flow_class, class_offset, class_size;
  std::vector<std::string> class_units;
  std::unordered_map<std::string, int> signal_class, internal_class;
  std::unordered_map<std::string, std::string> signal_state_units;
  int num_slots = 0;

  HandSlots(const BondGraph& g, const Structure& s) {
    for (int b = 0; b < g.num_bonds(); ++b) {
      const DomainUnits u = UnitsOf(s.bond_domain[b]);
      effort_class.push_back(Add(s.bond_dim[b], u.effort));
      flow_class.push_back(Add(s.bond_dim[b], u.flow));
    }
  }
  int Add(int size, const std::string& unit) {
    class_offset.push_back(num_slots);
    class_size.push_back(size);
    class_units.push_back(unit);
    num_slots += size;
    return static_cast<int>(class_offset.size()) - 1;
  }
  int AddSignal(const std::string& name, const std::string& unit) { return signal_class[name] = Add(1, unit); }
  int AddRate(const std::string& name) { return internal_class[name] = Add(1, "-"); }
  /// The slot class's first slot.
  int OffsetOf(int cls) const { return class_offset[cls]; }

  StateLayout::Input Input(const BondGraph& g, const Structure& s, bool energy_account = true) const {
    return {g, s, effort_class, flow_class, class_offset, class_size, class_units, signal_class, internal_class, signal_state_units,
            energy_account};
  }
};

}  // namespace multibond::testing
