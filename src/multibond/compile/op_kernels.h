#pragma once
/// \file
/// The functions the operation table's rows point to (internal to compile/): the interpreter's
/// kernels (op_exec.cc) and the code generator's emitters (op_emit.cc). Use them through
/// plan::Traits (operations.h), not by name.

#include "multibond/compile/operations.h"

namespace multibond::plan::kernels {

// State kernels (StateFn).
void StateScale(const Instr& in, const double* c, const double* r, const double* s, double* dst);
void StateScale3(const Instr& in, const double* c, const double* r, const double* s, double* dst);
void StateDiag3(const Instr& in, const double* c, const double* r, const double* s, double* dst);
void StateMatrix(const Instr& in, const double* c, const double* r, const double* s, double* dst);
void IFlowRotated(const Instr& in, const double* c, const double* r, const double* s, double* dst);
void IFlowRotatedDiag(const Instr& in, const double* c, const double* r, const double* s, double* dst);

// Interpreter kernels (ExecFn).
void ExecSource(const Instr& in, const ExecArgs& a);
template <StateFn kState>
void ExecState(const Instr& in, const ExecArgs& a);
void ExecScale(const Instr& in, const ExecArgs& a);
void ExecScale1(const Instr& in, const ExecArgs& a);
void ExecScale3(const Instr& in, const ExecArgs& a);
template <int N>
void ExecDiag(const Instr& in, const ExecArgs& a);
template <int R, int C>
void ExecMat(const Instr& in, const ExecArgs& a);
void ExecMatrix(const Instr& in, const ExecArgs& a);
template <int K>
void ExecRotFwd(const Instr& in, const ExecArgs& a);
template <int K>
void ExecRotBwd(const Instr& in, const ExecArgs& a);
void ExecLeverFwd(const Instr& in, const ExecArgs& a);
void ExecLeverBwd(const Instr& in, const ExecArgs& a);
void ExecModulated(const Instr& in, const ExecArgs& a);
void ExecCopy1(const Instr& in, const ExecArgs& a);
void ExecCopy3(const Instr& in, const ExecArgs& a);
void ExecSum(const Instr& in, const ExecArgs& a);
void ExecSum1(const Instr& in, const ExecArgs& a);
void ExecSum3(const Instr& in, const ExecArgs& a);
void ExecMultiplier(const Instr& in, const ExecArgs& a);
void ExecExpr(const Instr& in, const ExecArgs& a);
void ExecSolve(const Instr& in, const ExecArgs& a);

// State kernels as C++ (EmitStateFn).
void EmitStateScale(const Instr& in, const double* c, const std::function<std::string(int)>& src,
                    const std::function<std::string(int)>& dst, std::string& o);
void EmitStateDiag3(const Instr& in, const double* c, const std::function<std::string(int)>& src,
                    const std::function<std::string(int)>& dst, std::string& o);
void EmitStateMatrix(const Instr& in, const double* c, const std::function<std::string(int)>& src,
                     const std::function<std::string(int)>& dst, std::string& o);
void EmitIFlowRotated(const Instr& in, const double* c, const std::function<std::string(int)>& src,
                      const std::function<std::string(int)>& dst, std::string& o);

// Emitters (EmitFn).
void EmitSource(const Instr& in, const EmitArgs& a);
void EmitState(const Instr& in, const EmitArgs& a);
void EmitScale(const Instr& in, const EmitArgs& a);
void EmitDiag(const Instr& in, const EmitArgs& a);
void EmitMatrix(const Instr& in, const EmitArgs& a);
void EmitRotFwd(const Instr& in, const EmitArgs& a);
void EmitRotBwd(const Instr& in, const EmitArgs& a);
void EmitLever(const Instr& in, const EmitArgs& a);
void EmitModulated(const Instr& in, const EmitArgs& a);
void EmitCopy(const Instr& in, const EmitArgs& a);
void EmitSum(const Instr& in, const EmitArgs& a);
void EmitMultiplier(const Instr& in, const EmitArgs& a);
void EmitExpr(const Instr& in, const EmitArgs& a);
void EmitSolve(const Instr& in, const EmitArgs& a);

}  // namespace multibond::plan::kernels
