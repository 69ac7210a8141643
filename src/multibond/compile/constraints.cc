// Ideal constraints (docs/design.md, "Ideal constraints"): the part of CompiledModel that solves
// for constraint efforts.
//
// A constraint is an effort source of unknown effort lambda (a multiplier). It comes either from
// an Sf marked `constraint` (a rigid joint: zero relative velocity in chosen directions), or from
// cutting the bond of a storage element that the causality analysis put in derivative causality
// (two such sources, one on each side of the cut, sharing lambda). With every multiplier an
// effort source, the graph is integrally causal and the plan is the ordinary one; the constraint
// equations are that each constraint's flows take their prescribed values:
//     g(t, x) = sum_k s_k (f_k - v_k(t)) = 0,
// s_k = +1 if member k's bond points away from it, so that lambda . g is the power the constraint
// delivers. The junction structure conserves power, so g depends on the momenta as B^T M^-1 p,
// where B (momentum rate per unit multiplier) is read off the plan. At every evaluation:
//   1. the plan at lambda = 0 gives dx/dt;
//   2. a tangent pass (the time derivative along dx/dt, with dR/dt for the moduli, of every slot
//      the constraints' flows depend on) gives dg/dt at lambda = 0;
//   3. W = B^T M^-1 B, and W lambda = dv/dt - dg/dt|lambda=0 makes dg/dt = 0 (index reduction to
//      the acceleration level, exactly: no finite differences), by a sparse L D L^T;
//   4. what the multipliers reach, again with lambda: dx/dt and every effort, reactions included.
// Drift of g (the velocity-level constraint) is removed after every step by Project(t, x, ws).

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "multibond/causality/repair.h"
#include "multibond/compile/compiled_model.h"
#include "multibond/compile/exact_sum.h"

