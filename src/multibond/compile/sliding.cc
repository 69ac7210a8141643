/// \file
/// Sliding on a switching surface (docs/events.md, "Sliding on a switching surface"): a `sign`
/// of the state whose switching function g the motion drives back to zero from both sides
/// (g' < 0 with the sign at +1, g' > 0 at -1) would switch at every instant; it is held on g = 0
/// by its equivalent value, the value in [-1, 1] that makes g' = 0 (Filippov), solved at every
/// evaluation while it slides, and leaves where that value reaches the end of its range. The
/// formula's `sign(x)` is compiled as `sign(x)*m + s` over two slots of the workspace
/// (compile/kinks.h, Kink::slide_slot): m = 1, s = 0 off the surface (the sign itself); m = 0,
/// s = the equivalent value on it.

#include <cmath>

#include <fmt/format.h>

#include "multibond/compile/compiled_model.h"

namespace multibond {

bool CompiledModel::Sliding(const Workspace& ws) const {
  for (const signed char m : ws.kink_modes)
    if (m == Workspace::kSliding) return true;
  return false;
}

void CompiledModel::SetSlide(Workspace& ws, int kink, Workspace::KinkMode mode, double value) const {
  const KinkTable::Kink& k = events_.kinks.kinks()[static_cast<size_t>(kink)];
  ws.kink_modes[static_cast<size_t>(k.slide)] = mode;
  ws.slots[static_cast<size_t>(k.slide_slot)] = mode == Workspace::kFree ? 1.0 : 0.0;
  ws.slots[static_cast<size_t>(k.slide_slot) + 1] = mode == Workspace::kFree ? 0.0 : value;
}

double CompiledModel::SwitchingRate(double t, const double* x, Workspace& ws, int kink) const {
  // kink < 0: the plan and its tangent pass along the motion (d/dt of every slot); else the
  // kink's switching function differentiated along the last such pass (SolveSliding reads the
  // rates of several kinks from one pass).
  Workspace::SlideScratch& s = ws.slide;
  if (kink < 0) {
    EvalPlan(t, x, s.xdot.data(), ws);
    TangentPass(t, x, s.xdot.data(), /*time=*/true, nullptr, s.rate.data(), ws, s.d_slots, s.d_moduli, &s.tmp);
    return 0.0;
  }
  return expr::RunTangent(events_.kinks.kinks()[static_cast<size_t>(kink)].program, t, x, ws.slots.data(), 1.0, s.xdot.data(),
                          s.d_slots.data());
}

void CompiledModel::SolveSliding(double t, const double* x, Workspace& ws) const {
  // The switching functions' rates are affine in the held values sigma where the sign drives
  // the model linearly (a source's value, a coefficient): r(sigma) = r0 + B sigma, from one
  // evaluation at sigma = 0 and one more per sliding sign; then B sigma = -r0.
  Workspace::SlideScratch& s = ws.slide;
  s.active.clear();
  for (const int k : events_.slides)
    if (ws.kink_modes[static_cast<size_t>(events_.kinks.kinks()[static_cast<size_t>(k)].slide)] == Workspace::kSliding) s.active.push_back(k);
  const auto m = static_cast<Eigen::Index>(s.active.size());
  auto held = [&](Eigen::Index i) -> double& {
    return ws.slots[static_cast<size_t>(events_.kinks.kinks()[static_cast<size_t>(s.active[static_cast<size_t>(i)])].slide_slot) + 1];
  };
  auto rates = [&](Eigen::VectorXd& out) {
    SwitchingRate(t, x, ws, -1);
    for (Eigen::Index i = 0; i < m; ++i) out[i] = SwitchingRate(t, x, ws, s.active[static_cast<size_t>(i)]);
  };
  for (Eigen::Index i = 0; i < m; ++i) held(i) = 0.0;
  rates(s.r0);
  for (Eigen::Index j = 0; j < m; ++j) {
    held(j) = 1.0;
    rates(s.r1);
    s.b.col(j).head(m) = s.r1.head(m) - s.r0.head(m);
    held(j) = 0.0;
  }
  if (m == 1) {
    s.sigma[0] = -s.r0[0] / s.b(0, 0);
  } else {
    s.sigma.head(m) = s.b.topLeftCorner(m, m).partialPivLu().solve(-s.r0.head(m));  // several at once: rare, allocates
  }
  for (Eigen::Index i = 0; i < m; ++i) held(i) = s.sigma[i];
}

namespace {

/// Whether the motion drives a switching function back to zero from both sides: its rate with
/// the sign at +1 (`above`) and at -1 (`below`), each clearly of its sign (a rate that vanishes,
/// the motion grazing the surface, is no hold).
bool Holds(double above, double below) {
  const double tol = 1e-9 * (std::abs(above) + std::abs(below));
  return above < -tol && below > tol;
}

}  // namespace

std::pair<double, double> CompiledModel::RatesEitherSide(double t, const double* x, Workspace& ws, int kink) const {
  double rate[2];
  for (const int side : {0, 1}) {
    SetSlide(ws, kink, Workspace::kLocked, side == 0 ? 1.0 : -1.0);
    SwitchingRate(t, x, ws, -1);
    rate[side] = SwitchingRate(t, x, ws, kink);
  }
  return {rate[0], rate[1]};
}

EventRecord CompiledModel::HandleKink(double t, const double* x, Workspace& ws, int r) const {
  const KinkTable::Kink& k = events_.kinks.root_kink(r);
  EventRecord rec{t, "kink", k.owner, KinkTable::Describe(k)};
  if (k.slide < 0) return rec;
  const int index = events_.slides[static_cast<size_t>(k.slide)];
  const auto mode = static_cast<Workspace::KinkMode>(ws.kink_modes[static_cast<size_t>(k.slide)]);
  const double held = ws.slots[static_cast<size_t>(k.slide_slot) + 1];
  if (mode == Workspace::kSliding) {  // the equivalent value reached an end of its range: that side's branch
    SetSlide(ws, index, Workspace::kLocked, held >= 0.0 ? 1.0 : -1.0);
    rec.kind = "leave";
    rec.description = fmt::format("{} leaves 0: holding it would take sign = {:.6g}, beyond [-1, 1]: {} in {}", k.function, held,
                                  k.formula, k.what);
    return rec;
  }
  // The motion on either side, with the sign at +1 and at -1.
  const auto [above, below] = RatesEitherSide(t, x, ws, index);
  if (Holds(above, below) && constraints_.empty()) {
    SetSlide(ws, index, Workspace::kSliding, 0.0);
    SolveSliding(t, x, ws);
    rec.kind = "slide";
    rec.description = fmt::format("{} held at 0 by sign = {:.6g} (its rate {:.6g} with +1, {:.6g} with -1: Filippov's "
                                  "equivalent value): {} in {}",
                                  k.function, ws.slots[static_cast<size_t>(k.slide_slot) + 1], above, below, k.formula, k.what);
    return rec;
  }
  // Crossed: the other branch (a free sign: the side the motion goes to).
  const double side = mode == Workspace::kLocked ? -held : (above > 0.0 ? 1.0 : -1.0);
  SetSlide(ws, index, Workspace::kLocked, side);
  return rec;
}

void CompiledModel::InitializeKinks(double t, const double* x, Workspace& ws, double hysteresis) const {
  if (events_.slides.empty()) return;
  ws.kink_hysteresis = hysteresis;
  std::vector<double> xdot(num_states());
  for (const int index : events_.slides) SetSlide(ws, index, Workspace::kFree, 0.0);
  CalcDerivatives(t, x, xdot.data(), ws);
  for (const int index : events_.slides) {
    const KinkTable::Kink& k = events_.kinks.kinks()[static_cast<size_t>(index)];
    const double g = expr::Run(k.program, t, x, ws.slots.data());
    if (g != 0.0) {
      SetSlide(ws, index, Workspace::kLocked, g > 0.0 ? 1.0 : -1.0);
      continue;
    }
    const auto [above, below] = RatesEitherSide(t, x, ws, index);
    SetSlide(ws, index, Holds(above, below) && constraints_.empty() ? Workspace::kSliding : Workspace::kFree, 0.0);
  }
}

}  // namespace multibond
