/// \file
/// The evaluation of a compiled model (docs/design.md, "The evaluation plan"): the workspace,
/// the moduli, the plan run by the interpreter (the operation table's kernels) or the generated
/// code, algebraic loops solved around it, the state derivatives' gathers, the projection.

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <fmt/format.h>

#include "multibond/compile/compiled_model.h"
#include "multibond/compile/generated_rhs.h"
#include "multibond/compile/exact_sum.h"
#include "multibond/compile/torn_jacobian.h"

namespace multibond {

void CompiledModel::Project(double* x) const {
  using Rm3 = Eigen::Matrix<double, 3, 3, Eigen::RowMajor>;
  for (const StateBlock& b : layout_.blocks()) {
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

Workspace CompiledModel::MakeWorkspace(const GeneratedRhs* code) const {
  Workspace ws;
  ws.code = code;
  ws.slots.assign(slots_.num_slots, 0.0);
  ws.moduli.assign(plan_.num_moduli, 0.0);
  if (loops_.num_unknowns > 0) {
    Workspace::TearScratch& s = ws.tear;
    s.a.setZero(loops_.num_unknowns, loops_.num_unknowns);
    s.c0.setZero(loops_.num_unknowns);
    s.z.setZero(loops_.num_unknowns);
    s.lu = Eigen::PartialPivLU<Eigen::MatrixXd>(loops_.num_unknowns);
    if (loops_.nonlinear) {
      s.last.setZero(loops_.num_unknowns);
      s.r.setZero(loops_.num_unknowns);
      s.dz.setZero(loops_.num_unknowns);
      s.trial.setZero(loops_.num_unknowns);
      s.d.assign(ws.slots.size(), 0.0);
      s.tmp.assign(ws.slots.size(), 0.0);
      s.dx.assign(static_cast<size_t>(num_states()), 0.0);
      s.dmod.assign(ws.moduli.size(), 0.0);
    }
  }
  if (!constraints_.empty()) constraints_.SizeScratch(ws, slots_.num_slots, plan_.num_moduli, num_states());
  ws.modes.assign(events_.switches.size(), SwitchTable::kOpen);
  if (events_.kinks.num_roots() > 0) ws.event_xdot.assign(num_states(), 0.0);
  ws.kink_modes.assign(events_.slides.size(), Workspace::kFree);
  for (const int k : events_.slides) SetSlide(ws, k, Workspace::kFree, 0.0);
  if (!events_.slides.empty()) {
    Workspace::SlideScratch& s = ws.slide;
    s.xdot.assign(num_states(), 0.0);
    s.rate.assign(num_states(), 0.0);
    s.d_slots.assign(ws.slots.size(), 0.0);
    s.d_moduli.assign(ws.moduli.size(), 0.0);
    s.tmp.assign(ws.slots.size(), 0.0);
    s.active.reserve(events_.slides.size());
    const auto m = static_cast<Eigen::Index>(events_.slides.size());
    s.r0.setZero(m);
    s.r1.setZero(m);
    s.sigma.setZero(m);
    s.b.setZero(m, m);
  }
  return ws;
}

void CompiledModel::EvalModuli(const double* x, double* out, bool derivative) const {
  for (int index : plan_.needed_moduli) {
    const ModulusEval& me = plan_.moduli[index];
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
        m.noalias() = me.scale * Eigen::Map<const RowMajor>(plan_.coef.data() + me.left, me.rows, inner) *
                      Eigen::Map<const RowMajor>(plan_.coef.data() + me.constant, inner, me.cols);
      } else {
        m = me.scale * Eigen::Map<const RowMajor>(plan_.coef.data() + me.constant, me.rows, me.cols);
      }
    } else {
      if (me.right >= 0) core = core * Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(plan_.coef.data() + me.right);
      if (me.left >= 0)
        m.noalias() = me.scale * Eigen::Map<const RowMajor>(plan_.coef.data() + me.left, me.rows, 3) *
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

CompiledModel::SourceTable CompiledModel::Sources(const double* values) const {
  return {plan_.source_fns.data(), &EvalSource, &EvalSourceDerivative, plan_.programs.data(), &expr::SolveForIndexed, values,
          &expr::RunTangentIndexed};
}

const GeneratedCode* CompiledModel::Loaded(const Workspace& ws) { return ws.code ? ws.code->code() : nullptr; }

void CompiledModel::CalcStateDerivatives(double t, const double* x, double* xdot, Workspace& ws) const {
  if (!constraints_.empty()) {
    CalcConstrained(t, x, xdot, ws, /*share=*/false);  // the motion does not depend on the split
    return;
  }
  // Read once per evaluation: the code compiled in the background may arrive between two.
  const GeneratedCode* g = Loaded(ws);
  if (!g || !events_.slides.empty()) {  // the fast code keeps its slots to itself: not the slide slots
    CalcDerivatives(t, x, xdot, ws);
    return;
  }
  if (!plan_.needed_moduli.empty()) EvalModuli(x, ws.moduli.data());
  RunGenerated(*g, /*fast=*/true, t, x, xdot, ws);
}

void CompiledModel::RunGenerated(const GeneratedCode& g, bool fast, double t, const double* x, double* xdot, Workspace& ws) const {
  const SourceTable sources = Sources(g.values);
  if (fast && g.fast) {
    reinterpret_cast<void (*)(double, const double*, double*, const double*, const SourceTable*)>(g.fast)(t, x, xdot, ws.moduli.data(),
                                                                                                         &sources);
    return;
  }
  using Rhs = void (*)(double, const double*, double*, double*, const double*, const SourceTable*);
  if (g.rhs) {
    reinterpret_cast<Rhs>(g.rhs)(t, x, xdot, ws.slots.data(), ws.moduli.data(), &sources);
    return;
  }
  for (GeneratedCode::Fn part : g.parts) reinterpret_cast<Rhs>(part)(t, x, xdot, ws.slots.data(), ws.moduli.data(), &sources);
}


void CompiledModel::CalcDerivatives(double t, const double* x, double* xdot, Workspace& ws) const {
  if (!constraints_.empty()) {
    CalcConstrained(t, x, xdot, ws, /*share=*/true);
    return;
  }
  if (!events_.slides.empty() && Sliding(ws)) SolveSliding(t, x, ws);
  EvalPlan(t, x, xdot, ws);
}

void CompiledModel::EvalPlan(double t, const double* x, double* xdot, Workspace& ws) const {
  double* w = ws.slots.data();
  double* mod = ws.moduli.data();
  if (!plan_.needed_moduli.empty()) EvalModuli(x, mod);
  if (!loops_.tears.empty()) {
    EvalTorn(t, x, ws);
    for (const Gather& gt : layout_.gathers()) EvalGather(gt, x, w, xdot);
    return;
  }
  if (const GeneratedCode* g = Loaded(ws)) {
    RunGenerated(*g, /*fast=*/false, t, x, xdot, ws);
    return;
  }
  const plan::ExecArgs args{t, x, w, w, mod, ws.lambda.data(), tables()};
  for (const Instr& in : plan_.instrs) plan::Exec(in, args);
  for (const Gather& gt : layout_.gathers()) EvalGather(gt, x, w, xdot);
}

void CompiledModel::EvalTorn(double t, const double* x, Workspace& ws) const {
  double* w = ws.slots.data();
  auto exec = [&](const Instr& in) {
    Exec(in, t, x, w, w, ws.moduli.data(), ws.lambda.data());
  };
  auto run = [&] {
    for (const Instr& in : plan_.instrs) exec(in);
  };
  auto run_closure = [&] {  // what depends on the unknowns; every other slot keeps its value
    for (int at : loops_.closure) exec(plan_.instrs[at]);
  };
  // Every instruction is linear in the slots it reads, so what the torn variables' writers compute
  // is affine in the unknowns z: c(z) = c0 + A z. One pass of the plan at z = 0 and one of the
  // unknowns' closure per unknown give c0 and A; then (I - A) z = c0, and a last pass of the
  // closure with z makes every slot consistent.
  auto set_unknowns = [&](const double* z) {
    int k = 0;
    for (const Tear& tr : loops_.tears)
      for (int i = 0; i < tr.size; ++i) w[tr.slot + i] = z ? z[k++] : 0.0;
  };
  auto computed = [&](double* out) {
    int k = 0;
    for (const Tear& tr : loops_.tears)
      for (int i = 0; i < tr.size; ++i) out[k++] = w[tr.shadow + i];
  };
  Workspace::TearScratch& s = ws.tear;
  if (loops_.nonlinear) {
    // A loop through a formula: Newton's method on r(z) = z - c(z), started from the last
    // evaluation's solution, with the exact Jacobian I - dc/dz (the closure's tangent pass along
    // each unknown) and a step halved while it does not lower |r|. Converged when |r| is below
    // 1e-10 of the unknowns' scale and the step below 1e-13 of it (the iteration then sits at
    // rounding, quadratically) or no step lowers |r| further, or when r is exactly 0.
    const plan::TangentArgs args{t, x, s.dx.data(), w, s.d.data(), s.tmp.data(), ws.moduli.data(), s.dmod.data(), ws.lambda.data(),
                                 tables(), plan_.moduli.data(), /*source_rate=*/false};
    s.z = s.last;
    set_unknowns(s.z.data());
    run();
    computed(s.c0.data());
    s.r = s.z - s.c0;
    double norm = s.r.lpNorm<Eigen::Infinity>();
    constexpr int kMaxIterations = 60;
    int iteration = 0;
    const char* why = "after 60 Newton iterations";
    for (; iteration < kMaxIterations && std::isfinite(norm) && norm > 0.0; ++iteration) {
      TornJacobian(loops_.tears, s.d, s.a, [&] {
        for (int at : loops_.closure) plan::ExecTangent(plan_.instrs[at], args);
      });
      s.lu.compute(s.a);
      s.dz.noalias() = s.lu.solve(s.r);
      if (!s.a.allFinite() || !s.dz.allFinite() || s.dz.lpNorm<Eigen::Infinity>() == 0.0) {  // r != 0 here
        why = "its Jacobian is singular";
        iteration = kMaxIterations;
        break;
      }
      double step = 1.0, trial_norm = norm;
      for (int halving = 0; halving <= 30; ++halving, step *= 0.5) {
        s.trial = s.z - step * s.dz;
        set_unknowns(s.trial.data());
        run_closure();
        computed(s.c0.data());
        trial_norm = (s.trial - s.c0).lpNorm<Eigen::Infinity>();
        if (trial_norm < norm) break;
      }
      const bool stalled = !(trial_norm < norm);  // no step lowers |r|: rounding, or no solution here
      s.z = s.trial;
      s.r = s.z - s.c0;
      norm = trial_norm;
      // The scale of the unknowns: this solution's and the largest solved so far in this run (a
      // solution of 0 is then reached to rounding of the loop's usual size, not of 0).
      const double size = std::max({s.z.lpNorm<Eigen::Infinity>(), s.c0.lpNorm<Eigen::Infinity>(), s.scale});
      const double moved = step * s.dz.lpNorm<Eigen::Infinity>();
      const bool small = norm <= 1e-10 * size;
      if (norm == 0.0 || (small && (moved <= 1e-13 * size || stalled))) break;
      if (stalled) {
        why = "no Newton step lowers it";
        iteration = kMaxIterations;
      }
    }
    if (s.z.allFinite() && s.c0.allFinite() && iteration >= kMaxIterations) {
      std::string names;
      for (const AlgebraicLoop& loop : loops_.loops) names += (names.empty() ? "" : "; ") + loop.path;
      throw std::runtime_error(fmt::format("the nonlinear algebraic loop {} does not converge at t = {}: |z - c(z)| = {:.3g} for the "
                                           "torn {}, {} (the loop may have no solution there, or several)",
                                           names, t, norm, loops_.loops.front().torn, why));
    }
    if (s.z.allFinite()) {
      s.last = s.z;  // the next evaluation's start
      s.scale = std::max({s.scale, s.z.lpNorm<Eigen::Infinity>(), s.c0.lpNorm<Eigen::Infinity>()});
    }
    return;
  }
  set_unknowns(nullptr);
  run();
  computed(s.c0.data());
  for (int j = 0; j < loops_.num_unknowns; ++j) {
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
      for (const AlgebraicLoop& loop : loops_.loops) names += (names.empty() ? "" : ", ") + loop.torn;
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

}  // namespace multibond
