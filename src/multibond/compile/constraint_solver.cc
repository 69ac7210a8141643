// The ideal-constraint solver (constraint_solver.h; docs/design.md, "Ideal constraints"): its
// tables, built from the plan, and steps 2-4 of a constrained evaluation around the plan.
//
// The junction structure conserves power, so g depends on the storage states as B^T H x, where B
// (the rate of the momenta and displacements per unit multiplier) is read off the plan and H is
// the storage's energy Hessian (M^-1 for an inertia, K for a compliance). At every evaluation:
//   1. the plan at lambda = 0 gives dx/dt (the model's own evaluation);
//   2. a tangent pass (the time derivative along dx/dt, with dR/dt for the moduli, of every slot
//      the constraints' flows depend on) gives dg/dt at lambda = 0;
//   3. W = B^T H B, and W lambda = dv/dt - dg/dt|lambda=0 makes dg/dt = 0 (index reduction to
//      the acceleration level, exactly: no finite differences), by a sparse L D L^T;
//   4. what the multipliers reach, again with lambda: dx/dt and every effort, reactions included.
// Drift of g (affine in the storage states along B) is removed after every step by ProjectMomenta.

#include "multibond/compile/constraint_solver.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <queue>
#include <unordered_map>

#include <fmt/format.h>

#include "multibond/compile/compiled_model.h"
#include "multibond/compile/exact_sum.h"
#include "multibond/core/diagnostic_codes.h"

