/// \file
/// Storage laws that read time, signals or other states (docs/model-format.md, "Storage laws";
/// docs/design.md, "Energy account"). Such a C or I (a spring whose stiffness is switched at 5 s,
/// a capacitor whose plate moves) stores E(q, s): its `energy:` formula, or its law's integral in
/// its own state with everything else it reads (s) held fixed. Along the motion
///   dE/dt = e f + sum_s dE/ds ds/dt,
/// the port's power and the power of the modulation, which the energy account books as work (a
/// state, `<element>.modulation_work`, integrated like a source's work). That power is a formula
/// of its own: the symbolic derivative of E in each name it reads, times the name's rate (t: 1;
/// a state: its derivative, a slot of the plan; a signal: the same sum over what it reads), so it
/// is one more kExpr instruction of the plan, exact, interpreted and generated alike; where E
/// jumps at a kink of time (sign(t - t1)), a time event, the jump is booked there
/// (BookModulationJumps). The energy, for the account, has the signals written out in t and the
/// state. What has no such
/// rate (an effort or a flow, a controller's output, an orientation) is refused with
/// `law.energy`, after the plan is ordered (so that an algebraic loop through the law is
/// reported as one).

#include <cmath>
#include <functional>
#include <string>

#include <fmt/format.h>

#include "multibond/compile/compiled_model.h"
#include "multibond/compile/formula_trees.h"
#include "multibond/compile/symbolic.h"
#include "multibond/core/diagnostic_codes.h"

