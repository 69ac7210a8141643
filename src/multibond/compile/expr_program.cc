#include "multibond/compile/expr_program.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>
#include <utility>

#include <fmt/format.h>

#include "multibond/compile/code_text.h"
#include "multibond/core/diagnostic_codes.h"
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
      d.code = codes::kExprTooLarge;
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

/// The steps as Run executes them (Program::code): a load or a constant step only records where
/// its register's value is to be read, and the operations that use the register read it there
/// (nothing writes the state, the slots or the time while a program runs, so reading an input at
/// its use gives the value it had at its load). The operations are the steps' own, in their
/// order; `^` with a constant exponent of 2, 3 or -1 becomes what Power() computes for it.
void Lower(Program& p) {
  // Each register's current value: a constant (not yet among the program's constants: an
  // operator takes it as its k), or an operand.
  struct Value {
    std::optional<double> constant;
    std::uint32_t operand = 0;
  };
  std::vector<Value> at(static_cast<size_t>(p.num_regs));
  // The register's value as an operand: a constant is put among the program's constants (once).
  auto operand = [&](int reg) {
    const Value& v = at[static_cast<size_t>(reg)];
    if (!v.constant) return v.operand;
    const auto bits = std::bit_cast<std::uint64_t>(*v.constant);
    size_t k = 0;
    while (k < p.constants.size() && std::bit_cast<std::uint64_t>(p.constants[k]) != bits) ++k;
    if (k == p.constants.size()) p.constants.push_back(*v.constant);
    return MakeOperand(kInConstants, static_cast<std::uint32_t>(k));
  };
  auto constant = [&](int reg) { return at[static_cast<size_t>(reg)].constant; };
  p.code.reserve(static_cast<size_t>(std::count_if(p.steps.begin(), p.steps.end(), [](const Step& s) {
    return s.op != Step::Op::kLoad && s.op != Step::Op::kConst;
  })));
  for (const Step& s : p.steps) {
    RunStep r;
    using Op = RunStep::Op;
    // A binary operator: with a constant operand (in r.k), or on two operands.
    auto binary = [&](Op on_two, Op with_k, Op k_with) {
      if (const std::optional<double> b = constant(s.b)) {
        r.op = with_k;
        r.a = operand(s.a);
        r.k = *b;
      } else if (const std::optional<double> a = constant(s.a)) {
        r.op = k_with;
        r.a = operand(s.b);
        r.k = *a;
      } else {
        r.op = on_two;
        r.a = operand(s.a);
        r.b = operand(s.b);
      }
    };
    Value& dst = at[static_cast<size_t>(s.dst)];
    switch (s.op) {
      case Step::Op::kLoad:
        switch (s.input.in) {
          case Input::In::kTime: dst = {std::nullopt, MakeOperand(kInTime, 0)}; break;
          case Input::In::kState:
          case Input::In::kSlot:
            MB_ASSERT(s.input.offset >= 0 && s.input.offset < (1 << 29), "an offset an operand holds");
            dst = {std::nullopt, MakeOperand(s.input.in == Input::In::kState ? kInState : kInSlot, static_cast<std::uint32_t>(s.input.offset))};
            break;
          case Input::In::kConstant: dst = {s.input.value, 0}; break;
        }
        continue;
      case Step::Op::kConst: dst = {s.value, 0}; continue;
      case Step::Op::kNeg:
        r.op = Op::kNeg;
        r.a = operand(s.a);
        break;
      case Step::Op::kAdd: binary(Op::kAdd, Op::kAddK, Op::kKAdd); break;
      case Step::Op::kSub: binary(Op::kSub, Op::kSubK, Op::kKSub); break;
      case Step::Op::kMul: binary(Op::kMul, Op::kMulK, Op::kKMul); break;
      case Step::Op::kDiv: binary(Op::kDiv, Op::kDivK, Op::kKDiv); break;
      case Step::Op::kPow:
        binary(Op::kPow, Op::kPowK, Op::kKPow);
        if (r.op == Op::kPowK && r.k == 2.0) r.op = Op::kSquare;
        if (r.op == Op::kPowK && r.k == 3.0) r.op = Op::kCube;
        if (r.op == Op::kPowK && r.k == -1.0) r.op = Op::kRecip;
        break;
      case Step::Op::kCall: {
        const int arity = Info(s.fn).arity;
        r.op = arity == 1 ? Op::kCall1 : arity == 2 ? Op::kCall2 : Op::kCall3;
        r.fn = s.fn;
        r.a = operand(s.a);
        if (arity > 1) r.b = operand(s.b);
        if (arity > 2) r.c = operand(s.c);
        break;
      }
    }
    r.dst = static_cast<unsigned char>(s.dst);
    p.code.push_back(r);
    dst = {std::nullopt, MakeOperand(kInRegister, static_cast<std::uint32_t>(s.dst))};
  }
  p.value = operand(p.result);
  if (p.code.size() <= p.short_code.size()) {
    std::copy(p.code.begin(), p.code.end(), p.short_code.begin());
    p.short_size = static_cast<int>(p.code.size());
  }
}

}  // namespace

