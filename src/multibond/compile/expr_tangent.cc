// A formula's directional derivative (expr_program.h, RunTangent): forward-mode differentiation
// of the program's steps, each step's value and its derivative together, with the partial
// derivatives of the functions written out below (exact, not finite differences). Used by the
// linearisation only (analysis/linearize.cc), never by the right-hand side.

#include <cmath>

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

}  // namespace multibond::expr