namespace multibond {
namespace {

using expr::Node;
using expr::NodePtr;

using formula_trees::Replace;
using formula_trees::SlotRef;
using formula_trees::StateRef;
using formula_trees::Substitute;

bool IsZero(const NodePtr& n) { return n->kind == Node::Kind::kNumber && n->value == 0.0; }
bool IsOne(const NodePtr& n) { return n->kind == Node::Kind::kNumber && n->value == 1.0; }

/// a + b, either null for none.
NodePtr Plus(const NodePtr& a, const NodePtr& b) { return !a ? b : !b ? a : expr::Binary(Node::Kind::kAdd, a, b); }

const char* OwnName(const Element& e) { return e.kind == ElementKind::kI ? "p" : "q"; }

/// The full name of a scalar C's or I's state, as the layout names it ("spring.q").
std::string OwnStateName(const Element& e) {
  const std::string base = e.state_name.empty() ? e.name + (e.kind == ElementKind::kI ? ".p" : ".q") : e.state_name;
  const std::vector<std::string> comps = ComponentNames(1, e.components);
  return comps.empty() ? base : base + "." + comps.front();
}

/// The formula a storage element is given by: its energy, else its law.
const Formula& GivenLaw(const Element& e) { return e.energy.given() ? e.energy : e.law_effort; }

SourceLocation At(const Formula& f, int offset) {
  SourceLocation w = f.where;
  if (w.known()) w.column += offset;
  return w;
}

}  // namespace

bool CompiledModel::IsModulated(const Element& e) {
  if (!IsStorage(e.kind) || !HasFormulas(e) || IsMultiportEnergy(e)) return false;  // a multiport reads its own state only
  const Formula& f = GivenLaw(e);
  if (!f.given()) return false;
  const std::string own = OwnName(e), full = OwnStateName(e);
  for (const Node* n : expr::Names(*f.root))
    if (n->name != own && n->name != full && n->name != "pi") return true;
  return false;
}

void CompiledModel::AssignModulationSlots() {
  if (!options_.energy_account) return;
  for (int i = 0; i < graph_.num_elements(); ++i)
    if (IsModulated(graph_.element(i))) slots_.modulation_class.emplace(i, AddSignalClass(ModulationPowerName(graph_.element(i).name), "W", false));
  slots_.class_of_slot.resize(slots_.num_slots, -1);
  for (const auto& [element, c] : slots_.modulation_class) slots_.class_of_slot[slots_.class_offset[c]] = c;
}

void CompiledModel::AnalyzeModulatedStorage() {
  const BondGraph& g = graph_;
  // What a name that a storage law or a signal reads is (names resolve alike in every formula).
  struct Read {
    enum class Kind { kTime, kConstant, kState, kSlot, kSignal } kind = Kind::kConstant;
    int offset = 0;  ///< kState: in x; kSlot: in the workspace; kSignal: the signal's index
  };
  std::unordered_map<std::string, Read> reads;
  auto classify = [&](const Node& n, const FormulaScope& scope) {
    if (const auto it = reads.find(n.name); it != reads.end()) return it->second;
    Read r;
    if (n.name == "t") {
      r.kind = Read::Kind::kTime;
    } else if (n.name == "pi") {
      r.kind = Read::Kind::kConstant;
    } else if (const int s = g.FindSignal(n.name); s >= 0) {
      r = {Read::Kind::kSignal, s};
    } else {
      // The resolver of formulas (throws expr.unknown_variable, located, as the law's compile would).
      const expr::Program p = CompileFormulaProgram(std::make_shared<Node>(n), scope);
      if (!p.inputs.empty()) {
        const expr::Input& in = p.inputs.front();
        r.offset = in.offset;
        r.kind = in.in == expr::Input::In::kState ? Read::Kind::kState
                 : in.in == expr::Input::In::kSlot ? Read::Kind::kSlot
                 : in.in == expr::Input::In::kTime ? Read::Kind::kTime
                                                    : Read::Kind::kConstant;
      }
    }
    reads.emplace(n.name, r);
    return r;
  };
  // Why a rate is not known: what was read, where, and the signals it was read through.
  struct Failure {
    std::string what;  ///< "'v.f', an effort or a flow"
    const Formula* formula = nullptr;
    int offset = 0;
    std::vector<std::string> through;  ///< signals, outermost first
  };
  // The rate of a state: its derivative, a slot of the plan (or nothing: an orientation, a
  // source's work or a dissipation).
  auto state_rate = [&](int offset) -> NodePtr {
    const std::vector<StateBlock>& blocks = layout_.blocks();
    for (size_t b = 0; b < blocks.size(); ++b) {
      const StateBlock& blk = blocks[b];
      if (offset < blk.offset || offset >= blk.offset + blk.size) continue;
      const StateGather& gt = layout_.gathers()[b];
      const int k = offset - blk.offset;
      switch (gt.kind) {
        case StateBlock::Kind::kMomentum:
        case StateBlock::Kind::kDisplacement: {
          const NodePtr w = SlotRef(gt.effort + k);
          return gt.sign == 1.0    ? w
                 : gt.sign == -1.0 ? expr::Unary(Node::Kind::kNeg, w)
                                   : expr::Binary(Node::Kind::kMul, expr::Number(gt.sign), w);
        }
        case StateBlock::Kind::kIntegral:
          return SlotRef(gt.flow + k);
        default:
          return nullptr;
      }
    }
    return nullptr;
  };
  // Per signal: written out in t and the state, and its rate (memoised; `visiting` catches
  // signals that depend on each other, an algebraic loop that OrderPlan reports).
  struct SignalForms {
    bool done = false, visiting = false;
    NodePtr inlined, rate;
    std::optional<Failure> failure;
  };
  std::vector<SignalForms> signals(g.signals().size());
  std::function<NodePtr(const Node&, const std::string&, const Formula&, const FormulaScope&, std::optional<Failure>&)> rate_of;
  std::function<const SignalForms&(int)> signal_forms;
  std::function<NodePtr(const NodePtr&)> inline_signals = [&](const NodePtr& tree) {
    return Substitute(tree, [&](const Node& n) -> NodePtr {
      const int s = g.FindSignal(n.name);
      if (s < 0) return nullptr;
      const SignalForms& f = signal_forms(s);
      return f.inlined ? f.inlined : expr::Number(0.0);  // a loop of signals: refused by OrderPlan
    });
  };
  // d(tree)/dt along the motion with `own` held fixed: sum over the names it reads of the
  // partial derivative times the name's rate. `located`: the tree whose nodes give the places.
  auto power_of = [&](const NodePtr& tree, const std::string& own, const Node& located, const Formula& formula,
                      const FormulaScope& scope, std::optional<Failure>& failure) -> NodePtr {
    std::unordered_map<std::string, const Node*> at;
    for (const Node* n : expr::Names(located)) at.emplace(n->name, n);
    NodePtr sum;
    for (const Node* n : expr::Names(*tree)) {
      if (n->name == own || n->name == "pi") continue;
      const auto where = at.find(n->name);
      const NodePtr rate = rate_of(where != at.end() ? *where->second : *n, n->name, formula, scope, failure);
      if (!rate) return nullptr;
      if (IsZero(rate)) continue;
      const NodePtr partial = expr::Differentiate(*tree, n->name);
      if (IsZero(partial)) continue;
      sum = Plus(sum, IsOne(rate) ? partial : expr::Binary(Node::Kind::kMul, partial, rate));
    }
    return sum ? sum : expr::Number(0.0);
  };
  signal_forms = [&](int s) -> const SignalForms& {
    SignalForms& f = signals[s];
    if (f.done || f.visiting) return f;
    f.visiting = true;
    const Signal& sig = g.signals()[s];
    const FormulaScope scope{&sig.value, -1, "the signal " + sig.name};
    f.inlined = inline_signals(sig.value.root);
    f.rate = power_of(sig.value.root, "", *sig.value.root, sig.value, scope, f.failure);
    if (f.failure) f.failure->through.insert(f.failure->through.begin(), sig.name);
    f.visiting = false;
    f.done = true;
    return f;
  };
  rate_of = [&](const Node& n, const std::string& name, const Formula& formula, const FormulaScope& scope,
                std::optional<Failure>& failure) -> NodePtr {
    const Read r = classify(n, scope);
    auto fail = [&](std::string what) -> NodePtr {
      failure = Failure{std::move(what), &formula, n.offset, {}};
      return nullptr;
    };
    switch (r.kind) {
      case Read::Kind::kTime: return expr::Number(1.0);
      case Read::Kind::kConstant: return expr::Number(0.0);
      case Read::Kind::kState: {
        if (NodePtr rate = state_rate(r.offset)) return rate;
        return fail(fmt::format("the state '{}', whose rate is no variable of the plan (an orientation, or the energy account's)",
                                name));
      }
      case Read::Kind::kSlot:
        return fail(fmt::format("'{}', an effort, a flow or a controller's output", name));
      case Read::Kind::kSignal: {
        const SignalForms& f = signal_forms(r.offset);
        if (f.visiting) return fail(fmt::format("the signal '{}', which depends on itself", name));
        if (f.failure) {
          failure = f.failure;
          return nullptr;
        }
        return f.rate;
      }
    }
    return nullptr;
  };

  for (int i = 0; i < g.num_elements(); ++i) {
    const Element& e = g.element(i);
    if (!IsModulated(e)) continue;
    Modulation& m = modulation_[i];
    const Formula& given = GivenLaw(e);
    const std::string own = OwnName(e);
    const FormulaScope scope{&given, i, "the stored energy of " + e.name};
    auto refuse = [&](SourceLocation where, std::string message, std::string hint) {
      Diagnostic d;
      d.code = codes::kLawEnergy;
      d.where = std::move(where);
      d.element = e.name;
      d.message = std::move(message);
      d.hint = std::move(hint);
      d.details.push_back("in the " + std::string(e.energy.given() ? "stored energy" : "law") + " of " + e.name + ": " + given.text);
      m.refusal = std::move(d);
    };
    // E(q, s): the energy as given, or the law's integral in q with all else held fixed.
    const NodePtr root = Replace(given.root, OwnStateName(e), expr::Name(own));
    std::optional<NodePtr> energy = e.energy.given() ? std::optional<NodePtr>(root) : expr::IntegrateFromZero(*root, own);
    if (!energy) {
      refuse(given.where,
             fmt::format("the law '{}' of {} reads more than its own state {}, and its integral in {} has no closed form: its "
                         "stored energy, and the work of its modulation, cannot be formed",
                         given.text, e.name, own, own),
             fmt::format("give its stored energy instead (energy: a formula of {} and what it reads), whose derivative in {} is "
                         "the law",
                         own, own));
      continue;
    }
    std::optional<Failure> failure;
    m.power = power_of(*energy, own, *given.root, given, scope, failure);
    m.energy = inline_signals(*energy);
    if (failure) {
      std::string through;
      for (const std::string& s : failure->through) through += (through.empty() ? " (through the signal '" : "', '") + s;
      if (!through.empty()) through += "')";
      refuse(At(*failure->formula, failure->offset),
             fmt::format("the {} of {} reads {}{}: the power of its modulation, dE/ds ds/dt, needs the rate of what it reads, "
                         "which the energy account has for t, states and signals of them",
                         e.energy.given() ? "stored energy" : "law", e.name, failure->what, through),
             "read a state instead: pass the variable through a lag (states: {kind: lag, input: ..., time_constant: ...}) or "
             "integrate its rate (states: {kind: integral, rate: ...})");
      m.power = nullptr;
    }
  }
}

std::optional<CompiledModel::FormulaInstr> CompiledModel::ModulationPowerInstr(int element, int state, const Formula& given) {
  const auto c = slots_.modulation_class.find(element);
  if (c == slots_.modulation_class.end()) return std::nullopt;
  const Element& e = graph_.element(element);
  const Modulation& m = modulation_.at(element);
  // A refused one computes 0 until RefuseUnbookedModulation throws (after the plan is ordered).
  const NodePtr tree = m.power ? Replace(m.power, OwnName(e), StateRef(state)) : expr::Number(0.0);
  const int program = CompileFormula(tree, FormulaScope{&given, element, "the modulation power of " + e.name});
  FormulaInstr fi = MakeFormulaInstr(element, c->second, program, 1);
  // Shown by `multibond equations` with the engine's names as the variables they are.
  const NodePtr shown = Substitute(tree, [&](const Node& n) -> NodePtr {
    if (n.name.size() < 3 || n.name[0] != '#') return nullptr;
    const int offset = std::stoi(n.name.substr(2));
    return expr::Name(n.name[1] == 'x' ? layout_.state_names()[offset] : slots_.class_names[slots_.class_of_slot[offset]]);
  });
  fi.def.formula = fmt::format("d/dt of the stored energy of {} at fixed {}: {}", e.name, OwnName(e), expr::Format(*shown));
  return fi;
}

void CompiledModel::BookModulationJumps(double t, double* x) const {
  if (slots_.modulation_class.empty()) return;
  const double before = std::nextafter(t, -HUGE_VAL), after = std::nextafter(t, HUGE_VAL);
  for (const StateBlock& blk : layout_.blocks())
    if (blk.kind == StateBlock::Kind::kWork && blk.rate_class >= 0)
      x[blk.offset] += energy_.StoredEnergy(blk.owner, after, x) - energy_.StoredEnergy(blk.owner, before, x);
}

void CompiledModel::RefuseUnbookedModulation() const {
  for (int i = 0; i < graph_.num_elements(); ++i)
    if (const auto m = modulation_.find(i); m != modulation_.end() && m->second.refusal) throw ModelError(*m->second.refusal);
}

}  // namespace multibond