Program CompileProgram(const Node& root, const Resolver& resolve) {
  Program p = Compiler(root, resolve).Compile();
  Lower(p);
  return p;
}

double Run(const Program& p, double t, const double* x, const double* w) {
  double regs[kMaxRegs];
  const double* const from[5] = {regs, p.constants.data(), x, w, &t};  // by OperandPlace
  auto get = [&from](std::uint32_t o) { return from[o & 7u][o >> 3]; };
  const bool short_code = p.short_size >= 0;
  const RunStep* const begin = short_code ? p.short_code.data() : p.code.data();
  const RunStep* const end = begin + (short_code ? static_cast<size_t>(p.short_size) : p.code.size());
  for (const RunStep* step = begin; step != end; ++step) {
    const RunStep& s = *step;
    double v;
    switch (s.op) {
      case RunStep::Op::kNeg: v = -get(s.a); break;
      case RunStep::Op::kAdd: v = get(s.a) + get(s.b); break;
      case RunStep::Op::kSub: v = get(s.a) - get(s.b); break;
      case RunStep::Op::kMul: v = get(s.a) * get(s.b); break;
      case RunStep::Op::kDiv: v = get(s.a) / get(s.b); break;
      case RunStep::Op::kPow: v = Power(get(s.a), get(s.b)); break;
      case RunStep::Op::kAddK: v = get(s.a) + s.k; break;
      case RunStep::Op::kSubK: v = get(s.a) - s.k; break;
      case RunStep::Op::kMulK: v = get(s.a) * s.k; break;
      case RunStep::Op::kDivK: v = get(s.a) / s.k; break;
      case RunStep::Op::kPowK: v = Power(get(s.a), s.k); break;
      case RunStep::Op::kKAdd: v = s.k + get(s.a); break;
      case RunStep::Op::kKSub: v = s.k - get(s.a); break;
      case RunStep::Op::kKMul: v = s.k * get(s.a); break;
      case RunStep::Op::kKDiv: v = s.k / get(s.a); break;
      case RunStep::Op::kKPow: v = Power(s.k, get(s.a)); break;
      case RunStep::Op::kSquare: {  // Power(a, 2.0)
        const double a = get(s.a);
        v = a * a;
        break;
      }
      case RunStep::Op::kCube: {  // Power(a, 3.0)
        const double a = get(s.a);
        v = a * a * a;
        break;
      }
      case RunStep::Op::kRecip: v = 1.0 / get(s.a); break;  // Power(a, -1.0)
      case RunStep::Op::kCall1: {
        const double args[1] = {get(s.a)};
        v = Apply(s.fn, args);
        break;
      }
      case RunStep::Op::kCall2: {
        const double args[2] = {get(s.a), get(s.b)};
        v = Apply(s.fn, args);
        break;
      }
      case RunStep::Op::kCall3: {
        const double args[3] = {get(s.a), get(s.b), get(s.c)};
        v = Apply(s.fn, args);
        break;
      }
      default: __builtin_unreachable();  // (no range check before the jump)
    }
    regs[s.dst] = v;
  }
  return get(p.value);
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
          case Input::In::kConstant: e = code::Num(s.input.value); break;
        }
        break;
      case Step::Op::kConst: e = code::Num(s.value); break;
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
