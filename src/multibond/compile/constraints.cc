// Ideal constraints (docs/design.md, "Ideal constraints"): the compiled model's side. The graph
// pass that turns every constraint into a source of unknown value (a multiplier), and the
// model's calls of its ConstraintSolver (compile/constraint_solver.h), which owns the constraint
// tables and solves for the multipliers around the plan.
//
// A constraint comes either from an Sf marked `constraint` (a rigid joint: zero relative
// velocity in chosen directions; an effort source of unknown effort), or from cutting the bond
// of a storage element that the causality analysis put in derivative causality: two sources,
// one on each side of the cut, sharing one multiplier. An inertia's cut is a pair of effort
// sources (the inertia receives an effort again; the constraint: both sides' flows agree); a
// compliance's cut, dually, a pair of flow sources (the compliance receives a flow again; the
// constraint: both sides' efforts agree, a position-level constraint whose time derivative the
// solver enforces). With every multiplier a source, the graph is integrally causal and the
// plan is the ordinary one; the constraint equations are that each constraint's conjugate
// variables y_k (flows, or efforts for a compliance's cut) take their prescribed values:
//     g(t, x) = sum_k s_k (y_k - v_k(t)) = 0,
// s_k = +1 if member k's bond points away from it, so that lambda . g is the power the constraint
// delivers.

#include <algorithm>

#include <fmt/format.h>

#include "multibond/causality/repair.h"
#include "multibond/compile/compiled_model.h"
#include "multibond/compile/generated_rhs.h"
#include "multibond/core/diagnostic_codes.h"

