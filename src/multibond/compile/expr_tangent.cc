// A formula's directional derivative (expr_program.h, RunTangent): forward-mode differentiation
// of the program's steps, each step's value and its derivative together, with the partial
// derivatives of the functions written out below (exact, not finite differences). Used by the
// linearisation (analysis/linearize.cc), the Newton iteration of nonlinear algebraic loops, and
// the ideal-constraint solver for the formulas its constraints read (their time derivatives and
// B's columns through them, every evaluation: it allocates nothing). Degree classifies a program
// as constant, affine or nonlinear in chosen inputs (what the constraint solver accepts).

#include <algorithm>
#include <cmath>
#include <functional>

#include "multibond/compile/expr_program.h"
#include "multibond/core/error.h"

namespace multibond::expr {

namespace {

/// The partial derivatives of f at its arguments a (value v = f(a)) into da. Away from a kink the
/// derivative of the branch the function takes. Exactly at a kink the mean of the one-sided
/// slopes (docs/linear-analysis.md, "At a kink"), as the symbolic derivatives (compile/symbolic.cc)
/// have it: min and max at a tie a == b half of each argument's; clamp(x, lo, hi) at x == lo
/// (or hi) half for x and half for that bound (at lo == x == hi, half for each bound, none for
/// x); abs at 0 the mean of -1 and 1, 0; sign 0 everywhere (its jump at 0 has no slope).
/// (Comparisons, logic and if are not here: RunTangent takes their derivatives itself.)
void Partials(Fn fn, const double* a, double v, double* da) {
  switch (fn) {
    case Fn::kSin: da[0] = std::cos(a[0]); break;
    case Fn::kCos: da[0] = -std::sin(a[0]); break;
    case Fn::kTan: da[0] = 1.0 + v * v; break;
    case Fn::kAsin: da[0] = 1.0 / std::sqrt(1.0 - a[0] * a[0]); break;
    case Fn::kAcos: da[0] = -1.0 / std::sqrt(1.0 - a[0] * a[0]); break;
    case Fn::kAtan: da[0] = 1.0 / (1.0 + a[0] * a[0]); break;
    case Fn::kAtan2: {  // atan2(y, x)
      const double r2 = a[0] * a[0] + a[1] * a[1];
      da[0] = a[1] / r2;
      da[1] = -a[0] / r2;
      break;
    }
    case Fn::kSinh: da[0] = std::cosh(a[0]); break;
    case Fn::kCosh: da[0] = std::sinh(a[0]); break;
    case Fn::kTanh: da[0] = 1.0 - v * v; break;
    case Fn::kExp: da[0] = v; break;
    case Fn::kLog: da[0] = 1.0 / a[0]; break;
    case Fn::kSqrt: da[0] = 0.5 / v; break;
    case Fn::kAbs: da[0] = a[0] > 0.0 ? 1.0 : (a[0] < 0.0 ? -1.0 : 0.0); break;
    case Fn::kSign: da[0] = 0.0; break;
    case Fn::kMin:  // mb_min takes b when b < a; a tie: half of each
      da[0] = a[0] == a[1] ? 0.5 : (a[1] < a[0] ? 0.0 : 1.0);
      da[1] = 1.0 - da[0];
      break;
    case Fn::kMax:  // mb_max takes b when a < b; a tie: half of each
      da[0] = a[0] == a[1] ? 0.5 : (a[0] < a[1] ? 0.0 : 1.0);
      da[1] = 1.0 - da[0];
      break;
    case Fn::kHypot:
      da[0] = v > 0.0 ? a[0] / v : 0.0;
      da[1] = v > 0.0 ? a[1] / v : 0.0;
      break;
    case Fn::kClamp: {  // clamp(x, lo, hi): lo if x < lo, else hi if hi < x, else x
      const double x = a[0], lo = a[1], hi = a[2];
      if (x == lo && x == hi) {  // lo on one side, hi on the other
        da[0] = 0.0, da[1] = 0.5, da[2] = 0.5;
      } else if (x == lo && !(hi < x)) {  // at the lower bound: lo below, x above
        da[0] = 0.5, da[1] = 0.5, da[2] = 0.0;
      } else if (x == hi && !(x < lo)) {  // at the upper bound: x below, hi above
        da[0] = 0.5, da[1] = 0.0, da[2] = 0.5;
      } else {
        da[0] = (x < lo || hi < x) ? 0.0 : 1.0;
        da[1] = x < lo ? 1.0 : 0.0;
        da[2] = (!(x < lo) && hi < x) ? 1.0 : 0.0;
      }
      break;
    }
    case Fn::kSmoothAbs:  // sqrt(x^2 + eps^2)
      da[0] = a[0] / v;
      da[1] = a[1] / v;
      break;
    case Fn::kSmoothSign: {  // x / sqrt(x^2 + eps^2)
      const double s = std::sqrt(a[0] * a[0] + a[1] * a[1]);
      const double s3 = s * s * s;
      da[0] = a[1] * a[1] / s3;
      da[1] = -a[0] * a[1] / s3;
      break;
    }
    case Fn::kLt: case Fn::kLe: case Fn::kGt: case Fn::kGe: case Fn::kEq: case Fn::kNe:
    case Fn::kAnd: case Fn::kOr: case Fn::kNot: case Fn::kIf:
      MB_ASSERT(false, "a function RunTangent differentiates itself");
  }
}

/// The second partial derivatives of f at a (v = f(a)) into h (row-major, arity x arity), where
/// Partials gives the first: zero for the piecewise-linear functions and at their kinks, and for
/// sign (piecewise constant).
void SecondPartials(Fn fn, const double* a, double v, double* h) {
  for (int k = 0; k < 9; ++k) h[k] = 0.0;
  switch (fn) {
    case Fn::kSin: h[0] = -v; break;
    case Fn::kCos: h[0] = -v; break;
    case Fn::kTan: h[0] = 2.0 * v * (1.0 + v * v); break;
    case Fn::kAsin: h[0] = a[0] / std::pow(1.0 - a[0] * a[0], 1.5); break;
    case Fn::kAcos: h[0] = -a[0] / std::pow(1.0 - a[0] * a[0], 1.5); break;
    case Fn::kAtan: {
      const double q = 1.0 + a[0] * a[0];
      h[0] = -2.0 * a[0] / (q * q);
      break;
    }
    case Fn::kAtan2: {  // atan2(y, x), r2 = x^2 + y^2
      const double y = a[0], x = a[1], r2 = x * x + y * y, r4 = r2 * r2;
      h[0] = -2.0 * x * y / r4;          // d2/dy2
      h[1] = h[2] = (y * y - x * x) / r4;  // d2/dydx
      h[3] = 2.0 * x * y / r4;           // d2/dx2 (index 1 * 2 + 1 in a 2 x 2 table)
      break;
    }
    case Fn::kSinh: h[0] = v; break;
    case Fn::kCosh: h[0] = v; break;
    case Fn::kTanh: h[0] = -2.0 * v * (1.0 - v * v); break;
    case Fn::kExp: h[0] = v; break;
    case Fn::kLog: h[0] = -1.0 / (a[0] * a[0]); break;
    case Fn::kSqrt: h[0] = -0.25 / (v * v * v); break;
    case Fn::kHypot:
    case Fn::kSmoothAbs: {  // sqrt(x^2 + y^2)
      if (!(v > 0.0)) break;
      const double v3 = v * v * v;
      h[0] = a[1] * a[1] / v3;
      h[1] = h[2] = -a[0] * a[1] / v3;
      h[3] = a[0] * a[0] / v3;
      break;
    }
    case Fn::kSmoothSign: {  // x / s, s = sqrt(x^2 + e^2)
      const double x = a[0], e = a[1], s = std::sqrt(x * x + e * e), s5 = s * s * s * s * s;
      h[0] = -3.0 * x * e * e / s5;
      h[1] = h[2] = e * (2.0 * x * x - e * e) / s5;
      h[3] = x * (2.0 * e * e - x * x) / s5;
      break;
    }
    case Fn::kAbs: case Fn::kSign: case Fn::kMin: case Fn::kMax: case Fn::kClamp:
      break;
    case Fn::kLt: case Fn::kLe: case Fn::kGt: case Fn::kGe: case Fn::kEq: case Fn::kNe:
    case Fn::kAnd: case Fn::kOr: case Fn::kNot: case Fn::kIf:
      MB_ASSERT(false, "a function RunSecondTangent differentiates itself");
  }
}

}  // namespace

double RunTangent(const Program& p, double t, const double* x, const double* w, double dt, const double* dx, const double* dw,
                  double* value) {
  double regs[kMaxRegs], dregs[kMaxRegs];
  for (const Step& s : p.steps) {
    double v = 0.0, dv = 0.0;
    switch (s.op) {
      case Step::Op::kLoad:
        switch (s.input.in) {
          case Input::In::kTime: v = t, dv = dt; break;
          case Input::In::kState: v = x[s.input.offset], dv = dx[s.input.offset]; break;
          case Input::In::kSlot: v = w[s.input.offset], dv = dw[s.input.offset]; break;
          case Input::In::kConstant: v = s.input.value; break;
        }
        break;
      case Step::Op::kConst: v = s.value; break;
      case Step::Op::kNeg: v = -regs[s.a], dv = -dregs[s.a]; break;
      case Step::Op::kAdd: v = regs[s.a] + regs[s.b], dv = dregs[s.a] + dregs[s.b]; break;
      case Step::Op::kSub: v = regs[s.a] - regs[s.b], dv = dregs[s.a] - dregs[s.b]; break;
      case Step::Op::kMul: v = regs[s.a] * regs[s.b], dv = dregs[s.a] * regs[s.b] + regs[s.a] * dregs[s.b]; break;
      case Step::Op::kDiv:
        v = regs[s.a] / regs[s.b];
        dv = (dregs[s.a] - v * dregs[s.b]) / regs[s.b];
        break;
      case Step::Op::kPow: {
        const double a = regs[s.a], b = regs[s.b];
        v = Power(a, b);
        // d(a^b) = b a^(b-1) da + a^b ln(a) db; the second term only where b moves.
        dv = dregs[s.a] == 0.0 ? 0.0 : b * Power(a, b - 1.0) * dregs[s.a];
        if (dregs[s.b] != 0.0) dv += v * std::log(a) * dregs[s.b];
        break;
      }
      case Step::Op::kCall: {
        if (s.fn == Fn::kIf) {
          // A select: the value and the derivative of the branch taken, the other's (a NaN, an
          // infinity) never multiplied in; the condition is piecewise constant.
          const double args[3] = {regs[s.a], regs[s.b], regs[s.c]};
          v = Apply(s.fn, args);
          const double pick_true[3] = {regs[s.a], 1.0, 0.0};
          dv = Apply(s.fn, pick_true) == 1.0 ? dregs[s.b] : dregs[s.c];
          break;
        }
        if (IsComparison(s.fn) || s.fn == Fn::kAnd || s.fn == Fn::kOr || s.fn == Fn::kNot) {
          // Piecewise constant (0 or 1): derivative 0, whatever the operands' derivatives hold.
          const double args[2] = {regs[s.a], regs[s.b]};
          v = Apply(s.fn, args);
          break;
        }
        const int arity = Info(s.fn).arity;
        const int at[3] = {s.a, s.b, s.c};
        double args[3] = {0.0, 0.0, 0.0}, partials[3] = {0.0, 0.0, 0.0};
        for (int k = 0; k < arity; ++k) args[k] = regs[at[k]];
        v = Apply(s.fn, args);
        Partials(s.fn, args, v, partials);
        for (int k = 0; k < arity; ++k)
          if (dregs[at[k]] != 0.0) dv += partials[k] * dregs[at[k]];
        break;
      }
    }
    regs[s.dst] = v;
    dregs[s.dst] = dv;
  }
  if (value) *value = regs[p.result];
  return dregs[p.result];
}

double RunSecondTangent(const Program& p, double t, const double* x, const double* w, const Direction& v, const Direction& f,
                        const double* ddw) {
  // Each register as a hyper-dual number: its value, its derivatives along v and f, and the mixed
  // second derivative along both (the directions themselves constant).
  double r[kMaxRegs], rv[kMaxRegs], rf[kMaxRegs], rvf[kMaxRegs];
  for (const Step& s : p.steps) {
    double o = 0.0, ov = 0.0, of = 0.0, ovf = 0.0;
    const int a = s.a, b = s.b;
    switch (s.op) {
      case Step::Op::kLoad:
        switch (s.input.in) {
          case Input::In::kTime: o = t, ov = v.dt, of = f.dt; break;
          case Input::In::kState: o = x[s.input.offset], ov = v.dx[s.input.offset], of = f.dx[s.input.offset]; break;
          case Input::In::kSlot:
            o = w[s.input.offset], ov = v.dw[s.input.offset], of = f.dw[s.input.offset], ovf = ddw[s.input.offset];
            break;
          case Input::In::kConstant: o = s.input.value; break;
        }
        break;
      case Step::Op::kConst: o = s.value; break;
      case Step::Op::kNeg: o = -r[a], ov = -rv[a], of = -rf[a], ovf = -rvf[a]; break;
      case Step::Op::kAdd: o = r[a] + r[b], ov = rv[a] + rv[b], of = rf[a] + rf[b], ovf = rvf[a] + rvf[b]; break;
      case Step::Op::kSub: o = r[a] - r[b], ov = rv[a] - rv[b], of = rf[a] - rf[b], ovf = rvf[a] - rvf[b]; break;
      case Step::Op::kMul:
        o = r[a] * r[b];
        ov = rv[a] * r[b] + r[a] * rv[b];
        of = rf[a] * r[b] + r[a] * rf[b];
        ovf = rvf[a] * r[b] + rv[a] * rf[b] + rf[a] * rv[b] + r[a] * rvf[b];
        break;
      case Step::Op::kDiv: {  // a * (1/b): (1/b)' = -b'/b^2, (1/b)'' = 2 b_v b_f / b^3 - b_vf / b^2
        const double q = 1.0 / r[b], qv = -rv[b] * q * q, qf = -rf[b] * q * q;
        const double qvf = 2.0 * rv[b] * rf[b] * q * q * q - rvf[b] * q * q;
        o = r[a] / r[b];
        ov = rv[a] * q + r[a] * qv;
        of = rf[a] * q + r[a] * qf;
        ovf = rvf[a] * q + rv[a] * qf + rf[a] * qv + r[a] * qvf;
        break;
      }
      case Step::Op::kPow: {
        const double base = r[a], e = r[b];
        o = Power(base, e);
        if (rv[b] == 0.0 && rf[b] == 0.0 && rvf[b] == 0.0) {  // a constant exponent (any sign of the base)
          const double d1 = e * Power(base, e - 1.0), d2 = e * (e - 1.0) * Power(base, e - 2.0);
          ov = d1 * rv[a], of = d1 * rf[a], ovf = d1 * rvf[a] + d2 * rv[a] * rf[a];
        } else {  // a^b = exp(b ln a)
          const double ln = std::log(base);
          const double gv = rv[b] * ln + e * rv[a] / base, gf = rf[b] * ln + e * rf[a] / base;
          const double gvf = rvf[b] * ln + (rv[b] * rf[a] + rf[b] * rv[a]) / base + e * (rvf[a] / base - rv[a] * rf[a] / (base * base));
          ov = o * gv, of = o * gf, ovf = o * (gvf + gv * gf);
        }
        break;
      }
      case Step::Op::kCall: {
        if (s.fn == Fn::kIf) {  // the branch taken, whole
          const double args[3] = {r[a], r[b], r[s.c]};
          o = Apply(s.fn, args);
          const double pick_true[3] = {r[a], 1.0, 0.0};
          const int k = Apply(s.fn, pick_true) == 1.0 ? b : s.c;
          ov = rv[k], of = rf[k], ovf = rvf[k];
          break;
        }
        if (IsComparison(s.fn) || s.fn == Fn::kAnd || s.fn == Fn::kOr || s.fn == Fn::kNot) {
          const double args[2] = {r[a], r[b]};
          o = Apply(s.fn, args);
          break;
        }
        const int arity = Info(s.fn).arity;
        const int at[3] = {a, b, s.c};
        double args[3] = {0.0, 0.0, 0.0}, d1[3] = {0.0, 0.0, 0.0}, d2[9];
        for (int k = 0; k < arity; ++k) args[k] = r[at[k]];
        o = Apply(s.fn, args);
        Partials(s.fn, args, o, d1);
        SecondPartials(s.fn, args, o, d2);
        for (int i = 0; i < arity; ++i) {
          ov += d1[i] * rv[at[i]];
          of += d1[i] * rf[at[i]];
          ovf += d1[i] * rvf[at[i]];
          for (int j = 0; j < arity; ++j) {
            const double hij = d2[i * arity + j];
            if (hij != 0.0) ovf += hij * rv[at[i]] * rf[at[j]];
          }
        }
        break;
      }
    }
    r[s.dst] = o, rv[s.dst] = ov, rf[s.dst] = of, rvf[s.dst] = ovf;
  }
  return rvf[p.result];
}

}  // namespace multibond::expr