namespace multibond {

void CompiledModel::PrepareConstraintGraph() {
  BondGraph& g = graph_;
  struct Pending {
    std::string name;
    int element;
    std::vector<int> members;
    bool target;
  };
  std::vector<Pending> pending;
  // Rigid joints and other explicit constraints: the Sf becomes the multiplier's effort source
  // (the same view `check` analyses, causality/repair.h).
  g = CausalView(g);
  for (int i = 0; i < g.num_elements(); ++i)
    if (g.element(i).constraint) pending.push_back({g.element(i).name, i, {i}, true});
  for (;;) {
    DiagnosticSink sink;
    structure_ = AnalyzeStructure(g, options_.default_domain, sink);
    sink.ThrowIfErrors();
    causality_ = AssignCausality(g, structure_);
    if (!options_.ideal_constraints || causality_.derivative.empty()) break;
    // Cut the bond of the first inertia in derivative causality, then analyse again: one cut can
    // free others (a chain of rigidly joined inertias needs one cut per joint, not per inertia).
    int d = -1;
    for (int el : causality_.derivative)
      if (g.element(el).kind == ElementKind::kI && g.element(el).bonds.size() == 1) {
        d = el;
        break;
      }
    if (d < 0) break;  // a C in derivative causality: reported below
    const int b = g.element(d).bonds.front();
    const int other = g.Other(b, d);
    const bool into_storage = g.bond(b).to == d;
    const std::string base = g.element(d).name + ".cut";
    Element a;
    a.name = base;
    a.kind = ElementKind::kSe;
    a.constraint = true;
    a.where = g.element(d).where;
    a.domain = g.element(d).domain;
    a.source.components = {TimeFunction::Constant(0.0)};  // no prescribed flow: the two sides agree
    Element r = a;
    r.name = base + ".rest";
    const int ia = g.Add(a), ir = g.Add(r);
    // The storage element keeps bond b (now to or from `a`); `other` gets a new bond to `r` in the
    // same direction as before, at the same place in its list of bonds (ports keep their order).
    Bond nb = g.bond(b);
    if (into_storage) {
      g.bond(b).from = ia;
      nb.to = ir;
      nb.name = fmt::format("{}->{}", g.element(other).name, r.name);
    } else {
      g.bond(b).to = ia;
      nb.from = ir;
      nb.name = fmt::format("{}->{}", r.name, g.element(other).name);
    }
    g.element(ia).bonds = {b};
    const int nbi = g.AppendBond(nb);
    g.element(ir).bonds = {nbi};
    std::replace(g.element(other).bonds.begin(), g.element(other).bonds.end(), b, nbi);
    pending.push_back({base, d, {ia, ir}, false});
  }
  if (causality_.has_errors()) {
    if (!causality_.derivative.empty() && !options_.ideal_constraints)
      for (Diagnostic& dg : causality_.diagnostics)
        if (dg.code == "causality.derivative")
          dg.details.push_back("or keep the ideal mechanism: run with --constraints ideal (or 'constraints: ideal' at the top "
                               "of the model file) and the dependent storage is handled exactly by constraint efforts");
    throw ModelError(causality_.diagnostics);
  }
  for (const Pending& p : pending) {
    ConstraintGroup cg;
    cg.name = p.name;
    cg.element = p.element;
    for (int m : p.members) {
      const int b = g.element(m).bonds.front();
      cg.members.push_back({b, g.bond(b).from == m ? 1.0 : -1.0, p.target ? 0 : -1});
    }
    constraints_.push_back(std::move(cg));
  }
}

void CompiledModel::BuildConstraints(const std::vector<std::vector<int>>& plan_reads, const std::vector<int>& plan_writes) {
  if (constraints_.empty()) return;
  const BondGraph& g = graph_;
  const int np = static_cast<int>(plan_.size());
  // Members: bond -> flow slot; targets -> source functions.
  for (ConstraintGroup& cg : constraints_) {
    for (auto& m : cg.members) {
      const int bond = m.flow;
      m.flow = class_offset_[flow_class_[bond]];
      if (m.source_fn == 0) {
        const Element& e = g.element(cg.element);
        m.source_fn = static_cast<int>(source_fns_.size());
        for (int k = 0; k < cg.size; ++k)
          source_fns_.push_back(e.source.components.empty() ? TimeFunction::Constant(0.0)
                                : e.source.components.size() == 1 ? e.source.components[0] : e.source.components[k]);
      }
    }
  }
  // The couplings' compliances, when every constraint declares one (ShareRedundantEfforts).
  lambda_compliance_.clear();
  bool all_compliant = true;
  for (const ConstraintGroup& cg : constraints_) all_compliant &= g.element(cg.element).compliance.size() > 0;
  if (all_compliant)
    for (const ConstraintGroup& cg : constraints_) {
      const Element& e = g.element(cg.element);
      if (e.compliance.size() != 1 && e.compliance.size() != cg.size)
        throw ModelError(Diagnostic{Diagnostic::Severity::kError, e.where, e.name,
                                    fmt::format("the constraint has {} components but {} compliances", cg.size, e.compliance.size()),
                                    "give one compliance, or one per component", {}, "param.shape"});
      for (int k = 0; k < cg.size; ++k) lambda_compliance_.push_back(e.compliance[e.compliance.size() == 1 ? 0 : k]);
    }
  // The momentum gathers and the instruction that computes each inertia's flow.
  std::vector<int> flow_instr_of_element(g.num_elements(), -1);
  for (int k = 0; k < np; ++k) {
    const Op op = plan_[k].op;
    if (plan::Traits(op).reads == plan::Reads::kState)
      if (g.element(plan_[k].element).kind == ElementKind::kI) flow_instr_of_element[plan_[k].element] = k;
  }
  flow_instr_of_block_.assign(gathers_.size(), -1);
  for (size_t gi = 0; gi < gathers_.size(); ++gi)
    if (gathers_[gi].kind == StateBlock::Kind::kMomentum) flow_instr_of_block_[gi] = flow_instr_of_element[blocks_[gi].owner];

  std::vector<char> member_flow(num_slots_, 0), other_rate(num_slots_, 0);
  for (const ConstraintGroup& cg : constraints_)
    for (const auto& m : cg.members)
      for (int k = 0; k < cg.size; ++k) member_flow[m.flow + k] = 1;
  for (const Gather& gt : gathers_) {
    if (gt.kind == StateBlock::Kind::kOrientation || gt.kind == StateBlock::Kind::kIntegral)
      for (int k = 0; k < (gt.kind == StateBlock::Kind::kOrientation ? 3 : gt.size); ++k) other_rate[gt.flow + k] = 1;
    if (gt.kind == StateBlock::Kind::kDisplacement)
      for (int k = 0; k < gt.size; ++k) other_rate[gt.effort + k] = 1;
  }

  b_offset_.clear();
  b_rows_.clear();
  for (ConstraintGroup& cg : constraints_) {
    // The multiplier's instructions (two for a cut), then every instruction reading what they reach.
    std::vector<char> reached(num_slot_classes(), 0);
    cg.starts.clear();
    for (int k = 0; k < np; ++k)
      if (plan_[k].op == Op::kMultiplier && plan_[k].coef == cg.lambda) {
        cg.starts.push_back(k);
        reached[plan_writes[k]] = 1;
      }
    MB_ASSERT(!cg.starts.empty(), "constraint without its multiplier instruction");
    cg.closure.clear();
    for (int k = 0; k < np; ++k)
      for (int c : plan_reads[k])
        if (reached[c]) {
          reached[plan_writes[k]] = 1;
          cg.closure.push_back(k);
          break;
        }
    for (int c = 0; c < num_slot_classes(); ++c) {
      if (!reached[c]) continue;
      bool bad = false;
      for (int k = 0; k < class_size_[c]; ++k) bad |= member_flow[class_offset_[c] + k] || other_rate[class_offset_[c] + k];
      if (bad) {
        const Element& e = g.element(cg.element);
        throw ModelError(Diagnostic{
            Diagnostic::Severity::kError, e.where, e.name,
            fmt::format("the ideal constraint '{}' changes the flow '{}' through a resistor or gyrator: a constraint whose "
                        "flows depend on its own effort is not supported", cg.name, class_names_[c]),
            "make this coupling compliant (a C and an R instead of the constraint)", {}, "constraint.unsupported"});
      }
    }
    for (size_t gi = 0; gi < gathers_.size(); ++gi)
      if (gathers_[gi].kind == StateBlock::Kind::kMomentum)
        for (int c = 0; c < num_slot_classes(); ++c)
          if (reached[c] && class_offset_[c] == gathers_[gi].effort) cg.momenta.push_back(static_cast<int>(gi));
    for (int k = 0; k < cg.size; ++k) {
      b_offset_.push_back(static_cast<int>(b_rows_.size()));
      for (int gi : cg.momenta)
        for (int r = 0; r < gathers_[gi].size; ++r) b_rows_.push_back(gathers_[gi].state + r);
    }
  }
  b_offset_.push_back(static_cast<int>(b_rows_.size()));
  // What the multipliers reach, all constraints together: the second pass of an evaluation (with
  // lambda) re-runs only these instructions and gathers; every other slot keeps its value from
  // the pass at lambda = 0, which is what a full pass would compute again.
  std::vector<char> in_reaction(np, 0), reached_slot(num_slots_, 0);
  for (const ConstraintGroup& cg : constraints_) {
    for (int k : cg.starts) in_reaction[k] = 1;
    for (int k : cg.closure) in_reaction[k] = 1;
  }
  reaction_plan_.clear();
  for (int k = 0; k < np; ++k)
    if (in_reaction[k]) {
      reaction_plan_.push_back(k);
      const int c = plan_writes[k];
      std::fill(reached_slot.begin() + class_offset_[c], reached_slot.begin() + class_offset_[c] + class_size_[c], 1);
    }
  // The tangent pass is read only at the constraints' flows: it runs the instructions those flows
  // depend on (the flow side of the plan), not the efforts that only feed momentum rates.
  std::vector<char> feeds_flow(num_slot_classes(), 0);
  for (const ConstraintGroup& cg : constraints_)
    for (const auto& m : cg.members)
      for (int c = 0; c < num_slot_classes(); ++c)
        if (class_offset_[c] <= m.flow && m.flow < class_offset_[c] + class_size_[c]) feeds_flow[c] = 1;
  tangent_plan_.clear();
  for (int k = np - 1; k >= 0; --k)
    if (feeds_flow[plan_writes[k]]) {
      tangent_plan_.push_back(k);
      for (int c : plan_reads[k]) feeds_flow[c] = 1;
    }
  std::reverse(tangent_plan_.begin(), tangent_plan_.end());
  reaction_gathers_.clear();
  for (size_t gi = 0; gi < gathers_.size(); ++gi) {
    const Gather& gt = gathers_[gi];
    const bool effort = gt.kind == StateBlock::Kind::kMomentum || gt.kind == StateBlock::Kind::kDisplacement ||
                        gt.kind == StateBlock::Kind::kWork || gt.kind == StateBlock::Kind::kDissipation;
    const bool flow = gt.kind != StateBlock::Kind::kMomentum && gt.kind != StateBlock::Kind::kDisplacement;
    bool reads_reached = false;
    for (int k = 0; k < (gt.kind == StateBlock::Kind::kOrientation ? 3 : gt.size); ++k)
      reads_reached |= (effort && reached_slot[gt.effort + k]) || (flow && reached_slot[gt.flow + k]);
    if (reads_reached) reaction_gathers_.push_back(static_cast<int>(gi));
  }
  // The nonzeros of W = B^T M^-1 B: the pairs of columns that share momentum rows, with the
  // positions of the shared rows in their compressed columns (rows are sorted within a column).
  w_pairs_.clear();
  w_terms_.clear();
  for (int i = 0; i < num_lambda_; ++i)
    for (int j = 0; j <= i; ++j) {
      const int first = static_cast<int>(w_terms_.size());
      int p = b_offset_[i], q = b_offset_[j];
      while (p < b_offset_[i + 1] && q < b_offset_[j + 1]) {
        if (b_rows_[p] < b_rows_[q]) ++p;
        else if (b_rows_[p] > b_rows_[q]) ++q;
        else w_terms_.push_back({p++, q++});
      }
      if (static_cast<int>(w_terms_.size()) > first) w_pairs_.push_back({i, j, first, static_cast<int>(w_terms_.size())});
    }
}

std::vector<std::string> CompiledModel::constraint_names() const {
  std::vector<std::string> out;
  for (const ConstraintGroup& cg : constraints_) out.push_back(cg.name);
  return out;
}

void CompiledModel::ConstraintValues(double t, const double* w, double* out) const {
  for (const ConstraintGroup& cg : constraints_)
    for (int k = 0; k < cg.size; ++k) {
      double v = 0.0;
      for (const auto& m : cg.members) v += m.sign * (w[m.flow + k] - (m.source_fn >= 0 ? source_fns_[m.source_fn + k](t) : 0.0));
      out[cg.lambda + k] = v;
    }
}

void CompiledModel::Tangent(double t, const double* x, const double* xdot, Workspace& ws) const {
  const double* w = ws.slots.data();
  double* d = ws.con.dslots.data();
  double* tmp = ws.con.lin.data();  // scratch for second terms; restored to zero below
  const double* mod = ws.moduli.data();
  double* dmod = ws.con.dmoduli.data();
  if (!needed_moduli_.empty()) EvalModuli(xdot, dmod, true);
  if (generated_tangent_) {
    const SourceTable sources = Sources();
    generated_tangent_(t, x, xdot, w, d, mod, dmod, &sources);
    return;
  }
  const double* c = coef_.data();
  const double* lam = ws.lambda.data();
  auto exec = [&](const Instr& in, const double* xs, const double* win, double* wout, const double* m) {
    Exec(in, t, xs, win, wout, m, lam);
  };
  auto add_tmp = [&](const Instr& in) {
    for (int k = 0; k < in.n; ++k) {
      d[in.dst + k] += tmp[in.dst + k];
      tmp[in.dst + k] = 0.0;
    }
  };
  for (int index : tangent_plan_) {
    const Instr& in = plan_[index];
    switch (plan::Traits(in.op).tangent) {
      case plan::Tangent::kSourceRate:
        for (int k = 0; k < in.n; ++k) d[in.dst + k] = source_fns_[in.coef + k].Derivative(t);
        break;
      case plan::Tangent::kZero:
        for (int k = 0; k < in.n; ++k) d[in.dst + k] = 0.0;  // efforts only: never reaches a constraint's flow
        break;
      case plan::Tangent::kStateRate:
        exec(in, xdot, d, d, mod);
        break;
      case plan::Tangent::kRotatedInertia: {
        // f = R Ib^-1 R^T h  ->  df = dR a + R Ib^-1 (dR^T h + R^T dh),  a = Ib^-1 R^T h; written
        // out term by term in the generated code's order (GenerateTangentSource).
        const double *r = x + in.aux, *rd = xdot + in.aux, *h = x + in.src, *hd = xdot + in.src;
        auto ib = [&](int i, int j) {
          return in.op == Op::kIFlowRotatedDiag ? (i == j ? c[in.coef + i] : 0.0) : c[in.coef + 3 * i + j];
        };
        double hb[3], dhb[3], a[3], da[3];
        for (int i = 0; i < 3; ++i) {
          hb[i] = Dot3(r[i], h[0], r[3 + i], h[1], r[6 + i], h[2]);
          dhb[i] = kSumStart;
          for (int k = 0; k < 3; ++k) dhb[i] = AddProduct(dhb[i], rd[3 * k + i], h[k]);
          for (int k = 0; k < 3; ++k) dhb[i] = AddProduct(dhb[i], r[3 * k + i], hd[k]);
        }
        for (int i = 0; i < 3; ++i) {
          a[i] = AddTerm(AddTerm(AddTerm(kSumStart, ib(i, 0), hb[0]), ib(i, 1), hb[1]), ib(i, 2), hb[2]);
          da[i] = AddTerm(AddTerm(AddTerm(kSumStart, ib(i, 0), dhb[0]), ib(i, 1), dhb[1]), ib(i, 2), dhb[2]);
        }
        for (int i = 0; i < 3; ++i) {
          double s = kSumStart;
          for (int k = 0; k < 3; ++k) s = AddProduct(s, rd[3 * i + k], a[k]);
          for (int k = 0; k < 3; ++k) s = AddProduct(s, r[3 * i + k], da[k]);
          d[in.dst + i] = s;
        }
        break;
      }
      case plan::Tangent::kBilinear:
        // Bilinear in R and the input: d(K(R) u) = K(R) du + K(dR) u.
        exec(in, x, d, d, mod);
        exec(in, xdot, w, tmp, mod);
        add_tmp(in);
        break;
      case plan::Tangent::kModulated: {
        if (in.count <= 1) {
          exec(in, x, d, d, mod);
          exec(in, x, w, tmp, dmod);
          add_tmp(in);
        } else {
          // y = M^-1 u (mode 2) or M^-T u (mode 3): dy = M^-1 (du - dM y) (or transposed).
          const ModulusEval& me = moduli_[in.modulus];
          const double* dm = dmod + me.out;
          const double* y = w + in.dst;
          double z[16];
          MB_ASSERT(in.m <= 16, "modulated inverse larger than 16");
          for (int r = 0; r < in.m; ++r) {
            double s = d[in.src + r];
            for (int k = 0; k < in.n; ++k) s = AddProduct(s, -(in.count == 2 ? dm[r * in.n + k] : dm[k * in.m + r]), y[k]);
            z[r] = s;
          }
          const double* a = mod + in.coef;
          for (int r = 0; r < in.n; ++r) {
            double s = kSumStart;
            for (int k = 0; k < in.m; ++k) s = AddProduct(s, in.count == 2 ? a[r * in.m + k] : a[k * in.n + r], z[k]);
            d[in.dst + r] = s;
          }
        }
        break;
      }
      case plan::Tangent::kLinear:  // constant linear maps of slots: the same map of their derivatives
        exec(in, x, d, d, mod);
        break;
      case plan::Tangent::kNone:  // formulas: refused with constraints (CheckFormulaUse)
        MB_ASSERT(false, "a formula in the constraints' tangent pass");
        break;
    }
  }
}

void CompiledModel::AssembleConstraintMatrix(double t, const double* x, Workspace& ws) const {
  if (generated_bcols_) {
    generated_bcols_(x, ws.con.lin.data(), ws.moduli.data(), ws.con.b.data(), ws.con.v.data());
    return;
  }
  double* lin = ws.con.lin.data();
  double* b = ws.con.b.data();
  double* v = ws.con.v.data();
  const double* mod = ws.moduli.data();
  const double* c = coef_.data();
  const double* lam = ws.lambda.data();
  // B, column by column: a unit multiplier through its closure (everything else is zero in lin).
  for (const ConstraintGroup& cg : constraints_) {
    for (int k = 0; k < cg.size; ++k) {
      const int col = cg.lambda + k;
      for (int st : cg.starts)
        for (int j = 0; j < cg.size; ++j) lin[plan_[st].dst + j] = j == k ? 1.0 : 0.0;
      for (int q : cg.closure)
        Exec(plan_[q], t, x, lin, lin, mod, lam);
      double* bc = b + b_offset_[col];
      double* vc = v + b_offset_[col];
      for (int gi : cg.momenta) {
        const Gather& gt = gathers_[gi];
        for (int r = 0; r < gt.size; ++r) bc[r] = gt.sign * lin[gt.effort + r];
        const Instr& flow = plan_[flow_instr_of_block_[gi]];  // f = M^-1 p, applied to p = bc
        plan::Traits(flow.op).state(flow, c, x + flow.aux, bc, vc);
        bc += gt.size;
        vc += gt.size;
      }
      for (int q : cg.closure) std::fill(lin + plan_[q].dst, lin + plan_[q].dst + plan_[q].n, 0.0);
      for (int st : cg.starts) std::fill(lin + plan_[st].dst, lin + plan_[st].dst + cg.size, 0.0);
    }
  }
}

void CompiledModel::FormFullW(Workspace& ws) const {
  // W = B^T M^-1 B over the rows the two columns share (precomputed pairs).
  const int m = num_lambda_;
  const double* b = ws.con.b.data();
  const double* v = ws.con.v.data();
  double* wm = ws.con.w.data();
  std::fill(ws.con.w.begin(), ws.con.w.end(), 0.0);
  for (const WPair& pr : w_pairs_) wm[pr.i * m + pr.j] = wm[pr.j * m + pr.i] = WEntry(pr, b, v);
}

double CompiledModel::WEntry(const WPair& pr, const double* b, const double* v) const {
  double sum = 0.0;
  for (int k = pr.begin; k < pr.end; ++k) sum += b[w_terms_[k].first] * v[w_terms_[k].second];
  return sum;
}

bool CompiledModel::FactorIndependent(Workspace& ws) const {
  // The constraints found independent at t = 0 (redundant ones get zero effort): W restricted to
  // them is positive definite, and L D L^T solves it without pivoting, in the sparse pattern fixed
  // at compile time (FindIndependentConstraints). A configuration where they stop being
  // independent (a pivot below 1e-10 of W's diagonal entry: the square of the 1e-5 that Cholesky's
  // diagonal would be checked against) falls back to the pivoted solve.
  if (generated_factor_) return generated_factor_(ws.con.b.data(), ws.con.v.data(), ws.con.factor.data()) != 0;
  const IndependentFactor& f = factor_;
  const int n = f.size(), ne = f.entries();
  const double* b = ws.con.b.data();
  const double* v = ws.con.v.data();
  double* d = ws.con.factor.data();  // W's diagonal, then D^-1 (row by row); then L; then L D
  double* l = d + n;
  double* ld = l + ne;
  // W's nonzeros straight into their places in the factor; fill-in starts at zero.
  std::fill(ws.con.factor.begin(), ws.con.factor.end(), 0.0);
  for (const IndependentFactor::Dot& e : f.w3)
    d[e.target] += Dot3(b[e.a], v[e.b], b[e.a + 1], v[e.b + 1], b[e.a + 2], v[e.b + 2]);
  for (const IndependentFactor::Dot& e : f.w1) d[e.target] = MulAdd(b[e.a], v[e.b], d[e.target]);
  // Crout's L D L^T, row by row: (L D)(i, j) = W(i, j) - sum_{k < j} L(i, k) (L D)(j, k), then
  // L(i, j) = (L D)(i, j) / d_j and d_i = W(i, i) - sum_{k < i} L(i, k) (L D)(i, k). Each entry is
  // a dot product accumulated in a register over the precomputed common columns (the
  // column-by-column form scatters its updates into a work vector, which chains them through
  // memory: measured slower here). Sums of products are chains as everywhere (exact_sum.h), in
  // the order of the generated factorisation (GenerateFactorSource).
  for (int i = 0; i < n; ++i) {
    double di = d[i];
    for (int e = f.row_offset[i]; e < f.row_offset[i + 1]; ++e) {
      double c = l[e];
      for (int t = f.l3_offset[e]; t < f.l3_offset[e + 1]; ++t) {
        const IndependentFactor::Dot& u = f.l3[t];
        c -= Dot3(l[u.a], ld[u.b], l[u.a + 1], ld[u.b + 1], l[u.a + 2], ld[u.b + 2]);
      }
      for (int t = f.l1_offset[e]; t < f.l1_offset[e + 1]; ++t) c = MulAdd(-l[f.l1[t].a], ld[f.l1[t].b], c);
      ld[e] = c;
      l[e] = c * d[f.cols[e]];  // the next entries wait for this one: a product, not a division
      di = MulAdd(-l[e], c, di);
    }
    if (!(di > 1e-10 * d[i])) return false;  // not positive definite here, or nearly dependent
    d[i] = 1.0 / di;  // from here on, d holds D^-1
  }
  return true;
}

void CompiledModel::SolveFactored(Workspace& ws) const { SolveFactored(ws.con.rhs.data(), ws.lambda.data(), ws); }

void CompiledModel::SolveFactored(const double* rhs, double* out, Workspace& ws) const {
  if (generated_solve_) {
    generated_solve_(rhs, out, ws.con.factor.data(), ws.con.y.data());
    return;
  }
  // L D L^T y = rhs (in the factor's order), then back to the multipliers.
  const IndependentFactor& f = factor_;
  const int n = f.size();
  const double* d = ws.con.factor.data();
  const double* l = d + n;
  double* y = ws.con.y.data();
  for (int i = 0; i < n; ++i) {
    double s = rhs[f.multiplier[i]];
    for (int e = f.row_offset[i]; e < f.row_offset[i + 1]; ++e) s = MulAdd(-l[e], y[f.cols[e]], s);
    y[i] = s;
  }
  for (int i = 0; i < n; ++i) y[i] *= d[i];
  for (int i = n - 1; i >= 0; --i)
    for (int e = f.row_offset[i]; e < f.row_offset[i + 1]; ++e) y[f.cols[e]] = MulAdd(-l[e], y[i], y[f.cols[e]]);
  std::fill(out, out + num_lambda_, 0.0);
  for (int i = 0; i < n; ++i) out[f.multiplier[i]] = y[i];
}

void CompiledModel::ShareRedundantEfforts(Workspace& ws) const {
  const int m = num_lambda_;
  double* nsp = ws.con.nullspace.data();  // column k: nsp[k * m ..]
  double* c = ws.con.weight.data();
  int d = 0;  // null vectors found
  if (ws.con.factored) {
    // The independent set of t = 0 (factor_): each redundant multiplier j has b_j = B_I c_j with
    // W_II c_j = W_Ij (the factor solves it), so n_j = e_j - c_j moves nothing (B n_j = 0).
    if (dependent_.empty()) return;
    const double* b = ws.con.b.data();
    const double* v = ws.con.v.data();
    double* wm = ws.con.w.data();  // only the redundant multipliers' rows are used here
    for (int j : dependent_) std::fill(wm + static_cast<size_t>(j) * m, wm + static_cast<size_t>(j + 1) * m, 0.0);
    std::fill(c, c + m, 0.0);
    for (int k : share_pairs_) {
      const WPair& pr = w_pairs_[k];
      const double sum = WEntry(pr, b, v);
      wm[pr.i * m + pr.j] = wm[pr.j * m + pr.i] = sum;
      if (pr.i == pr.j) c[pr.i] = sum;  // W_ii
    }
    for (int j : dependent_) {
      if (!(c[j] > 0.0)) continue;  // a constraint that acts on nothing: its effort stays 0
      double* n = nsp + static_cast<size_t>(d) * m;
      SolveFactored(wm + static_cast<size_t>(j) * m, n, ws);  // W's row j = its column j
      // Redundant here too? b_j's part outside span(B_I) is W_jj - W_jI c_j (a Schur complement);
      // if it is not ~0, n_j would move something: the split is then left as the solve made it.
      double schur = c[j];
      for (int i = 0; i < m; ++i) schur -= wm[static_cast<size_t>(j) * m + i] * n[i];
      if (schur > 1e-8 * c[j]) continue;
      for (int i = 0; i < m; ++i) n[i] = -n[i];
      n[j] = 1.0;
      ++d;
    }
  } else {
    // After SolvePivoted: w holds L D L^T of the scaled, permuted W, whose first `rank` pivots
    // are independent. For a redundant position r, W_II c = W_Ir gives (in scaled form)
    // c = L_II^-T L_rI^T: one back substitution on L's row r. Unscaled: n = S (e_r - c).
    const int rank = ws.con.rank;
    if (rank == m) return;
    const double* a = ws.con.w.data();
    const double* s = ws.con.scale.data();
    const int* perm = ws.con.perm.data();
    for (int i = 0; i < m; ++i) c[i] = s[i] > 0.0 ? 1.0 / (s[i] * s[i]) : 0.0;  // W_ii
    for (int r = rank; r < m; ++r) {
      if (!(s[perm[r]] > 0.0)) continue;  // a constraint that acts on nothing: its effort stays 0
      double* n = nsp + static_cast<size_t>(d) * m;
      std::fill(n, n + m, 0.0);
      double* y = ws.con.proj.data();  // c in the factor's order, positions 0..rank
      for (int k = rank - 1; k >= 0; --k) {
        double sum = a[r * m + k];
        for (int i = k + 1; i < rank; ++i) sum -= a[i * m + k] * y[i];
        y[k] = sum;
      }
      for (int k = 0; k < rank; ++k) n[perm[k]] = -y[k] * s[perm[k]];
      n[perm[r]] = s[perm[r]];
      ++d;
    }
  }
  if (d == 0) return;
  if (!lambda_compliance_.empty()) std::copy(lambda_compliance_.begin(), lambda_compliance_.end(), c);
  // min over alpha of sum_i c_i (lambda + N alpha)_i^2: (N^T C N) alpha = -N^T C lambda, by
  // Cholesky (N's columns are independent: each has a 1 where the others have 0).
  double* g = ws.con.gram.data();
  double* rhs = ws.con.proj.data();
  const double* lam = ws.lambda.data();
  for (int p = 0; p < d; ++p) {
    const double* np = nsp + static_cast<size_t>(p) * m;
    double r = 0.0;
    for (int i = 0; i < m; ++i) r -= c[i] * np[i] * lam[i];
    rhs[p] = r;
    for (int q = 0; q <= p; ++q) {
      const double* nq = nsp + static_cast<size_t>(q) * m;
      double sum = 0.0;
      for (int i = 0; i < m; ++i) sum += c[i] * np[i] * nq[i];
      g[p * d + q] = sum;
    }
  }
  for (int p = 0; p < d; ++p) {
    for (int q = 0; q < p; ++q) {
      double sum = g[p * d + q];
      for (int k = 0; k < q; ++k) sum -= g[p * d + k] * g[q * d + k];
      g[p * d + q] = sum / g[q * d + q];
    }
    double diag = g[p * d + p];
    for (int k = 0; k < p; ++k) diag -= g[p * d + k] * g[p * d + k];
    if (!(diag > 0.0)) return;  // cannot happen with positive weights; keep the solve's own split
    g[p * d + p] = std::sqrt(diag);
  }
  for (int p = 0; p < d; ++p) {
    for (int k = 0; k < p; ++k) rhs[p] -= g[p * d + k] * rhs[k];
    rhs[p] /= g[p * d + p];
  }
  for (int p = d - 1; p >= 0; --p) {
    for (int k = p + 1; k < d; ++k) rhs[p] -= g[k * d + p] * rhs[k];
    rhs[p] /= g[p * d + p];
  }
  for (int p = 0; p < d; ++p) {
    const double* np = nsp + static_cast<size_t>(p) * m;
    for (int i = 0; i < m; ++i) ws.lambda[i] += rhs[p] * np[i];
  }
}

void CompiledModel::SolveConstraintsAt(double t, const double* x, Workspace& ws) const {
  const int n = num_states();
  if (ws.con.factored && t == ws.con.factored_t && std::equal(x, x + n, ws.con.factored_at.begin())) {
    SolveFactored(ws);
    return;
  }
  AssembleConstraintMatrix(t, x, ws);
  ws.con.factored = factor_.size() > 0 && FactorIndependent(ws);
  if (ws.con.factored) {
    SolveFactored(ws);
    std::copy(x, x + n, ws.con.factored_at.begin());
    ws.con.factored_t = t;
    return;
  }
  FormFullW(ws);
  SolvePivoted(ws);
}

void CompiledModel::SolvePivoted(Workspace& ws) const {
  const int m = num_lambda_;
  double* a = ws.con.w.data();
  double* y = ws.con.rhs.data();
  double* s = ws.con.scale.data();
  int* perm = ws.con.perm.data();
  // Jacobi scaling: unit diagonal, so that force and moment constraints compare.
  for (int i = 0; i < m; ++i) s[i] = a[i * m + i] > 0.0 ? 1.0 / std::sqrt(a[i * m + i]) : 0.0;
  for (int i = 0; i < m; ++i) {
    for (int j = 0; j < m; ++j) a[i * m + j] *= s[i] * s[j];
    y[i] *= s[i];
    perm[i] = i;
  }
  // LDL^T with diagonal pivoting (W is symmetric positive semi-definite). Pivots below 1e-11 of
  // the unit diagonal belong to redundant constraints: their multipliers are set to zero.
  constexpr double kTol = 1e-11;
  int rank = 0;
  for (int k = 0; k < m; ++k) {
    int p = k;
    for (int i = k + 1; i < m; ++i)
      if (a[i * m + i] > a[p * m + p]) p = i;
    if (!(a[p * m + p] > kTol)) break;
    if (p != k) {
      for (int j = 0; j < m; ++j) std::swap(a[k * m + j], a[p * m + j]);
      for (int i = 0; i < m; ++i) std::swap(a[i * m + k], a[i * m + p]);
      std::swap(perm[k], perm[p]);
      std::swap(y[k], y[p]);
    }
    const double dk = a[k * m + k];
    // The trailing block is kept whole (both triangles) so that later symmetric swaps stay exact.
    for (int i = k + 1; i < m; ++i) {
      const double lik = a[i * m + k] / dk;
      if (lik == 0.0) continue;
      for (int j = k + 1; j < m; ++j) a[i * m + j] -= lik * a[k * m + j];
    }
    for (int i = k + 1; i < m; ++i) a[i * m + k] /= dk;
    ++rank;
  }
  // Solve L D L^T z = y on the first `rank` (pivoted) unknowns; the rest are zero.
  for (int i = 0; i < rank; ++i)
    for (int j = 0; j < i; ++j) y[i] -= a[i * m + j] * y[j];
  for (int i = 0; i < rank; ++i) y[i] /= a[i * m + i];
  for (int i = rank - 1; i >= 0; --i)
    for (int j = i + 1; j < rank; ++j) y[i] -= a[j * m + i] * y[j];
  for (int i = rank; i < m; ++i) y[i] = 0.0;
  // Undo the permutation and the scaling (lambda written to ws.lambda).
  for (int i = 0; i < m; ++i) ws.lambda[perm[i]] = y[i] * s[perm[i]];
  ws.con.rank = rank;
}

void CompiledModel::FindIndependentConstraints() {
  factor_ = IndependentFactor{};
  if (constraints_.empty()) return;
  // At the initial state: the pivoted factorisation's first `rank` pivots are an independent set.
  Workspace ws = MakeWorkspace();
  std::vector<double> xdot(num_states());
  EvalPlan(0.0, x0_.data(), xdot.data(), ws);
  AssembleConstraintMatrix(0.0, x0_.data(), ws);
  FormFullW(ws);
  std::fill(ws.con.rhs.begin(), ws.con.rhs.end(), 0.0);
  SolvePivoted(ws);
  std::vector<int> independent(ws.con.perm.begin(), ws.con.perm.begin() + ws.con.rank);
  std::sort(independent.begin(), independent.end());
  dependent_.clear();
  share_pairs_.clear();
  for (int j = 0; j < num_lambda_; ++j)
    if (!std::binary_search(independent.begin(), independent.end(), j)) dependent_.push_back(j);
  for (size_t k = 0; k < w_pairs_.size(); ++k) {
    const WPair& pr = w_pairs_[k];
    if (pr.i == pr.j || std::binary_search(dependent_.begin(), dependent_.end(), pr.i) ||
        std::binary_search(dependent_.begin(), dependent_.end(), pr.j))
      share_pairs_.push_back(static_cast<int>(k));
  }
  // W's graph on the independent constraints: constraints sharing a body's momentum are adjacent.
  const int n = static_cast<int>(independent.size());
  std::vector<int> position(num_lambda_, -1);
  for (int k = 0; k < n; ++k) position[independent[k]] = k;
  std::vector<std::vector<char>> adjacent(n, std::vector<char>(n, 0));
  for (const WPair& pr : w_pairs_)
    if (position[pr.i] >= 0 && position[pr.j] >= 0)
      adjacent[position[pr.i]][position[pr.j]] = adjacent[position[pr.j]][position[pr.i]] = 1;
  // Minimum-degree order (ties to the lowest index, so it is reproducible): eliminating the
  // constraint with the fewest neighbours first keeps the fill-in of L small (in the differential,
  // 405 nonzeros and a quarter of the dense factorisation's operations). Eliminating a vertex
  // joins its remaining neighbours: `adjacent` becomes the pattern of L + L^T.
  IndependentFactor& f = factor_;
  std::vector<char> done(n, 0);
  std::vector<int> order;  // order[pos] = index in independent
  for (int step = 0; step < n; ++step) {
    int best = 0, best_degree = n + 1;  // the first vertex not done has degree <= n
    for (int u = 0; u < n; ++u) {
      if (done[u]) continue;
      int degree = 0;
      for (int w = 0; w < n; ++w) degree += !done[w] && adjacent[u][w];
      if (degree < best_degree) best = u, best_degree = degree;
    }
    done[best] = 1;
    std::vector<int> neighbours;
    for (int u = 0; u < n; ++u)
      if (!done[u] && adjacent[best][u]) neighbours.push_back(u);
    for (int a : neighbours)
      for (int c : neighbours)
        if (a != c) adjacent[a][c] = 1;
    order.push_back(best);
  }
  std::vector<int> pos_of(n);
  for (int p = 0; p < n; ++p) {
    pos_of[order[p]] = p;
    f.multiplier.push_back(independent[order[p]]);
  }
  // L's pattern row by row in the new order (columns sorted).
  std::vector<std::vector<int>> index_of(n, std::vector<int>(n, -1));  // [row][col] -> entry of L
  f.row_offset.push_back(0);
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < i; ++j)
      if (adjacent[order[i]][order[j]]) {
        index_of[i][j] = f.entries();
        f.cols.push_back(j);
      }
    f.row_offset.push_back(f.entries());
  }
  // Runs of three consecutive positions on both sides become one Dot3, the rest Dot1s.
  auto cut = [](const std::vector<std::pair<int, int>>& terms, int target, std::vector<IndependentFactor::Dot>& dot3,
                std::vector<IndependentFactor::Dot>& dot1) {
    for (size_t k = 0; k < terms.size();) {
      const auto [a, b] = terms[k];
      if (k + 2 < terms.size() && terms[k + 2].first == a + 2 && terms[k + 2].second == b + 2) {
        dot3.push_back({target, a, b});  // positions are increasing: k + 1 is (a + 1, b + 1)
        k += 3;
      } else {
        dot1.push_back({target, a, b});
        k += 1;
      }
    }
  };
  // Each entry's update terms: the columns k < j that rows i and j share.
  f.l3_offset.push_back(0);
  f.l1_offset.push_back(0);
  for (int i = 0; i < n; ++i)
    for (int e = f.row_offset[i]; e < f.row_offset[i + 1]; ++e) {
      const int j = f.cols[e];
      std::vector<std::pair<int, int>> terms;
      for (int k = 0; k < j; ++k)
        if (index_of[i][k] >= 0 && index_of[j][k] >= 0) terms.push_back({index_of[i][k], index_of[j][k]});
      cut(terms, e, f.l3, f.l1);
      f.l3_offset.push_back(static_cast<int>(f.l3.size()));
      f.l1_offset.push_back(static_cast<int>(f.l1.size()));
    }
  // Where each nonzero of W goes in Workspace::con.factor (D first, then L's entries).
  for (const WPair& pr : w_pairs_) {
    if (position[pr.i] < 0 || position[pr.j] < 0) continue;
    const int i = std::max(pos_of[position[pr.i]], pos_of[position[pr.j]]);
    const int j = std::min(pos_of[position[pr.i]], pos_of[position[pr.j]]);
    cut(std::vector<std::pair<int, int>>(w_terms_.begin() + pr.begin, w_terms_.begin() + pr.end),
        i == j ? i : n + index_of[i][j], f.w3, f.w1);
  }
}

