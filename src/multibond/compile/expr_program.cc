#include "multibond/compile/expr_program.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <utility>

#include <fmt/format.h>

#include "multibond/compile/code_text.h"
#include "multibond/core/error.h"

namespace multibond::expr {

namespace {

/// The value of an operator on constants: the very operation Run performs (this file is compiled
/// with -ffp-contract=off, as the generated code is), so folding changes no bit.
double Fold(Step::Op op, double a, double b) {
  switch (op) {
    case Step::Op::kNeg: return -a;
    case Step::Op::kAdd: return a + b;
    case Step::Op::kSub: return a - b;
    case Step::Op::kMul: return a * b;
    case Step::Op::kDiv: return a / b;
    case Step::Op::kPow: return Power(a, b);
    default: MB_ASSERT(false, "an operator");
  }
}

Step::Op OpOf(Node::Kind kind) {
  switch (kind) {
    case Node::Kind::kNeg: return Step::Op::kNeg;
    case Node::Kind::kAdd: return Step::Op::kAdd;
    case Node::Kind::kSub: return Step::Op::kSub;
    case Node::Kind::kMul: return Step::Op::kMul;
    case Node::Kind::kDiv: return Step::Op::kDiv;
    case Node::Kind::kPow: return Step::Op::kPow;
    default: MB_ASSERT(false, "an operator node");
  }
}

/// Post-order walk of the tree: a subtree whose leaves are all numbers or constant inputs is
/// folded into a value; anything else is computed into a register. Registers are taken lowest
/// first and given back as soon as their value has been used, so a program needs as many as the
/// deepest chain of pending operands.
class Compiler {
 public:
  Compiler(const Node& root, const Resolver& resolve) : root_(root), resolve_(resolve) {}

  Program Compile() {
    const Value v = Walk(root_);
    p_.result = InRegister(v);
    return std::move(p_);
  }

 private:
  struct Value {
    bool constant = false;
    double value = 0.0;
    int reg = -1;
  };

  int Take() {
    for (size_t r = 0; r < busy_.size(); ++r)
      if (!busy_[r]) {
        busy_[r] = true;
        return static_cast<int>(r);
      }
    if (busy_.size() >= static_cast<size_t>(kMaxRegs)) {
      Diagnostic d;
      d.message = fmt::format("the formula '{}' needs more than {} intermediate values at once", Format(root_), kMaxRegs);
      d.hint = "split it into parameters, or sum its terms from the left";
      d.code = "expr.too_large";
      throw ModelError(std::move(d));
    }
    busy_.push_back(true);
    p_.num_regs = static_cast<int>(busy_.size());
    return p_.num_regs - 1;
  }
  void Give(const Value& v) {
    if (!v.constant) busy_[static_cast<size_t>(v.reg)] = false;
  }
  int InRegister(const Value& v) {
    if (!v.constant) return v.reg;
    Step s;
    s.op = Step::Op::kConst;
    s.value = v.value;
    s.dst = Take();
    p_.steps.push_back(s);
    return s.dst;
  }
  static Value Constant(double v) { return Value{true, v, -1}; }

  Value Walk(const Node& n) {
    switch (n.kind) {
      case Node::Kind::kNumber: return Constant(n.value);
      case Node::Kind::kName: return Load(n);
      case Node::Kind::kNeg: {
        const Value a = Walk(*n.args[0]);
        if (a.constant) return Constant(Fold(Step::Op::kNeg, a.value, 0.0));
        Give(a);
        Step s;
        s.op = Step::Op::kNeg;
        s.a = a.reg;
        s.dst = Take();
        p_.steps.push_back(s);
        return Value{false, 0.0, s.dst};
      }
      case Node::Kind::kAdd:
      case Node::Kind::kSub:
      case Node::Kind::kMul:
      case Node::Kind::kDiv:
      case Node::Kind::kPow: {
        const Step::Op op = OpOf(n.kind);
        Value a = Walk(*n.args[0]);
        Value b = Walk(*n.args[1]);
        if (a.constant && b.constant) return Constant(Fold(op, a.value, b.value));
        Step s;
        s.op = op;
        s.a = InRegister(a);
        s.b = InRegister(b);
        a.constant = b.constant = false;
        a.reg = s.a;
        b.reg = s.b;
        Give(a);
        Give(b);
        s.dst = Take();
        p_.steps.push_back(s);
        return Value{false, 0.0, s.dst};
      }
      case Node::Kind::kCall: {
        std::array<Value, 3> v{};
        MB_ASSERT(n.args.size() <= v.size() && static_cast<int>(n.args.size()) == Info(n.fn).arity, "a call of the table");
        const size_t count = std::min(n.args.size(), v.size());  // (the bound, for GCC's -Wstringop-overflow)
        bool constant = true;
        for (size_t i = 0; i < count; ++i) {
          v[i] = Walk(*n.args[i]);
          constant = constant && v[i].constant;
        }
        if (constant) {
          std::array<double, 3> args{v[0].value, v[1].value, v[2].value};
          return Constant(Apply(n.fn, args.data()));
        }
        Step s;
        s.op = Step::Op::kCall;
        s.fn = n.fn;
        std::array<int, 3> regs{};
        for (size_t i = 0; i < count; ++i) {
          regs[i] = InRegister(v[i]);
          v[i] = Value{false, 0.0, regs[i]};
        }
        // Run reads three registers: an unused one repeats the first (read, never used).
        for (size_t i = count; i < regs.size(); ++i) regs[i] = regs[0];
        for (size_t i = 0; i < count; ++i) Give(v[i]);
        s.a = regs[0];
        s.b = regs[1];
        s.c = regs[2];
        s.dst = Take();
        p_.steps.push_back(s);
        return Value{false, 0.0, s.dst};
      }
    }
    MB_ASSERT(false, "a node kind");
  }