namespace multibond {

using plan::Instr;
using plan::Op;

void ConstraintSolver::Add(std::string name, int element, std::vector<Group::Member> members, bool imposes_flow) {
  Group cg;
  cg.name = std::move(name);
  cg.element = element;
  cg.imposes_flow = imposes_flow;
  cg.members = std::move(members);
  groups_.push_back(std::move(cg));
}

void ConstraintSolver::AssignMultipliers(const std::vector<int>& bond_dim) {
  for (Group& cg : groups_) {
    cg.size = bond_dim[cg.members.front().slot];  // still the member's bond (Build maps it)
    cg.lambda = num_lambda_;
    num_lambda_ += cg.size;
    for (const auto& m : cg.members) lambda_of_bond_[m.slot] = cg.lambda;  // the last constraint a bond is a member of
  }
}

int ConstraintSolver::MultiplierOf(int bond) const {
  const auto it = lambda_of_bond_.find(bond);
  return it == lambda_of_bond_.end() ? 0 : it->second;
}

std::vector<std::string> ConstraintSolver::names() const {
  std::vector<std::string> out;
  for (const Group& cg : groups_) out.push_back(cg.name);
  return out;
}

void ConstraintSolver::Build(const BuildInput& in) {
  if (groups_.empty()) return;
  const BondGraph& g = in.graph;
  const std::vector<Instr>& plan = in.plan;
  const std::vector<StateGather>& gathers = in.gathers;
  const int np = static_cast<int>(plan.size());
  const int num_classes = static_cast<int>(in.class_offset.size());
  // Members: bond -> the constrained variable's slot (flow, or effort for a flow multiplier);
  // targets -> source functions.
  targets_.clear();
  for (Group& cg : groups_) {
    for (auto& m : cg.members) {
      const int bond = m.slot;
      m.slot = in.class_offset[cg.imposes_flow ? in.effort_class[bond] : in.flow_class[bond]];
      if (m.target == 0) {
        const Element& e = g.element(cg.element);
        m.target = static_cast<int>(targets_.size());
        for (int k = 0; k < cg.size; ++k)
          targets_.push_back(e.source.components.empty() ? TimeFunction::Constant(0.0)
                             : e.source.components.size() == 1 ? e.source.components[0] : e.source.components[k]);
      }
    }
  }
  // The couplings' compliances, when every constraint declares one (ConstraintFactor::Share).
  std::vector<double> compliance;
  bool all_compliant = true;
  for (const Group& cg : groups_) all_compliant &= g.element(cg.element).compliance.size() > 0;
  if (all_compliant)
    for (const Group& cg : groups_) {
      const Element& e = g.element(cg.element);
      if (e.compliance.size() != 1 && e.compliance.size() != cg.size)
        throw ModelError(Diagnostic{Diagnostic::Severity::kError, e.where, e.name,
                                    fmt::format("the constraint has {} components but {} compliances", cg.size, e.compliance.size()),
                                    "give one compliance, or one per component", {}, codes::kParamShape});
      for (int k = 0; k < cg.size; ++k) compliance.push_back(e.compliance[e.compliance.size() == 1 ? 0 : k]);
    }
  // The storage gathers and the instruction that computes each one's co-energy variable from its
  // state (an inertia's flow M^-1 p, a compliance's effort sigma K q): V = H B applies it to B.
  std::vector<int> state_instr_of_element(g.num_elements(), -1);
  for (int k = 0; k < np; ++k)
    if (plan::Traits(plan[k].op).reads == plan::Reads::kState && IsStorage(g.element(plan[k].element).kind))
      state_instr_of_element[plan[k].element] = k;
  auto storage = [](const StateGather& gt) {
    return gt.kind == StateBlock::Kind::kMomentum || gt.kind == StateBlock::Kind::kDisplacement;
  };
  flow_instr_of_block_.assign(gathers.size(), -1);
  std::vector<char> negate_block(gathers.size(), 0);
  for (size_t gi = 0; gi < gathers.size(); ++gi) {
    if (!storage(gathers[gi])) continue;
    const int owner = in.blocks[gi].owner;
    flow_instr_of_block_[gi] = state_instr_of_element[owner];
    // A compliance's kernel gives sigma K q (its bond's effort); H = K.
    if (gathers[gi].kind == StateBlock::Kind::kDisplacement) negate_block[gi] = g.PowerSign(g.element(owner).bonds.front(), owner) < 0;
  }

  // What no multiplier may reach: a constrained variable (its value would depend on the
  // multipliers themselves: index 1), and an orientation's rate (the moduli and rotated inertias
  // depend on the orientation: dg/dt would have a term in lambda that W = B^T H B leaves out).
  // An integral's rate may be reached: only formulas read integral states, and none in the
  // tangent plan reads one whose rate is reached (CheckFormulas), so g does not depend on it;
  // step 4 updates it.
  std::vector<int> member_of(in.num_slots, -1);
  std::vector<int> orientation_of(in.num_slots, -1);
  for (int gi = 0; gi < static_cast<int>(groups_.size()); ++gi)
    for (const auto& m : groups_[gi].members)
      for (int k = 0; k < groups_[gi].size; ++k) member_of[m.slot + k] = gi;
  for (size_t gi = 0; gi < gathers.size(); ++gi)
    if (gathers[gi].kind == StateBlock::Kind::kOrientation)
      for (int k = 0; k < 3; ++k) orientation_of[gathers[gi].flow + k] = static_cast<int>(gi);

  std::vector<int> b_offset, b_rows;
  negated_v_.clear();
  auto gi_of = [&](const Group& cg) { return static_cast<int>(&cg - groups_.data()); };
  // Indexes that keep each constraint's tables proportional to what it reaches (not to the
  // plan's size): the multiplier instructions by multiplier, the readers of each slot class (in
  // plan order), and the storage gather whose rate each slot class is.
  std::unordered_map<int, std::vector<int>> starts_of;
  for (int k = 0; k < np; ++k)
    if (plan[k].op == Op::kMultiplier) starts_of[plan[k].coef].push_back(k);
  std::vector<int> reader_offset(num_classes + 1, 0), readers;
  for (int k = 0; k < np; ++k)
    for (int c : in.plan_reads[k]) ++reader_offset[c + 1];
  for (int c = 0; c < num_classes; ++c) reader_offset[c + 1] += reader_offset[c];
  readers.resize(reader_offset[num_classes]);
  {
    std::vector<int> fill(reader_offset.begin(), reader_offset.end() - 1);
    for (int k = 0; k < np; ++k)
      for (int c : in.plan_reads[k]) readers[fill[c]++] = k;
  }
  std::unordered_map<int, int> storage_gather_at;  // a storage gather's effort slot -> the gather
  for (size_t gi = 0; gi < gathers.size(); ++gi)
    if (storage(gathers[gi])) storage_gather_at.emplace(gathers[gi].effort, static_cast<int>(gi));
  // Per constraint, the classes reached: reached_at[c] is the plan index of the instruction that
  // reached c first (-1: a multiplier instruction), or np; reset after each constraint.
  std::vector<int> reached_at(num_classes, np), in_closure(np, 0);
  for (Group& cg : groups_) {
    // The multiplier's instructions (two for a cut), then every instruction reading what they
    // reach, in plan order: an instruction joins the closure when it reads a class reached
    // before it (the plan is visited in order from a heap of candidates, so this is the scan of
    // the whole plan, restricted to what the multiplier reaches).
    std::vector<int> reached;  // the classes reached, in the order they were
    cg.starts.clear();
    if (const auto it = starts_of.find(cg.lambda); it != starts_of.end()) cg.starts = it->second;
    MB_ASSERT(!cg.starts.empty(), "constraint without its multiplier instruction");
    std::priority_queue<int, std::vector<int>, std::greater<int>> candidates;
    auto reach = [&](int c, int at) {
      if (reached_at[c] != np) return;
      reached_at[c] = at;
      reached.push_back(c);
      for (int r = reader_offset[c]; r < reader_offset[c + 1]; ++r)
        if (readers[r] > at) candidates.push(readers[r]);
    };
    for (int k : cg.starts) reach(in.plan_writes[k], -1);
    cg.closure.clear();
    while (!candidates.empty()) {
      const int k = candidates.top();
      candidates.pop();
      if (in_closure[k]) continue;
      in_closure[k] = 1;
      cg.closure.push_back(k);
      reach(in.plan_writes[k], k);
    }
    for (int k : cg.closure) in_closure[k] = 0;
    const Element& e = g.element(cg.element);
    // A cut (of a storage element) is undone by making that element independent; a rigid
    // coupling by making it compliant.
    const bool cut = IsStorage(e.kind);
    const std::string hint =
        !cut ? "make this coupling compliant (a C and an R instead of the constraint)"
        : e.kind == ElementKind::kI
            ? fmt::format("give I '{}' a momentum of its own: join it to what fixes its flow through a compliant coupling (a C "
                          "and an R); 'constraints: compliant' shows the causal path", e.name)
            : fmt::format("give C '{}' a displacement of its own: put a resistor or an inertia between it and what fixes its "
                          "effort; 'constraints: compliant' shows the causal path", e.name);
    const char* own = cg.imposes_flow ? "flow" : "effort";
    auto refuse = [&](const std::string& what) {
      throw ModelError(Diagnostic{Diagnostic::Severity::kError, e.where, e.name, what, hint, {}, codes::kConstraintUnsupported});
    };
    std::sort(reached.begin(), reached.end());
    for (int c : reached) {
      for (int k = 0; k < in.class_size[c]; ++k) {
        const int slot = in.class_offset[c] + k;
        if (member_of[slot] >= 0) {
          const Group& other = groups_[member_of[slot]];
          const char* var = other.imposes_flow ? "effort" : "flow";
          refuse(member_of[slot] == gi_of(cg)
                     ? fmt::format("the ideal constraint '{}' changes the {} '{}' it constrains through a resistor or gyrator: a "
                                   "constraint whose {}s depend on its own {} is not supported",
                                   cg.name, var, in.class_names[c], var, own)
                     : fmt::format("the ideal constraint '{}' changes the {} '{}' that the constraint '{}' constrains: constraints "
                                   "whose variables depend on each other's multipliers are not supported",
                                   cg.name, var, in.class_names[c], other.name));
        }
        if (orientation_of[slot] >= 0)
          refuse(fmt::format("the ideal constraint '{}' changes the angular velocity '{}' that turns the orientation '{}': a "
                             "constraint whose {} turns an orientation is not supported", cg.name, in.class_names[c],
                             g.aux_states()[in.blocks[orientation_of[slot]].owner].name, own));
      }
    }
    // Through a resistor, B is no longer the adjoint of g's dependence on the states (W = B^T H B
    // would be wrong): refused, wherever the resistor's output goes.
    for (int k : cg.closure)
      if (plan[k].element >= 0 && g.element(plan[k].element).kind == ElementKind::kR)
        refuse(fmt::format("the {} of the ideal constraint '{}' passes through the resistor '{}' (to '{}'): a constraint whose "
                           "{} acts through a resistor is not supported", own, cg.name, g.element(plan[k].element).name,
                           in.class_names[in.plan_writes[k]], own));
    for (int c : reached)
      if (const auto it = storage_gather_at.find(in.class_offset[c]); it != storage_gather_at.end()) cg.momenta.push_back(it->second);
    std::sort(cg.momenta.begin(), cg.momenta.end());
    cg.momenta.erase(std::unique(cg.momenta.begin(), cg.momenta.end()), cg.momenta.end());
    for (int c : reached) reached_at[c] = np;
    for (int k = 0; k < cg.size; ++k) {
      b_offset.push_back(static_cast<int>(b_rows.size()));
      for (int gi : cg.momenta) {
        if (negate_block[gi]) negated_v_.push_back({static_cast<int>(b_rows.size()), gathers[gi].size});
        for (int r = 0; r < gathers[gi].size; ++r) b_rows.push_back(gathers[gi].state + r);
      }
    }
  }
  b_offset.push_back(static_cast<int>(b_rows.size()));
  // What the multipliers reach, all constraints together: the second pass of an evaluation (with
  // lambda) re-runs only these instructions and gathers; every other slot keeps its value from
  // the pass at lambda = 0, which is what a full pass would compute again.
  std::vector<char> in_reaction(np, 0), reached_slot(in.num_slots, 0);
  for (const Group& cg : groups_) {
    for (int k : cg.starts) in_reaction[k] = 1;
    for (int k : cg.closure) in_reaction[k] = 1;
  }
  reaction_plan_.clear();
  for (int k = 0; k < np; ++k)
    if (in_reaction[k]) {
      reaction_plan_.push_back(k);
      const int c = in.plan_writes[k];
      std::fill(reached_slot.begin() + in.class_offset[c], reached_slot.begin() + in.class_offset[c] + in.class_size[c], 1);
    }
  // The tangent pass is read only at the constrained variables: it runs the instructions those
  // depend on (for rigid couplings the flow side of the plan), not what only feeds other rates.
  std::vector<char> feeds(num_classes, 0);
  std::vector<int> class_of_slot(in.num_slots, -1);
  for (int c = 0; c < num_classes; ++c)
    for (int k = 0; k < in.class_size[c]; ++k) class_of_slot[in.class_offset[c] + k] = c;
  for (const Group& cg : groups_)
    for (const auto& m : cg.members)
      if (m.slot >= 0 && m.slot < in.num_slots && class_of_slot[m.slot] >= 0) feeds[class_of_slot[m.slot]] = 1;
  tangent_plan_.clear();
  for (int k = np - 1; k >= 0; --k)
    if (feeds[in.plan_writes[k]]) {
      tangent_plan_.push_back(k);
      for (int c : in.plan_reads[k]) feeds[c] = 1;
    }
  std::reverse(tangent_plan_.begin(), tangent_plan_.end());
  CheckFormulas(in, reached_slot);
  reaction_gathers_.clear();
  for (size_t gi = 0; gi < gathers.size(); ++gi) {
    const StateGather& gt = gathers[gi];
    const bool effort = gt.kind == StateBlock::Kind::kMomentum || gt.kind == StateBlock::Kind::kDisplacement ||
                        gt.kind == StateBlock::Kind::kWork || gt.kind == StateBlock::Kind::kDissipation;
    const bool flow = gt.kind != StateBlock::Kind::kMomentum && gt.kind != StateBlock::Kind::kDisplacement;
    bool reads_reached = false;
    for (int k = 0; k < (gt.kind == StateBlock::Kind::kOrientation ? 3 : gt.size); ++k)
      reads_reached |= (effort && reached_slot[gt.effort + k]) || (flow && reached_slot[gt.flow + k]);
    if (reads_reached) reaction_gathers_.push_back(static_cast<int>(gi));
  }
  // B's sparsity and W's nonzeros (the pairs of columns that share momentum rows).
  factor_ = ConstraintFactor(std::move(b_offset), std::move(b_rows), std::move(compliance));
}

void ConstraintSolver::CheckFormulas(const BuildInput& in, const std::vector<char>& reached_slot) {
  // The solver differentiates what the constrained variables depend on (the tangent plan) and
  // runs what the multipliers reach linearly (B's columns). A formula (kExpr, kSolve) there is
  // differentiated by forward mode (plan::FormulaTangent): exact, but W = B^T H B, the one-solve
  // projection and the columns hold only if g stays affine in the storage states along B with
  // dg/dx = B^T H, and the reaction reaches the storage rates linearly. So, with "moving" the
  // storage states and every slot that depends on them or on a multiplier:
  //  - in the tangent plan, a formula of a modulated transformer or gyrator (MTF, MGY, TF, GY: power
  //    conserving, its two equations the transposes of each other) is accepted when it is affine
  //    in what moves (its modulus of time, parameters, signal states, orientations); any other
  //    formula when it reads nothing that moves (a source's or a signal's formula of time or of
  //    signal states). A formula there must not read a signal state whose rate a multiplier
  //    reaches (dg/dt would have a term in lambda that W leaves out);
  //  - in a multiplier's closure, a modulated transformer's formula affine in what moves; any
  //    other formula (an output or a signal that reads a reaction) only if nothing it feeds is a
  //    storage rate, a constrained variable or such a signal state's rate.
  // Anything else is refused (expr.unsupported, located at the formula, naming the constraint).
  const BondGraph& g = in.graph;
  const std::vector<Instr>& plan = in.plan;
  const int np = static_cast<int>(plan.size());
  const int num_classes = static_cast<int>(in.class_offset.size());
  auto formula = [&](int k) { return plan[k].op == Op::kExpr || plan[k].op == Op::kSolve; };
  auto junction = [&](int k) {
    if (plan[k].op != Op::kExpr || plan[k].element < 0) return false;
    const ElementKind kind = g.element(plan[k].element).kind;
    return kind == ElementKind::kMTF || kind == ElementKind::kMGY || kind == ElementKind::kTF || kind == ElementKind::kGY;
  };
  std::vector<int> class_of_slot(in.num_slots, -1);
  for (int c = 0; c < num_classes; ++c)
    for (int k = 0; k < in.class_size[c]; ++k) class_of_slot[in.class_offset[c] + k] = c;
  std::vector<char> storage_state(static_cast<size_t>(in.num_states), 0);
  std::vector<int> rate_slot_of_state(static_cast<size_t>(in.num_states), -1);  // a signal state's rate slot
  for (size_t bi = 0; bi < in.blocks.size(); ++bi) {
    const StateBlock& b = in.blocks[bi];
    const bool storage = b.kind == StateBlock::Kind::kMomentum || b.kind == StateBlock::Kind::kDisplacement;
    for (int k = 0; k < b.size; ++k) {
      storage_state[b.offset + k] = storage;
      if (b.kind == StateBlock::Kind::kIntegral) rate_slot_of_state[b.offset + k] = in.gathers[bi].flow + k;
    }
  }
  // What moves, in plan order.
  std::vector<char> moving(num_classes, 0);
  auto moves = [&](const expr::Input& input) {
    if (input.in == expr::Input::In::kState) return storage_state[input.offset] != 0;
    return input.in == expr::Input::In::kSlot && class_of_slot[input.offset] >= 0 && moving[class_of_slot[input.offset]] != 0;
  };
  for (int k = 0; k < np; ++k) {
    const Instr& f = plan[k];
    bool m = f.op == Op::kMultiplier || plan::Traits(f.op).reads == plan::Reads::kState;
    for (int c : in.plan_reads[k]) m = m || moving[c];
    if (formula(k))
      for (int p = f.coef; p < f.coef + (f.op == Op::kExpr ? f.n : 1); ++p)
        for (const expr::Input& input : in.programs[p].inputs) m = m || moves(input);
    if (m) moving[in.plan_writes[k]] = 1;
  }
  auto degree = [&](int k) {
    int d = 0;
    for (int p = plan[k].coef; p < plan[k].coef + (plan[k].op == Op::kExpr ? plan[k].n : 1); ++p)
      d = std::max(d, expr::Degree(in.programs[p], moves));
    return d;
  };
  auto refuse = [&](int k, const Group& cg, const std::string& reach, const std::string& hint) {
    const Instr& f = plan[k];
    const std::string& written = in.class_names[in.plan_writes[k]];
    Diagnostic d;
    d.code = codes::kExprUnsupported;
    std::string who = written;
    if (f.element >= 0) {
      d.where = g.element(f.element).where;
      d.element = g.element(f.element).name;
      who = fmt::format("the formula of {} for '{}'", d.element, written);
    } else if (const int s = g.FindSignal(written); s >= 0) {
      d.where = g.signals()[s].where;
      d.element = written;
      who = fmt::format("the formula of the signal '{}'", written);
    } else {
      for (const AuxState& a : g.aux_states())
        if (written == a.name + ".rate" || written == a.name + ".input") {
          d.where = a.where;
          d.element = a.name;
          who = fmt::format("the {} formula of the state '{}'", written == a.name + ".rate" ? "rate" : "input", a.name);
        }
    }
    const Element& e = g.element(cg.element);
    const bool cut = IsStorage(e.kind);
    d.message = fmt::format("{} cannot reach an ideal constraint: it {}", who, reach);
    if (cut)
      d.message += fmt::format("; {} '{}' is in derivative causality (its bond is cut into an ideal constraint)",
                               e.kind == ElementKind::kI ? "I" : "C", e.name);
    if (!hint.empty())
      d.hint = hint + "; or make the coupling compliant ('constraints: compliant', or joints without 'rigid')";
    else if (!cut)
      d.hint = "keep the formula off what the constraint holds and transmits, or make the coupling compliant "
               "('constraints: compliant', or joints without 'rigid')";
    else if (e.kind == ElementKind::kI)
      d.hint = fmt::format("join I '{}' to what fixes its flow through a compliant coupling ('check --suggest' proposes one)",
                           e.name);
    else
      d.hint = fmt::format("give C '{}' a displacement of its own: put a resistor or an inertia between it and what fixes its "
                           "effort", e.name);
    throw ModelError(d);
  };
  const std::string affine_hint =
      "a modulus (MTF, MGY, TF, GY) may read time, parameters, signal states (an integral such as an angle) and "
      "orientations, not a momentum, a displacement or a variable that depends on one";
  // The signal states that formulas of the tangent plan read.
  std::vector<char> read_by_tangent(static_cast<size_t>(in.num_states), 0);
  for (int k : tangent_plan_)
    if (formula(k))
      for (int p = plan[k].coef; p < plan[k].coef + (plan[k].op == Op::kExpr ? plan[k].n : 1); ++p)
        for (const expr::Input& input : in.programs[p].inputs)
          if (input.in == expr::Input::In::kState) read_by_tangent[input.offset] = 1;
  // The closures: a modulated transformer affine in what moves; any other formula an observer.
  for (const Group& cg : groups_)
    for (int k : cg.closure) {
      if (!formula(k)) continue;
      formulas_ = true;
      emittable_ = emittable_ && plan[k].op == Op::kExpr;
      const std::string reads = fmt::format("reads the {} of the ideal constraint '{}' (its reaction, which is solved for)",
                                            cg.imposes_flow ? "flow" : "effort", cg.name);
      if (junction(k)) {
        if (degree(k) > 1) refuse(k, cg, reads + " and is not linear in it", affine_hint);
        continue;
      }
      // What it feeds, in plan order.
      std::vector<char> fed(num_classes, 0);
      fed[in.plan_writes[k]] = 1;
      for (int j = k + 1; j < np; ++j)
        for (int c : in.plan_reads[j])
          if (fed[c]) {
            fed[in.plan_writes[j]] = 1;
            break;
          }
      bool dynamic = false;
      for (const StateGather& gt : in.gathers) {
        const bool storage = gt.kind == StateBlock::Kind::kMomentum || gt.kind == StateBlock::Kind::kDisplacement;
        if (!storage && gt.kind != StateBlock::Kind::kIntegral) continue;
        for (int r = 0; r < gt.size; ++r) {
          const int rate = (storage ? gt.effort : gt.flow) + r;
          if (class_of_slot[rate] < 0 || !fed[class_of_slot[rate]]) continue;
          dynamic = dynamic || storage || read_by_tangent[gt.state + r];
        }
      }
      for (const Group& other : groups_)
        for (const auto& m : other.members) dynamic = dynamic || fed[class_of_slot[m.slot]];
      if (dynamic)
        refuse(k, cg, reads + " and feeds back into the motion",
               "a reaction may be read by outputs and by signals that feed no storage element's rate; feed it back through "
               "a compliant coupling");
    }
  // The tangent plan.
  for (int k : tangent_plan_) {
    if (!formula(k)) continue;
    formulas_ = true;
    emittable_ = emittable_ && plan[k].op == Op::kExpr;
    // The constraint whose variables depend on it, and what it holds (for the message).
    auto held_by = [&](std::string& held) -> const Group& {
      for (const Group& cg : groups_) {
        std::vector<char> feeds(num_classes, 0);
        held.clear();
        for (const auto& m : cg.members) {
          const int c = class_of_slot[m.slot];
          if (c < 0 || feeds[c]) continue;
          feeds[c] = 1;
          held += (held.empty() ? "'" : ", '") + in.class_names[c] + "'";
        }
        for (int j = np - 1; j >= k; --j)
          if (feeds[in.plan_writes[j]])
            for (int c : in.plan_reads[j]) feeds[c] = 1;
        if (feeds[in.plan_writes[k]]) return cg;
      }
      return groups_.front();
    };
    const int d = degree(k);
    if (d > (junction(k) ? 1 : 0)) {
      std::string held;
      const Group& cg = held_by(held);
      refuse(k, cg,
             fmt::format("feeds the {} {} that the ideal constraint '{}' holds, and {} a momentum or a displacement (or a "
                         "variable that depends on one){}", cg.imposes_flow ? "efforts" : "flows", held, cg.name,
                         junction(k) ? "is not linear in" : "reads", junction(k) ? "" : " without being a modulated transformer"),
             junction(k) ? affine_hint : "");
    }
    for (int p = plan[k].coef; p < plan[k].coef + (plan[k].op == Op::kExpr ? plan[k].n : 1); ++p)
      for (const expr::Input& input : in.programs[p].inputs) {
        if (input.in != expr::Input::In::kState || rate_slot_of_state[input.offset] < 0) continue;
        if (!reached_slot[rate_slot_of_state[input.offset]]) continue;
        std::string held;
        const Group& cg = held_by(held);
        refuse(k, cg,
               fmt::format("feeds the {} {} that the ideal constraint '{}' holds, and reads the state '{}', whose rate a "
                           "constraint's reaction changes", cg.imposes_flow ? "efforts" : "flows", held, cg.name,
                           in.state_names[input.offset]),
               "let the modulus read a state whose rate is a flow or effort of the motion, not of a reaction");
      }
  }
}

void ConstraintSolver::FindIndependent(const PlanView& view, const double* x, Workspace& ws) {
  if (groups_.empty()) return;
  AssembleConstraintMatrix(view, 0.0, x, ws);
  factor_.FindIndependent(ws.con);
}

void ConstraintSolver::SizeScratch(Workspace& ws, int num_slots, int num_moduli, int num_states) const {
  ws.lambda.assign(num_lambda_, 0.0);
  ws.con.dslots.assign(num_slots, 0.0);
  ws.con.dmoduli.assign(num_moduli, 0.0);
  ws.con.lin.assign(num_slots, 0.0);
  ws.con.xdot.assign(num_states, 0.0);
  ws.con.zero_x.assign(num_states, 0.0);
  factor_.SizeScratch(ws.con);
  ws.con.factored_at.assign(num_states, 0.0);
  ws.con.fixed.assign(num_lambda_, 0);
  ws.con.fixed_value.assign(num_lambda_, 0.0);
  ws.con.any_fixed = false;
}

void ConstraintSolver::ConstraintValues(double t, const double* w, double* out) const {
  for (const Group& cg : groups_)
    for (int k = 0; k < cg.size; ++k) {
      double v = 0.0;
      for (const auto& m : cg.members) v += m.sign * (w[m.slot + k] - (m.target >= 0 ? targets_[m.target + k](t) : 0.0));
      out[cg.lambda + k] = v;
    }
}

void ConstraintSolver::Tangent(const PlanView& view, double t, const double* x, const double* xdot, Workspace& ws) const {
  const double* w = ws.slots.data();
  double* d = ws.con.dslots.data();
  double* tmp = ws.con.lin.data();  // scratch for second terms; restored to zero below
  const double* mod = ws.moduli.data();
  const double* dmod = ws.con.dmoduli.data();  // the model's step 1 made dM/dt
  if (view.generated) {
    view.generated->tangent(t, x, xdot, w, d, mod, dmod, view.sources);
    return;
  }
  const plan::TangentArgs args{t, x, xdot, w, d, tmp, mod, dmod, ws.lambda.data(), view.tables, view.moduli.data()};
  for (int index : tangent_plan_) plan::ExecTangent(view.plan[index], args);
}

void ConstraintSolver::ConstraintRates(const double* d, double* out) const {
  for (const Group& cg : groups_)
    for (int k = 0; k < cg.size; ++k) {
      double v = 0.0;
      for (const auto& m : cg.members) v += m.sign * d[m.slot + k];
      out[cg.lambda + k] = v;
    }
}

void ConstraintSolver::Respond(const PlanView& view, double t, const double* x, const double* r, Workspace& ws, double* dlambda,
                               double* lin, double* dxdot) const {
  const std::vector<double> saved = ws.lambda;
  std::copy(r, r + num_lambda_, ws.con.rhs.begin());
  SolveAt(view, t, x, ws, /*fixed_values=*/false);  // the prescribed multipliers do not move
  std::copy(ws.lambda.begin(), ws.lambda.end(), dlambda);
  ws.lambda = saved;
  // What the multipliers reach is linear in them (index 1: no state kernel on the way, formulas
  // affine in them), so the reaction plan run on zero slots with dlambda gives the response.
  for (int q : reaction_plan_) ExecLinear(view, view.plan[q], t, x, lin, dlambda, ws);
  std::vector<double> rate(view.num_states, 0.0);
  for (int gi : reaction_gathers_) {
    const StateGather& gt = view.gathers[gi];
    view.gather(gt, x, lin, rate.data());
    for (int k = 0; k < gt.size; ++k) dxdot[gt.state + k] += rate[gt.state + k];
  }
}

void ConstraintSolver::ExecLinear(const PlanView& view, const Instr& in, double t, const double* x, double* lin, const double* lambda,
                                  const Workspace& ws) const {
  if (in.op != Op::kExpr && in.op != Op::kSolve) {
    plan::Exec(in, plan::ExecArgs{t, x, lin, lin, ws.moduli.data(), lambda, view.tables});
    return;
  }
  // A formula: its derivative along lin at the point (ws.slots), the state and time fixed; exact
  // for what is affine in the multipliers (CheckFormulas).
  const double* zero = ws.con.zero_x.data();
  plan::FormulaTangent(in, plan::TangentArgs{t, x, zero, ws.slots.data(), lin, nullptr, ws.moduli.data(), nullptr, lambda, view.tables,
                                             view.moduli.data(), /*source_rate=*/false});
}

void ConstraintSolver::AssembleConstraintMatrix(const PlanView& view, double t, const double* x, Workspace& ws) const {
  // A compliance whose bond points away from it: its kernel gave -K b.
  auto negate = [&] {
    for (const auto& [offset, size] : negated_v_)
      for (int r = 0; r < size; ++r) ws.con.v[offset + r] = -ws.con.v[offset + r];
  };
  if (view.generated) {
    view.generated->columns(t, x, ws.con.lin.data(), ws.moduli.data(), ws.con.b.data(), ws.con.v.data(), ws.slots.data(),
                       ws.con.zero_x.data(), view.sources);
    negate();
    return;
  }
  double* lin = ws.con.lin.data();
  double* b = ws.con.b.data();
  double* v = ws.con.v.data();
  const double* c = view.tables.coef;
  const double* lam = ws.lambda.data();
  // B, column by column: a unit multiplier through its closure (everything else is zero in lin),
  // and V = H B by each storage element's own kernel.
  const std::vector<Instr>& plan = view.plan;
  const std::vector<int>& b_offset = factor_.column_offset();
  for (const Group& cg : groups_) {
    for (int k = 0; k < cg.size; ++k) {
      const int col = cg.lambda + k;
      for (int st : cg.starts)
        for (int j = 0; j < cg.size; ++j) lin[plan[st].dst + j] = j == k ? 1.0 : 0.0;
      for (int q : cg.closure) ExecLinear(view, plan[q], t, x, lin, lam, ws);
      double* bc = b + b_offset[col];
      double* vc = v + b_offset[col];
      for (int gi : cg.momenta) {
        const StateGather& gt = view.gathers[gi];
        for (int r = 0; r < gt.size; ++r) bc[r] = gt.sign * lin[gt.effort + r];
        const Instr& flow = plan[flow_instr_of_block_[gi]];  // f = M^-1 p (or e = sigma K q), applied to bc
        plan::Traits(flow.op).state(flow, c, x + flow.aux, bc, vc);
        bc += gt.size;
        vc += gt.size;
      }
      for (int q : cg.closure) std::fill(lin + plan[q].dst, lin + plan[q].dst + plan[q].n, 0.0);
      for (int st : cg.starts) std::fill(lin + plan[st].dst, lin + plan[st].dst + cg.size, 0.0);
    }
  }
  negate();
}

void ConstraintSolver::SolveAt(const PlanView& view, double t, const double* x, Workspace& ws, bool fixed_values) const {
  const int n = view.num_states;
  if (ws.con.any_fixed) {
    SolveWithFixed(view, t, x, ws, fixed_values);
    return;
  }
  if (ws.con.factored && t == ws.con.factored_t && std::equal(x, x + n, ws.con.factored_at.begin())) {
    factor_.Solve(ws.con.rhs.data(), ws.lambda.data(), ws.con, view.generated ? view.generated->solve : nullptr);
    return;
  }
  AssembleConstraintMatrix(view, t, x, ws);
  ws.con.factored = factor_.factor_size() > 0 && factor_.Factor(ws.con, view.generated ? view.generated->factor : nullptr);
  if (ws.con.factored) {
    factor_.Solve(ws.con.rhs.data(), ws.lambda.data(), ws.con, view.generated ? view.generated->solve : nullptr);
    std::copy(x, x + n, ws.con.factored_at.begin());
    ws.con.factored_t = t;
    return;
  }
  factor_.FormFull(ws.con);
  factor_.SolvePivoted(ws.con, ws.lambda.data());
}

void ConstraintSolver::SolveWithFixed(const PlanView& view, double t, const double* x, Workspace& ws, bool fixed_values) const {
  // Switching elements whose multipliers their modes prescribe: W_aa lambda_a = rhs_a - W_ap
  // lambda_p on the others. The prescribed rows and columns of W are zeroed, so that the pivoted
  // solve takes them for redundant (zero), and then get their values. Dense: a model has few
  // switching elements, and the sparse factor's pattern is that of all constraints.
  AssembleConstraintMatrix(view, t, x, ws);
  factor_.FormFull(ws.con);
  ws.con.factored = false;
  const int m = num_lambda_;
  double* w = ws.con.w.data();
  double* rhs = ws.con.rhs.data();
  const unsigned char* fixed = ws.con.fixed.data();
  const double* value = ws.con.fixed_value.data();
  for (int j = 0; j < m; ++j) {
    if (!fixed[j]) continue;
    const double v = fixed_values ? value[j] : 0.0;
    for (int i = 0; i < m; ++i)
      if (!fixed[i]) rhs[i] -= w[i * m + j] * v;
  }
  for (int j = 0; j < m; ++j) {
    if (!fixed[j]) continue;
    for (int i = 0; i < m; ++i) w[i * m + j] = w[j * m + i] = 0.0;
    rhs[j] = 0.0;
  }
  factor_.SolvePivoted(ws.con, ws.lambda.data());
  for (int j = 0; j < m; ++j)
    if (fixed[j]) ws.lambda[j] = fixed_values ? value[j] : 0.0;
}

void ConstraintSolver::Solve(const PlanView& view, double t, const double* x, double* xdot, Workspace& ws, bool share) const {
  Tangent(view, t, x, xdot, ws);
  double* rhs = ws.con.rhs.data();
  const double* d = ws.con.dslots.data();
  for (const Group& cg : groups_)
    for (int k = 0; k < cg.size; ++k) {
      double r = 0.0;
      for (const auto& mb : cg.members)
        r -= mb.sign * (d[mb.slot + k] - (mb.target >= 0 ? targets_[mb.target + k].Derivative(t) : 0.0));
      rhs[cg.lambda + k] = r;
    }
  SolveAt(view, t, x, ws, /*fixed_values=*/true);
  if (share && !ws.con.any_fixed) factor_.Share(ws.con, ws.lambda.data());
  // Step 4: only what the multipliers reach changes (Build, reaction_plan_).
  double* w = ws.slots.data();
  const double* mod = ws.moduli.data();
  if (view.generated) {
    view.generated->react(t, x, xdot, w, mod, ws.lambda.data(), view.sources);
    return;
  }
  for (int k : reaction_plan_)
    plan::Exec(view.plan[k], plan::ExecArgs{t, x, w, w, mod, ws.lambda.data(), view.tables});
  for (int gi : reaction_gathers_) view.gather(view.gathers[gi], x, w, xdot);
}

double ConstraintSolver::Residual(double t, Workspace& ws) const {
  ConstraintValues(t, ws.slots.data(), ws.con.rhs.data());
  double worst = 0.0;
  for (int i = 0; i < num_lambda_; ++i)
    if (!ws.con.any_fixed || !ws.con.fixed[i]) worst = std::max(worst, std::abs(ws.con.rhs[i]));
  return worst;
}

void ConstraintSolver::MoveAlongB(double* x, const Workspace& ws) const {
  const std::vector<int>& b_offset = factor_.column_offset();
  const std::vector<int>& b_rows = factor_.rows();
  for (int col = 0; col < num_lambda_; ++col) {
    const double mu = ws.lambda[col];
    if (mu == 0.0) continue;
    for (int q = b_offset[col]; q < b_offset[col + 1]; ++q) x[b_rows[q]] += ws.con.b[q] * mu;
  }
}

void ConstraintSolver::ApplyImpulse(const PlanView& view, double t, double* x, Workspace& ws, int index, double target) const {
  ConstraintValues(t, ws.slots.data(), ws.con.rhs.data());
  for (int i = 0; i < num_lambda_; ++i) ws.con.rhs[i] = (i == index ? target : 0.0) - ws.con.rhs[i];
  const unsigned char was_fixed = ws.con.fixed[index];
  const bool was_any = ws.con.any_fixed;
  ws.con.fixed[index] = 0;
  ws.con.any_fixed = std::any_of(ws.con.fixed.begin(), ws.con.fixed.end(), [](unsigned char f) { return f != 0; });
  SolveAt(view, t, x, ws, /*fixed_values=*/false);
  ws.con.fixed[index] = was_fixed;
  ws.con.any_fixed = was_any;
  MoveAlongB(x, ws);
  ws.con.factored = false;
  std::fill(ws.lambda.begin(), ws.lambda.end(), 0.0);
}

void ConstraintSolver::ProjectMomenta(const PlanView& view, double t, double* x, Workspace& ws) const {
  // g is affine in the storage states along B, with dg/dx = B^T H there: x += B mu with
  // W mu = -g restores g = 0 exactly, by the least change of energy (kinetic for momenta,
  // potential for displacements).
  ConstraintValues(t, ws.slots.data(), ws.con.rhs.data());
  for (int i = 0; i < num_lambda_; ++i) ws.con.rhs[i] = -ws.con.rhs[i];
  SolveAt(view, t, x, ws, /*fixed_values=*/false);  // a constraint that does not hold now is not projected onto
  MoveAlongB(x, ws);
  // Only storage states moved (the rows of B): B and the factor stay right for x, which the
  // evaluation at an output time, right after this, reuses.
  if (ws.con.factored) std::copy(x, x + view.num_states, ws.con.factored_at.begin());
  std::fill(ws.lambda.begin(), ws.lambda.end(), 0.0);
}

}  // namespace multibond
