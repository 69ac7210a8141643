/// \file
/// Formulas into the plan (docs/design.md, "Formulas"): the signals' slots, the names a formula
/// may read, and the kExpr instructions of elements whose laws, values or ratios are formulas,
/// of signals and of signal states (a rate's integral, a lag, a PID). A formula is a tree
/// (core/expression.h); the engine writes its own equations as trees too (a transformer's
/// `r f1`, a lag's `(u - x) / T`), so that one compiler (compile/expr_program.h) turns every one
/// into a program for the interpreter and the code generator alike.

#include <cmath>
#include <functional>
#include <string>

#include <fmt/format.h>

#include "multibond/compile/compiled_model.h"
#include "multibond/compile/formula_trees.h"
#include "multibond/compile/multiport_energy.h"
#include "multibond/compile/symbolic.h"
#include "multibond/core/diagnostic_codes.h"
#include "multibond/core/units.h"

namespace multibond {
namespace {

using expr::Node;
using expr::NodePtr;

using formula_trees::Replace;
using formula_trees::SlotRef;
using formula_trees::StateRef;
using formula_trees::Substitute;

NodePtr Signed(double sign, NodePtr a) { return sign < 0 ? expr::Unary(Node::Kind::kNeg, std::move(a)) : a; }

SourceLocation At(const Formula* f, int offset) {
  if (!f) return {};
  SourceLocation w = f->where;
  if (w.known()) w.column += offset;
  return w;
}

/// The readable form of a tree: the engine's own names shown as the variables they are.
std::string Readable(const Node& root, const std::function<std::string(const std::string&)>& name_of) {
  NodePtr shown = Substitute(std::make_shared<Node>(root), [&](const Node& m) -> NodePtr {
    if (m.name.empty() || m.name[0] != '#') return nullptr;
    return expr::Name(name_of(m.name));
  });
  return expr::Format(*shown);
}

}  // namespace

bool CompiledModel::HasFormulas(const Element& e) {
  if (e.law_effort.given() || e.law_flow.given() || e.energy.given() || !e.modulus.entries.empty()) return true;
  for (const Formula& f : e.value)
    if (f.given()) return true;
  return false;
}

int CompiledModel::AddSignalClass(const std::string& name, const std::string& unit, bool visible) {
  const int c = slots_.num_classes();
  slots_.class_offset.push_back(slots_.num_slots);
  slots_.class_size.push_back(1);
  slots_.class_units.push_back(unit.empty() ? "-" : unit);
  slots_.class_names.push_back(name);
  slots_.num_slots += 1;
  (visible ? slots_.signal_class : slots_.internal_class).emplace(name, c);
  return c;
}

std::string CompiledModel::FormulaUnitText(const Formula& f) const {
  if (!f.given()) return "";
  auto class_named = [&](const std::string& id) {
    if (const auto it = slots_.signal_class.find(id); it != slots_.signal_class.end()) return it->second;
    for (int c = 0; c < static_cast<int>(slots_.class_names.size()); ++c)
      if (slots_.class_names[c] == id) return c;
    return -1;
  };
  const FormulaUnits u = CheckFormulaUnits(
      *f.root, f.text,
      [&](const std::string& id) -> std::optional<DeclaredUnit> {
        const int c = class_named(id);
        if (c < 0 || slots_.class_units[c] == "-") return std::nullopt;
        const std::optional<Unit> unit = ParseUnit(slots_.class_units[c]);
        if (!unit) return std::nullopt;
        return DeclaredUnit{*unit, slots_.class_units[c]};
      },
      [](const std::string&) { return std::optional<double>(); });
  if (u.mismatch || u.unit.kind != FormulaUnit::Kind::kUnit || !u.unit.scale_known) return "";
  if (!u.unit.label.empty()) return u.unit.label;
  return u.unit.unit.scale == 1.0 ? FormatDimension(u.unit.unit.dim) : "";
}

void CompiledModel::AssignSignalSlots() {
  const BondGraph& g = graph_;
  for (const Signal& s : g.signals()) AddSignalClass(s.name, s.unit, true);
  // The signal states' units: the file's, else from their formulas' (signals, efforts and flows
  // are known by now; a formula reading only states or unit-less names leaves it unknown, "-").
  for (const AuxState& a : g.aux_states()) {
    if (a.kind == AuxState::Kind::kPid) {
      const std::string e = FormulaUnitText(a.input);
      if (!e.empty()) slots_.signal_state_units[a.name + ".i"] = TimeIntegralUnit(e);
      if (!e.empty()) slots_.signal_state_units[a.name + ".d"] = e;
    } else if (a.kind == AuxState::Kind::kLag) {
      slots_.signal_state_units[a.name] = a.unit.empty() ? FormulaUnitText(a.input) : a.unit;
    } else if (a.kind == AuxState::Kind::kIntegral && a.rate.given()) {
      slots_.signal_state_units[a.name] = a.unit.empty() ? TimeIntegralUnit(FormulaUnitText(a.rate)) : a.unit;
    }
  }
  for (const AuxState& a : g.aux_states()) {
    switch (a.kind) {
      case AuxState::Kind::kIntegral:
        if (a.rate.given()) AddSignalClass(a.name + ".rate", "", false);
        break;
      case AuxState::Kind::kLag:
        AddSignalClass(a.name + ".rate", "", false);
        break;
      case AuxState::Kind::kPid: {
        // A PID's unit is its output's: the file's, else that of the source it drives when a
        // source's value is the output itself (supply: {type: Se, effort: "pid.u"}).
        std::string unit = a.unit;
        for (int i = 0; unit.empty() && i < g.num_elements(); ++i) {
          const Element& e = g.element(i);
          if ((e.kind != ElementKind::kSe && e.kind != ElementKind::kSf) || e.value.size() != 1 || !e.value.front().given()) continue;
          const std::string& text = e.value.front().text;
          const std::size_t first = text.find_first_not_of(" \t"), last = text.find_last_not_of(" \t");
          if (first == std::string::npos || text.substr(first, last - first + 1) != a.name + ".u") continue;
          const int c = (e.kind == ElementKind::kSe ? slots_.effort_class : slots_.flow_class)[e.bonds.front()];
          if (slots_.class_units[c] != "-") unit = slots_.class_units[c];
        }
        AddSignalClass(a.name + ".e", "", false);
        AddSignalClass(a.name + ".u_raw", unit, false);
        AddSignalClass(a.name + ".u", unit, true);
        AddSignalClass(a.name + ".i.rate", "", false);
        if (a.pid.kd > 0.0) AddSignalClass(a.name + ".d.rate", "", false);
        break;
      }
      case AuxState::Kind::kOrientation:
        break;
    }
  }
  // A resistor whose causality needs the inverse of the one law it was given solves for it
  // (kSolve): a scratch slot, of no class, holds the unknown while the law is evaluated.
  for (int i = 0; i < g.num_elements(); ++i) {
    const Element& e = g.element(i);
    if (e.kind != ElementKind::kR || !HasFormulas(e)) continue;
    const bool effort_out = !causality_.EffortInto(g, e.bonds.front(), i);
    if (!(effort_out ? e.law_effort : e.law_flow).given()) slots_.solve_slot.emplace(i, slots_.num_slots++);
  }
  slots_.class_of_slot.assign(slots_.num_slots, -1);
  for (int c = 0; c < num_slot_classes(); ++c)
    for (int k = 0; k < slots_.class_size[c]; ++k) slots_.class_of_slot[slots_.class_offset[c] + k] = c;
}

expr::Program CompiledModel::CompileFormulaProgram(const NodePtr& root, const FormulaScope& scope) const {
  auto fail = [&](const Node& n, const std::string& code, const std::string& message, const std::string& hint) {
    Diagnostic d;
    d.code = code;
    d.where = At(scope.formula, n.offset);
    d.element = scope.element >= 0 ? graph_.element(scope.element).name : "";
    d.message = message;
    d.hint = hint;
    if (scope.formula) d.details.push_back("in " + scope.what + ": " + scope.formula->text);
    throw ModelError(d);
  };
  const expr::Resolver resolve = [&](const Node& n) -> expr::Input {
    const std::string& name = n.name;
    if (name.size() > 2 && name[0] == '#') {
      const int offset = std::stoi(name.substr(2));
      return {name[1] == 'w' ? expr::Input::In::kSlot : expr::Input::In::kState, offset, 0.0};
    }
    if (name == "t") return {expr::Input::In::kTime, 0, 0.0};
    if (name == "pi") return {expr::Input::In::kConstant, 0, M_PI};
    if (const auto it = slots_.signal_class.find(name); it != slots_.signal_class.end())
      return {expr::Input::In::kSlot, slots_.class_offset[it->second], 0.0};
    auto read = [&](const VariableRef& v, int k) {
      return expr::Input{v.in == VariableRef::In::kState ? expr::Input::In::kState : expr::Input::In::kSlot, v.offset + k, 0.0};
    };
    if (const auto v = FindVariable(name)) {
      if (v->size == 1) return read(*v, 0);
      fail(n, codes::kExprUnknownVariable, fmt::format("'{}' has {} components; a formula reads one", name, v->size),
           fmt::format("name a component: {}.{}", name, v->components.empty() ? "1" : v->components.front()));
    }
    if (const auto dot = name.rfind('.'); dot != std::string::npos) {
      if (const auto v = FindVariable(name.substr(0, dot))) {
        const std::string comp = name.substr(dot + 1);
        for (int k = 0; k < static_cast<int>(v->components.size()); ++k)
          if (v->components[k] == comp) return read(*v, k);
        std::string list;
        for (const std::string& c : v->components) list += (list.empty() ? "" : ", ") + c;
        fail(n, codes::kExprUnknownVariable, fmt::format("'{}' has no component '{}'", name.substr(0, dot), comp),
             list.empty() ? "it is a scalar: leave the component out" : "its components are " + list);
      }
    }
    fail(n, codes::kExprUnknownVariable, fmt::format("unknown name '{}' in {}", name, scope.what),
         "a formula reads parameters, signals, t, pi and model variables such as spring.q, j.f or gear.e2 "
         "(`multibond check` lists them); in a law, the element's own variable is q (C), p (I), f or e (R)");
    return {};
  };
  return expr::CompileProgram(*root, resolve);
}

int CompiledModel::CompileFormula(const NodePtr& root, const FormulaScope& scope) {
  plan_.programs.push_back(CompileFormulaProgram(CollectKinks(root, scope), scope));
  return static_cast<int>(plan_.programs.size()) - 1;
}

std::string CompiledModel::InternalName(const std::string& internal) const {
  const int offset = std::stoi(internal.substr(2));
  if (internal[1] == 'x') return layout_.state_names()[offset];
  const int c = slots_.class_of_slot[offset];
  return c >= 0 ? slots_.class_names[c] : "u";  // the unknown of a resistor's law solved backwards
}

NodePtr CompiledModel::CollectKinks(const NodePtr& root, const FormulaScope& scope) {
  auto name_of = [this](const std::string& internal) { return InternalName(internal); };
  std::string owner;
  if (scope.element >= 0) {
    owner = graph_.element(scope.element).name;
  } else {  // "the signal w_ref", "the input of pid": the last word
    owner = scope.what.substr(scope.what.rfind(' ') + 1);
  }
  const std::string formula = scope.formula && root == scope.formula->root ? scope.formula->text : Readable(*root, name_of);
  // Bottom up: each call's switching functions into the table; a `sign` of the state compiled as
  // sign(x)*m + s over its two slide slots (compile/sliding.cc).
  const std::function<NodePtr(const NodePtr&)> walk = [&](const NodePtr& n) -> NodePtr {
    NodePtr out = n;
    if (!n->args.empty()) {
      auto copy = std::make_shared<Node>(*n);
      bool changed = false;
      for (NodePtr& a : copy->args) {
        NodePtr b = walk(a);
        changed = changed || b != a;
        a = std::move(b);
      }
      if (changed) out = copy;
    }
    for (const NodePtr& g : SwitchingFunctions(*n)) {
      KinkTable::Kink k;
      k.owner = owner;
      k.what = scope.what;
      k.formula = formula;
      k.function = Readable(*g, name_of);
      k.program = CompileFormulaProgram(g, scope);
      const int index = events_.kinks.Add(std::move(k));
      if (index < 0 || n->fn != expr::Fn::kSign || events_.kinks.kinks()[static_cast<size_t>(index)].time_only) continue;
      if (events_.kinks.kinks()[static_cast<size_t>(index)].slide_slot < 0) {
        events_.kinks.SetSlideSlot(index, slots_.num_slots, static_cast<int>(events_.slides.size()));
        slots_.num_slots += 2;
        slots_.class_of_slot.resize(static_cast<size_t>(slots_.num_slots), -1);
        events_.slides.push_back(index);
      }
      const int slot = events_.kinks.kinks()[static_cast<size_t>(index)].slide_slot;
      out = expr::Binary(Node::Kind::kAdd, expr::Binary(Node::Kind::kMul, out, SlotRef(slot)), SlotRef(slot + 1));
    }
    return out;
  };
  return walk(root);
}

CompiledModel::FormulaInstr CompiledModel::MakeFormulaInstr(int element, int out_class, int first, int n) {
  FormulaInstr fi;
  fi.in = Instr{};
  fi.in.op = Op::kExpr;
  fi.in.element = element;
  fi.in.n = n;
  fi.in.m = 0;
  fi.in.coef = first;
  fi.out_class = out_class;
  for (int k = 0; k < n; ++k)
    for (const expr::Input& put : plan_.programs[first + k].inputs)
      if (put.in == expr::Input::In::kSlot && slots_.class_of_slot[put.offset] >= 0) fi.reads.push_back(slots_.class_of_slot[put.offset]);
  fi.def.kind = Definition::Kind::kFormula;
  fi.def.element = element;
  return fi;
}

std::vector<CompiledModel::FormulaInstr> CompiledModel::FormulaInstructions(int i) {
  const BondGraph& g = graph_;
  const Element& e = g.element(i);
  const auto& dim = structure_.bond_dim;
  std::vector<FormulaInstr> out;
  auto name_of = [&](const std::string& internal) -> std::string {
    const int offset = std::stoi(internal.substr(2));
    if (internal[1] == 'x') return layout_.state_names()[offset];
    return slots_.class_names[slots_.class_of_slot[offset]];
  };
  // One program per output component, from `tree(k)`, into class `out_class`.
  // `shown`: how `multibond equations` writes it ("" = the compiled tree, parameters as numbers);
  // a formula used as written is shown as written, parameters by name.
  auto emit = [&](int out_class, int n, const std::function<NodePtr(int)>& tree, const Formula* f, const std::string& what,
                  std::string shown = {}) {
    const int first = static_cast<int>(plan_.programs.size());
    for (int k = 0; k < n; ++k) {
      const NodePtr t = tree(k);
      CompileFormula(t, FormulaScope{f, i, what});
      if (k == 0 && shown.empty()) shown = f && t == f->root ? f->text : Readable(*t, name_of);
    }
    FormulaInstr fi = MakeFormulaInstr(i, out_class, first, n);
    fi.def.formula = shown;
    out.push_back(std::move(fi));
  };
  auto scalar_only = [&](int b, const Formula& f) {
    if (dim[b] == 1) return;
    Diagnostic d;
    d.code = codes::kExprVectorLaw;
    d.where = f.where;
    d.element = e.name;
    d.message = fmt::format("a law given by a formula needs a scalar bond; this one has {} components", dim[b]);
    d.hint = "split the element into scalar ones, or give a matrix instead of a formula";
    throw ModelError(d);
  };

  switch (e.kind) {
    case ElementKind::kSe:
    case ElementKind::kSf: {
      const int b = e.bonds.front();
      const int cls = e.kind == ElementKind::kSe ? slots_.effort_class[b] : slots_.flow_class[b];
      const std::string what = fmt::format("the {} of {}", e.kind == ElementKind::kSe ? "effort" : "flow", e.name);
      // A list may mix formulas and time functions: a constant is a number of the program; other
      // time functions (steps, ramps, tables) do not mix with formulas in one source.
      const Formula* first = nullptr;
      for (const Formula& f : e.value)
        if (f.given() && !first) first = &f;
      auto component = [&](int k) -> NodePtr {
        const size_t at = e.value.size() == 1 ? 0 : static_cast<size_t>(k);
        if (e.value[at].given()) return e.value[at].root;
        const TimeFunction& tf = e.source.components[e.source.components.size() == 1 ? 0 : at];
        if (tf.kind != TimeFunction::Kind::kConstant) {
          Diagnostic d;
          d.code = codes::kExprUnsupported;
          d.where = e.where;
          d.element = e.name;
          d.message = "a source mixes formulas with a step, ramp, sine or table in one list";
          d.hint = "write the time function as a formula of t too (a sine: \"A*sin(2*pi*F*t)\"), or split the source";
          throw ModelError(d);
        }
        return expr::Number(tf.value);
      };
      emit(cls, dim[b], component, first, what);
      break;
    }
    case ElementKind::kC:
    case ElementKind::kI: {
      const bool inertia = e.kind == ElementKind::kI;
      const int b = e.bonds.front();
      const Formula& given = e.energy.given() ? e.energy : e.law_effort;  // an I's flow law is its law_effort (graph.h)
      const int state = layout_.blocks()[layout_.element_block(i)].offset;
      if (IsMultiportEnergy(e) && dim[b] == e.dim) {
        // One energy of the vector state: the efforts (flows) are its gradient.
        const MultiportEnergy m = BuildMultiportEnergy(e, layout_.state_names(), state);
        const double sigma = inertia ? 1.0 : g.PowerSign(b, i);
        const std::vector<std::string> own = OwnVariables(e);
        emit(inertia ? slots_.flow_class[b] : slots_.effort_class[b], e.dim, [&](int k) { return Signed(sigma, m.gradient[static_cast<size_t>(k)]); },
             &e.energy, fmt::format("the {} law of {}", inertia ? "flow" : "effort", e.name),
             fmt::format("{}grad({}) in ({} ... {})", sigma < 0 ? "-" : "", e.energy.text, own.front(), own.back()));
        break;
      }
      scalar_only(b, given);
      const char* own = inertia ? "p" : "q";
      // The law (or energy) may read t, signals and other states besides its own (a modulated
      // storage, compile/modulated_storage.cc: those are held fixed in its stored energy, and the
      // power of their change is booked as the modulation's work). Its own state by its full
      // name is its own variable.
      const NodePtr root = Replace(given.root, layout_.state_names()[state], expr::Name(own));
      NodePtr law = root;
      if (e.energy.given()) {
        // The law is the energy's derivative in the element's own state, which the energy must
        // depend on.
        if (!expr::DependsOn(*root, own)) {
          Diagnostic d;
          d.code = codes::kLawEnergy;
          d.where = e.energy.where;
          d.element = e.name;
          d.message = fmt::format("the stored energy '{}' is not a function of {}", e.energy.text, own);
          d.hint = fmt::format("write the energy in the element's own {} ({})", inertia ? "momentum" : "displacement", own);
          throw ModelError(d);
        }
        law = expr::Differentiate(*root, own);
      }
      const double sigma = inertia ? 1.0 : g.PowerSign(b, i);
      const NodePtr tree = Signed(sigma, Replace(law, own, StateRef(state)));
      const std::string what = fmt::format("the {} law of {}", inertia ? "flow" : "effort", e.name);
      const std::string law_text = e.energy.given() ? fmt::format("d({})/d{}", e.energy.text, own) : given.text;
      const std::string shown = fmt::format("{}({} at {} = {})", sigma < 0 ? "-" : "", law_text, own, layout_.state_names()[state]);
      emit(inertia ? slots_.flow_class[b] : slots_.effort_class[b], 1, [&](int) { return tree; }, &given, what, shown);
      if (std::optional<FormulaInstr> power = ModulationPowerInstr(i, state, given)) out.push_back(std::move(*power));
      break;
    }
    case ElementKind::kR: {
      const int b = e.bonds.front();
      const double sigma = g.PowerSign(b, i);
      const bool effort_out = !causality_.EffortInto(g, b, i);
      // The form the causality needs (effort of f, or flow of e), else the other one solved for
      // its input at every evaluation (kSolve).
      const Formula& direct = effort_out ? e.law_effort : e.law_flow;
      const Formula& inverse = effort_out ? e.law_flow : e.law_effort;
      const Formula& law = direct.given() ? direct : inverse;
      scalar_only(b, law);
      if (!e.active) passive_.push_back({i, slots_.class_offset[slots_.effort_class[b]], slots_.class_offset[slots_.flow_class[b]], sigma});
      // The resistor sees the effort sigma e and the flow f (graph.h's sign rules).
      const int e_slot = slots_.class_offset[slots_.effort_class[b]], f_slot = slots_.class_offset[slots_.flow_class[b]];
      if (direct.given() && effort_out) {
        const NodePtr tree = Signed(sigma, Replace(law.root, "f", SlotRef(f_slot)));
        emit(slots_.effort_class[b], 1, [&](int) { return tree; }, &law, "the effort law of " + e.name,
             fmt::format("{}({} at f = {})", sigma < 0 ? "-" : "", law.text, name_of("#w" + std::to_string(f_slot))));
      } else if (direct.given()) {
        const NodePtr tree = Replace(law.root, "e", Signed(sigma, SlotRef(e_slot)));
        emit(slots_.flow_class[b], 1, [&](int) { return tree; }, &law, "the flow law of " + e.name,
             fmt::format("({} at e = {}{})", law.text, sigma < 0 ? "-" : "", name_of("#w" + std::to_string(e_slot))));
      } else {
        // effort out: g(u) = f, e = sigma u; flow out: r(u) = sigma e, f = u.
        const char* own = effort_out ? "e" : "f";
        const int unknown = slots_.solve_slot.at(i);
        const FormulaScope scope{&law, i, fmt::format("the {} law of {}", effort_out ? "flow" : "effort", e.name)};
        FormulaInstr fi;
        fi.in = Instr{};
        fi.in.op = Op::kSolve;
        fi.in.element = i;
        fi.in.n = 1;
        fi.in.m = 1;
        fi.in.coef = CompileFormula(Replace(law.root, own, SlotRef(unknown)), scope);
        fi.in.aux = CompileFormula(Replace(expr::Differentiate(*law.root, own), own, SlotRef(unknown)), scope);
        fi.in.count = unknown;
        fi.in.src = effort_out ? f_slot : e_slot;
        fi.in.transpose = !effort_out && sigma < 0;
        fi.in.scale = effort_out ? sigma : 1.0;
        fi.out_class = effort_out ? slots_.effort_class[b] : slots_.flow_class[b];
        fi.reads.push_back(effort_out ? slots_.flow_class[b] : slots_.effort_class[b]);
        for (const expr::Input& put : plan_.programs[fi.in.coef].inputs)
          if (put.in == expr::Input::In::kSlot && slots_.class_of_slot[put.offset] >= 0) fi.reads.push_back(slots_.class_of_slot[put.offset]);
        fi.def.kind = Definition::Kind::kFormula;
        fi.def.element = i;
        fi.def.formula = fmt::format("{} solved from {} = {}", effort_out ? e.name + ".e" : e.name + ".f",
                                     effort_out ? e.name + ".f" : e.name + ".e", Readable(*law.root, name_of));
        out.push_back(std::move(fi));
      }
      break;
    }
    case ElementKind::kTF:
    case ElementKind::kGY: {
      // A scalar ratio r(t, x, ...): TF f2 = r f1, e1 = r e2 (or e2 = e1 / r, f1 = f2 / r);
      // GY e2 = r f1, e1 = r f2 (or f2 = e1 / r, f1 = e2 / r).
      const int b1 = structure_.port_in[i], b2 = structure_.port_out[i];
      const bool gyrator = e.kind == ElementKind::kGY;
      const bool forward = !causality_.EffortInto(g, b1, i);
      const NodePtr r = e.value.front().root;
      struct Eq { int out, in; };
      Eq eq[2];
      if (!gyrator) {
        eq[0] = forward ? Eq{slots_.flow_class[b2], slots_.flow_class[b1]} : Eq{slots_.effort_class[b2], slots_.effort_class[b1]};
        eq[1] = forward ? Eq{slots_.effort_class[b1], slots_.effort_class[b2]} : Eq{slots_.flow_class[b1], slots_.flow_class[b2]};
      } else {
        eq[0] = forward ? Eq{slots_.effort_class[b2], slots_.flow_class[b1]} : Eq{slots_.flow_class[b2], slots_.effort_class[b1]};
        eq[1] = forward ? Eq{slots_.effort_class[b1], slots_.flow_class[b2]} : Eq{slots_.flow_class[b1], slots_.effort_class[b2]};
      }
      for (const Eq& q : eq) {
        const int n = slots_.class_size[q.out];
        emit(q.out, n, [&](int k) {
          const NodePtr u = SlotRef(slots_.class_offset[q.in] + k);
          return forward ? expr::Binary(Node::Kind::kMul, r, u) : expr::Binary(Node::Kind::kDiv, u, r);
        }, &e.value.front(), "the ratio of " + e.name);
      }
      break;
    }
    case ElementKind::kMTF:
    case ElementKind::kMGY: {
      // A modulus whose entries are formulas: M u written out, sum_j M_ij u_j, and M^T u; a 1 x 1
      // one also backwards (u / M). TF: f2 = M f1, e1 = M^T e2; GY: e2 = M f1, e1 = M^T f2.
      const Modulus& mod = e.modulus;
      const int b1 = structure_.port_in[i], b2 = structure_.port_out[i];
      const int rows = mod.rows(), cols = mod.cols();
      const bool gyrator = e.kind == ElementKind::kMGY;
      const bool forward = !causality_.EffortInto(g, b1, i);
      auto entry = [&](int r, int c) -> NodePtr {
        const Formula& f = mod.entries[static_cast<size_t>(r * cols + c)];
        const double s = mod.scale;
        if (f.given()) return s == 1.0 ? f.root : expr::Binary(Node::Kind::kMul, expr::Number(s), f.root);
        const double v = s * mod.constant(r, c);
        return v == 0.0 ? nullptr : expr::Number(v);
      };
      const Formula* first = nullptr;
      for (const Formula& f : mod.entries)
        if (f.given() && !first) first = &f;
      struct Eq { int out, in; bool transpose; };
      Eq eq[2];
      if (!gyrator) {
        eq[0] = forward ? Eq{slots_.flow_class[b2], slots_.flow_class[b1], false} : Eq{slots_.effort_class[b2], slots_.effort_class[b1], false};
        eq[1] = forward ? Eq{slots_.effort_class[b1], slots_.effort_class[b2], true} : Eq{slots_.flow_class[b1], slots_.flow_class[b2], true};
      } else {
        eq[0] = forward ? Eq{slots_.effort_class[b2], slots_.flow_class[b1], false} : Eq{slots_.flow_class[b2], slots_.effort_class[b1], false};
        eq[1] = forward ? Eq{slots_.effort_class[b1], slots_.flow_class[b2], true} : Eq{slots_.flow_class[b1], slots_.effort_class[b2], true};
      }
      // Shown as "arm.M^T arm.e2, M = [[-L*sin(angle)], [L*cos(angle)]]".
      std::string matrix;
      for (int r = 0; r < rows; ++r) {
        std::string row;
        for (int c = 0; c < cols; ++c) {
          const Formula& f = mod.entries[static_cast<size_t>(r * cols + c)];
          row += (c ? ", " : "") + (f.given() ? f.text : fmt::format("{}", mod.constant(r, c)));
        }
        matrix += (r ? ", [" : "[") + row + "]";
      }
      matrix = "[" + matrix + "]" + (mod.scale != 1.0 ? fmt::format(" * {}", mod.scale) : "");
      for (const Eq& q : eq) {
        const int n = slots_.class_size[q.out];
        const std::string shown = fmt::format("{}.M{} {}, M = {}", e.name, forward ? (q.transpose ? "^T" : "") : "^-1",
                                              slots_.class_names[q.in], matrix);
        emit(q.out, n, [&](int k) -> NodePtr {
          if (!forward) {  // 1 x 1 (Modulus::invertible): u / M
            return expr::Binary(Node::Kind::kDiv, SlotRef(slots_.class_offset[q.in]), entry(0, 0));
          }
          NodePtr sum;
          const int terms = q.transpose ? rows : cols;
          for (int j = 0; j < terms; ++j) {
            const NodePtr mij = q.transpose ? entry(j, k) : entry(k, j);
            if (!mij) continue;
            const NodePtr term = expr::Binary(Node::Kind::kMul, mij, SlotRef(slots_.class_offset[q.in] + j));
            sum = sum ? expr::Binary(Node::Kind::kAdd, sum, term) : term;
          }
          return sum ? sum : expr::Number(0.0);
        }, first, "the modulus of " + e.name, shown);
      }
      break;
    }
    default: {
      Diagnostic d;
      d.code = codes::kExprUnsupported;
      d.where = e.where;
      d.element = e.name;
      d.message = fmt::format("a {} cannot be given by a formula", KindName(e.kind));
      throw ModelError(d);
    }
  }
  return out;
}

std::vector<CompiledModel::FormulaInstr> CompiledModel::SignalInstructions() {
  const BondGraph& g = graph_;
  std::vector<FormulaInstr> out;
  auto cls = [&](const std::string& name) { return slots_.internal_class.at(name); };
  auto name_of = [&](const std::string& internal) -> std::string {
    const int offset = std::stoi(internal.substr(2));
    if (internal[1] == 'x') return layout_.state_names()[offset];
    return slots_.class_names[slots_.class_of_slot[offset]];
  };
  auto emit = [&](int out_class, const NodePtr& tree, const Formula* f, const std::string& what) {
    const int first = CompileFormula(tree, FormulaScope{f, -1, what});
    FormulaInstr fi = MakeFormulaInstr(-1, out_class, first, 1);
    fi.def.formula = f && tree == f->root ? f->text : Readable(*tree, name_of);
    out.push_back(std::move(fi));
  };
  using K = Node::Kind;
  auto num = [](double v) { return expr::Number(v); };
  for (const Signal& s : g.signals()) emit(slots_.signal_class.at(s.name), s.value.root, &s.value, "the signal " + s.name);
  for (size_t a = 0; a < g.aux_states().size(); ++a) {
    const AuxState& s = g.aux_states()[a];
    const StateBlock& blk = layout_.blocks()[layout_.aux_block(a)];
    const NodePtr self = StateRef(blk.offset);
    switch (s.kind) {
      case AuxState::Kind::kIntegral:
        if (s.rate.given()) emit(blk.rate_class, s.rate.root, &s.rate, "the rate of " + s.name);
        break;
      case AuxState::Kind::kLag: {
        const NodePtr rate = expr::Binary(K::kDiv, expr::Binary(K::kSub, s.input.root, self), num(s.time_constant));
        emit(blk.rate_class, rate, &s.input, "the input of " + s.name);
        break;
      }
      case AuxState::Kind::kPid: {
        const AuxState::Pid& p = s.pid;
        const int c_e = cls(s.name + ".e"), c_raw = cls(s.name + ".u_raw"), c_u = slots_.signal_class.at(s.name + ".u");
        emit(c_e, s.input.root, &s.input, "the input of " + s.name);
        const NodePtr e = SlotRef(slots_.class_offset[c_e]);
        NodePtr raw = expr::Binary(K::kAdd, expr::Binary(K::kMul, num(p.kp), e), expr::Binary(K::kMul, num(p.ki), self));
        NodePtr d_rate;
        if (p.kd > 0.0) {
          const NodePtr d = StateRef(layout_.blocks()[layout_.aux_block(a) + 1].offset);
          d_rate = expr::Binary(K::kDiv, expr::Binary(K::kSub, e, d), num(p.tf));
          raw = expr::Binary(K::kAdd, raw, expr::Binary(K::kMul, num(p.kd), d_rate));
        }
        emit(c_raw, raw, &s.input, "the controller " + s.name);
        const NodePtr r = SlotRef(slots_.class_offset[c_raw]);
        const bool lo = std::isfinite(p.u_min), hi = std::isfinite(p.u_max);
        const NodePtr u = lo && hi ? expr::Call(expr::Fn::kClamp, {r, num(p.u_min), num(p.u_max)})
                          : lo     ? expr::Call(expr::Fn::kMax, {r, num(p.u_min)})
                          : hi     ? expr::Call(expr::Fn::kMin, {r, num(p.u_max)})
                                   : r;
        emit(c_u, u, &s.input, "the output of " + s.name);
        // Back-calculation: while the output is limited, the integral is pulled back at the rate
        // 1 / tt (Astrom and Hagglund); tt defaults to sqrt(Ti Td) = sqrt(kd / ki), else Ti = kp / ki.
        const double tt = p.tt > 0.0 ? p.tt : p.kd > 0.0 && p.ki > 0.0 ? std::sqrt(p.kd / p.ki) : p.ki > 0.0 && p.kp > 0.0 ? p.kp / p.ki : 1.0;
        const NodePtr i_rate =
            p.ki > 0.0 ? expr::Binary(K::kAdd, e, expr::Binary(K::kDiv, expr::Binary(K::kSub, SlotRef(slots_.class_offset[c_u]), r), num(p.ki * tt)))
                       : num(0.0);
        emit(blk.rate_class, i_rate, &s.input, "the integral of " + s.name);
        if (p.kd > 0.0) emit(layout_.blocks()[layout_.aux_block(a) + 1].rate_class, d_rate, &s.input, "the derivative filter of " + s.name);
        break;
      }
      case AuxState::Kind::kOrientation:
        break;
    }
  }
  return out;
}

std::optional<EnergyAccount::FormulaEnergy> CompiledModel::StoredEnergyFormula(int element, int state) const {
  const Element& e = graph_.element(element);
  if (!HasFormulas(e)) return std::nullopt;
  const char* own = e.kind == ElementKind::kI ? "p" : "q";
  const Formula* f = e.energy.given() ? &e.energy : &e.law_effort;  // C: effort of q; I: flow of p
  const FormulaScope scope{f, element, "the stored energy of " + e.name};
  if (IsMultiportEnergy(e))
    return EnergyAccount::FormulaEnergy{CompileFormulaProgram(BuildMultiportEnergy(e, layout_.state_names(), state).energy, scope)};
  // A law that reads more than its own state: E(q, s) at fixed s, its signals written out in t
  // and the state (AnalyzeModulatedStorage); a refused one stores 0 until the refusal is thrown.
  if (const auto m = modulation_.find(element); m != modulation_.end())
    return EnergyAccount::FormulaEnergy{
        CompileFormulaProgram(m->second.refusal ? expr::Number(0.0) : Replace(m->second.energy, own, StateRef(state)), scope)};
  const NodePtr root = Replace(f->root, layout_.state_names()[state], expr::Name(own));  // its state by its full name
  const std::optional<NodePtr> energy = e.energy.given() ? std::optional<NodePtr>(root) : expr::IntegrateFromZero(*root, own);
  if (energy) return EnergyAccount::FormulaEnergy{CompileFormulaProgram(Replace(*energy, own, StateRef(state)), scope)};
  return EnergyAccount::FormulaEnergy{CompileFormulaProgram(Replace(root, own, StateRef(0)), scope), true};  // of x[0]
}


std::string CompiledModel::DiagnoseFormulas(double t, const double* x, Workspace& ws) const {
  double* w = ws.slots.data();
  if (!plan_.needed_moduli.empty()) EvalModuli(x, ws.moduli.data());
  const plan::ExecArgs args{t, x, w, w, ws.moduli.data(), ws.lambda.data(), tables()};
  for (const Instr& in : plan_.instrs) {
    plan::Exec(in, args);
    if (in.op != Op::kExpr && in.op != Op::kSolve) continue;
    for (int k = 0; k < in.n; ++k) {
      if (std::isfinite(w[in.dst + k])) continue;
      const expr::Program& p = plan_.programs[in.coef + k];
      std::string reads;
      bool inputs_finite = true;
      for (const expr::Input& put : p.inputs) {
        if (put.in != expr::Input::In::kState && put.in != expr::Input::In::kSlot) continue;
        const bool state = put.in == expr::Input::In::kState;
        const double v = state ? x[put.offset] : w[put.offset];
        inputs_finite = inputs_finite && std::isfinite(v);
        const std::string name = state                              ? layout_.state_names()[put.offset]
                                 : slots_.class_of_slot[put.offset] >= 0 ? slots_.class_names[slots_.class_of_slot[put.offset]]
                                                                   : std::string("the unknown");
        reads += fmt::format("{}{} = {:.9g}", reads.empty() ? "" : ", ", name, v);
      }
      if (!inputs_finite) continue;  // a diverging state: not this formula's fault
      const int cls = slots_.class_of_slot[in.dst];
      const std::string who = in.element >= 0 ? graph_.element(in.element).name : slots_.class_names[cls];
      return fmt::format("the formula of {} for {} `{}` gives {} at t = {:.9g} s{}", who, slots_.class_names[cls],
                         plan_.definitions[cls].formula, w[in.dst + k], t, reads.empty() ? "" : " (it reads " + reads + ")");
    }
  }
  return {};
}

std::string CompiledModel::FindActiveResistor(const Workspace& ws) const {
  for (const Passive& r : passive_) {
    const double e = ws.slots[r.effort], f = ws.slots[r.flow];
    if (r.sigma * e * f < 0.0) {
      const Element& el = graph_.element(r.element);
      return fmt::format("the resistor {} delivers power ({} W: e = {:.9g}, f = {:.9g}) although it is not marked active; "
                         "its law `{}` must give e f >= 0, or mark it `active: true`",
                         el.name, -r.sigma * e * f, r.sigma * e, f, (el.law_effort.given() ? el.law_effort : el.law_flow).text);
    }
  }
  return {};
}

}  // namespace multibond
