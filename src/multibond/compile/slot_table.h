#pragma once
/// \file
/// The workspace's slot classes, a part of the compiled model (docs/design.md, "The compiled
/// model's parts and passes"): the efforts and flows that share one slot (0- and 1-junctions,
/// identity transformers) as one class, with its offset, size, unit and name, and the classes
/// beyond the bonds' (signals, the signal states' rates, the scratch of laws used backwards).
/// Made by the slot passes (CompiledModel::AssignSlots, AssignSignalSlots,
/// AssignModulationSlots); read by every later pass and by the symbolic view.

#include <string>
#include <unordered_map>
#include <vector>

namespace multibond {

struct SlotTable {
  std::vector<int> effort_class, flow_class;  ///< per bond: the class of its effort, of its flow
  std::vector<int> class_offset, class_size;  ///< per class: its first workspace slot, its size
  std::vector<std::string> class_names, class_units;  ///< per class: "j.f", "spring.e"; its unit
  int num_slots = 0;                           ///< the workspace's slots, scratch included
  std::vector<int> class_of_slot;  ///< per workspace slot: its class (formulas' dependencies), -1 for scratch
  std::unordered_map<std::string, int> signal_class;  ///< signal name ("u", "pid.u") -> its class
  /// The signal states' units found from their formulas (AssignSignalSlots): a PID's "pid.i"
  /// (its input's times s) and "pid.d" (its input's), a lag's (its input's), an integral of a rate
  /// (the rate's times s) when the file gives none.
  std::unordered_map<std::string, std::string> signal_state_units;
  std::unordered_map<std::string, int> internal_class;  ///< the signal states' rates ("lag.rate") -> class
  std::unordered_map<int, int> modulation_class;  ///< modulated C or I -> the class of its power
  std::unordered_map<int, int> solve_slot;  ///< resistor -> the scratch slot of its solved law's unknown

  int num_classes() const { return static_cast<int>(class_offset.size()); }
};

}  // namespace multibond
