#include "multibond/compile/compiled_model.h"
#include "multibond/compile/exact_sum.h"

#include "multibond/compile/jit.h"

#include <dlfcn.h>

#include <algorithm>
#include <numeric>
#include <queue>
#include <stdexcept>

#include <fmt/format.h>

namespace multibond {

namespace {

class UnionFind {
 public:
  explicit UnionFind(int n) : parent_(n) { std::iota(parent_.begin(), parent_.end(), 0); }
  int Root(int i) {
    while (parent_[i] != i) i = parent_[i] = parent_[parent_[i]];
    return i;
  }
  void Merge(int a, int b) {
    a = Root(a), b = Root(b);
    if (a != b) parent_[std::max(a, b)] = std::min(a, b);
  }

 private:
  std::vector<int> parent_;
};

bool IsIdentityTransformer(const Element& e) {
  if (e.kind != ElementKind::kTF) return false;
  if (e.param.is_scalar) return e.param.scalar == 1.0;
  const Eigen::MatrixXd& m = e.param.matrix;
  return m.rows() == m.cols() && m == Eigen::MatrixXd::Identity(m.rows(), m.cols());
}

void AppendRowMajor(std::vector<double>& pool, const Eigen::MatrixXd& m) {
  for (int r = 0; r < m.rows(); ++r)
    for (int c = 0; c < m.cols(); ++c) pool.push_back(m(r, c));
}

}  // namespace

std::vector<std::string> ComponentNames(int n, const std::vector<std::string>& names) {
  if (static_cast<int>(names.size()) == n) return names;
  if (n == 1) return {};
  if (n == 3) return {"x", "y", "z"};
  std::vector<std::string> out;
  for (int i = 1; i <= n; ++i) out.push_back(std::to_string(i));
  return out;
}

std::shared_ptr<const CompiledModel> CompiledModel::Compile(BondGraph graph, const CompileOptions& options) {
  std::shared_ptr<CompiledModel> m(new CompiledModel());
  m->graph_ = std::move(graph);
  m->options_ = options;
  m->Build();
  return m;
}

void CompiledModel::Build() {
  PrepareConstraintGraph();  // structure, causality; ideal constraints become effort sources
  const BondGraph& g = graph_;

  const int nb = g.num_bonds();
  const auto& dim = structure_.bond_dim;
  auto effort_into = [&](int b, int e) { return causality_.EffortInto(g, b, e); };

  // --- Slot classes: shared efforts at 0-junctions, shared flows at 1-junctions. ---
  UnionFind uf(2 * nb);  // slot 2b = effort of bond b, 2b+1 = flow
  for (int i = 0; i < g.num_elements(); ++i) {
    const Element& e = g.element(i);
    if (IsJunction(e.kind)) {
      const int parity = e.kind == ElementKind::kZero ? 0 : 1;
      for (int b : e.bonds) uf.Merge(2 * e.bonds.front() + parity, 2 * b + parity);
    } else if (IsIdentityTransformer(e)) {
      // An identity TF passes effort and flow unchanged: both sides share their slots.
      const int in = structure_.port_in[i], out = structure_.port_out[i];
      uf.Merge(2 * in, 2 * out);
      uf.Merge(2 * in + 1, 2 * out + 1);
    }
  }
  std::vector<int> class_of_root(2 * nb, -1);
  effort_class_.resize(nb);
  flow_class_.resize(nb);
  for (int s = 0; s < 2 * nb; ++s) {
    const int root = uf.Root(s);
    if (class_of_root[root] < 0) {
      class_of_root[root] = static_cast<int>(class_offset_.size());
      class_offset_.push_back(num_slots_);
      class_size_.push_back(dim[s / 2]);
      num_slots_ += dim[s / 2];
      const DomainUnits u = UnitsOf(structure_.bond_domain[s / 2]);
      class_units_.push_back(s % 2 == 0 ? u.effort : u.flow);
      class_names_.emplace_back();
    }
    (s % 2 == 0 ? effort_class_ : flow_class_)[s / 2] = class_of_root[root];
  }
  auto name_class = [&](int c, const std::string& n) {
    if (class_names_[c].empty()) class_names_[c] = n;
  };
  for (int i = 0; i < g.num_elements(); ++i) {
    const Element& e = g.element(i);
    if (e.kind == ElementKind::kZero) name_class(effort_class_[e.bonds.front()], e.name + ".e");
    if (e.kind == ElementKind::kOne) name_class(flow_class_[e.bonds.front()], e.name + ".f");
  }
  for (int i = 0; i < g.num_elements(); ++i) {
    const Element& e = g.element(i);
    if (IsOnePort(e.kind)) {
      name_class(effort_class_[e.bonds.front()], e.name + ".e");
      name_class(flow_class_[e.bonds.front()], e.name + ".f");
    } else if (IsTwoPort(e.kind)) {
      name_class(effort_class_[structure_.port_in[i]], e.name + ".e1");
      name_class(flow_class_[structure_.port_in[i]], e.name + ".f1");
      name_class(effort_class_[structure_.port_out[i]], e.name + ".e2");
      name_class(flow_class_[structure_.port_out[i]], e.name + ".f2");
    }
  }
  for (int b = 0; b < nb; ++b) {
    name_class(effort_class_[b], g.bond(b).name + ".e");
    name_class(flow_class_[b], g.bond(b).name + ".f");
  }

  // --- Ideal constraints: one multiplier per dimension of each. ---
  for (ConstraintGroup& cg : constraints_) {
    cg.size = dim[cg.members.front().flow];  // still the member's bond (BuildConstraints maps it)
    cg.lambda = num_lambda_;
    num_lambda_ += cg.size;
  }

  // --- State layout. ---
  element_block_.assign(g.num_elements(), -1);
  aux_block_.assign(g.aux_states().size(), -1);
  energy_matrix_.resize(g.num_elements());
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
    const Eigen::MatrixXd p = e.param.AsMatrix(n, n);
    energy_matrix_[i] = inertia ? Eigen::MatrixXd(p.inverse()) : p;
  }
  for (size_t a = 0; a < g.aux_states().size(); ++a) {
    const AuxState& s = g.aux_states()[a];
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
  energy_term_of_element_.assign(g.num_elements(), -1);
  for (const StateBlock& blk : blocks_) {
    if (blk.kind != StateBlock::Kind::kMomentum && blk.kind != StateBlock::Kind::kDisplacement) continue;
    const Element& e = g.element(blk.owner);
    EnergyTerm et{blk.offset, blk.size, -1, static_cast<int>(energy_coef_.size()), blk.kind == StateBlock::Kind::kMomentum};
    if (e.kind == ElementKind::kI && !e.rotation.empty())
      et.rotation = blocks_[aux_block_[g.FindAux(e.rotation)]].offset;
    AppendRowMajor(energy_coef_, energy_matrix_[blk.owner]);
    energy_term_of_element_.resize(g.num_elements(), -1);
    energy_term_of_element_[blk.owner] = static_cast<int>(energy_terms_.size());
    energy_terms_.push_back(et);
  }
  auto state_offset = [&](int block) { return blocks_[block].offset; };
  auto aux_offset = [&](const std::string& name) { return state_offset(aux_block_[g.FindAux(name)]); };

  // --- Moduli of MTF and MGY, evaluated once per right-hand side. ---
  std::vector<int> modulus_of(g.num_elements(), -1);
  for (int i = 0; i < g.num_elements(); ++i) {
    const Element& e = g.element(i);
    if (e.kind != ElementKind::kMTF && e.kind != ElementKind::kMGY) continue;
    const Modulus& mod = e.modulus;
    ModulusEval me{mod.kind, mod.rows(), mod.cols(), num_moduli_, -1, -1, -1, -1, -1, mod.scale, mod.transpose, mod.lever};
    num_moduli_ += me.rows * me.cols;
    if (mod.kind != Modulus::Kind::kConstant) me.rotation = aux_offset(mod.rotation);
    if (mod.left.size() > 0) {
      me.left = static_cast<int>(coef_.size());
      AppendRowMajor(coef_, mod.left);
    }
    if (mod.right.size() > 0) {
      // Stored padded to 3x3 so that the evaluation multiplies fixed-size matrices.
      MB_ASSERT(mod.right.rows() == 3 && mod.right.cols() <= 3, "a modulus' right factor is 3 x n with n <= 3");
      Eigen::Matrix3d padded = Eigen::Matrix3d::Zero();
      padded.leftCols(mod.right.cols()) = mod.right;
      me.right = static_cast<int>(coef_.size());
      AppendRowMajor(coef_, padded);
    }
    if (mod.kind == Modulus::Kind::kConstant) {
      me.constant_rows = static_cast<int>(mod.constant.rows());
      me.constant = static_cast<int>(coef_.size());
      AppendRowMajor(coef_, mod.constant);
    }
    // The inverse is needed when the effort enters at port 1 (backward transformer) or a
    // gyrator is driven by efforts.
    if (effort_into(structure_.port_in[i], i)) {
      me.out_inverse = num_moduli_;
      num_moduli_ += me.rows * me.cols;
    }
    modulus_of[i] = static_cast<int>(moduli_.size());
    moduli_.push_back(me);
  }

  // --- Instructions: one per computed slot class. ---
  const int nclasses = num_slot_classes();
  definitions_.assign(nclasses, Definition{Definition::Kind::kSource, -1, {}});
  std::vector<int> writer(nclasses, -1);
  std::vector<std::vector<int>> reads;  // per instruction: slot classes read
  std::vector<Instr> instrs;
  auto emit = [&](Instr in, int out_class, std::vector<int> in_classes, Definition def) {
    if (writer[out_class] >= 0) {
      throw ModelError(Diagnostic{Diagnostic::Severity::kError, g.element(in.element).where, g.element(in.element).name,
                                  fmt::format("variable '{}' is computed twice (by {} and {})", class_names_[out_class],
                                              Describe(g, instrs[writer[out_class]].element), Describe(g, in.element)),
                                  "this is a causality conflict the analysis did not catch; please report it", {},
                                  "internal.double_writer"});
    }
    in.dst = class_offset_[out_class];
    writer[out_class] = static_cast<int>(instrs.size());
    instrs.push_back(in);
    reads.push_back(std::move(in_classes));
    def.element = in.element;
    definitions_[out_class] = std::move(def);
  };
  // dst = sign * A src. The numbers carry the sign; the definition keeps it apart from the
  // coefficient's symbol so that `multibond equations` shows "- damper.R f" whatever the values.
  auto emit_linear = [&](int element, int out_class, int in_class, double sign, const Eigen::MatrixXd& a,
                         const std::string& symbol) {
    Instr in{};
    in.element = element;
    in.n = class_size_[out_class];
    in.m = class_size_[in_class];
    in.src = class_offset_[in_class];
    in.coef = static_cast<int>(coef_.size());
    const bool scalar = a.rows() == a.cols() && a.isApprox(a(0, 0) * Eigen::MatrixXd::Identity(a.rows(), a.cols()), 0.0);
    if (scalar) {
      in.op = Op::kScale;
      coef_.push_back(sign * a(0, 0));
    } else {
      in.op = Op::kMatrix;
      AppendRowMajor(coef_, sign * a);
    }
    emit(in, out_class, {in_class}, {Definition::Kind::kLinear, element, {{in_class, sign, symbol}}});
  };
  auto emit_modulated = [&](int element, int out_class, int in_class, int mode, const std::string& symbol) {
    Instr in{};
    in.op = Op::kModulated;
    in.element = element;
    in.n = class_size_[out_class];
    in.m = class_size_[in_class];
    in.src = class_offset_[in_class];
    const ModulusEval& me = moduli_[modulus_of[element]];
    in.coef = mode >= 2 ? me.out_inverse : me.out;
    in.count = mode;
    in.modulus = modulus_of[element];
    emit(in, out_class, {in_class}, {Definition::Kind::kLinear, element, {{in_class, 1.0, symbol}}});
  };

  for (int i = 0; i < g.num_elements(); ++i) {
    const Element& e = g.element(i);
    switch (e.kind) {
      case ElementKind::kSe:
      case ElementKind::kSf: {
        const int b = e.bonds.front(), n = dim[b];
        if (e.constraint) {
          // Its effort is the multiplier of its constraint, set by the constraint solve.
          Instr in{};
          in.op = Op::kMultiplier;
          in.element = i;
          in.n = n;
          for (const ConstraintGroup& cg : constraints_)
            for (const auto& m : cg.members)
              if (m.flow == b) in.coef = cg.lambda;
          emit(in, effort_class_[b], {}, {Definition::Kind::kSource, i, {}});
          break;
        }
        Instr in{};
        in.op = Op::kSource;
        in.element = i;
        in.n = n;
        in.coef = static_cast<int>(source_fns_.size());
        for (int k = 0; k < n; ++k) source_fns_.push_back(e.source.components.size() == 1 ? e.source.components[0] : e.source.components[k]);
        emit(in, e.kind == ElementKind::kSe ? effort_class_[b] : flow_class_[b], {}, {Definition::Kind::kSource, i, {}});
        break;
      }
      case ElementKind::kI: {
        const int b = e.bonds.front(), n = dim[b];
        Instr in{};
        in.element = i;
        in.n = n;
        in.src = state_offset(element_block_[i]);
        in.coef = static_cast<int>(coef_.size());
        if (!e.rotation.empty()) {
          in.op = Op::kIFlowRotated;
          in.aux = aux_offset(e.rotation);
          AppendRowMajor(coef_, energy_matrix_[i]);  // Ib^-1
        } else if (e.param.is_scalar) {
          in.op = Op::kStateScale;
          coef_.push_back(1.0 / e.param.scalar);
        } else {
          in.op = Op::kStateMatrix;
          AppendRowMajor(coef_, energy_matrix_[i]);
        }
        emit(in, flow_class_[b], {}, {Definition::Kind::kMomentumFlow, i, {}});
        break;
      }
      case ElementKind::kC: {
        const int b = e.bonds.front(), n = dim[b];
        const double sigma = g.PowerSign(b, i);
        Instr in{};
        in.element = i;
        in.n = n;
        in.src = state_offset(element_block_[i]);
        in.coef = static_cast<int>(coef_.size());
        if (e.param.is_scalar) {
          in.op = Op::kStateScale;
          coef_.push_back(sigma * e.param.scalar);
        } else {
          in.op = Op::kStateMatrix;
          AppendRowMajor(coef_, sigma * e.param.matrix);
        }
        emit(in, effort_class_[b], {}, {Definition::Kind::kStiffnessEffort, i, {}});
        break;
      }
      case ElementKind::kR: {
        const int b = e.bonds.front(), n = dim[b];
        const double sigma = g.PowerSign(b, i);
        const Eigen::MatrixXd r = e.param.AsMatrix(n, n);
        if (!effort_into(b, i)) {
          emit_linear(i, effort_class_[b], flow_class_[b], sigma, r, e.name + ".R");
        } else {
          Eigen::FullPivLU<Eigen::MatrixXd> lu(r);
          if (!lu.isInvertible())
            throw ModelError(Diagnostic{Diagnostic::Severity::kError, e.where, e.name,
                                        "resistor in conductance causality (effort in, flow out) has a singular resistance",
                                        "give it a non-zero resistance, or change the structure so that its flow is imposed", {},
                                        "param.singular"});
          emit_linear(i, flow_class_[b], effort_class_[b], sigma, Eigen::MatrixXd(lu.inverse()),
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
        in.coef = static_cast<int>(sum_terms_.size());
        Definition def{Definition::Kind::kSum, i, {}};
        std::vector<int> in_classes;
        const double s_strong = g.PowerSign(strong, i);
        for (int b : e.bonds) {
          if (b == strong) continue;
          const int c = zero ? flow_class_[b] : effort_class_[b];
          const double sign = -s_strong * g.PowerSign(b, i);
          sum_terms_.push_back(class_offset_[c]);
          sum_signs_.push_back(sign);
          in_classes.push_back(c);
          def.terms.push_back({c, sign, ""});
        }
        in.count = static_cast<int>(in_classes.size());
        emit(in, zero ? flow_class_[strong] : effort_class_[strong], in_classes, def);
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
          eq[0] = forward ? Eq{flow_class_[b2], flow_class_[b1], 0} : Eq{effort_class_[b2], effort_class_[b1], 3};
          eq[1] = forward ? Eq{effort_class_[b1], effort_class_[b2], 1} : Eq{flow_class_[b1], flow_class_[b2], 2};
        } else {
          eq[0] = forward ? Eq{effort_class_[b2], flow_class_[b1], 0} : Eq{flow_class_[b2], effort_class_[b1], 3};
          eq[1] = forward ? Eq{effort_class_[b1], flow_class_[b2], 1} : Eq{flow_class_[b1], effort_class_[b2], 2};
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
  for (int c = 0; c < nclasses; ++c)
    MB_ASSERT(writer[c] >= 0, "slot '" + class_names_[c] + "' has no writer after causality");

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
    int tear = -1;  // the class to tear: a junction's sum if the loop has one (it joins most paths)
    for (int c : cycle) {
      elements.push_back(instrs[c].element);
      for (int cls = 0; cls < nclasses; ++cls)
        if (writer[cls] == c) {
          vars += (vars.empty() ? "" : ", ") + class_names_[cls];
          if (tear < 0 || (instrs[c].op == Op::kSum && instrs[writer[tear]].op != Op::kSum)) tear = cls;
        }
    }
    elements.push_back(elements.front());
    if (options_.solve_algebraic_loops && tear >= 0) {
      torn[tear] = 1;
      algebraic_loops_.push_back({FormatPath(g, elements), class_names_[tear], elements.front(), tear});
      continue;
    }
    Diagnostic d;
    d.where = g.element(elements.front()).where;
    d.element = g.element(elements.front()).name;
    d.code = "causality.algebraic_loop";
    d.message = "algebraic loop: these variables depend on themselves with no storage element in between";
    d.details.push_back("loop: " + FormatPath(g, elements));
    d.details.push_back("variables: " + vars);
    d.hint = "add a storage element in the loop (a small C or I where the physics has one), merge the resistors into "
             "one, or let multibond solve it (algebraic_loops: solve in the model file, --algebraic-loops solve)";
    throw ModelError(d);
  }
  for (int k : order) plan_.push_back(instrs[k]);
  std::vector<int> out_class(ni, -1);  // per instruction: the class it writes
  for (int cls = 0; cls < nclasses; ++cls) out_class[writer[cls]] = cls;
  // Torn variables: the slot of each keeps the unknown; its writer writes to a slot of its own.
  for (int cls = 0; cls < nclasses; ++cls) {
    if (!torn[cls]) continue;
    const int at = static_cast<int>(std::find(order.begin(), order.end(), writer[cls]) - order.begin());
    tears_.push_back({class_offset_[cls], class_size_[cls], num_slots_});
    plan_[at].dst = num_slots_;
    num_slots_ += class_size_[cls];
    num_tear_ += class_size_[cls];
  }
  if (!tears_.empty()) {
    // The instructions that depend on an unknown (through the slots they read, in plan order):
    // the only ones the probes and the last pass of EvalTorn need to run again.
    std::vector<char> reached(torn.begin(), torn.end());
    for (int at = 0; at < ni; ++at) {
      const int k = order[at];
      bool depends = false;
      for (int c : reads[k]) depends = depends || reached[c];
      if (!depends) continue;
      tear_closure_.push_back(at);
      reached[out_class[k]] = 1;
    }
  }
  needed_moduli_ = plan::Specialize(plan_, coef_, sum_terms_, sum_signs_, moduli_);
  BuildGathers();
  {
    std::vector<std::vector<int>> plan_reads;
    std::vector<int> plan_writes;
    for (int k : order) {
      plan_reads.push_back(reads[k]);
      plan_writes.push_back(out_class[k]);
    }
    if (!tears_.empty() && !constraints_.empty()) {
      Diagnostic d;
      d.code = "causality.algebraic_loop";
      d.where = graph_.element(algebraic_loops_.front().element).where;
      d.element = graph_.element(algebraic_loops_.front().element).name;
      d.message = "algebraic loops are not solved in a model with ideal constraints (yet)";
      for (const AlgebraicLoop& loop : algebraic_loops_) d.details.push_back("loop: " + loop.path);
      d.hint = "add a storage element in the loop, or use compliant joints";
      throw ModelError(d);
    }
    BuildConstraints(plan_reads, plan_writes);
    FindIndependentConstraints();
  }
  BuildJacobianPattern();
  if (options_.generate_code && !constraints_.empty()) {
    rhs_engine_ = "interpreter (ideal constraints are solved around the plan)";
    // Every part of a constrained evaluation as generated code, in one library: the plan at zero
    // multipliers (step 1 of CalcConstrained), its tangent (step 2), B's columns and W's
    // L D L^T (step 3) and what the multipliers reach (step 4).
    const JitResult jit = CompileAndLoad(GenerateSource(/*with_fast=*/false) + GenerateColumnsSource() +
                                             (factor_.size() > 0 ? GenerateFactorSource() : "") + GenerateTangentSource() +
                                             GenerateReactSource(),
                                         "multibond_bcols");
    void* factor = jit.symbol && factor_.size() > 0 ? dlsym(jit.library.get(), "multibond_ldlt_factor") : nullptr;
    void* solve = jit.symbol && factor_.size() > 0 ? dlsym(jit.library.get(), "multibond_ldlt_solve") : nullptr;
    void* plan = jit.symbol ? dlsym(jit.library.get(), "multibond_rhs") : nullptr;
    void* tangent = jit.symbol ? dlsym(jit.library.get(), "multibond_tangent") : nullptr;
    void* react = jit.symbol ? dlsym(jit.library.get(), "multibond_react") : nullptr;
    if (jit.symbol && plan && tangent && react && ((factor && solve) || factor_.size() == 0)) {
      generated_factor_ = reinterpret_cast<GeneratedFactor>(factor);
      generated_solve_ = reinterpret_cast<GeneratedSolve>(solve);
      generated_bcols_ = reinterpret_cast<GeneratedColumns>(jit.symbol);
      generated_ = reinterpret_cast<GeneratedRhs>(plan);  // no generated_fast_: CalcStateDerivatives must solve
      generated_tangent_ = reinterpret_cast<GeneratedTangent>(tangent);
      generated_react_ = reinterpret_cast<GeneratedReact>(react);
      generated_constraints_library_ = jit.library;
      rhs_engine_ = "generated code for the plan at zero multipliers, its tangent, the constraint matrix and its L D L^T, "
                    "and what the multipliers reach (" + jit.description + ")";
    } else {
      rhs_engine_ += " (code generation for the constrained evaluation failed: " + jit.description + ")";
    }
  } else if (options_.generate_code && !tears_.empty()) {
    rhs_engine_ = "interpreter (algebraic loops are solved around the plan, which the generated code does not do)";
  } else if (options_.generate_code) {
    const JitResult jit = CompileAndLoad(GenerateSource(), "multibond_rhs");
    void* fast = jit.symbol ? dlsym(jit.library.get(), "multibond_rhs_fast") : nullptr;
    if (jit.symbol && fast) {
      generated_ = reinterpret_cast<GeneratedRhs>(jit.symbol);
      generated_fast_ = reinterpret_cast<GeneratedRhs>(fast);
      generated_library_ = jit.library;
      rhs_engine_ = "generated code (" + jit.description + ")";
    } else {
      rhs_engine_ = "interpreter (code generation failed: " + jit.description + ")";
    }
  }
}

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

bool CompiledModel::has_invariants() const {
  if (!constraints_.empty()) return true;
  for (const StateBlock& b : blocks_)
    if (b.kind == StateBlock::Kind::kOrientation) return true;
  return false;
}

void CompiledModel::Project(double* x) const {
  using Rm3 = Eigen::Matrix<double, 3, 3, Eigen::RowMajor>;
  for (const StateBlock& b : blocks_) {
    if (b.kind != StateBlock::Kind::kOrientation) continue;
    Eigen::Map<Rm3> r(x + b.offset);
    // One Bjorck iteration maps a deviation e = |R^T R - I| to about (3/4) e^2; a second one is
    // only needed when e is not small (a step's drift is below 1e-8 even at loose tolerances).
    for (int k = 0; k < 2; ++k) {
      const Rm3 rtr = r.transpose() * r;
      const bool close = (rtr - Rm3::Identity()).cwiseAbs().maxCoeff() < 1e-6;
      const Rm3 next = 0.5 * r * (3.0 * Rm3::Identity() - rtr);
      r = next;
      if (close) break;
    }
  }
}

Workspace CompiledModel::MakeWorkspace() const {
  Workspace ws;
  ws.slots.assign(num_slots_, 0.0);
  ws.moduli.assign(num_moduli_, 0.0);
  if (num_tear_ > 0) {
    ws.tear.a.setZero(num_tear_, num_tear_);
    ws.tear.c0.setZero(num_tear_);
    ws.tear.z.setZero(num_tear_);
    ws.tear.lu = Eigen::PartialPivLU<Eigen::MatrixXd>(num_tear_);
  }
  if (!constraints_.empty()) {
    const int m = num_lambda_;
    ws.lambda.assign(m, 0.0);
    ws.con.dslots.assign(num_slots_, 0.0);
    ws.con.dmoduli.assign(num_moduli_, 0.0);
    ws.con.lin.assign(num_slots_, 0.0);
    ws.con.xdot.assign(num_states(), 0.0);
    ws.con.b.assign(b_rows_.size(), 0.0);
    ws.con.v.assign(b_rows_.size(), 0.0);
    ws.con.w.assign(static_cast<size_t>(m) * m, 0.0);
    ws.con.rhs.assign(m, 0.0);
    ws.con.scale.assign(m, 0.0);
    ws.con.perm.assign(m, 0);
    ws.con.nullspace.assign(static_cast<size_t>(m) * m, 0.0);
    ws.con.gram.assign(static_cast<size_t>(m) * m, 0.0);
    ws.con.proj.assign(m, 0.0);
    ws.con.weight.assign(m, 0.0);
    ws.con.factor.assign(factor_.values(), 0.0);
    ws.con.y.assign(factor_.size(), 0.0);
    ws.con.factored_at.assign(num_states(), 0.0);
  }
  return ws;
}

Eigen::VectorXd CompiledModel::MakeInitialState() const { return x0_; }

void CompiledModel::EvalModuli(const double* x, double* out, bool derivative) const {
  for (int index : needed_moduli_) {
    const ModulusEval& me = moduli_[index];
    if (derivative && me.kind == Modulus::Kind::kConstant) {
      std::fill(out + me.out, out + me.out + me.rows * me.cols, 0.0);
      continue;
    }
    // Core 3x3 (or constant) factor, then the left selection and the scale.
    Eigen::Matrix3d core;
    if (me.kind != Modulus::Kind::kConstant) {
      const Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> r(x + me.rotation);
      if (me.kind == Modulus::Kind::kRotation) {
        core = me.transpose ? Eigen::Matrix3d(r.transpose()) : Eigen::Matrix3d(r);
      } else {
        const Eigen::Vector3d a = r * me.lever;  // lever arm in the inertial frame
        core << 0, a.z(), -a.y(), -a.z(), 0, a.x(), a.y(), -a.x(), 0;  // -[a x]
      }
    }
    using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
    Eigen::Map<RowMajor> m(out + me.out, me.rows, me.cols);
    if (me.kind == Modulus::Kind::kConstant) {
      // The constant factor has the modulus' columns and as many rows as `left` has columns.
      if (me.left >= 0) {
        const int inner = me.constant_rows;
        m.noalias() = me.scale * Eigen::Map<const RowMajor>(coef_.data() + me.left, me.rows, inner) *
                      Eigen::Map<const RowMajor>(coef_.data() + me.constant, inner, me.cols);
      } else {
        m = me.scale * Eigen::Map<const RowMajor>(coef_.data() + me.constant, me.rows, me.cols);
      }
    } else {
      if (me.right >= 0) core = core * Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(coef_.data() + me.right);
      if (me.left >= 0)
        m.noalias() = me.scale * Eigen::Map<const RowMajor>(coef_.data() + me.left, me.rows, 3) *
                      core.leftCols(me.cols);
      else
        m = me.scale * core.leftCols(me.cols);
    }
    if (me.out_inverse >= 0 && !derivative) {
      Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>> inv(out + me.out_inverse, me.rows, me.cols);
      if (me.kind == Modulus::Kind::kRotation && me.left < 0 && me.right < 0)
        inv = m.transpose() / (me.scale * me.scale);  // a scaled rotation: inverse by transpose
      else if (me.rows == 3 && me.cols == 3) {
        using Rm3 = Eigen::Matrix<double, 3, 3, Eigen::RowMajor>;
        Eigen::Map<Rm3>(out + me.out_inverse) = Eigen::Map<const Rm3>(out + me.out).inverse();
      } else
        inv = m.inverse();
    }
  }
}

namespace {
// The generated code's view of the source functions (see codegen.cc).
double EvalSource(const void* fns, int i, double t) { return static_cast<const TimeFunction*>(fns)[i](t); }
double EvalSourceDerivative(const void* fns, int i, double t) { return static_cast<const TimeFunction*>(fns)[i].Derivative(t); }
}  // namespace

CompiledModel::SourceTable CompiledModel::Sources() const { return {source_fns_.data(), &EvalSource, &EvalSourceDerivative}; }

void CompiledModel::CalcStateDerivatives(double t, const double* x, double* xdot, Workspace& ws) const {
  if (!constraints_.empty()) {
    CalcConstrained(t, x, xdot, ws, /*share=*/false);  // the motion does not depend on the split
    return;
  }
  if (!generated_fast_) {
    CalcDerivatives(t, x, xdot, ws);
    return;
  }
  if (!needed_moduli_.empty()) EvalModuli(x, ws.moduli.data());
  const SourceTable sources = Sources();
  reinterpret_cast<void (*)(double, const double*, double*, const double*, const SourceTable*)>(generated_fast_)(
      t, x, xdot, ws.moduli.data(), &sources);
}


void CompiledModel::CalcDerivatives(double t, const double* x, double* xdot, Workspace& ws) const {
  if (!constraints_.empty()) {
    CalcConstrained(t, x, xdot, ws, /*share=*/true);
    return;
  }
  EvalPlan(t, x, xdot, ws);
}

void CompiledModel::EvalPlan(double t, const double* x, double* xdot, Workspace& ws) const {
  double* w = ws.slots.data();
  double* mod = ws.moduli.data();
  if (!needed_moduli_.empty()) EvalModuli(x, mod);
  if (!tears_.empty()) {
    EvalTorn(t, x, ws);
    for (const Gather& gt : gathers_) EvalGather(gt, x, w, xdot);
    return;
  }
  if (generated_) {
    const SourceTable sources = Sources();
    reinterpret_cast<void (*)(double, const double*, double*, double*, const double*, const SourceTable*)>(generated_)(
        t, x, xdot, w, mod, &sources);
    return;
  }
  const plan::ExecArgs args{t, x, w, w, mod, ws.lambda.data(), tables()};
  for (const Instr& in : plan_) plan::Exec(in, args);
  for (const Gather& gt : gathers_) EvalGather(gt, x, w, xdot);
}

void CompiledModel::EvalTorn(double t, const double* x, Workspace& ws) const {
  double* w = ws.slots.data();
  auto exec = [&](const Instr& in) {
    Exec(in, t, x, w, w, ws.moduli.data(), ws.lambda.data());
  };
  auto run = [&] {
    for (const Instr& in : plan_) exec(in);
  };
  auto run_closure = [&] {  // what depends on the unknowns; every other slot keeps its value
    for (int at : tear_closure_) exec(plan_[at]);
  };
  // Every instruction is linear in the slots it reads, so what the torn variables' writers compute
  // is affine in the unknowns z: c(z) = c0 + A z. One pass of the plan at z = 0 and one of the
  // unknowns' closure per unknown give c0 and A; then (I - A) z = c0, and a last pass of the
  // closure with z makes every slot consistent.
  auto set_unknowns = [&](const double* z) {
    int k = 0;
    for (const Tear& tr : tears_)
      for (int i = 0; i < tr.size; ++i) w[tr.slot + i] = z ? z[k++] : 0.0;
  };
  auto computed = [&](double* out) {
    int k = 0;
    for (const Tear& tr : tears_)
      for (int i = 0; i < tr.size; ++i) out[k++] = w[tr.shadow + i];
  };
  Workspace::TearScratch& s = ws.tear;
  set_unknowns(nullptr);
  run();
  computed(s.c0.data());
  for (int j = 0; j < num_tear_; ++j) {
    // Probed at the scale of the unknown, so that c(probe) - c0 keeps its digits whatever the units.
    const double probe = std::max(1.0, std::abs(s.c0[j]));
    s.z.setZero();
    s.z[j] = probe;
    set_unknowns(s.z.data());
    run_closure();
    computed(s.a.col(j).data());
    s.a.col(j) = (s.a.col(j) - s.c0) / probe;
  }
  s.a = -s.a;
  s.a.diagonal().array() += 1.0;
  s.lu.compute(s.a);
  s.z.noalias() = s.lu.solve(s.c0);
  // A loop whose gain is 1 (I - A singular) has no unique solution: the model is ill-posed there.
  // Judged from U's pivots (no allocation, unlike rcond()); non-finite inputs (a diverging trial
  // state) pass through as they would without a loop, for the integrator to reject.
  if (s.a.allFinite() && s.c0.allFinite()) {
    const auto pivots = s.lu.matrixLU().diagonal().cwiseAbs();
    if (!(pivots.minCoeff() > 1e-13 * std::max(1.0, pivots.maxCoeff()))) {
      std::string names;
      for (const AlgebraicLoop& loop : algebraic_loops_) names += (names.empty() ? "" : ", ") + loop.torn;
      throw std::runtime_error(fmt::format("the algebraic loop through {} has no unique solution at t = {} (its "
                                           "linear system is singular: smallest pivot {:.3g})", names, t, pivots.minCoeff()));
    }
  }
  set_unknowns(s.z.data());
  run_closure();
}

void CompiledModel::EvalGather(const Gather& gt, const double* x, const double* w, double* xdot) {
  double* out = xdot + gt.state;
  switch (gt.kind) {
    case StateBlock::Kind::kMomentum:
    case StateBlock::Kind::kDisplacement:
      for (int k = 0; k < gt.size; ++k) out[k] = gt.sign * w[gt.effort + k];
      break;
    case StateBlock::Kind::kIntegral:
      for (int k = 0; k < gt.size; ++k) out[k] = w[gt.flow + k];
      break;
    case StateBlock::Kind::kOrientation: {
      // dR/dt = [w x] R  (- g (R R^T - I) R: zero on SO(3), pulls a drifting R back). Written out
      // term by term as the generated code is (codegen.cc, EmitGather): the same operations in
      // the same operations in the same order, the same chains (exact_sum.h).
      const double* om = w + gt.flow;
      const double* r = x + gt.state;
      if (gt.sign > 0.0) {
        double s[9] = {0.0, -om[2], om[1], om[2], 0.0, -om[0], -om[1], om[0], 0.0};
        for (int i = 0; i < 3; ++i)
          for (int j = 0; j < 3; ++j) {
            const double rrt = Dot3(r[3 * i], r[3 * j], r[3 * i + 1], r[3 * j + 1], r[3 * i + 2], r[3 * j + 2]);
            s[3 * i + j] = MulAdd(-gt.sign, rrt - (i == j ? 1.0 : 0.0), s[3 * i + j]);
          }
        for (int i = 0; i < 3; ++i)
          for (int j = 0; j < 3; ++j) out[3 * i + j] = Dot3(s[3 * i], r[j], s[3 * i + 1], r[3 + j], s[3 * i + 2], r[6 + j]);
      } else {
        // ([w x] R)_ij = w_{i+1} R_{i+2,j} - w_{i+2} R_{i+1,j}
        for (int i = 0; i < 3; ++i)
          for (int j = 0; j < 3; ++j)
            out[3 * i + j] = MulAdd(-om[(i + 2) % 3], r[3 * ((i + 1) % 3) + j], om[(i + 1) % 3] * r[3 * ((i + 2) % 3) + j]);
      }
      break;
    }
    case StateBlock::Kind::kWork:
    case StateBlock::Kind::kDissipation: {
      double p = kSumStart;
      for (int k = 0; k < gt.size; ++k) p = AddProduct(p, w[gt.effort + k], w[gt.flow + k]);
      out[0] = gt.sign * p;
      break;
    }
  }
}

std::optional<VariableRef> CompiledModel::FindVariable(const std::string& name) const {
  // States by full name of their block ("mass.p", "A.R", "A.r").
  for (const StateBlock& b : blocks_) {
    const std::string& first = state_names_[b.offset];
    std::string base = first;
    if (b.size > 1 || b.kind == StateBlock::Kind::kOrientation) base = first.substr(0, first.rfind('.'));
    if (base == name) {
      VariableRef v{VariableRef::In::kState, b.offset, b.size, state_units_[b.offset], {}};
      for (int k = 0; k < b.size; ++k)
        if (state_names_[b.offset + k] != base) v.components.push_back(state_names_[b.offset + k].substr(base.size() + 1));
      return v;
    }
  }
  const auto dot = name.rfind('.');
  if (dot == std::string::npos) return std::nullopt;
  const std::string owner = name.substr(0, dot), var = name.substr(dot + 1);
  const int e = graph_.Find(owner);
  if (e < 0) {
    // A named bond: "<bond>.e" or "<bond>.f".
    for (int b = 0; b < graph_.num_bonds(); ++b) {
      if (graph_.bond(b).name != owner || (var != "e" && var != "f")) continue;
      const int cls = var == "e" ? effort_class_[b] : flow_class_[b];
      return VariableRef{VariableRef::In::kSlot, class_offset_[cls], class_size_[cls], class_units_[cls],
                         ComponentNames(class_size_[cls])};
    }
    return std::nullopt;
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

double CompiledModel::EnergyOf(const EnergyTerm& et, const double* x) const {
  // 1/2 s^T E s with E = I^-1 or K (row-major in energy_coef_); a body's angular momentum is
  // taken to its frame first (h_b = R^T h), where its inertia is constant. No allocation: these
  // run at every output time.
  const double* s = x + et.state;
  double hb[3];
  if (et.rotation >= 0) {
    const double* r = x + et.rotation;
    for (int i = 0; i < 3; ++i) hb[i] = r[i] * s[0] + r[3 + i] * s[1] + r[6 + i] * s[2];
    s = hb;
  }
  const double* e = energy_coef_.data() + et.coef;
  double sum = 0.0;
  for (int i = 0; i < et.size; ++i) {
    double row = 0.0;
    for (int j = 0; j < et.size; ++j) row += e[i * et.size + j] * s[j];
    sum += s[i] * row;
  }
  return 0.5 * sum;
}

double CompiledModel::StoredEnergy(int element, const double* x) const {
  const int term = energy_term_of_element_.at(element);
  return term < 0 ? 0.0 : EnergyOf(energy_terms_[term], x);
}

CompiledModel::EnergyTotals CompiledModel::StoredEnergies(const double* x, double* per_term) const {
  EnergyTotals t;
  for (size_t k = 0; k < energy_terms_.size(); ++k) {
    const double e = EnergyOf(energy_terms_[k], x);
    per_term[k] = e;
    (energy_terms_[k].kinetic ? t.kinetic : t.potential) += e;
  }
  return t;
}

double CompiledModel::KineticEnergy(const double* x) const {
  double sum = 0.0;
  for (const EnergyTerm& et : energy_terms_)
    if (et.kinetic) sum += EnergyOf(et, x);
  return sum;
}

double CompiledModel::PotentialEnergy(const double* x) const {
  double sum = 0.0;
  for (const EnergyTerm& et : energy_terms_)
    if (!et.kinetic) sum += EnergyOf(et, x);
  return sum;
}

double CompiledModel::Work(const double* x) const {
  double sum = 0.0;
  for (const StateBlock& b : blocks_)
    if (b.kind == StateBlock::Kind::kWork) sum += x[b.offset];
  return sum;
}

double CompiledModel::Dissipated(const double* x) const {
  double sum = 0.0;
  for (const StateBlock& b : blocks_)
    if (b.kind == StateBlock::Kind::kDissipation) sum += x[b.offset];
  return sum;
}

}  // namespace multibond