namespace multibond {

void CompiledModel::PrepareConstraintGraph() {
  BondGraph& g = graph_;
  struct Pending {
    std::string name;
    int element;
    std::vector<int> members;
    bool target;
    bool imposes_flow;
  };
  std::vector<Pending> pending;
  // Rigid joints and other explicit constraints: the Sf becomes the multiplier's effort source
  // (the same view `check` analyses, causality/repair.h).
  g = CausalView(std::move(g));
  for (int i = 0; i < g.num_elements(); ++i)
    if (g.element(i).constraint) pending.push_back({g.element(i).name, i, {i}, true, false});
  for (;;) {
    DiagnosticSink sink;
    structure_ = AnalyzeStructure(g, options_.default_domain, sink);
    sink.ThrowIfErrors();
    causality_ = AssignCausality(g, structure_);
    if (!options_.ideal_constraints || causality_.derivative.empty()) break;
    // Cut the bond of the first storage element in derivative causality, then analyse again: one
    // cut can free others (a chain of rigidly joined inertias needs one cut per joint, not per
    // inertia; three compliances on one 0-junction need two).
    int d = -1;
    for (int el : causality_.derivative)
      if (IsStorage(g.element(el).kind) && g.element(el).bonds.size() == 1) {
        d = el;
        break;
      }
    if (d < 0) break;  // (a storage element has one bond: the loader sees to it)
    // The storage element gets back the variable of its integral causality from its side's
    // source (an effort for an inertia, a flow for a compliance); the rest of the graph keeps
    // receiving the variable the element imposed on it, from the other side's source.
    const bool inertia = g.element(d).kind == ElementKind::kI;
    const int b = g.element(d).bonds.front();
    const int other = g.Other(b, d);
    const bool into_storage = g.bond(b).to == d;
    const std::string base = g.element(d).name + ".cut";
    Element a;
    a.name = base;
    a.kind = inertia ? ElementKind::kSe : ElementKind::kSf;
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
    pending.push_back({base, d, {ia, ir}, false, !inertia});
  }
  if (causality_.has_errors()) {
    // With ideal constraints every storage element in derivative causality has been cut: what is
    // left are conflicts, which no constraint resolves. Without, the option is named when the
    // model compiles with it (else why not: a suggestion that only leads to another refusal,
    // which would send the reader back here, is no help).
    bool only_derivative = true;  // conflicts are reported as they are: no option resolves them
    for (const Diagnostic& dg : causality_.diagnostics)
      only_derivative &= dg.severity != Diagnostic::Severity::kError || dg.code == codes::kCausalityDerivative;
    if (!causality_.derivative.empty() && !options_.ideal_constraints && only_derivative) {
      CompileOptions ideal = options_;
      ideal.ideal_constraints = true;
      std::string refused;
      try {
        (void)CompiledModel::Compile(g, ideal);
      } catch (const ModelError& e) {
        refused = e.diagnostics().empty() ? "it is refused" : e.diagnostics().front().message;
      }
      for (Diagnostic& dg : causality_.diagnostics)
        if (dg.code == codes::kCausalityDerivative) {
          const int el = g.Find(dg.element);
          const bool compliance = el >= 0 && g.element(el).kind == ElementKind::kC;
          if (refused.empty())
            dg.details.push_back(fmt::format("or keep the ideal mechanism: run with --constraints ideal (or 'constraints: ideal' "
                                             "at the top of the model file) and the dependent storage is handled exactly by {}",
                                             compliance ? "a constraint flow (its displacement follows the effort imposed on it)"
                                                        : "constraint efforts"));
          else
            dg.details.push_back("--constraints ideal does not take this model either: " + refused);
        }
    }
    throw ModelError(causality_.diagnostics);
  }
  // A formula that a constraint's variables depend on, or that reads its multiplier, is checked
  // once the plan is known (ConstraintSolver::Build, CheckFormulas: what is refused names the
  // formula, the constraint, and for a cut the storage element in derivative causality).
  for (const Pending& p : pending) {
    std::vector<ConstraintSolver::Group::Member> members;
    for (int m : p.members) {
      const int b = g.element(m).bonds.front();
      members.push_back({b, g.bond(b).from == m ? 1.0 : -1.0, p.target ? 0 : -1});
    }
    constraints_.Add(p.name, p.element, std::move(members), p.imposes_flow);
  }
}

ConstraintSolver::PlanView CompiledModel::ConstraintPlan(const SourceTable* sources, const GeneratedCode* code) const {
  // The generated steps once the (background) compile has published them: the same bits.
  return {plan_.instrs, tables(), plan_.moduli, layout_.gathers(), &CompiledModel::EvalGather, sources, num_states(),
          code && code->has_constrained ? &code->constrained : nullptr};
}

void CompiledModel::BuildConstraints(const std::vector<std::vector<int>>& plan_reads, const std::vector<int>& plan_writes) {
  constraints_.Build({graph_, plan_.instrs, plan_reads, plan_writes, layout_.blocks(), layout_.gathers(), slots_.class_offset, slots_.class_size,
                      slots_.class_names, slots_.flow_class, slots_.effort_class, slots_.num_slots, plan_.programs, layout_.state_names(), num_states()});
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
  if (!plan_.needed_moduli.empty()) EvalModuli(xdot, ws.con.dmoduli.data(), true);
  PrescribeSwitches(t, ws);  // the multipliers the switching elements' modes fix
  const GeneratedCode* code = Loaded(ws);
  const SourceTable sources = Sources(code ? code->values : nullptr);
  constraints_.Solve(ConstraintPlan(&sources, code), t, x, xdot, ws, share);
}

double CompiledModel::ConstraintResidual(double t, const double* x, Workspace& ws) const {
  if (constraints_.empty()) return 0.0;
  std::fill(ws.lambda.begin(), ws.lambda.end(), 0.0);
  EvalPlan(t, x, ws.con.xdot.data(), ws);
  PrescribeSwitches(t, ws);
  return constraints_.Residual(t, ws);
}

void CompiledModel::Project(double t, double* x, Workspace& ws) const {
  Project(x);
  if (constraints_.empty()) return;
  std::fill(ws.lambda.begin(), ws.lambda.end(), 0.0);
  EvalPlan(t, x, ws.con.xdot.data(), ws);
  PrescribeSwitches(t, ws);  // only the constraints that hold
  const GeneratedCode* code = Loaded(ws);
  const SourceTable sources = Sources(code ? code->values : nullptr);
  constraints_.ProjectMomenta(ConstraintPlan(&sources, code), t, x, ws);
}

}  // namespace multibond
