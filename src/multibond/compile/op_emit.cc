/// \file
/// The code generator's emitters: the `emit` and `emit_state` columns of the operation table
/// (operations.cc). Each writes its opcode as straight-line C++ with every offset and
/// coefficient a literal, performing the interpreter's operations (op_exec.cc) in the same order.

#include <fmt/format.h>

#include "multibond/compile/code_text.h"
#include "multibond/compile/op_kernels.h"

namespace multibond::plan::kernels {
namespace {

using code::Chain;
using code::Fma;
using code::LinComb;
using code::Num;
using code::Neg;

void Line(std::string& o, const std::string& s) {
  o += "  ";
  o += s;
  o += '\n';
}
std::string In(const EmitArgs& a, int i) { return fmt::format("{}[{}]", a.names.in, i); }
std::string Out(const EmitArgs& a, int i) { return fmt::format("{}[{}]", a.names.out, i); }
std::string St(const EmitArgs& a, int i) { return fmt::format("{}[{}]", a.names.x, i); }
std::string Rot(const EmitArgs& a, int r, int i, int j, bool transpose) { return St(a, transpose ? r + 3 * j + i : r + 3 * i + j); }

}  // namespace

// --- state kernels ---

void EmitStateScale(const Instr& in, const double* c, const std::function<std::string(int)>& src,
                    const std::function<std::string(int)>& dst, std::string& o) {
  for (int k = 0; k < in.n; ++k) Line(o, fmt::format("{} = {} * {};", dst(k), Num(c[in.coef]), src(k)));
}

void EmitStateDiag3(const Instr& in, const double* c, const std::function<std::string(int)>& src,
                    const std::function<std::string(int)>& dst, std::string& o) {
  for (int k = 0; k < 3; ++k) Line(o, fmt::format("{} = {} * {};", dst(k), Num(c[in.coef + k]), src(k)));
}

void EmitStateMatrix(const Instr& in, const double* c, const std::function<std::string(int)>& src,
                     const std::function<std::string(int)>& dst, std::string& o) {
  for (int r = 0; r < in.n; ++r) {
    std::vector<std::pair<double, std::string>> terms;
    for (int k = 0; k < in.n; ++k) terms.push_back({c[in.coef + r * in.n + k], src(k)});
    Line(o, fmt::format("{} = {};", dst(r), LinComb(terms)));
  }
}

void EmitIFlowRotated(const Instr& in, const double* c, const std::function<std::string(int)>& src,
                      const std::function<std::string(int)>& dst, std::string& o) {
  // f = R Ib^-1 R^T h, R row-major at state offset a.
  const int a = in.aux;
  const bool diagonal = in.op == Op::kIFlowRotatedDiag;
  auto x = [](int k) { return fmt::format("x[{}]", k); };
  Line(o, "{");
  for (int i = 0; i < 3; ++i)  // hb = R^T h
    Line(o, fmt::format("  const double hb{} = {};", i, Chain({{x(a + i), src(0)}, {x(a + 3 + i), src(1)}, {x(a + 6 + i), src(2)}})));
  for (int i = 0; i < 3; ++i) {
    if (diagonal)
      Line(o, fmt::format("  const double wb{} = {} * hb{};", i, Num(c[in.coef + i]), i));
    else
      Line(o, fmt::format("  const double wb{} = {};", i,
                          LinComb({{c[in.coef + 3 * i], "hb0"}, {c[in.coef + 3 * i + 1], "hb1"}, {c[in.coef + 3 * i + 2], "hb2"}})));
  }
  for (int i = 0; i < 3; ++i)  // f = R wb
    Line(o, fmt::format("  {} = {};", dst(i), Chain({{x(a + 3 * i), "wb0"}, {x(a + 3 * i + 1), "wb1"}, {x(a + 3 * i + 2), "wb2"}})));
  Line(o, "}");
}

// --- instructions ---

void EmitSource(const Instr& in, const EmitArgs& a) {
  for (int k = 0; k < in.n; ++k) {
    const TimeFunction& f = a.tables.sources[in.coef + k];
    if (f.kind == TimeFunction::Kind::kConstant)
      Line(*a.out, fmt::format("{} = {};", Out(a, in.dst + k), Num(f.value)));
    else if (f.kind == TimeFunction::Kind::kStep)
      Line(*a.out, fmt::format("{} = t >= {} ? {} : {};", Out(a, in.dst + k), Num(f.start), Num(f.value), Num(f.before)));
    else
      Line(*a.out, fmt::format("{} = src->eval(src->fns, {}, t);", Out(a, in.dst + k), in.coef + k));
  }
}

void EmitState(const Instr& in, const EmitArgs& a) {
  Traits(in.op).emit_state(in, a.tables.coef, [&](int k) { return St(a, in.src + k); },
                           [&](int k) { return Out(a, in.dst + k); }, *a.out);
}

void EmitScale(const Instr& in, const EmitArgs& a) {
  const double* c = a.tables.coef;
  for (int k = 0; k < in.n; ++k) Line(*a.out, fmt::format("{} = {} * {};", Out(a, in.dst + k), Num(c[in.coef]), In(a, in.src + k)));
}

void EmitDiag(const Instr& in, const EmitArgs& a) {
  const double* c = a.tables.coef;
  for (int k = 0; k < in.n; ++k) Line(*a.out, fmt::format("{} = {} * {};", Out(a, in.dst + k), Num(c[in.coef + k]), In(a, in.src + k)));
}

void EmitMatrix(const Instr& in, const EmitArgs& a) {
  // Written to a temporary first: the interpreter computes each row in a local too.
  const double* c = a.tables.coef;
  for (int r = 0; r < in.n; ++r) {
    std::vector<std::pair<double, std::string>> terms;
    for (int k = 0; k < in.m; ++k) terms.push_back({c[in.coef + r * in.m + k], In(a, in.src + k)});
    Line(*a.out, fmt::format("{} = {};", Out(a, in.dst + r), LinComb(terms)));
  }
}

namespace {
double LeftFactor(const Instr& in, const double* c, int row, int col) {
  return in.coef < 0 ? (row == col ? 1.0 : 0.0) : c[in.coef + 3 * row + col];
}
}  // namespace

void EmitRotFwd(const Instr& in, const EmitArgs& a) {
  // dst_r = s sum_i L_ri (op(R) v)_i : only the rows of op(R) that L selects are computed.
  const double* c = a.tables.coef;
  for (int r = 0; r < in.n; ++r) {
    std::vector<std::pair<double, std::string>> terms;
    for (int i = 0; i < 3; ++i) {
      if (LeftFactor(in, c, r, i) == 0.0) continue;
      std::vector<std::pair<std::string, std::string>> row;
      for (int j = 0; j < 3; ++j) row.push_back({Rot(a, in.aux, i, j, in.transpose), In(a, in.src + j)});
      terms.push_back({LeftFactor(in, c, r, i), fmt::format("({})", Chain(row))});
    }
    Line(*a.out, fmt::format("{} = {} * ({});", Out(a, in.dst + r), Num(in.scale), LinComb(terms)));
  }
}

void EmitRotBwd(const Instr& in, const EmitArgs& a) {
  // dst = s op(R)^T z with z = L^T src: only the columns of L that are not zero count.
  const double* c = a.tables.coef;
  std::string& o = *a.out;
  Line(o, "{");
  bool used[3] = {false, false, false};
  for (int col = 0; col < 3; ++col) {
    std::vector<std::pair<double, std::string>> terms;
    for (int i = 0; i < in.m; ++i) terms.push_back({LeftFactor(in, c, i, col), In(a, in.src + i)});
    const std::string z = LinComb(terms);  // once: each call takes its numbers into the value table
    used[col] = z != "(-0.0)";
    if (used[col]) Line(o, fmt::format("  const double z{} = {};", col, z));
  }
  for (int i = 0; i < 3; ++i) {
    std::vector<std::pair<std::string, std::string>> products;
    for (int col = 0; col < 3; ++col)
      if (used[col]) products.push_back({Rot(a, in.aux, col, i, in.transpose), fmt::format("z{}", col)});
    Line(o, fmt::format("  {} = {} * ({});", Out(a, in.dst + i), Num(in.scale), Chain(products)));
  }
  Line(o, "}");
}

void EmitLever(const Instr& in, const EmitArgs& a) {
  // The lever arm a = R r, computed once per MTF and kept for its other equation.
  const double* c = a.tables.coef;
  const std::string arm_name = fmt::format("arm_{}{}", a.names.x, in.coef);  // one per state array (R or dR/dt)
  if (a.levers_done->insert(arm_name).second) {
    for (int i = 0; i < 3; ++i) {
      std::vector<std::pair<double, std::string>> terms;
      for (int j = 0; j < 3; ++j) terms.push_back({c[in.coef + j], St(a, in.aux + 3 * i + j)});
      Line(*a.out, fmt::format("const double {}_{} = {};", arm_name, i, LinComb(terms)));
    }
  }
  // s (p x q) with (p x q)_i = p_j q_k - p_k q_j = fma(-p_k, q_j, p_j q_k), as Cross in op_exec.cc.
  const std::string v[3] = {In(a, in.src), In(a, in.src + 1), In(a, in.src + 2)};
  const std::string arm[3] = {arm_name + "_0", arm_name + "_1", arm_name + "_2"};
  const bool fwd = in.op == Op::kLeverFwd;  // s (v x a), else s (a x v)
  const std::string* p = fwd ? v : arm;
  const std::string* q = fwd ? arm : v;
  for (int i = 0; i < 3; ++i) {
    const int j = (i + 1) % 3, k = (i + 2) % 3;
    Line(*a.out, fmt::format("{} = {} * {};", Out(a, in.dst + i), Num(in.scale), Fma(Neg(p[k]), q[j], p[j] + " * " + q[k])));
  }
}

void EmitModulated(const Instr& in, const EmitArgs& a) {
  const bool plain = in.count == 0 || in.count == 2;
  for (int r = 0; r < in.n; ++r) {
    std::vector<std::pair<std::string, std::string>> products;
    for (int k = 0; k < in.m; ++k)
      products.push_back({fmt::format("{}[{}]", a.names.mod, in.coef + (plain ? r * in.m + k : k * in.n + r)), In(a, in.src + k)});
    Line(*a.out, fmt::format("{} = {};", Out(a, in.dst + r), Chain(products)));
  }
}

void EmitCopy(const Instr& in, const EmitArgs& a) {
  for (int k = 0; k < in.n; ++k) Line(*a.out, fmt::format("{} = {};", Out(a, in.dst + k), In(a, in.src + k)));
}

void EmitSum(const Instr& in, const EmitArgs& a) {
  for (int k = 0; k < in.n; ++k) {
    std::vector<std::pair<double, std::string>> terms;
    for (int j = 0; j < in.count; ++j) terms.push_back({a.tables.sum_signs[in.coef + j], In(a, a.tables.sum_terms[in.coef + j] + k)});
    Line(*a.out, fmt::format("{} = {};", Out(a, in.dst + k), LinComb(terms)));
  }
}

void EmitMultiplier(const Instr& in, const EmitArgs& a) {
  // The plan at zero multipliers (step 1 of CalcConstrained, and the projection); with
  // names.multipliers, what they reach once they are known (step 4, multibond_react).
  for (int k = 0; k < in.n; ++k)
    Line(*a.out, fmt::format("{} = {};", Out(a, in.dst + k),
                             a.names.multipliers ? fmt::format("lam[{}]", in.coef + k) : std::string("0.0")));
}

void EmitExpr(const Instr& in, const EmitArgs& a) {
  // Each program in its own block: its registers are named after the slot it writes.
  for (int k = 0; k < in.n; ++k) {
    std::string body;
    const std::string result = expr::EmitProgram(a.tables.programs[in.coef + k], fmt::format("f{}_", in.dst + k),
                                                 expr::EmitNames{"t", a.names.x, a.names.in}, body);
    Line(*a.out, "{");
    *a.out += body;
    Line(*a.out, fmt::format("{} = {};", Out(a, in.dst + k), result));
    Line(*a.out, "}");
  }
}

void EmitSolve(const Instr& in, const EmitArgs& a) {
  // The interpreter's very solver, called back (MbSources::solve): the same bits in both engines.
  Line(*a.out, fmt::format("{} = {} * src->solve(src->programs, {}, {}, {}, {}{}, t, {}, {});", Out(a, in.dst), Num(in.scale),
                           in.coef, in.aux, in.count, in.transpose ? "-" : "", In(a, in.src), a.names.x, a.names.out));
}

}  // namespace multibond::plan::kernels
