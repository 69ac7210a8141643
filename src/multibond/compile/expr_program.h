#pragma once
/// \file
/// An expression compiled for the right-hand side: a flat program of steps over registers,
/// whose inputs are resolved to where their values live at evaluation time (time, a state entry,
/// a workspace slot, a constant). The interpreter (Run) and the code generator (EmitProgram)
/// perform the same operations in the same order with the same function bodies, so both give
/// the same bits (compiled with -ffp-contract=off on both sides). Running allocates nothing.
/// Run executes the steps in a denser form made from them (Program::code): one instruction per
/// operation, reading constants and inputs where they are instead of loading them first.

#include <array>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "multibond/core/expression.h"

namespace multibond::expr {

/// Where a name's value is read from when the program runs.
struct Input {
  enum class In : unsigned char { kTime, kState, kSlot, kConstant };
  In in = In::kConstant;
  int offset = 0;      ///< kState: index in x; kSlot: index in the workspace slots
  double value = 0.0;  ///< kConstant
};

/// Resolves a name of the tree (the node, for its offset in error messages) to an input. It
/// throws (ModelError, with the place and a hint) for a name it does not know; `t` and `pi`
/// reach it too (the usual answers: {kTime}, {kConstant, M_PI}).
using Resolver = std::function<Input(const Node& name)>;

/// One step: regs[dst] = op(regs[a], regs[b], regs[c]) or a load.
struct Step {
  enum class Op : unsigned char { kLoad, kConst, kNeg, kAdd, kSub, kMul, kDiv, kPow, kCall };
  Op op = Op::kConst;
  Fn fn = Fn::kSin;  ///< kCall
  int dst = 0;
  int a = 0, b = 0, c = 0;  ///< argument registers (kCall: up to 3, by arity)
  Input input;              ///< kLoad
  double value = 0.0;       ///< kConst
};

/// Where an operand of a RunStep is read: MakeOperand(place, index) = (index << 3) | place.
enum OperandPlace : unsigned char { kInRegister, kInConstants, kInState, kInSlot, kInTime };
inline constexpr std::uint32_t MakeOperand(OperandPlace place, std::uint32_t index) { return index << 3 | place; }

/// One instruction of the form Run executes: regs[dst] = op(...), each operand read where it
/// lives (a register, the program's constants, the state, a slot, the time), a constant operand
/// of an operator in the instruction itself (k). The steps' loads and constants are not
/// instructions of their own, and `^` with a constant exponent of exactly 2, 3 or -1 is what
/// Power() computes for it.
struct RunStep {
  enum class Op : unsigned char {
    kNeg,                                // -a
    kAdd, kSub, kMul, kDiv, kPow,        // a op b
    kAddK, kSubK, kMulK, kDivK, kPowK,   // a op k
    kKAdd, kKSub, kKMul, kKDiv, kKPow,   // k op a
    kSquare, kCube, kRecip,              // a^2, a^3, a^-1 as Power() computes them: a*a, (a*a)*a, 1/a
    kCall1, kCall2, kCall3,              // fn(a), fn(a, b), fn(a, b, c)
  };
  Op op = Op::kNeg;
  Fn fn = Fn::kSin;           ///< kCall1..3
  unsigned char dst = 0;      ///< a register (kMaxRegs = 256)
  std::uint32_t a = 0, b = 0, c = 0;  ///< operands (MakeOperand), as many as the operation reads
  double k = 0.0;             ///< the constant operand of the ...K and K... operators
};

inline constexpr int kMaxRegs = 256;
inline constexpr int kShortCode = 6;  ///< Program::short_code (a spring k1*q + k3*q^3 is 4 instructions)

struct Program {
  std::vector<Step> steps;
  int num_regs = 0;  ///< at most kMaxRegs
  int result = 0;    ///< the register that holds the value at the end
  std::vector<Input> inputs;  ///< every distinct input read (for the plan's dependencies)
  /// What Run executes, made from `steps` by CompileProgram: the same operations in the same
  /// order on the same values (EmitProgram writes the steps; the test compares the two).
  std::vector<RunStep> code;
  std::vector<double> constants;  ///< the constants `code` reads as operands (kInConstants)
  std::uint32_t value = 0;        ///< the operand that holds the program's value at the end
  /// `code` again when it is short (short_size instructions; -1: longer), inside the Program:
  /// Run reads it there, next to the fields it reads anyway, so that running the programs of an
  /// array reads one block of memory in order instead of a heap block per program (with 1,000
  /// springs and dampers, 30% of the interpreter's time).
  int short_size = -1;
  std::array<RunStep, kShortCode> short_code{};
};

/// Compiles a tree; constant subtrees are folded (with the same Apply, so folding changes no
/// bit). Throws what the resolver throws, or ModelError(code "expr.too_large") beyond kMaxRegs.
Program CompileProgram(const Node& root, const Resolver& resolve);

/// Runs a program. `x` the state, `w` the workspace slots. No allocation (registers on the stack).
double Run(const Program& p, double t, const double* x, const double* w);

/// The program's derivative along a direction: `dt` of the time, `dx` of the state, `dw` of the
/// slots (forward-mode differentiation of its steps, exact). Writes the value to *value if given.
/// No allocation (the constraint solver runs it at every evaluation).
double RunTangent(const Program& p, double t, const double* x, const double* w, double dt, const double* dx, const double* dw,
                  double* value = nullptr);

/// The degree of the program's value in the inputs `moving` selects (by the steps, not by
/// simplification): 0 if it reads none of them, 1 if it is affine in them (a sum of terms each
/// linear in one of them, with coefficients that read none), 2 otherwise. A select `if(c, a, b)`
/// whose condition does not move has the larger of its branches' degrees.
int Degree(const Program& p, const std::function<bool(const Input&)>& moving);

/// A direction of the inputs: `dt` of the time, `dx` of the state, `dw` of the slots.
struct Direction {
  double dt;
  const double* dx;
  const double* dw;
};
/// The program's mixed second derivative along two directions v and f (constant directions of
/// the time and the state; the slots' mixed second derivatives `ddw`), by hyper-dual numbers
/// (each step's value, its two derivatives and their mixed one). Kinks contribute no second
/// derivative (min, max, clamp, abs, sign, comparisons); `if` takes its branch's. For the
/// linearisation of ideal constraints whose equations read the formula.
double RunSecondTangent(const Program& p, double t, const double* x, const double* w, const Direction& v, const Direction& f,
                        const double* ddw);

/// RunTangent of program `index` in an array of programs: the form generated code calls.
double RunTangentIndexed(const void* programs, int index, double t, const double* x, const double* w, double dt, const double* dx,
                         const double* dw);

/// Solves law(u) = target for u, where the law's program reads u from the scratch slot
/// w[unknown] (and `slope`, its derivative, likewise): a resistor whose causality needs the
/// inverse of the law it was given. Newton's method kept inside a bracket (the root is
/// bracketed first, from u = 0 outwards by doubling steps; a Newton step that leaves the bracket
/// or has no slope is replaced by bisection), to the last bits of u; NaN if no root is bracketed
/// (a law that is not monotonic there, or does not reach the target). Leaves w[unknown] = u.
/// No allocation. The generated code calls this very function (its MbSources::solve), so both
/// engines give the same bits.
double SolveFor(const Program& law, const Program& slope, int unknown, double target, double t, const double* x, double* w);
/// SolveFor with the programs by index in an array of programs: the form generated code calls.
double SolveForIndexed(const void* programs, int law, int slope, int unknown, double target, double t, const double* x, double* w);

/// Names of the arrays in generated code.
struct EmitNames {
  const char* t = "t";
  const char* x = "x";
  const char* w = "w";
};
/// The program as C++ statements that declare `const double <prefix>k` values (k the step: each
/// step writes a new constant) and end with the program's value in the one whose name is
/// returned. `prefix` must be unique in
/// the enclosing scope (e.g. "e12_"). Function calls use the helpers of ProgramPreamble().
std::string EmitProgram(const Program& p, const std::string& prefix, const EmitNames& names, std::string& out);

/// C++ text defining the helper functions generated code calls (mb_sign, mb_clamp, ...), with
/// the very bodies Apply uses; written once at the top of a generated file.
std::string ProgramPreamble();

}  // namespace multibond::expr
