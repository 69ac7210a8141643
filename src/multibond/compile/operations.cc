/// \file
/// The operation table (operations.h): one row per opcode, and the specialisation pass that
/// rewrites generic instructions into the fixed-size rows.

#include "multibond/compile/operations.h"

#include "multibond/compile/op_kernels.h"

namespace multibond::plan {

namespace k = kernels;

// clang-format off
const OpTraits kOpTable[kNumOps] = {
  // op                     name                 n  m  generic               reads               coupling                  rot    mod    tangent                    exec                               emit              state                  emit_state
  {Op::kSource,           "source",             0, 0, Op::kSource,        Reads::kNothing,    Coupling::kComponentwise, false, false, Tangent::kSourceRate,     k::ExecSource,                     k::EmitSource},
  {Op::kStateScale,       "state_scale",        0, 0, Op::kStateScale,    Reads::kState,      Coupling::kComponentwise, false, false, Tangent::kStateRate,      k::ExecState<k::StateScale>,       k::EmitState,     k::StateScale,         k::EmitStateScale},
  {Op::kStateMatrix,      "state_matrix",       0, 0, Op::kStateMatrix,   Reads::kState,      Coupling::kDense,         false, false, Tangent::kStateRate,      k::ExecState<k::StateMatrix>,      k::EmitState,     k::StateMatrix,        k::EmitStateMatrix},
  {Op::kIFlowRotated,     "i_flow_rotated",     3, 0, Op::kIFlowRotated,  Reads::kState,      Coupling::kDense,         true,  false, Tangent::kRotatedInertia, k::ExecState<k::IFlowRotated>,     k::EmitState,     k::IFlowRotated,       k::EmitIFlowRotated},
  {Op::kScale,            "scale",              0, 0, Op::kScale,         Reads::kSlots,      Coupling::kComponentwise, false, false, Tangent::kLinear,         k::ExecScale,                      k::EmitScale},
  {Op::kMatrix,           "matrix",             0, 0, Op::kMatrix,        Reads::kSlots,      Coupling::kDense,         false, false, Tangent::kLinear,         k::ExecMatrix,                     k::EmitMatrix},
  {Op::kModulated,        "modulated",          0, 0, Op::kModulated,     Reads::kSlots,      Coupling::kDense,         false, true,  Tangent::kModulated,      k::ExecModulated,                  k::EmitModulated},
  {Op::kSum,              "sum",                0, 0, Op::kSum,           Reads::kSumTerms,   Coupling::kComponentwise, false, false, Tangent::kLinear,         k::ExecSum,                        k::EmitSum},
  {Op::kStateScale3,      "state_scale3",       3, 0, Op::kStateScale,    Reads::kState,      Coupling::kComponentwise, false, false, Tangent::kStateRate,      k::ExecState<k::StateScale3>,      k::EmitState,     k::StateScale3,        k::EmitStateScale},
  {Op::kStateDiag3,       "state_diag3",        3, 0, Op::kStateMatrix,   Reads::kState,      Coupling::kComponentwise, false, false, Tangent::kStateRate,      k::ExecState<k::StateDiag3>,       k::EmitState,     k::StateDiag3,         k::EmitStateDiag3},
  {Op::kIFlowRotatedDiag, "i_flow_rotated_diag",3, 0, Op::kIFlowRotated,  Reads::kState,      Coupling::kDense,         true,  false, Tangent::kRotatedInertia, k::ExecState<k::IFlowRotatedDiag>, k::EmitState,     k::IFlowRotatedDiag,   k::EmitIFlowRotated},
  {Op::kScale1,           "scale1",             1, 1, Op::kScale,         Reads::kSlots,      Coupling::kComponentwise, false, false, Tangent::kLinear,         k::ExecScale1,                     k::EmitScale},
  {Op::kScale3,           "scale3",             3, 3, Op::kScale,         Reads::kSlots,      Coupling::kComponentwise, false, false, Tangent::kLinear,         k::ExecScale3,                     k::EmitScale},
  {Op::kDiag2,            "diag2",              2, 2, Op::kMatrix,        Reads::kSlots,      Coupling::kComponentwise, false, false, Tangent::kLinear,         k::ExecDiag<2>,                    k::EmitDiag},
  {Op::kDiag3,            "diag3",              3, 3, Op::kMatrix,        Reads::kSlots,      Coupling::kComponentwise, false, false, Tangent::kLinear,         k::ExecDiag<3>,                    k::EmitDiag},
  {Op::kMat13,            "mat13",              1, 3, Op::kMatrix,        Reads::kSlots,      Coupling::kDense,         false, false, Tangent::kLinear,         k::ExecMat<1, 3>,                  k::EmitMatrix},
  {Op::kMat23,            "mat23",              2, 3, Op::kMatrix,        Reads::kSlots,      Coupling::kDense,         false, false, Tangent::kLinear,         k::ExecMat<2, 3>,                  k::EmitMatrix},
  {Op::kMat33,            "mat33",              3, 3, Op::kMatrix,        Reads::kSlots,      Coupling::kDense,         false, false, Tangent::kLinear,         k::ExecMat<3, 3>,                  k::EmitMatrix},
  {Op::kMat31,            "mat31",              3, 1, Op::kMatrix,        Reads::kSlots,      Coupling::kDense,         false, false, Tangent::kLinear,         k::ExecMat<3, 1>,                  k::EmitMatrix},
  {Op::kMat32,            "mat32",              3, 2, Op::kMatrix,        Reads::kSlots,      Coupling::kDense,         false, false, Tangent::kLinear,         k::ExecMat<3, 2>,                  k::EmitMatrix},
  {Op::kRotFwd1,          "rot_fwd1",           1, 3, Op::kModulated,     Reads::kSlots,      Coupling::kDense,         true,  false, Tangent::kBilinear,       k::ExecRotFwd<1>,                  k::EmitRotFwd},
  {Op::kRotFwd2,          "rot_fwd2",           2, 3, Op::kModulated,     Reads::kSlots,      Coupling::kDense,         true,  false, Tangent::kBilinear,       k::ExecRotFwd<2>,                  k::EmitRotFwd},
  {Op::kRotFwd3,          "rot_fwd3",           3, 3, Op::kModulated,     Reads::kSlots,      Coupling::kDense,         true,  false, Tangent::kBilinear,       k::ExecRotFwd<3>,                  k::EmitRotFwd},
  {Op::kRotBwd1,          "rot_bwd1",           3, 1, Op::kModulated,     Reads::kSlots,      Coupling::kDense,         true,  false, Tangent::kBilinear,       k::ExecRotBwd<1>,                  k::EmitRotBwd},
  {Op::kRotBwd2,          "rot_bwd2",           3, 2, Op::kModulated,     Reads::kSlots,      Coupling::kDense,         true,  false, Tangent::kBilinear,       k::ExecRotBwd<2>,                  k::EmitRotBwd},
  {Op::kRotBwd3,          "rot_bwd3",           3, 3, Op::kModulated,     Reads::kSlots,      Coupling::kDense,         true,  false, Tangent::kBilinear,       k::ExecRotBwd<3>,                  k::EmitRotBwd},
  {Op::kLeverFwd,         "lever_fwd",          3, 3, Op::kModulated,     Reads::kSlots,      Coupling::kDense,         true,  false, Tangent::kBilinear,       k::ExecLeverFwd,                   k::EmitLever},
  {Op::kLeverBwd,         "lever_bwd",          3, 3, Op::kModulated,     Reads::kSlots,      Coupling::kDense,         true,  false, Tangent::kBilinear,       k::ExecLeverBwd,                   k::EmitLever},
  {Op::kSum1,             "sum1",               1, 0, Op::kSum,           Reads::kSumTerms,   Coupling::kComponentwise, false, false, Tangent::kLinear,         k::ExecSum1,                       k::EmitSum},
  {Op::kSum3,             "sum3",               3, 0, Op::kSum,           Reads::kSumTerms,   Coupling::kComponentwise, false, false, Tangent::kLinear,         k::ExecSum3,                       k::EmitSum},
  {Op::kCopy1,            "copy1",              1, 0, Op::kSum,           Reads::kSlots,      Coupling::kComponentwise, false, false, Tangent::kLinear,         k::ExecCopy1,                      k::EmitCopy},
  {Op::kCopy3,            "copy3",              3, 0, Op::kSum,           Reads::kSlots,      Coupling::kComponentwise, false, false, Tangent::kLinear,         k::ExecCopy3,                      k::EmitCopy},
  {Op::kExpr,             "expr",               0, 0, Op::kExpr,          Reads::kProgram,    Coupling::kDense,         false, false, Tangent::kNone,           k::ExecExpr,                       k::EmitExpr},
  {Op::kSolve,            "solve",              1, 0, Op::kSolve,         Reads::kSolve,      Coupling::kDense,         false, false, Tangent::kNone,           k::ExecSolve,                      k::EmitSolve},
  {Op::kMultiplier,       "multiplier",         0, 0, Op::kMultiplier,    Reads::kMultipliers,Coupling::kComponentwise, false, false, Tangent::kZero,           k::ExecMultiplier,                 k::EmitMultiplier},
};
// clang-format on

std::vector<int> Specialize(std::vector<Instr>& plan, std::vector<double>& coef, const std::vector<int>& sum_terms,
                            const std::vector<double>& sum_signs, std::vector<ModulusEval>& moduli) {
  auto is_diagonal = [&](int at, int n) {
    for (int r = 0; r < n; ++r)
      for (int c = 0; c < n; ++c)
        if (r != c && coef[at + r * n + c] != 0.0) return false;
    return true;
  };
  // Appends the diagonal of the n x n matrix at `at`; returns its offset.
  auto diagonal = [&](int at, int n) {
    const int out = static_cast<int>(coef.size());
    for (int r = 0; r < n; ++r) coef.push_back(coef[at + r * n + r]);
    return out;
  };
  // The rewrite rules, by generic opcode (the table's `generic` column names the results' origin).
  for (Instr& in : plan) {
    switch (in.op) {
      case Op::kStateScale:
        if (in.n == 3) in.op = Op::kStateScale3;
        break;
      case Op::kStateMatrix:
        if (in.n == 3 && is_diagonal(in.coef, 3)) {
          in.coef = diagonal(in.coef, 3);
          in.op = Op::kStateDiag3;
        }
        break;
      case Op::kIFlowRotated:
        if (is_diagonal(in.coef, 3)) {
          in.coef = diagonal(in.coef, 3);
          in.op = Op::kIFlowRotatedDiag;
        }
        break;
      case Op::kScale:
        if (in.n == 1) in.op = Op::kScale1;
        else if (in.n == 3) in.op = Op::kScale3;
        break;
      case Op::kMatrix:
        if (in.n == in.m && (in.n == 2 || in.n == 3) && is_diagonal(in.coef, in.n)) {
          in.coef = diagonal(in.coef, in.n);
          in.op = in.n == 2 ? Op::kDiag2 : Op::kDiag3;
        } else if (in.m == 3 && in.n == 1) {
          in.op = Op::kMat13;
        } else if (in.m == 3 && in.n == 2) {
          in.op = Op::kMat23;
        } else if (in.m == 3 && in.n == 3) {
          in.op = Op::kMat33;
        } else if (in.n == 3 && in.m == 1) {
          in.op = Op::kMat31;
        } else if (in.n == 3 && in.m == 2) {
          in.op = Op::kMat32;
        }
        break;
      case Op::kModulated: {
        ModulusEval& me = moduli[in.modulus];
        const bool plain = me.right < 0 && in.count <= 1;
        if (plain && me.kind == Modulus::Kind::kRotation && me.rows <= 3) {
          // M = s L op(R): forward dst = s L op(R) src; backward dst = s op(R)^T L^T src.
          const int rows = me.rows;
          in.aux = me.rotation;
          in.scale = me.scale;
          in.transpose = me.transpose;
          in.coef = me.left;  // -1: L is the identity
          static const Op kFwd[] = {Op::kRotFwd1, Op::kRotFwd2, Op::kRotFwd3};
          static const Op kBwd[] = {Op::kRotBwd1, Op::kRotBwd2, Op::kRotBwd3};
          in.op = in.count == 0 ? kFwd[rows - 1] : kBwd[rows - 1];
        } else if (plain && me.kind == Modulus::Kind::kLever && me.left < 0) {
          // M = -s [a x], a = R r: forward dst = s (src x a); backward dst = s (a x src).
          in.aux = me.rotation;
          in.scale = me.scale;
          in.coef = static_cast<int>(coef.size());
          coef.insert(coef.end(), {me.lever.x(), me.lever.y(), me.lever.z()});
          in.op = in.count == 0 ? Op::kLeverFwd : Op::kLeverBwd;
        } else {
          me.needed = true;
        }
        break;
      }
      case Op::kSum:
        if (in.count == 1 && sum_signs[in.coef] == 1.0 && (in.n == 1 || in.n == 3)) {
          in.src = sum_terms[in.coef];
          in.op = in.n == 1 ? Op::kCopy1 : Op::kCopy3;
        } else if (in.n == 1) {
          in.op = Op::kSum1;
        } else if (in.n == 3) {
          in.op = Op::kSum3;
        }
        break;
      default:
        break;
    }
  }
  std::vector<int> needed;
  for (size_t i = 0; i < moduli.size(); ++i)
    if (moduli[i].needed) needed.push_back(static_cast<int>(i));
  return needed;
}

}  // namespace multibond::plan