void CompiledModel::CalcConstrained(double t, const double* x, double* xdot, Workspace& ws, bool share) const {
  std::fill(ws.lambda.begin(), ws.lambda.end(), 0.0);
  EvalPlan(t, x, xdot, ws);
  Tangent(t, x, xdot, ws);
  double* rhs = ws.con.rhs.data();
  const double* d = ws.con.dslots.data();
  for (const ConstraintGroup& cg : constraints_)
    for (int k = 0; k < cg.size; ++k) {
      double r = 0.0;
      for (const auto& mb : cg.members)
        r -= mb.sign * (d[mb.flow + k] - (mb.source_fn >= 0 ? source_fns_[mb.source_fn + k].Derivative(t) : 0.0));
      rhs[cg.lambda + k] = r;
    }
  SolveConstraintsAt(t, x, ws);
  if (share) ShareRedundantEfforts(ws);
  // Step 4: only what the multipliers reach changes (BuildConstraints, reaction_plan_).
  double* w = ws.slots.data();
  const double* mod = ws.moduli.data();
  if (generated_react_) {
    const SourceTable sources = Sources();
    generated_react_(t, x, xdot, w, mod, ws.lambda.data(), &sources);
    return;
  }
  for (int k : reaction_plan_)
    Exec(plan_[k], t, x, w, w, mod, ws.lambda.data());
  for (int gi : reaction_gathers_) EvalGather(gathers_[gi], x, w, xdot);
}

