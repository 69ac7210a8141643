// Ideal constraints (docs/design.md, "Ideal constraints"): the compiled model's side. The graph
// pass that turns every constraint into an effort source of unknown effort (a multiplier), and
// the model's calls of its ConstraintSolver (compile/constraint_solver.h), which owns the
// constraint tables and solves for the multipliers around the plan.
//
// A constraint comes either from an Sf marked `constraint` (a rigid joint: zero relative
// velocity in chosen directions), or from cutting the bond of a storage element that the
// causality analysis put in derivative causality (two such sources, one on each side of the
// cut, sharing lambda). With every multiplier an effort source, the graph is integrally causal
// and the plan is the ordinary one; the constraint equations are that each constraint's flows
// take their prescribed values:
//     g(t, x) = sum_k s_k (f_k - v_k(t)) = 0,
// s_k = +1 if member k's bond points away from it, so that lambda . g is the power the constraint
// delivers.

#include <algorithm>

#include <fmt/format.h>

#include "multibond/causality/repair.h"
#include "multibond/compile/compiled_model.h"

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
    std::vector<ConstraintSolver::Group::Member> members;
    for (int m : p.members) {
      const int b = g.element(m).bonds.front();
      members.push_back({b, g.bond(b).from == m ? 1.0 : -1.0, p.target ? 0 : -1});
    }
    constraints_.Add(p.name, p.element, std::move(members));
  }
}

ConstraintSolver::PlanView CompiledModel::ConstraintPlan(const SourceTable* sources) const {
  return {plan_, tables(), moduli_, layout_.gathers(), &CompiledModel::EvalGather, sources, num_states()};
}

void CompiledModel::BuildConstraints(const std::vector<std::vector<int>>& plan_reads, const std::vector<int>& plan_writes) {
  constraints_.Build({graph_, plan_, plan_reads, plan_writes, layout_.blocks(), layout_.gathers(), class_offset_, class_size_, class_names_,
                      flow_class_, num_slots_});
}

void CompiledModel::FindIndependentConstraints() {
  if (constraints_.empty()) return;
  // At the initial state, with the multipliers at zero.
  Workspace ws = MakeWorkspace();
  std::vector<double> xdot(num_states());
  EvalPlan(0.0, layout_.x0().data(), xdot.data(), ws);
  const SourceTable sources = Sources();
  constraints_.FindIndependent(ConstraintPlan(&sources), layout_.x0().data(), ws);
}

std::vector<std::string> CompiledModel::constraint_names() const { return constraints_.names(); }

std::string CompiledModel::GenerateFactorSource() const { return constraints_.factor().GenerateSource(graph_.name()); }

void CompiledModel::CalcConstrained(double t, const double* x, double* xdot, Workspace& ws, bool share) const {
  // Step 1: the plan at lambda = 0, and the moduli's time derivatives for the tangent pass
  // (every modulus is linear in its orientation state: dM/dt is M evaluated at dR/dt).
  std::fill(ws.lambda.begin(), ws.lambda.end(), 0.0);
  EvalPlan(t, x, xdot, ws);
  if (!needed_moduli_.empty()) EvalModuli(xdot, ws.con.dmoduli.data(), true);
  const SourceTable sources = Sources();
  constraints_.Solve(ConstraintPlan(&sources), t, x, xdot, ws, share);
}

double CompiledModel::ConstraintResidual(double t, const double* x, Workspace& ws) const {
  if (constraints_.empty()) return 0.0;
  std::fill(ws.lambda.begin(), ws.lambda.end(), 0.0);
  EvalPlan(t, x, ws.con.xdot.data(), ws);
  return constraints_.Residual(t, ws);
}

void CompiledModel::Project(double t, double* x, Workspace& ws) const {
  Project(x);
  if (constraints_.empty()) return;
  std::fill(ws.lambda.begin(), ws.lambda.end(), 0.0);
  EvalPlan(t, x, ws.con.xdot.data(), ws);
  const SourceTable sources = Sources();
  constraints_.ProjectMomenta(ConstraintPlan(&sources), t, x, ws);
}

}  // namespace multibond