namespace multibond::expr {

double RunTangentIndexed(const void* programs, int index, double t, const double* x, const double* w, double dt, const double* dx,
                         const double* dw) {
  return RunTangent(static_cast<const Program*>(programs)[index], t, x, w, dt, dx, dw);
}

int Degree(const Program& p, const std::function<bool(const Input&)>& moving) {
  // Per register: 0 constant in the inputs that move, 1 affine in them with coefficients that do
  // not move, 2 anything else (a product of two, a function or a comparison of one, a divisor).
  unsigned char deg[kMaxRegs] = {};
  auto at_most = [](int d) { return static_cast<unsigned char>(d > 2 ? 2 : d); };
  for (const Step& s : p.steps) {
    int d = 0;
    switch (s.op) {
      case Step::Op::kLoad: d = s.input.in != Input::In::kConstant && moving(s.input) ? 1 : 0; break;
      case Step::Op::kConst: d = 0; break;
      case Step::Op::kNeg: d = deg[s.a]; break;
      case Step::Op::kAdd:
      case Step::Op::kSub: d = std::max(deg[s.a], deg[s.b]); break;
      case Step::Op::kMul: d = deg[s.a] + deg[s.b]; break;
      case Step::Op::kDiv: d = deg[s.b] > 0 ? 2 : deg[s.a]; break;
      case Step::Op::kPow: d = deg[s.a] > 0 || deg[s.b] > 0 ? 2 : 0; break;
      case Step::Op::kCall:
        if (s.fn == Fn::kIf) {  // a select by a condition that does not move: the branch's degree
          d = deg[s.a] > 0 ? 2 : std::max(deg[s.b], deg[s.c]);
        } else {
          const int at[3] = {s.a, s.b, s.c};
          for (int k = 0; k < Info(s.fn).arity; ++k) d = std::max<int>(d, deg[at[k]] > 0 ? 2 : 0);
        }
        break;
    }
    deg[s.dst] = at_most(d);
  }
  return p.steps.empty() ? 0 : deg[p.result];
}

}  // namespace multibond::expr
