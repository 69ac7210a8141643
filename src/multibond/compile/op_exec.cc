/// \file
/// The interpreter's kernels: the `exec` and `state` columns of the operation table
/// (operations.cc). Each performs the floating-point operations of its opcode in the order the
/// generated code does (op_emit.cc; exact_sum.h), so that both give bit-identical numbers.

#include "multibond/compile/op_kernels.h"

#include "multibond/compile/exact_sum.h"
#include "multibond/core/error.h"

namespace multibond::plan::kernels {
namespace {

/// dst(R) = A(R x C, row-major) src(C).
template <int R, int C>
inline void MatVec(double* dst, const double* a, const double* src) {
  for (int r = 0; r < R; ++r) {
    double s = kSumStart;
    for (int c = 0; c < C; ++c) s = AddTerm(s, a[r * C + c], src[c]);
    dst[r] = s;
  }
}

/// y = op(R) v for a row-major R (op = transpose when `transpose`).
inline void RotApply(double* y, const double* r, const double* v, bool transpose) {
  if (transpose) {
    for (int i = 0; i < 3; ++i) y[i] = Dot3(r[i], v[0], r[3 + i], v[1], r[6 + i], v[2]);
  } else {
    for (int i = 0; i < 3; ++i) y[i] = Dot3(r[3 * i], v[0], r[3 * i + 1], v[1], r[3 * i + 2], v[2]);
  }
}

/// Forward rotation kernel: dst(K) = s L op(R) src, L = K x 3 (identity when null).
template <int K>
inline void RotFwd(double* dst, const double* r, const double* l, const double* src, double s, bool transpose) {
  double y[3];
  RotApply(y, r, src, transpose);
  if (l == nullptr) {
    for (int i = 0; i < 3; ++i) dst[i] = s * y[i];
    return;
  }
  for (int i = 0; i < K; ++i) dst[i] = s * AddTerm(AddTerm(AddTerm(kSumStart, l[3 * i], y[0]), l[3 * i + 1], y[1]), l[3 * i + 2], y[2]);
}

/// Backward rotation kernel: dst(3) = s op(R)^T L^T src(K).
template <int K>
inline void RotBwd(double* dst, const double* r, const double* l, const double* src, double s, bool transpose) {
  double z[3];
  if (l == nullptr) {
    for (int i = 0; i < 3; ++i) z[i] = src[i];
    double y[3];
    RotApply(y, r, z, !transpose);
    for (int i = 0; i < 3; ++i) dst[i] = s * y[i];
    return;
  }
  // A column of L that is zero leaves its z out of the product, as in the generated code.
  bool used[3];
  for (int c = 0; c < 3; ++c) {
    double acc = kSumStart;
    used[c] = false;
    for (int i = 0; i < K; ++i) {
      acc = AddTerm(acc, l[3 * i + c], src[i]);
      used[c] = used[c] || l[3 * i + c] != 0.0;
    }
    z[c] = acc;
  }
  for (int i = 0; i < 3; ++i) {
    double y = kSumStart;
    for (int c = 0; c < 3; ++c)
      if (used[c]) y = AddProduct(y, transpose ? r[3 * i + c] : r[3 * c + i], z[c]);
    dst[i] = s * y;
  }
}

/// The lever arm a = R r in the inertial frame (R row-major); zero components of r add nothing.
inline void LeverArm(double* a, const double* rot, const double* lever) {
  for (int i = 0; i < 3; ++i) a[i] = AddTerm(AddTerm(AddTerm(kSumStart, lever[0], rot[3 * i]), lever[1], rot[3 * i + 1]), lever[2], rot[3 * i + 2]);
}

/// out = s (a x b), each component a_j b_k - a_k b_j as the chain a_j b_k + (-a_k) b_j.
inline void Cross(double* out, const double* a, const double* b, double s) {
  out[0] = s * MulAdd(-a[2], b[1], a[1] * b[2]);
  out[1] = s * MulAdd(-a[0], b[2], a[2] * b[0]);
  out[2] = s * MulAdd(-a[1], b[0], a[0] * b[1]);
}

inline const double* L(const Instr& in, const double* c) { return in.coef < 0 ? nullptr : c + in.coef; }

}  // namespace

// --- state kernels: dst = E s (s a state block; r the orientation for rotated inertias) ---

void StateScale(const Instr& in, const double* c, const double*, const double* s, double* dst) {
  for (int k = 0; k < in.n; ++k) dst[k] = c[in.coef] * s[k];
}
void StateScale3(const Instr& in, const double* c, const double*, const double* s, double* dst) {
  for (int k = 0; k < 3; ++k) dst[k] = c[in.coef] * s[k];
}
void StateDiag3(const Instr& in, const double* c, const double*, const double* s, double* dst) {
  for (int k = 0; k < 3; ++k) dst[k] = c[in.coef + k] * s[k];
}
void StateMatrix(const Instr& in, const double* c, const double*, const double* s, double* dst) {
  for (int row = 0; row < in.n; ++row) {
    double sum = kSumStart;
    for (int k = 0; k < in.n; ++k) sum = AddTerm(sum, c[in.coef + row * in.n + k], s[k]);
    dst[row] = sum;
  }
}
// f = R Ib^-1 R^T h: the inertia tensor turns with the body (no Euler junction structure).
void IFlowRotated(const Instr& in, const double* c, const double* r, const double* s, double* dst) {
  double hb[3], wb[3];
  RotApply(hb, r, s, true);
  MatVec<3, 3>(wb, c + in.coef, hb);
  RotApply(dst, r, wb, false);
}
void IFlowRotatedDiag(const Instr& in, const double* c, const double* r, const double* s, double* dst) {
  double hb[3], wb[3];
  RotApply(hb, r, s, true);
  for (int k = 0; k < 3; ++k) wb[k] = c[in.coef + k] * hb[k];
  RotApply(dst, r, wb, false);
}

// --- the interpreter's kernels ---

void ExecSource(const Instr& in, const ExecArgs& a) {
  double* dst = a.wout + in.dst;
  for (int k = 0; k < in.n; ++k) dst[k] = a.tables.sources[in.coef + k](a.t);
}

template <StateFn kState>
void ExecState(const Instr& in, const ExecArgs& a) {
  kState(in, a.tables.coef, a.x + in.aux, a.x + in.src, a.wout + in.dst);
}
template void ExecState<StateScale>(const Instr&, const ExecArgs&);
template void ExecState<StateScale3>(const Instr&, const ExecArgs&);
template void ExecState<StateDiag3>(const Instr&, const ExecArgs&);
template void ExecState<StateMatrix>(const Instr&, const ExecArgs&);
template void ExecState<IFlowRotated>(const Instr&, const ExecArgs&);
template void ExecState<IFlowRotatedDiag>(const Instr&, const ExecArgs&);

void ExecScale(const Instr& in, const ExecArgs& a) {
  const double* c = a.tables.coef;
  double* dst = a.wout + in.dst;
  for (int k = 0; k < in.n; ++k) dst[k] = c[in.coef] * a.win[in.src + k];
}
void ExecScale1(const Instr& in, const ExecArgs& a) { a.wout[in.dst] = a.tables.coef[in.coef] * a.win[in.src]; }
void ExecScale3(const Instr& in, const ExecArgs& a) {
  const double* c = a.tables.coef;
  double* dst = a.wout + in.dst;
  for (int k = 0; k < 3; ++k) dst[k] = c[in.coef] * a.win[in.src + k];
}
template <int N>
void ExecDiag(const Instr& in, const ExecArgs& a) {
  const double* c = a.tables.coef;
  double* dst = a.wout + in.dst;
  for (int k = 0; k < N; ++k) dst[k] = c[in.coef + k] * a.win[in.src + k];
}
template void ExecDiag<2>(const Instr&, const ExecArgs&);
template void ExecDiag<3>(const Instr&, const ExecArgs&);

template <int R, int C>
void ExecMat(const Instr& in, const ExecArgs& a) {
  MatVec<R, C>(a.wout + in.dst, a.tables.coef + in.coef, a.win + in.src);
}
template void ExecMat<1, 3>(const Instr&, const ExecArgs&);
template void ExecMat<2, 3>(const Instr&, const ExecArgs&);
template void ExecMat<3, 3>(const Instr&, const ExecArgs&);
template void ExecMat<3, 1>(const Instr&, const ExecArgs&);
template void ExecMat<3, 2>(const Instr&, const ExecArgs&);

void ExecMatrix(const Instr& in, const ExecArgs& a) {
  const double* c = a.tables.coef;
  double* dst = a.wout + in.dst;
  for (int r = 0; r < in.n; ++r) {
    double s = kSumStart;
    for (int k = 0; k < in.m; ++k) s = AddTerm(s, c[in.coef + r * in.m + k], a.win[in.src + k]);
    dst[r] = s;
  }
}

template <int K>
void ExecRotFwd(const Instr& in, const ExecArgs& a) {
  RotFwd<K>(a.wout + in.dst, a.x + in.aux, L(in, a.tables.coef), a.win + in.src, in.scale, in.transpose);
}
template <int K>
void ExecRotBwd(const Instr& in, const ExecArgs& a) {
  RotBwd<K>(a.wout + in.dst, a.x + in.aux, L(in, a.tables.coef), a.win + in.src, in.scale, in.transpose);
}
template void ExecRotFwd<1>(const Instr&, const ExecArgs&);
template void ExecRotFwd<2>(const Instr&, const ExecArgs&);
template void ExecRotFwd<3>(const Instr&, const ExecArgs&);
template void ExecRotBwd<1>(const Instr&, const ExecArgs&);
template void ExecRotBwd<2>(const Instr&, const ExecArgs&);
template void ExecRotBwd<3>(const Instr&, const ExecArgs&);

void ExecLeverFwd(const Instr& in, const ExecArgs& a) {  // s (src x arm)
  double arm[3];
  LeverArm(arm, a.x + in.aux, a.tables.coef + in.coef);
  Cross(a.wout + in.dst, a.win + in.src, arm, in.scale);
}
void ExecLeverBwd(const Instr& in, const ExecArgs& a) {  // s (arm x src)
  double arm[3];
  LeverArm(arm, a.x + in.aux, a.tables.coef + in.coef);
  Cross(a.wout + in.dst, arm, a.win + in.src, in.scale);
}

void ExecModulated(const Instr& in, const ExecArgs& a) {
  const double* m = a.mod + in.coef;
  double* dst = a.wout + in.dst;
  // Stored row-major as (rows x cols) of M (or of M^-1); modes 1 and 3 read it transposed.
  if (in.count == 0 || in.count == 2) {
    for (int r = 0; r < in.n; ++r) {
      double s = kSumStart;
      for (int k = 0; k < in.m; ++k) s = AddProduct(s, m[r * in.m + k], a.win[in.src + k]);
      dst[r] = s;
    }
  } else {
    for (int r = 0; r < in.n; ++r) {
      double s = kSumStart;
      for (int k = 0; k < in.m; ++k) s = AddProduct(s, m[k * in.n + r], a.win[in.src + k]);
      dst[r] = s;
    }
  }
}

void ExecCopy1(const Instr& in, const ExecArgs& a) { a.wout[in.dst] = a.win[in.src]; }
void ExecCopy3(const Instr& in, const ExecArgs& a) {
  for (int k = 0; k < 3; ++k) a.wout[in.dst + k] = a.win[in.src + k];
}

void ExecSum(const Instr& in, const ExecArgs& a) {
  const int* src = a.tables.sum_terms + in.coef;
  const double* sign = a.tables.sum_signs + in.coef;
  double* dst = a.wout + in.dst;
  for (int k = 0; k < in.n; ++k) {
    double s = kSumStart;
    for (int j = 0; j < in.count; ++j) s += sign[j] * a.win[src[j] + k];
    dst[k] = s;
  }
}
void ExecSum1(const Instr& in, const ExecArgs& a) {
  const int* src = a.tables.sum_terms + in.coef;
  const double* sign = a.tables.sum_signs + in.coef;
  double s = kSumStart;
  for (int j = 0; j < in.count; ++j) s += sign[j] * a.win[src[j]];
  a.wout[in.dst] = s;
}
void ExecSum3(const Instr& in, const ExecArgs& a) {
  const int* src = a.tables.sum_terms + in.coef;
  const double* sign = a.tables.sum_signs + in.coef;
  double s0 = kSumStart, s1 = kSumStart, s2 = kSumStart;
  for (int j = 0; j < in.count; ++j) {
    const double* v = a.win + src[j];
    s0 += sign[j] * v[0];
    s1 += sign[j] * v[1];
    s2 += sign[j] * v[2];
  }
  double* dst = a.wout + in.dst;
  dst[0] = s0;
  dst[1] = s1;
  dst[2] = s2;
}

void ExecMultiplier(const Instr& in, const ExecArgs& a) {
  for (int k = 0; k < in.n; ++k) a.wout[in.dst + k] = a.lambda[in.coef + k];
}

void ExecExpr(const Instr& in, const ExecArgs& a) {
  for (int k = 0; k < in.n; ++k) a.wout[in.dst + k] = expr::Run(a.tables.programs[in.coef + k], a.t, a.x, a.win);
}

void ExecSolve(const Instr& in, const ExecArgs& a) {
  // The plain pass only (win == wout): the solve writes its scratch slot as it goes.
  const double target = in.transpose ? -a.win[in.src] : a.win[in.src];
  a.wout[in.dst] = in.scale * expr::SolveFor(a.tables.programs[in.coef], a.tables.programs[in.aux], in.count, target, a.t, a.x, a.wout);
}

}  // namespace multibond::plan::kernels