double CompiledModel::ConstraintResidual(double t, const double* x, Workspace& ws) const {
  if (constraints_.empty()) return 0.0;
  std::fill(ws.lambda.begin(), ws.lambda.end(), 0.0);
  EvalPlan(t, x, ws.con.xdot.data(), ws);
  ConstraintValues(t, ws.slots.data(), ws.con.rhs.data());
  double worst = 0.0;
  for (int i = 0; i < num_lambda_; ++i) worst = std::max(worst, std::abs(ws.con.rhs[i]));
  return worst;
}

void CompiledModel::Project(double t, double* x, Workspace& ws) const {
  Project(x);
  if (constraints_.empty()) return;
  // g is affine in p with dg/dp = B^T M^-1: p += B mu with W mu = -g restores g = 0 exactly,
  // changing the kinetic energy least.
  std::fill(ws.lambda.begin(), ws.lambda.end(), 0.0);
  EvalPlan(t, x, ws.con.xdot.data(), ws);
  ConstraintValues(t, ws.slots.data(), ws.con.rhs.data());
  for (int i = 0; i < num_lambda_; ++i) ws.con.rhs[i] = -ws.con.rhs[i];
  SolveConstraintsAt(t, x, ws);
  for (int col = 0; col < num_lambda_; ++col) {
    const double mu = ws.lambda[col];
    if (mu == 0.0) continue;
    for (int q = b_offset_[col]; q < b_offset_[col + 1]; ++q) x[b_rows_[q]] += ws.con.b[q] * mu;
  }
  // Only momenta moved (the rows of B): B and the factor stay right for x, which the evaluation
  // at an output time, right after this, reuses.
  if (ws.con.factored) std::copy(x, x + num_states(), ws.con.factored_at.begin());
  std::fill(ws.lambda.begin(), ws.lambda.end(), 0.0);
}

}  // namespace multibond
