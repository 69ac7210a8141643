// The compiled model's plain parts (compile/slot_table.h, plan.h, torn_loops.h, switch_set.h),
// checked on every example the way a pass that reads them relies on them: each bond's effort
// and flow has a class, the classes' slots are disjoint and inside the workspace, junctions share
// what they must (a 0-junction one effort, a 1-junction one flow), every instruction writes
// inside the workspace, the moduli inside theirs, and the torn loops' unknowns add up.

#include <filesystem>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "multibond/compile/compiled_model.h"
#include "multibond/io/model_loader.h"

namespace multibond {
namespace {

std::vector<std::shared_ptr<const CompiledModel>> CompileEveryExample() {
  std::vector<std::shared_ptr<const CompiledModel>> models;
  for (const auto& e : std::filesystem::recursive_directory_iterator(std::string(MULTIBOND_SOURCE_DIR) + "/examples")) {
    if (e.path().extension() != ".yaml") continue;
    try {
      const LoadedModel lm = LoadModelFile(e.path().string());
      models.push_back(CompiledModel::Compile(lm.graph, lm.compile));
    } catch (const std::exception&) {
      // Not a model on its own (a figure list, a sweep, a part) or one that shows an error.
    }
  }
  return models;
}

const std::vector<std::shared_ptr<const CompiledModel>>& Models() {
  static const auto models = CompileEveryExample();
  return models;
}

TEST(ModelParts, EveryExampleCompiles) {
  EXPECT_GE(Models().size(), 40u);  // of 47 files: figure lists, sweeps and error demonstrations are not
}

TEST(ModelParts, SlotClassesAreDisjointAndInsideTheWorkspace) {
  for (const auto& m : Models()) {
    const SlotTable& s = m->slot_table();
    const int nc = s.num_classes();
    ASSERT_EQ(static_cast<int>(s.class_size.size()), nc);
    ASSERT_EQ(static_cast<int>(s.class_names.size()), nc);
    ASSERT_EQ(static_cast<int>(s.class_units.size()), nc);
    // The last slots are the torn variables' shadows (OrderPlan, after the formulas' map).
    int shadows = 0;
    for (const TornLoops::Tear& t : m->torn_loops().tears) shadows += t.size;
    ASSERT_EQ(static_cast<int>(s.class_of_slot.size()) + shadows, s.num_slots);
    std::vector<int> owner(s.num_slots, -1);
    for (int c = 0; c < nc; ++c) {
      ASSERT_GE(s.class_offset[c], 0) << s.class_names[c];
      ASSERT_LE(s.class_offset[c] + s.class_size[c], s.num_slots) << s.class_names[c];
      EXPECT_FALSE(s.class_names[c].empty()) << "class " << c;
      for (int k = 0; k < s.class_size[c]; ++k) {
        const int slot = s.class_offset[c] + k;
        EXPECT_EQ(owner[slot], -1) << s.class_names[c] << " and " << (owner[slot] < 0 ? "" : s.class_names[owner[slot]]);
        owner[slot] = c;
      }
    }
    for (int slot = 0; slot < static_cast<int>(s.class_of_slot.size()); ++slot) {
      if (s.class_of_slot[slot] >= 0) {
        EXPECT_EQ(s.class_of_slot[slot], owner[slot]) << "slot " << slot;
      }
    }
  }
}

TEST(ModelParts, EveryBondHasItsClassesAndJunctionsShareThem) {
  for (const auto& m : Models()) {
    const SlotTable& s = m->slot_table();
    const BondGraph& g = m->graph();
    ASSERT_EQ(static_cast<int>(s.effort_class.size()), g.num_bonds());
    ASSERT_EQ(static_cast<int>(s.flow_class.size()), g.num_bonds());
    for (int b = 0; b < g.num_bonds(); ++b) {
      EXPECT_GE(s.effort_class[b], 0);
      EXPECT_LT(s.effort_class[b], s.num_classes());
      EXPECT_GE(s.flow_class[b], 0);
      EXPECT_LT(s.flow_class[b], s.num_classes());
    }
    for (int i = 0; i < g.num_elements(); ++i) {
      const Element& e = g.element(i);
      if (e.bonds.empty() || (e.kind != ElementKind::kZero && e.kind != ElementKind::kOne)) continue;
      const std::vector<int>& shared = e.kind == ElementKind::kZero ? s.effort_class : s.flow_class;
      for (int b : e.bonds) EXPECT_EQ(shared[b], shared[e.bonds[0]]) << e.name;
    }
  }
}

TEST(ModelParts, ThePlanWritesInsideTheWorkspaceAndDefinesEveryClass) {
  for (const auto& m : Models()) {
    const plan::Plan& p = m->plan();
    const int num_slots = m->slot_table().num_slots;
    EXPECT_EQ(static_cast<int>(p.definitions.size()), m->slot_table().num_classes());
    for (const plan::Instr& in : p.instrs) {
      if (in.op == plan::Op::kMultiplier) continue;  // writes the multipliers, not the slots
      EXPECT_GE(in.dst, 0);
      EXPECT_LE(in.dst + in.n, num_slots);
    }
    for (const plan::ModulusEval& me : p.moduli) {
      EXPECT_GE(me.out, 0);
      EXPECT_LE(me.out + me.rows * me.cols, p.num_moduli);
    }
    for (int k : p.needed_moduli) {
      EXPECT_GE(k, 0);
      EXPECT_LT(k, static_cast<int>(p.moduli.size()));
    }
    EXPECT_EQ(p.sum_terms.size(), p.sum_signs.size());
  }
}

TEST(ModelParts, TornLoopsAddUpAndSlidesAreKinks) {
  int torn = 0;
  for (const auto& m : Models()) {
    const TornLoops& l = m->torn_loops();
    int unknowns = 0;
    for (const TornLoops::Tear& t : l.tears) unknowns += t.size;
    EXPECT_EQ(unknowns, l.num_unknowns);
    EXPECT_EQ(l.tears.size(), l.loops.size());
    for (size_t k = 0; k < l.closure.size(); ++k) {
      EXPECT_LT(l.closure[k], m->num_instructions());
      if (k > 0) {
        EXPECT_LT(l.closure[k - 1], l.closure[k]);
      }
    }
    torn += !l.empty();
    for (int k : m->switch_set().slides) EXPECT_LT(k, static_cast<int>(m->switch_set().kinks.kinks().size()));
  }
  EXPECT_GE(torn, 1);  // examples/equations/diode_*.yaml solve theirs
}

}  // namespace
}  // namespace multibond