  Value Load(const Node& n) {
    const Input in = resolve_(n);
    if (in.in == Input::In::kConstant) return Constant(in.value);
    bool seen = false;
    for (const Input& i : p_.inputs) seen = seen || (i.in == in.in && i.offset == in.offset);
    if (!seen) p_.inputs.push_back(in);
    Step s;
    s.op = Step::Op::kLoad;
    s.input = in;
    s.dst = Take();
    p_.steps.push_back(s);
    return Value{false, 0.0, s.dst};
  }

  const Node& root_;
  const Resolver& resolve_;
  Program p_;
  std::vector<bool> busy_;
};

/// An exact literal of any double: hexadecimal for finite values (code::Lit), the bits for
/// infinities and NaNs (a folded 1/0 or 0/0 keeps its sign and payload).
std::string ExactLit(double v) {
  if (std::isfinite(v)) return code::Lit(v);
  return fmt::format("(__builtin_bit_cast(double, 0x{:016x}ULL))", std::bit_cast<std::uint64_t>(v));
}

}  // namespace

Program CompileProgram(const Node& root, const Resolver& resolve) { return Compiler(root, resolve).Compile(); }

double Run(const Program& p, double t, const double* x, const double* w) {
  double regs[kMaxRegs];
  for (const Step& s : p.steps) {
    double& d = regs[s.dst];
    switch (s.op) {
      case Step::Op::kLoad:
        switch (s.input.in) {
          case Input::In::kTime: d = t; break;
          case Input::In::kState: d = x[s.input.offset]; break;
          case Input::In::kSlot: d = w[s.input.offset]; break;
          case Input::In::kConstant: d = s.input.value; break;
        }
        break;
      case Step::Op::kConst: d = s.value; break;
      case Step::Op::kNeg: d = -regs[s.a]; break;
      case Step::Op::kAdd: d = regs[s.a] + regs[s.b]; break;
      case Step::Op::kSub: d = regs[s.a] - regs[s.b]; break;
      case Step::Op::kMul: d = regs[s.a] * regs[s.b]; break;
      case Step::Op::kDiv: d = regs[s.a] / regs[s.b]; break;
      case Step::Op::kPow: d = Power(regs[s.a], regs[s.b]); break;
      case Step::Op::kCall: {
        const double args[3] = {regs[s.a], regs[s.b], regs[s.c]};
        d = Apply(s.fn, args);
        break;
      }
    }
  }
  return regs[p.result];
}

double SolveFor(const Program& law, const Program& slope, int unknown, double target, double t, const double* x, double* w) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  auto h = [&](double u) {
    w[unknown] = u;
    return Run(law, t, x, w) - target;
  };
  auto dh = [&](double u) {
    w[unknown] = u;
    return Run(slope, t, x, w);
  };
  if (!std::isfinite(target)) return w[unknown] = nan;
  double a = 0.0, ha = h(a);
  if (ha == 0.0) return 0.0;
  if (std::isnan(ha)) return w[unknown] = nan;
  // Bracket the root: outwards from 0 towards where h changes sign (an increasing law: up if
  // h(0) < 0), the first step from the slope at 0, then doubling.
  const double dir = ha < 0.0 ? 1.0 : -1.0;
  const double d0 = dh(0.0);
  double step = std::isfinite(d0) && d0 > 0.0 ? std::fabs(ha) / d0 : 1.0;
  if (!(step > 0.0 && std::isfinite(step))) step = 1.0;
  double b = dir * step, hb = h(b);
  // An infinite h (an exponential law far out) is a side of the bracket like any other; NaN is not.
  for (int k = 0; k < 2200 && !std::isnan(hb) && hb != 0.0 && (hb < 0.0) == (ha < 0.0); ++k) {
    a = b;
    ha = hb;
    b *= 2.0;
    hb = h(b);
  }
  if (hb == 0.0) return b;
  if (std::isnan(hb) || (hb < 0.0) == (ha < 0.0)) return w[unknown] = nan;
  double lo = ha < 0.0 ? a : b, hi = ha < 0.0 ? b : a;  // h(lo) < 0 < h(hi)
  double u = b;
  double hu = hb;
  // Newton's step where it stays inside the bracket and at least halves the step before the
  // last, else bisection (Numerical Recipes' rtsafe): never slower than bisection, so the bracket
  // shrinks to adjacent doubles within ~2,100 iterations from any start.
  double dx_old = std::fabs(hi - lo), dx = dx_old;
  for (int it = 0; it < 2200; ++it) {
    const double du = dh(u);
    const double mn = std::min(lo, hi), mx = std::max(lo, hi);
    double next = u - hu / du;
    const bool bisect = !(next > mn && next < mx) || !(std::fabs(2.0 * hu) <= std::fabs(dx_old * du));
    dx_old = dx;
    if (bisect) next = 0.5 * (lo + hi);  // NaN-safe: every test above fails on a NaN
    dx = std::fabs(next - u);
    if (next == u || std::nextafter(mn, mx) >= mx) break;
    u = next;
    hu = h(u);
    if (hu == 0.0) break;
    if (std::isnan(hu)) return w[unknown] = nan;
    (hu < 0.0 ? lo : hi) = u;
  }
  w[unknown] = u;
  return u;
}

