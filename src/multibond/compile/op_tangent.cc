// The tangent rule of one instruction (operations.h, ExecTangent): the derivative of its output
// along a direction of the state (and of the sources), from the derivatives of its inputs. Shared
// by the constraints' tangent pass (the time derivative along dx/dt) and the linearisation (the
// directional derivative along a state or input direction, CompiledModel::CalcTangent); and the
// second-order rule (ExecSecondTangent) that differentiates the constraint equations once more.

#include "multibond/compile/exact_sum.h"
#include "multibond/compile/expr_program.h"
#include "multibond/compile/operations.h"
#include "multibond/core/error.h"

namespace multibond::plan {

namespace {

/// The instruction's own kernel on other arrays (the state or direction that gives R, the slots
/// it reads and writes, the moduli), and the sum of a second term computed into scratch.
struct Kernel {
  const Instr& in;
  double t;
  const double* lambda;
  const Tables& tables;
  void operator()(const double* xs, const double* win, double* wout, const double* m) const {
    plan::Exec(in, plan::ExecArgs{t, xs, win, wout, m, lambda, tables});
  }
  /// out += tmp over the output, tmp back to zero.
  void AddScratch(double* out, double* tmp) const {
    for (int k = 0; k < in.n; ++k) {
      out[in.dst + k] += tmp[in.dst + k];
      tmp[in.dst + k] = 0.0;
    }
  }
};

}  // namespace

void ExecTangent(const Instr& in, const TangentArgs& a) {
  double* d = a.d;
  double* tmp = a.tmp;
  const double* w = a.w;
  const double* x = a.x;
  const double* xdot = a.xdot;
  const double* c = a.tables.coef;
  const Kernel exec{in, a.t, a.lambda, a.tables};
  auto add_tmp = [&] { exec.AddScratch(d, tmp); };
  switch (Traits(in.op).tangent) {
    case Tangent::kSourceRate:
      for (int k = 0; k < in.n; ++k) d[in.dst + k] = a.source_rate ? a.tables.sources[in.coef + k].Derivative(a.t) : 0.0;
      break;
    case Tangent::kZero:
      // A multiplier: its part of dg/dt is W lambda (it never reaches a constrained variable).
      for (int k = 0; k < in.n; ++k) d[in.dst + k] = 0.0;
      break;
    case Tangent::kStateRate:
      exec(xdot, d, d, a.mod);
      break;
    case Tangent::kRotatedInertia: {
      // f = R Ib^-1 R^T h  ->  df = dR a + R Ib^-1 (dR^T h + R^T dh),  a = Ib^-1 R^T h; written
      // out term by term in the generated code's order (CompiledModel::GenerateTangentSource).
      const double *r = x + in.aux, *rd = xdot + in.aux, *h = x + in.src, *hd = xdot + in.src;
      auto ib = [&](int i, int j) {
        return in.op == Op::kIFlowRotatedDiag ? (i == j ? c[in.coef + i] : 0.0) : c[in.coef + 3 * i + j];
      };
      double hb[3], dhb[3], av[3], da[3];
      for (int i = 0; i < 3; ++i) {
        hb[i] = Dot3(r[i], h[0], r[3 + i], h[1], r[6 + i], h[2]);
        dhb[i] = kSumStart;
        for (int k = 0; k < 3; ++k) dhb[i] = AddProduct(dhb[i], rd[3 * k + i], h[k]);
        for (int k = 0; k < 3; ++k) dhb[i] = AddProduct(dhb[i], r[3 * k + i], hd[k]);
      }
      for (int i = 0; i < 3; ++i) {
        av[i] = AddTerm(AddTerm(AddTerm(kSumStart, ib(i, 0), hb[0]), ib(i, 1), hb[1]), ib(i, 2), hb[2]);
        da[i] = AddTerm(AddTerm(AddTerm(kSumStart, ib(i, 0), dhb[0]), ib(i, 1), dhb[1]), ib(i, 2), dhb[2]);
      }
      for (int i = 0; i < 3; ++i) {
        double s = kSumStart;
        for (int k = 0; k < 3; ++k) s = AddProduct(s, rd[3 * i + k], av[k]);
        for (int k = 0; k < 3; ++k) s = AddProduct(s, r[3 * i + k], da[k]);
        d[in.dst + i] = s;
      }
      break;
    }
    case Tangent::kBilinear:
      // Bilinear in R and the input: d(K(R) u) = K(R) du + K(dR) u.
      exec(x, d, d, a.mod);
      exec(xdot, w, tmp, a.mod);
      add_tmp();
      break;
    case Tangent::kModulated: {
      if (in.count <= 1) {
        exec(x, d, d, a.mod);
        exec(x, w, tmp, a.dmod);
        add_tmp();
      } else {
        // y = M^-1 u (mode 2) or M^-T u (mode 3): dy = M^-1 (du - dM y) (or transposed).
        const ModulusEval& me = a.moduli[in.modulus];
        const double* dm = a.dmod + me.out;
        const double* y = w + in.dst;
        double z[16];
        MB_ASSERT(in.m <= 16, "modulated inverse larger than 16");
        for (int r = 0; r < in.m; ++r) {
          double s = d[in.src + r];
          for (int k = 0; k < in.n; ++k) s = AddProduct(s, -(in.count == 2 ? dm[r * in.n + k] : dm[k * in.m + r]), y[k]);
          z[r] = s;
        }
        const double* mv = a.mod + in.coef;
        for (int r = 0; r < in.n; ++r) {
          double s = kSumStart;
          for (int k = 0; k < in.m; ++k) s = AddProduct(s, in.count == 2 ? mv[r * in.m + k] : mv[k * in.n + r], z[k]);
          d[in.dst + r] = s;
        }
      }
      break;
    }
    case Tangent::kLinear:  // constant linear maps of slots: the same map of their derivatives
      exec(x, d, d, a.mod);
      break;
    case Tangent::kNone:  // formulas: forward-mode differentiation of their programs
      FormulaTangent(in, a);
      break;
  }
}

void FormulaTangent(const Instr& in, const TangentArgs& a) {
  double* d = a.d;
  const expr::Program* programs = a.tables.programs;
  const double rate_of_t = a.source_rate ? 1.0 : 0.0;
  if (in.op == Op::kExpr) {
    for (int k = 0; k < in.n; ++k) d[in.dst + k] = expr::RunTangent(programs[in.coef + k], a.t, a.x, a.w, rate_of_t, a.xdot, d);
    return;
  }
  MB_ASSERT(in.op == Op::kSolve, "FormulaTangent on an instruction without a program");
  // law(u, rest) = target: du = (dtarget - dlaw/drest . drest) / law'(u), the scratch slot (which
  // holds u since the plain pass) taken as fixed in the law's own derivative.
  const double target_rate = in.transpose ? -d[in.src] : d[in.src];
  d[in.count] = 0.0;
  const double rest = expr::RunTangent(programs[in.coef], a.t, a.x, a.w, rate_of_t, a.xdot, d);
  const double slope = expr::Run(programs[in.aux], a.t, a.x, a.w);
  const double du_rate = (target_rate - rest) / slope;
  d[in.count] = du_rate;
  d[in.dst] = in.scale * du_rate;
}

void ExecSecondTangent(const Instr& in, const SecondTangentArgs& a) {
  double* dd = a.dd;
  double* tmp = a.tmp;
  const Kernel exec{in, a.t, a.lambda, a.tables};
  auto add_tmp = [&] { exec.AddScratch(dd, tmp); };
  switch (Traits(in.op).tangent) {
    case Tangent::kSourceRate:  // functions of time alone: no second derivative with a state direction
    case Tangent::kZero:
    case Tangent::kStateRate:   // linear in the state with constant coefficients
      for (int k = 0; k < in.n; ++k) dd[in.dst + k] = 0.0;
      break;
    case Tangent::kRotatedInertia: {
      // f = R A R^T h (A = Ib^-1): the six mixed terms of the trilinear form (the directions are
      // constant, so h_vF = 0 and R_vF = 0).
      using Rm3 = Eigen::Matrix<double, 3, 3, Eigen::RowMajor>;
      const Eigen::Map<const Rm3> r(a.x + in.aux), rv(a.xv + in.aux), rf(a.xf + in.aux);
      const Eigen::Map<const Eigen::Vector3d> h(a.x + in.src), hv(a.xv + in.src), hf(a.xf + in.src);
      const double* c = a.tables.coef + in.coef;
      Eigen::Matrix3d m = Eigen::Matrix3d::Zero();
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) m(i, j) = in.op == Op::kIFlowRotatedDiag ? (i == j ? c[i] : 0.0) : c[3 * i + j];
      const Eigen::Vector3d f = rv * m * rf.transpose() * h + rf * m * rv.transpose() * h + rv * m * r.transpose() * hf +
                                rf * m * r.transpose() * hv + r * m * rv.transpose() * hf + r * m * rf.transpose() * hv;
      for (int i = 0; i < 3; ++i) dd[in.dst + i] = f[i];
      break;
    }
    case Tangent::kBilinear:
      // K(R) u:  K(R) u_vF + K(R_v) u_F + K(R_F) u_v.
      exec(a.x, dd, dd, a.mod);
      exec(a.xv, a.df, tmp, a.mod);
      add_tmp();
      exec(a.xf, a.dv, tmp, a.mod);
      add_tmp();
      break;
    case Tangent::kModulated: {
      if (in.count <= 1) {  // M u (M linear in R):  M u_vF + M_v u_F + M_F u_v
        exec(a.x, dd, dd, a.mod);
        exec(a.x, a.df, tmp, a.dmod_v);
        add_tmp();
        exec(a.x, a.dv, tmp, a.dmod_f);
        add_tmp();
      } else {
        // y = M^-1 u:  M y = u  ->  y_vF = M^-1 (u_vF - M_v y_F - M_F y_v) (or transposed).
        const ModulusEval& me = a.moduli[in.modulus];
        const double *mv = a.dmod_v + me.out, *mf = a.dmod_f + me.out;
        const double *yv = a.dv + in.dst, *yf = a.df + in.dst;
        double z[16];
        MB_ASSERT(in.m <= 16, "modulated inverse larger than 16");
        for (int r = 0; r < in.m; ++r) {
          double s = dd[in.src + r];
          for (int k = 0; k < in.n; ++k) {
            const double av = in.count == 2 ? mv[r * in.n + k] : mv[k * in.m + r];
            const double af = in.count == 2 ? mf[r * in.n + k] : mf[k * in.m + r];
            s -= av * yf[k] + af * yv[k];
          }
          z[r] = s;
        }
        const double* inv = a.mod + in.coef;
        for (int r = 0; r < in.n; ++r) {
          double s = 0.0;
          for (int k = 0; k < in.m; ++k) s += (in.count == 2 ? inv[r * in.m + k] : inv[k * in.n + r]) * z[k];
          dd[in.dst + r] = s;
        }
      }
      break;
    }
    case Tangent::kLinear:
      exec(a.x, dd, dd, a.mod);
      break;
    case Tangent::kNone: {
      // A formula: hyper-dual numbers through its program (v a direction of the state, F the
      // motion, along which the time moves at rate 1). A law used backwards is not linearised
      // here (CompiledModel::can_linearize refuses it).
      MB_ASSERT(in.op == Op::kExpr, "ExecSecondTangent on a law used backwards");
      const expr::Direction v{0.0, a.xv, a.dv}, f{1.0, a.xf, a.df};
      for (int k = 0; k < in.n; ++k) dd[in.dst + k] = expr::RunSecondTangent(a.tables.programs[in.coef + k], a.t, a.x, a.w, v, f, dd);
      break;
    }
  }
}

}  // namespace multibond::plan
