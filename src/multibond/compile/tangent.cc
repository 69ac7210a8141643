/// \file
/// Directional derivatives of the right-hand side (compiled_model.h, CalcTangent and
/// SourceInputs): the plan walked once in order, each instruction's tangent rule applied to the
/// derivatives of what it reads (the operation table's rules, plan::ExecTangent; formulas by
/// forward-mode differentiation of their programs, expr::RunTangent; a law used backwards by the
/// implicit function theorem), then the state derivatives' gathers. Exact to rounding: the
/// linearisation's Jacobians (analysis/linearize.cc) are built from it, column by column.

#include <algorithm>
#include <vector>

#include <fmt/format.h>

#include "multibond/compile/compiled_model.h"
#include "multibond/compile/generated_rhs.h"
#include "multibond/compile/torn_jacobian.h"
#include "multibond/core/error.h"

namespace multibond {

namespace {

bool IsSourceInstruction(const plan::Instr& in, const BondGraph& g) {
  if (in.element < 0) return false;
  const ElementKind kind = g.element(in.element).kind;
  if (kind != ElementKind::kSe && kind != ElementKind::kSf) return false;
  return in.op == plan::Op::kSource || in.op == plan::Op::kExpr;
}

}  // namespace

std::vector<CompiledModel::SourceInput> CompiledModel::SourceInputs() const {
  std::vector<SourceInput> inputs;
  for (int i = 0; i < plan_.size(); ++i) {
    const Instr& in = plan_.instrs[i];
    if (!IsSourceInstruction(in, graph_)) continue;
    const Element& e = graph_.element(in.element);
    const int cls = slots_.class_of_slot.empty() ? -1 : slots_.class_of_slot[in.dst];
    const std::vector<std::string> comps = ComponentNames(in.n);
    for (int k = 0; k < in.n; ++k)
      inputs.push_back({in.n == 1 ? e.name : e.name + "." + comps[k], cls >= 0 ? slots_.class_units[cls] : "", in.element, i, k});
  }
  return inputs;
}

bool CompiledModel::can_linearize(std::string* why) const {
  // The linearisation of ideal constraints differentiates the constraint equations twice
  // (ExecSecondTangent): a formula's by hyper-dual numbers, but not a law used backwards.
  for (int k : constraints_.tangent_plan())
    if (plan_.instrs[k].op == Op::kSolve) {
      const std::string& name = plan_.instrs[k].element >= 0 ? graph_.element(plan_.instrs[k].element).name : slots_.class_names[slots_.class_of_slot[plan_.instrs[k].dst]];
      if (why)
        *why = fmt::format("ideal constraints whose equations read a law used backwards (that of '{}'): the "
                           "linearisation of such a constraint needs the inverse law's second derivatives, which are not derived",
                           name);
      return false;
    }
  return true;
}

void CompiledModel::TangentPass(double t, const double* x, const double* dx, bool time, const double* du, double* dxdot,
                                const Workspace& ws, std::vector<double>& d_slots, std::vector<double>& d_moduli,
                                std::vector<double>* scratch) const {
  const double* w = ws.slots.data();
  double* d = d_slots.data();
  std::fill(d_slots.begin(), d_slots.end(), 0.0);
  std::vector<double> own;
  std::vector<double>& tmp = scratch ? *scratch : own;
  tmp.assign(d_slots.size(), 0.0);
  if (!plan_.needed_moduli.empty()) EvalModuli(dx, d_moduli.data(), /*derivative=*/true);
  const plan::TangentArgs args{t, x, dx, w, d, tmp.data(), ws.moduli.data(), d_moduli.data(), ws.lambda.data(), tables(), plan_.moduli.data(),
                               /*source_rate=*/time};
  int input = 0;
  for (const Instr& in : plan_.instrs) {
    plan::ExecTangent(in, args);
    if (IsSourceInstruction(in, graph_)) {
      for (int k = 0; k < in.n; ++k, ++input)
        if (du) d[in.dst + k] += du[input];
    }
  }
  if (!loops_.tears.empty()) {
    // The pass took the torn variables' derivatives as 0, so each writer's own slot holds dc0, the
    // derivative of c(z) along the direction at fixed z. The loop's solution z = c(z) moves by
    // dz = (I - dc/dz)^-1 dc0 (the implicit function theorem; dc/dz column by column, as Newton's
    // method takes it in EvalTorn), and the closure runs again with dz: every slot's derivative is
    // then that of the solved loop. Not on the hot path (linearisation, sliding modes): it allocates.
    const int n = loops_.num_unknowns;
    Eigen::VectorXd dc0(n);
    int k = 0;
    for (const Tear& tr : loops_.tears)
      for (int i = 0; i < tr.size; ++i) dc0[k++] = d[tr.shadow + i];
    std::vector<double> dj(d_slots.size()), tj(d_slots.size(), 0.0), zero_x(static_cast<size_t>(num_states()), 0.0), zero_mod(d_moduli.size(), 0.0);
    const plan::TangentArgs along_z{t, x, zero_x.data(), ws.slots.data(), dj.data(), tj.data(), ws.moduli.data(), zero_mod.data(),
                                    ws.lambda.data(), tables(), plan_.moduli.data(), /*source_rate=*/false};
    Eigen::MatrixXd a(n, n);
    TornJacobian(loops_.tears, dj, a, [&] {
      for (int at : loops_.closure) plan::ExecTangent(plan_.instrs[at], along_z);
    });
    const Eigen::VectorXd dz = a.partialPivLu().solve(dc0);
    k = 0;
    for (const Tear& tr : loops_.tears)
      for (int i = 0; i < tr.size; ++i) d[tr.slot + i] = dz[k++];
    for (int at : loops_.closure) plan::ExecTangent(plan_.instrs[at], args);
  }
  for (const Gather& gt : layout_.gathers()) TangentGather(gt, x, dx, w, d, dxdot);
}

void CompiledModel::CalcTangent(double t, const double* x, const double* dx, const double* du, double* dxdot, Workspace& ws,
                                Workspace& dws) const {
  TangentPass(t, x, dx, /*time=*/false, du, dxdot, ws, dws.slots, dws.moduli);
  if (constraints_.empty()) return;
  // Ideal constraints: dx/dt = P(x, lambda(x)), lambda from dg/dt = dv/dt, that is
  // J_y(x) P(x, lambda) + dy/dt|explicit = dv/dt (y: the constrained variables, which the
  // multipliers never reach). Along the direction (dx, du), with P's derivative u at fixed
  // multipliers (above):  W dlambda = -(J_y u + y''[dx, (P, 1)]),  d(dx/dt) = u + B dlambda.
  const int n = num_states(), m = num_multipliers();
  std::vector<double> rate(n), u(dxdot, dxdot + n), scratch_rate(n), d_moduli(dws.moduli.size());
  CalcDerivatives(t, x, rate.data(), ws);  // P at the point, the multipliers solved (ws as the caller's)
  std::vector<double> df(dws.slots.size()), jyu(dws.slots.size()), dd(dws.slots.size(), 0.0), tmp(dws.slots.size(), 0.0);
  std::vector<double> dmod_f(dws.moduli.size());
  TangentPass(t, x, rate.data(), /*time=*/true, nullptr, scratch_rate.data(), ws, df, dmod_f);
  TangentPass(t, x, u.data(), /*time=*/false, nullptr, scratch_rate.data(), ws, jyu, d_moduli);
  const GeneratedCode* code = Loaded(ws);
  const SourceTable sources = Sources(code ? code->values : nullptr);
  const ConstraintSolver::PlanView view = ConstraintPlan(&sources, code);
  const plan::SecondTangentArgs second{t, x, dx, rate.data(), ws.slots.data(), dws.slots.data(), df.data(), dd.data(), tmp.data(),
                                       ws.moduli.data(), dws.moduli.data(), dmod_f.data(), ws.lambda.data(), tables(), plan_.moduli.data()};
  for (int index : constraints_.tangent_plan()) plan::ExecSecondTangent(plan_.instrs[index], second);
  std::vector<double> r1(m), r2(m), r(m), dlambda(m), lin(dws.slots.size(), 0.0);
  constraints_.ConstraintRates(jyu.data(), r1.data());
  constraints_.ConstraintRates(dd.data(), r2.data());
  for (int k = 0; k < m; ++k) r[k] = -(r1[k] + r2[k]);
  constraints_.Respond(view, t, x, r.data(), ws, dlambda.data(), lin.data(), dxdot);
  for (size_t k = 0; k < lin.size(); ++k) dws.slots[k] += lin[k];
}

void CompiledModel::TangentGather(const Gather& gt, const double* x, const double* dx, const double* w, const double* d, double* dxdot) {
  double* out = dxdot + gt.state;
  switch (gt.kind) {
    case StateBlock::Kind::kMomentum:
    case StateBlock::Kind::kDisplacement:
    case StateBlock::Kind::kIntegral:
      EvalGather(gt, dx, d, dxdot);  // linear in the slots
      break;
    case StateBlock::Kind::kOrientation: {
      // dR/dt = [w x] R - g (R R^T - I) R:  d = [dw x] R + [w x] dR - g ((dR R^T + R dR^T) R + (R R^T - I) dR).
      using Rm3 = Eigen::Matrix<double, 3, 3, Eigen::RowMajor>;
      const Eigen::Map<const Rm3> r(x + gt.state), dr(dx + gt.state);
      auto skew = [](const double* v) {
        Eigen::Matrix3d s;
        s << 0.0, -v[2], v[1], v[2], 0.0, -v[0], -v[1], v[0], 0.0;
        return s;
      };
      Rm3 o = skew(d + gt.flow) * r + skew(w + gt.flow) * dr;
      if (gt.sign > 0.0)
        o -= gt.sign * ((dr * r.transpose() + r * dr.transpose()) * r + (r * r.transpose() - Eigen::Matrix3d::Identity()) * dr);
      Eigen::Map<Rm3> result(out);
      result = o;
      break;
    }
    case StateBlock::Kind::kWork:
    case StateBlock::Kind::kDissipation: {
      double p = 0.0;
      for (int k = 0; k < gt.size; ++k) p += d[gt.effort + k] * w[gt.flow + k] + w[gt.effort + k] * d[gt.flow + k];
      out[0] = gt.sign * p;
      break;
    }
  }
}

}  // namespace multibond
