/// \file
/// Build's passes from the slots to the ordered plan (docs/design.md, "The compiled model's
/// parts and passes"): AssignSlots, PlanModuli, EmitInstructions, OrderPlan.

#include <algorithm>
#include <numeric>
#include <queue>

#include <fmt/format.h>

#include "multibond/compile/compiled_model.h"
#include "multibond/core/diagnostic_codes.h"
#include "multibond/core/union_find.h"

namespace multibond {
namespace {

bool IsIdentityTransformer(const Element& e) {
  if (e.kind != ElementKind::kTF || !e.value.empty()) return false;
  if (e.param.is_scalar) return e.param.scalar == 1.0;
  const Eigen::MatrixXd& m = e.param.matrix;
  return m.rows() == m.cols() && m == Eigen::MatrixXd::Identity(m.rows(), m.cols());
}

using plan::AppendRowMajor;

}  // namespace

void CompiledModel::AssignSlots() {
  const BondGraph& g = graph_;
  const int nb = g.num_bonds();
  const auto& dim = structure_.bond_dim;

  // --- Slot classes: shared efforts at 0-junctions, shared flows at 1-junctions. ---
  UnionFind uf(2 * nb);  // slot 2b = effort of bond b, 2b+1 = flow
  for (int i = 0; i < g.num_elements(); ++i) {
    const Element& e = g.element(i);
    if (IsJunction(e.kind)) {
      const int parity = e.kind == ElementKind::kZero ? 0 : 1;
      for (int b : e.bonds) uf.Unite(2 * e.bonds.front() + parity, 2 * b + parity);
    } else if (IsIdentityTransformer(e)) {
      // An identity TF passes effort and flow unchanged: both sides share their slots.
      const int in = structure_.port_in[i], out = structure_.port_out[i];
      uf.Unite(2 * in, 2 * out);
      uf.Unite(2 * in + 1, 2 * out + 1);
    }
  }
  std::vector<int> class_of_root(2 * nb, -1);
  slots_.effort_class.resize(nb);
  slots_.flow_class.resize(nb);
  for (int s = 0; s < 2 * nb; ++s) {
    const int root = uf.Root(s);
    if (class_of_root[root] < 0) {
      class_of_root[root] = slots_.num_classes();
      slots_.class_offset.push_back(slots_.num_slots);
      slots_.class_size.push_back(dim[s / 2]);
      slots_.num_slots += dim[s / 2];
      const DomainUnits u = UnitsOf(structure_.bond_domain[s / 2]);
      slots_.class_units.push_back(s % 2 == 0 ? u.effort : u.flow);
      slots_.class_names.emplace_back();
    }
    (s % 2 == 0 ? slots_.effort_class : slots_.flow_class)[s / 2] = class_of_root[root];
  }
  auto name_class = [&](int c, const std::string& n) {
    if (slots_.class_names[c].empty()) slots_.class_names[c] = n;
  };
  for (int i = 0; i < g.num_elements(); ++i) {
    const Element& e = g.element(i);
    if (e.kind == ElementKind::kZero) name_class(slots_.effort_class[e.bonds.front()], e.name + ".e");
    if (e.kind == ElementKind::kOne) name_class(slots_.flow_class[e.bonds.front()], e.name + ".f");
  }
  for (int i = 0; i < g.num_elements(); ++i) {
    const Element& e = g.element(i);
    if (IsOnePort(e.kind)) {
      name_class(slots_.effort_class[e.bonds.front()], e.name + ".e");
      name_class(slots_.flow_class[e.bonds.front()], e.name + ".f");
    } else if (IsTwoPort(e.kind)) {
      name_class(slots_.effort_class[structure_.port_in[i]], e.name + ".e1");
      name_class(slots_.flow_class[structure_.port_in[i]], e.name + ".f1");
      name_class(slots_.effort_class[structure_.port_out[i]], e.name + ".e2");
      name_class(slots_.flow_class[structure_.port_out[i]], e.name + ".f2");
    }
  }
  for (int b = 0; b < nb; ++b) {
    name_class(slots_.effort_class[b], g.bond(b).name + ".e");
    name_class(slots_.flow_class[b], g.bond(b).name + ".f");
  }

  AssignSignalSlots();      // formulas.cc: signals, signal states' rates
  AssignModulationSlots();  // modulated_storage.cc: the power of each modulated storage element

  // --- Ideal constraints: one multiplier per dimension of each. ---
  constraints_.AssignMultipliers(dim);
}

std::vector<int> CompiledModel::PlanModuli() {
  const BondGraph& g = graph_;
  auto effort_into = [&](int b, int e) { return causality_.EffortInto(g, b, e); };
  auto state_offset = [&](int block) { return layout_.blocks()[block].offset; };
  auto aux_offset = [&](const std::string& name) { return state_offset(layout_.aux_block(g.FindAux(name))); };

  // --- Moduli of MTF and MGY, evaluated once per right-hand side. ---
  std::vector<int> modulus_of(g.num_elements(), -1);
  for (int i = 0; i < g.num_elements(); ++i) {
    const Element& e = g.element(i);
    if (e.kind != ElementKind::kMTF && e.kind != ElementKind::kMGY) continue;
    if (HasFormulas(e)) continue;  // its entries are formulas: FormulaInstructions writes M u out
    const Modulus& mod = e.modulus;
    ModulusEval me{mod.kind, mod.rows(), mod.cols(), plan_.num_moduli, -1, -1, -1, -1, -1, mod.scale, mod.transpose, mod.lever};
    plan_.num_moduli += me.rows * me.cols;
    if (mod.kind != Modulus::Kind::kConstant) me.rotation = aux_offset(mod.rotation);
    if (mod.left.size() > 0) {
      me.left = static_cast<int>(plan_.coef.size());
      AppendRowMajor(plan_.coef, mod.left);
    }
    if (mod.right.size() > 0) {
      // Stored padded to 3x3 so that the evaluation multiplies fixed-size matrices.
      MB_ASSERT(mod.right.rows() == 3 && mod.right.cols() <= 3, "a modulus' right factor is 3 x n with n <= 3");
      Eigen::Matrix3d padded = Eigen::Matrix3d::Zero();
      padded.leftCols(mod.right.cols()) = mod.right;
      me.right = static_cast<int>(plan_.coef.size());
      AppendRowMajor(plan_.coef, padded);
    }
    if (mod.kind == Modulus::Kind::kConstant) {
      me.constant_rows = static_cast<int>(mod.constant.rows());
      me.constant = static_cast<int>(plan_.coef.size());
      AppendRowMajor(plan_.coef, mod.constant);
    }
    // The inverse is needed when the effort enters at port 1 (backward transformer) or a
    // gyrator is driven by efforts.
    if (effort_into(structure_.port_in[i], i)) {
      me.out_inverse = plan_.num_moduli;
      plan_.num_moduli += me.rows * me.cols;
    }
    modulus_of[i] = static_cast<int>(plan_.moduli.size());
    plan_.moduli.push_back(me);
  }

  return modulus_of;
}

CompiledModel::Draft CompiledModel::EmitInstructions(const std::vector<int>& modulus_of) {
  const BondGraph& g = graph_;
  const auto& dim = structure_.bond_dim;
  auto effort_into = [&](int b, int e) { return causality_.EffortInto(g, b, e); };
  auto state_offset = [&](int block) { return layout_.blocks()[block].offset; };
  auto aux_offset = [&](const std::string& name) { return state_offset(layout_.aux_block(g.FindAux(name))); };

  // --- Instructions: one per computed slot class. ---
  const int nclasses = num_slot_classes();
  plan_.definitions.assign(nclasses, Definition{Definition::Kind::kSource, -1, {}});
  std::vector<int> writer(nclasses, -1);
  std::vector<std::vector<int>> reads;  // per instruction: slot classes read
  std::vector<Instr> instrs;
  auto emit = [&](Instr in, int out_class, std::vector<int> in_classes, Definition def) {
    if (writer[out_class] >= 0) {
      throw ModelError(Diagnostic{Diagnostic::Severity::kError, g.element(in.element).where, g.element(in.element).name,
                                  fmt::format("variable '{}' is computed twice (by {} and {})", slots_.class_names[out_class],
                                              Describe(g, instrs[writer[out_class]].element), Describe(g, in.element)),
                                  "this is a causality conflict the analysis did not catch; please report it", {},
                                  codes::kInternalDoubleWriter});
    }
    in.dst = slots_.class_offset[out_class];
    writer[out_class] = static_cast<int>(instrs.size());
    instrs.push_back(in);
    reads.push_back(std::move(in_classes));
    def.element = in.element;
    plan_.definitions[out_class] = std::move(def);
  };
  // dst = sign * A src. The numbers carry the sign; the definition keeps it apart from the
  // coefficient's symbol so that `multibond equations` shows "- damper.R f" whatever the values.
  auto emit_linear = [&](int element, int out_class, int in_class, double sign, const Eigen::MatrixXd& a,
                         const std::string& symbol) {
    Instr in{};
    in.element = element;
    in.n = slots_.class_size[out_class];
    in.m = slots_.class_size[in_class];
    in.src = slots_.class_offset[in_class];
    in.coef = static_cast<int>(plan_.coef.size());
    const bool scalar = a.rows() == a.cols() && a.isApprox(a(0, 0) * Eigen::MatrixXd::Identity(a.rows(), a.cols()), 0.0);
    if (scalar) {
      in.op = Op::kScale;
      plan_.coef.push_back(sign * a(0, 0));
    } else {
      in.op = Op::kMatrix;
      AppendRowMajor(plan_.coef, sign * a);
    }
    emit(in, out_class, {in_class}, {Definition::Kind::kLinear, element, {{in_class, sign, symbol}}});
  };
  auto emit_modulated = [&](int element, int out_class, int in_class, int mode, const std::string& symbol) {
    Instr in{};
    in.op = Op::kModulated;
    in.element = element;
    in.n = slots_.class_size[out_class];
    in.m = slots_.class_size[in_class];
    in.src = slots_.class_offset[in_class];
    const ModulusEval& me = plan_.moduli[modulus_of[element]];
    in.coef = mode >= 2 ? me.out_inverse : me.out;
    in.count = mode;
    in.modulus = modulus_of[element];
    emit(in, out_class, {in_class}, {Definition::Kind::kLinear, element, {{in_class, 1.0, symbol}}});
  };

  auto emit_formula = [&](FormulaInstr& fi) { emit(fi.in, fi.out_class, std::move(fi.reads), std::move(fi.def)); };
  for (int i = 0; i < g.num_elements(); ++i) {
    const Element& e = g.element(i);
    if (HasFormulas(e)) {  // formulas.cc
      for (FormulaInstr& fi : FormulaInstructions(i)) emit_formula(fi);
      continue;
    }
    switch (e.kind) {
      case ElementKind::kSe:
      case ElementKind::kSf: {
        const int b = e.bonds.front(), n = dim[b];
        if (e.constraint) {
          // Its effort (its flow, for an Sf: a compliance's cut) is the multiplier of its
          // constraint, set by the constraint solve.
          Instr in{};
          in.op = Op::kMultiplier;
          in.element = i;
          in.n = n;
          in.coef = constraints_.MultiplierOf(b);
          emit(in, e.kind == ElementKind::kSe ? slots_.effort_class[b] : slots_.flow_class[b], {}, {Definition::Kind::kSource, i, {}});
          break;
        }
        Instr in{};
        in.op = Op::kSource;
        in.element = i;
        in.n = n;
        in.coef = static_cast<int>(plan_.source_fns.size());
        for (int k = 0; k < n; ++k) plan_.source_fns.push_back(e.source.components.size() == 1 ? e.source.components[0] : e.source.components[k]);
        emit(in, e.kind == ElementKind::kSe ? slots_.effort_class[b] : slots_.flow_class[b], {}, {Definition::Kind::kSource, i, {}});
        break;
      }
      case ElementKind::kI: {
        const int b = e.bonds.front(), n = dim[b];
        Instr in{};
        in.element = i;
        in.n = n;
        in.src = state_offset(layout_.element_block(i));
        in.coef = static_cast<int>(plan_.coef.size());
        if (!e.rotation.empty()) {
          in.op = Op::kIFlowRotated;
          in.aux = aux_offset(e.rotation);
          AppendRowMajor(plan_.coef, Eigen::MatrixXd(e.param.AsMatrix(n, n).inverse()));  // Ib^-1
        } else if (e.param.is_scalar) {
          in.op = Op::kStateScale;
          plan_.coef.push_back(1.0 / e.param.scalar);
        } else {
          in.op = Op::kStateMatrix;
          AppendRowMajor(plan_.coef, Eigen::MatrixXd(e.param.AsMatrix(n, n).inverse()));
        }
        emit(in, slots_.flow_class[b], {}, {Definition::Kind::kMomentumFlow, i, {}});
        break;
      }
      case ElementKind::kC: {
        const int b = e.bonds.front(), n = dim[b];
        const double sigma = g.PowerSign(b, i);
        Instr in{};
        in.element = i;
        in.n = n;
        in.src = state_offset(layout_.element_block(i));
        in.coef = static_cast<int>(plan_.coef.size());
        if (e.param.is_scalar) {
          in.op = Op::kStateScale;
          plan_.coef.push_back(sigma * e.param.scalar);
        } else {
          in.op = Op::kStateMatrix;
          AppendRowMajor(plan_.coef, sigma * e.param.matrix);
        }
        emit(in, slots_.effort_class[b], {}, {Definition::Kind::kStiffnessEffort, i, {}});
        break;
      }
      case ElementKind::kR: {
        const int b = e.bonds.front(), n = dim[b];
        const double sigma = g.PowerSign(b, i);
        const Eigen::MatrixXd r = e.param.AsMatrix(n, n);
        if (!effort_into(b, i)) {
          emit_linear(i, slots_.effort_class[b], slots_.flow_class[b], sigma, r, e.name + ".R");
        } else {
          Eigen::FullPivLU<Eigen::MatrixXd> lu(r);
          if (!lu.isInvertible())
            throw ModelError(Diagnostic{Diagnostic::Severity::kError, e.where, e.name,
                                        "resistor in conductance causality (effort in, flow out) has a singular resistance",
                                        "give it a non-zero resistance, or change the structure so that its flow is imposed", {},
                                        codes::kParamSingular});
          emit_linear(i, slots_.flow_class[b], slots_.effort_class[b], sigma, Eigen::MatrixXd(lu.inverse()),
                      e.param.is_scalar ? "1/" + e.name + ".R" : e.name + ".R^-1");
        }
        break;
      }
      case ElementKind::kZero:
      case ElementKind::kOne: {
        const bool zero = e.kind == ElementKind::kZero;
        int strong = -1;
        for (int b : e.bonds)
          if (effort_into(b, i) == zero) strong = b;
        MB_ASSERT(strong >= 0, "junction without a strong bond after causality");
        Instr in{};
        in.op = Op::kSum;
        in.element = i;
        in.n = dim[strong];
        in.coef = static_cast<int>(plan_.sum_terms.size());
        Definition def{Definition::Kind::kSum, i, {}};
        std::vector<int> in_classes;
        const double s_strong = g.PowerSign(strong, i);
        for (int b : e.bonds) {
          if (b == strong) continue;
          const int c = zero ? slots_.flow_class[b] : slots_.effort_class[b];
          const double sign = -s_strong * g.PowerSign(b, i);
          plan_.sum_terms.push_back(slots_.class_offset[c]);
          plan_.sum_signs.push_back(sign);
          in_classes.push_back(c);
          def.terms.push_back({c, sign, ""});
        }
        in.count = static_cast<int>(in_classes.size());
        emit(in, zero ? slots_.flow_class[strong] : slots_.effort_class[strong], in_classes, def);
        break;
      }
      case ElementKind::kTF:
      case ElementKind::kGY:
      case ElementKind::kMTF:
      case ElementKind::kMGY: {
        if (IsIdentityTransformer(e)) break;  // its ports share their slots
        const int b1 = structure_.port_in[i], b2 = structure_.port_out[i];
        const bool gyrator = e.kind == ElementKind::kGY || e.kind == ElementKind::kMGY;
        const bool modulated = e.kind == ElementKind::kMTF || e.kind == ElementKind::kMGY;
        const bool forward = !effort_into(b1, i);  // flow given at port 1
        // Inputs and outputs of the two equations, by causality:
        //   TF forward:  f2 = M f1,      e1 = M^T e2     TF backward: e2 = M^-T e1, f1 = M^-1 f2
        //   GY forward:  e2 = M f1,      e1 = M^T f2     GY backward: f2 = M^-T e1, f1 = M^-1 e2
        struct Eq { int out, in, mode; };
        Eq eq[2];
        if (!gyrator) {
          eq[0] = forward ? Eq{slots_.flow_class[b2], slots_.flow_class[b1], 0} : Eq{slots_.effort_class[b2], slots_.effort_class[b1], 3};
          eq[1] = forward ? Eq{slots_.effort_class[b1], slots_.effort_class[b2], 1} : Eq{slots_.flow_class[b1], slots_.flow_class[b2], 2};
        } else {
          eq[0] = forward ? Eq{slots_.effort_class[b2], slots_.flow_class[b1], 0} : Eq{slots_.flow_class[b2], slots_.effort_class[b1], 3};
          eq[1] = forward ? Eq{slots_.effort_class[b1], slots_.flow_class[b2], 1} : Eq{slots_.flow_class[b1], slots_.effort_class[b2], 2};
        }
        static const char* kSuffix[] = {"", "^T", "^-1", "^-T"};
        for (const Eq& q : eq) {
          // A scalar ratio needs no transpose: r or 1/r.
          const std::string symbol = !modulated && e.param.is_scalar ? (q.mode >= 2 ? "1/" + e.name + ".r" : e.name + ".r")
                                                                     : e.name + (modulated ? ".M" : ".r") + kSuffix[q.mode];
          if (modulated) {
            emit_modulated(i, q.out, q.in, q.mode, symbol);
          } else {
            const Eigen::MatrixXd mm = e.param.AsMatrix(dim[b2], dim[b1]);
            Eigen::MatrixXd a;
            switch (q.mode) {
              case 0: a = mm; break;
              case 1: a = mm.transpose(); break;
              case 2: a = mm.inverse(); break;
              default: a = mm.inverse().transpose(); break;
            }
            emit_linear(i, q.out, q.in, 1.0, a, symbol);
          }
        }
        break;
      }
    }
  }
  for (FormulaInstr& fi : SignalInstructions()) emit_formula(fi);
  for (int c = 0; c < nclasses; ++c)
    MB_ASSERT(writer[c] >= 0, "slot '" + slots_.class_names[c] + "' has no writer after causality");

  return {std::move(instrs), std::move(reads), std::move(writer)};
}

CompiledModel::PlanDeps CompiledModel::OrderPlan(const Draft& draft) {
  const BondGraph& g = graph_;
  const int nclasses = num_slot_classes();
  const std::vector<Instr>& instrs = draft.instrs;
  const std::vector<std::vector<int>>& reads = draft.reads;
  const std::vector<int>& writer = draft.writer;

  // --- Order: topological sort of the causal dependencies; a cycle is an algebraic loop. ---
  // With solve_algebraic_loops, each cycle is broken by tearing one of its variables: its
  // readers take it as an unknown (solved at every evaluation, see EvalTorn), its writer's
  // result goes to a slot of its own. Cycles are torn one at a time until the order exists.
  const int ni = static_cast<int>(instrs.size());
  std::vector<char> torn(nclasses, 0);
  std::vector<int> order;
  for (;;) {
    std::vector<int> indegree(ni, 0);
    std::vector<std::vector<int>> users(ni);
    for (int k = 0; k < ni; ++k)
      for (int c : reads[k]) {
        if (torn[c]) continue;
        users[writer[c]].push_back(k);
        ++indegree[k];
      }
    std::priority_queue<int, std::vector<int>, std::greater<int>> ready;  // deterministic order
    for (int k = 0; k < ni; ++k)
      if (indegree[k] == 0) ready.push(k);
    order.clear();
    while (!ready.empty()) {
      const int k = ready.top();
      ready.pop();
      order.push_back(k);
      for (int u : users[k])
        if (--indegree[u] == 0) ready.push(u);
    }
    if (static_cast<int>(order.size()) == ni) break;
    // Walk back from a blocked instruction through blocked inputs until a node repeats: a cycle.
    int k = 0;
    while (indegree[k] == 0) ++k;
    std::vector<int> seen(ni, -1), walk;
    while (seen[k] < 0) {
      seen[k] = static_cast<int>(walk.size());
      walk.push_back(k);
      for (int c : reads[k])
        if (!torn[c] && indegree[writer[c]] > 0) {
          k = writer[c];
          break;
        }
    }
    std::vector<int> cycle(walk.begin() + seen[k], walk.end());
    std::reverse(cycle.begin(), cycle.end());
    std::vector<int> elements;
    std::string vars;
    // The class to tear: a junction's sum if the loop has one (it joins most paths), else an
    // effort or flow rather than a signal (a nonlinear loop's Newton iteration starts from 0 at
    // first, natural for a power variable at rest, not for a signal such as a temperature).
    auto rank = [&](int cls) {
      if (instrs[writer[cls]].op == Op::kSum) return 2;
      return slots_.signal_class.count(slots_.class_names[cls]) || slots_.internal_class.count(slots_.class_names[cls]) ? 0 : 1;
    };
    int tear = -1;
    for (int c : cycle) {
      elements.push_back(instrs[c].element);
      for (int cls = 0; cls < nclasses; ++cls)
        if (writer[cls] == c) {
          vars += (vars.empty() ? "" : ", ") + slots_.class_names[cls];
          if (tear < 0 || rank(cls) > rank(tear)) tear = cls;
        }
    }
    elements.push_back(elements.front());
    // The loop's first element; a loop of signals alone has none (element -1): its first signal's
    // or signal state's place instead.
    int first = -1;
    for (int e : elements)
      if (first < 0 && e >= 0) first = e;
    if (options_.solve_algebraic_loops && tear >= 0) {
      torn[tear] = 1;
      loops_.loops.push_back({FormatPath(g, elements), slots_.class_names[tear], first, tear});
      continue;
    }
    Diagnostic d;
    if (first >= 0) {
      d.where = g.element(first).where;
      d.element = g.element(first).name;
    } else {
      const std::string name = vars.substr(0, vars.find(','));
      if (const int sig = g.FindSignal(name); sig >= 0) d.where = g.signals()[sig].where;
      else if (const int aux = g.FindAux(name.substr(0, name.find('.'))); aux >= 0) d.where = g.aux_states()[aux].where;
      d.element = name;
    }
    d.code = codes::kCausalityAlgebraicLoop;
    d.message = "algebraic loop: these variables depend on themselves with no storage element in between";
    d.details.push_back("loop: " + (first >= 0 ? FormatPath(g, elements) : "signals " + vars));
    d.details.push_back("variables: " + vars);
    d.hint = "add a storage element in the loop (a small C or I where the physics has one), merge the resistors into "
             "one, or let multibond solve it (algebraic_loops: solve in the model file, --algebraic-loops solve)";
    throw ModelError(d);
  }
  for (int k : order) plan_.instrs.push_back(instrs[k]);
  std::vector<int> out_class(ni, -1);  // per instruction: the class it writes
  for (int cls = 0; cls < nclasses; ++cls) out_class[writer[cls]] = cls;
  // Torn variables: the slot of each keeps the unknown; its writer writes to a slot of its own.
  for (int cls = 0; cls < nclasses; ++cls) {
    if (!torn[cls]) continue;
    const int at = static_cast<int>(std::find(order.begin(), order.end(), writer[cls]) - order.begin());
    loops_.tears.push_back({slots_.class_offset[cls], slots_.class_size[cls], slots_.num_slots});
    plan_.instrs[at].dst = slots_.num_slots;
    slots_.num_slots += slots_.class_size[cls];
    loops_.num_unknowns += slots_.class_size[cls];
  }
  if (!loops_.tears.empty()) {
    // The instructions that depend on an unknown (through the slots they read, in plan order):
    // the only ones the probes and the last pass of EvalTorn need to run again.
    std::vector<char> reached(torn.begin(), torn.end());
    for (int at = 0; at < ni; ++at) {
      const int k = order[at];
      bool depends = false;
      for (int c : reads[k]) depends = depends || reached[c];
      if (!depends) continue;
      loops_.closure.push_back(at);
      reached[out_class[k]] = 1;
    }
  }
  PlanDeps deps;
  for (int k : order) {
    deps.reads.push_back(reads[k]);
    deps.writes.push_back(out_class[k]);
  }
  return deps;
}

}  // namespace multibond