double SolveForIndexed(const void* programs, int law, int slope, int unknown, double target, double t, const double* x, double* w) {
  const Program* p = static_cast<const Program*>(programs);
  return SolveFor(p[law], p[slope], unknown, target, t, x, w);
}

std::string EmitProgram(const Program& p, const std::string& prefix, const EmitNames& names, std::string& out) {
  // Each step gets its own constant (a register's successive values are distinct names).
  std::vector<std::string> reg(static_cast<size_t>(p.num_regs));
  auto r = [&](int i) -> const std::string& { return reg[static_cast<size_t>(i)]; };
  for (size_t k = 0; k < p.steps.size(); ++k) {
    const Step& s = p.steps[k];
    std::string e;
    switch (s.op) {
      case Step::Op::kLoad:
        switch (s.input.in) {
          case Input::In::kTime: e = names.t; break;
          case Input::In::kState: e = fmt::format("{}[{}]", names.x, s.input.offset); break;
          case Input::In::kSlot: e = fmt::format("{}[{}]", names.w, s.input.offset); break;
          case Input::In::kConstant: e = ExactLit(s.input.value); break;
        }
        break;
      case Step::Op::kConst: e = ExactLit(s.value); break;
      case Step::Op::kNeg: e = code::Neg(r(s.a)); break;
      case Step::Op::kAdd: e = r(s.a) + " + " + r(s.b); break;
      case Step::Op::kSub: e = r(s.a) + " - " + r(s.b); break;
      case Step::Op::kMul: e = r(s.a) + " * " + r(s.b); break;
      case Step::Op::kDiv: e = r(s.a) + " / " + r(s.b); break;
      case Step::Op::kPow: e = fmt::format("mb_pow({}, {})", r(s.a), r(s.b)); break;
      case Step::Op::kCall: {
        const int arity = Info(s.fn).arity;
        e = fmt::format("mb_{}({}", Info(s.fn).name, r(s.a));
        if (arity > 1) e += ", " + r(s.b);
        if (arity > 2) e += ", " + r(s.c);
        e += ")";
        break;
      }
    }
    std::string name = fmt::format("{}{}", prefix, k);
    out += fmt::format("  const double {} = {};\n", name, e);
    reg[static_cast<size_t>(s.dst)] = std::move(name);
  }
  return r(p.result);
}

std::string ProgramPreamble() {
  return std::string("#include <cmath>\n// The functions of formulas (multibond core/expression.cc), as the interpreter runs them.\n") +
         FunctionDefinitions();
}

}  // namespace multibond::expr
