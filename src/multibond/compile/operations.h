#pragma once
/// \file
/// The operations of the evaluation plan and their ONE table of traits (docs/design.md, "The
/// compiled model's parts and passes"). A plan is a list of `Instr`; every property of an
/// opcode lives in its row of the table `Traits(op)`: its name, its operand sizes, what it
/// reads (for the Jacobian pattern and the constraint passes), the rule of its time
/// derivative (the constraints' tangent pass), how the interpreter evaluates it (`exec`) and
/// how the code generator writes it (`emit`). The interpreter's kernel and the generated code
/// perform the same floating-point operations in the same order (exact_sum.h): the plan's
/// interpreter and the generated code give bit-identical numbers.

#include <functional>
#include <set>
#include <string>
#include <vector>

#include <Eigen/Dense>

#include "multibond/compile/expr_program.h"
#include "multibond/core/graph.h"
#include "multibond/core/time_function.h"

namespace multibond::plan {

/// Opcodes. Emission produces the generic ones (sizes known at run time); the specialisation
/// pass (Specialize) rewrites most into kernels whose sizes and structure are compile-time
/// constants: diagonal coefficients, 1x3/2x3/3x3 blocks, rotations and lever arms applied
/// straight from the orientation state.
enum class Op : unsigned char {
  // generic
  kSource, kStateScale, kStateMatrix, kIFlowRotated, kScale, kMatrix, kModulated, kSum,
  // specialised
  kStateScale3, kStateDiag3, kIFlowRotatedDiag, kScale1, kScale3, kDiag2, kDiag3,
  kMat13, kMat23, kMat33, kMat31, kMat32,
  kRotFwd1, kRotFwd2, kRotFwd3, kRotBwd1, kRotBwd2, kRotBwd3, kLeverFwd, kLeverBwd,
  kSum1, kSum3, kCopy1, kCopy3,
  // formulas (docs/model-format.md, "Expressions"): dst[k] = program coef + k, of t, x and slots
  kExpr,
  // dst = scale * u with law(u) = (transpose ? -1 : 1) * slot src, law = program coef (reading u
  // from the scratch slot count), its derivative program aux: a law used the other way round
  kSolve,
  // ideal constraints: dst = the multipliers of one constraint (Workspace::lambda + coef)
  kMultiplier,
};
inline constexpr int kNumOps = static_cast<int>(Op::kMultiplier) + 1;

/// One instruction. Plain data: evaluating the plan dispatches on `op` only.
struct Instr {
  Op op;
  bool transpose = false;  ///< rotation kernels: the modulus uses R^T
  int n = 1;       ///< output size
  int m = 1;       ///< input size
  int dst = 0;     ///< workspace offset of the output
  int src = 0;     ///< workspace offset of the input, or state offset (I, C)
  int coef = 0;    ///< offset in the coefficients (scale, matrices, sum terms) or in moduli (modulated); -1 = identity
  int count = 0;   ///< kSum: number of terms; kModulated: 0 = M, 1 = M^T, 2 = M^-1, 3 = M^-T
  int aux = 0;     ///< state offset of R (rotated inertia, rotation and lever kernels)
  int modulus = -1;  ///< kModulated: index in the moduli
  double scale = 1.0;  ///< rotation and lever kernels
  int element = -1;
};

/// How one MTF's or MGY's modulus is evaluated from the state (CompiledModel::EvalModuli).
struct ModulusEval {
  Modulus::Kind kind;
  int rows, cols;
  int out;          ///< offset in Workspace::moduli of M (rows*cols, row-major)
  int out_inverse;  ///< offset of M^-1 or -1 if not needed
  int rotation;     ///< state offset of R (row-major 3x3)
  int left;         ///< offset in the coefficients of the left matrix (rows x 3) or -1
  int right;        ///< offset in the coefficients of the right matrix (3 x cols) or -1
  int constant;     ///< offset in the coefficients of the constant matrix or -1
  double scale;
  bool transpose;
  Eigen::Vector3d lever;
  int constant_rows = 0;  ///< rows of the constant factor (= columns of `left`)
  bool needed = false;    ///< read by a generic kModulated instruction (others apply it on the fly)
};

/// The read-only tables an instruction refers to (all owned by the compiled model).
struct Tables {
  const double* coef = nullptr;       ///< coefficients (Instr::coef)
  const int* sum_terms = nullptr;     ///< sums: workspace offsets of the terms
  const double* sum_signs = nullptr;  ///< sums: their signs
  const TimeFunction* sources = nullptr;
  const expr::Program* programs = nullptr;  ///< formulas (kExpr: programs coef .. coef + n)
};

/// What one evaluation of an instruction reads and writes: reads slots from `win`, writes its
/// output in `wout` (the same array in the plain pass; the constraint passes use others).
struct ExecArgs {
  double t;
  const double* x;       ///< the state (or, in the tangent pass, its rate)
  const double* win;
  double* wout;
  const double* mod;     ///< the moduli
  const double* lambda;  ///< the multipliers
  Tables tables;
};

/// The arrays an instruction's generated code reads and writes, by their names in the code.
struct CodeNames {
  const char* x = "x";    ///< states: the inputs of state kernels, R of rotation and lever kernels
  const char* in = "w";   ///< the slots it reads
  const char* out = "w";  ///< the slots it writes
  const char* mod = "mod";
  bool multipliers = false;  ///< kMultiplier reads lam[] (else 0: the plan at zero multipliers)
};

/// What the code generator needs to write an instruction: its tables, the names of the arrays,
/// the lever arms already declared in the enclosing scope; the code is appended to `out`.
struct EmitArgs {
  Tables tables;
  CodeNames names;
  std::set<std::string>* levers_done;
  std::string* out;
};

/// What `src` of an instruction indexes.
enum class Reads : unsigned char {
  kNothing,      ///< a source: a function of time
  kState,        ///< a state block (I momenta, C displacements): src is a state offset
  kSlots,        ///< slots src .. src + m
  kSumTerms,     ///< the slots listed in sum_terms[coef .. coef + count]
  kMultipliers,  ///< lambda[coef .. coef + n]
  kProgram,      ///< the inputs of programs coef .. coef + n (time, states, slots)
  kSolve,        ///< the inputs of program coef, and slot src
};

/// How the outputs depend on the inputs (the Jacobian pattern).
enum class Coupling : unsigned char {
  kComponentwise,  ///< output k reads input component k only (scalings, diagonals, copies, sums)
  kDense,          ///< every output reads every input
};

/// The rule of the constraints' tangent pass (time derivative of the output along dx/dt).
enum class Tangent : unsigned char {
  kSourceRate,      ///< d/dt of the source functions
  kZero,            ///< multipliers: efforts only, never reach a constraint's flow
  kStateRate,       ///< linear in the state: the same kernel on dx/dt
  kRotatedInertia,  ///< R Ib^-1 R^T h: the product rule written out
  kBilinear,        ///< bilinear in R and the input: K(R) du + K(dR) u
  kModulated,       ///< M u: M du + dM u; M^-1 u: M^-1 (du - dM y)
  kLinear,          ///< a constant linear map of slots: the same map of their derivatives
  kNone,            ///< not derived (formulas): a model with ideal constraints refuses them
};

/// The state kernel of an instruction that reads a state block s: dst = E s (or R Ib^-1 R^T s
/// with the orientation r). The interpreter passes the state; the constraint solve its own momenta.
using StateFn = void (*)(const Instr& in, const double* c, const double* r, const double* s, double* dst);
/// The same as C++ text, from the input expressions src(k) to the outputs dst(k); R from x[].
using EmitStateFn = void (*)(const Instr& in, const double* c, const std::function<std::string(int)>& src,
                             const std::function<std::string(int)>& dst, std::string& o);
using ExecFn = void (*)(const Instr& in, const ExecArgs& a);
using EmitFn = void (*)(const Instr& in, const EmitArgs& a);

/// One row of the table: everything about one opcode.
struct OpTraits {
  Op op;             ///< the row's opcode (the table is in enum order; checked by the tests)
  const char* name;  ///< as in dumps and tests: "scale1", "rot_fwd3"
  int n, m;          ///< fixed output and input sizes, 0 = the instruction's own (n, m)
  Op generic;        ///< the generic opcode it specialises (itself for a generic one)
  Reads reads;
  Coupling coupling;
  bool rotation;     ///< also reads the orientation R (9 states at Instr::aux)
  bool modulus;      ///< also reads a modulus (Instr::modulus, evaluated by EvalModuli)
  Tangent tangent;
  ExecFn exec;       ///< the interpreter's kernel
  EmitFn emit;       ///< the code generator's
  StateFn state = nullptr;           ///< Reads::kState only
  EmitStateFn emit_state = nullptr;  ///< Reads::kState only
};

/// The table, in enum order (operations.cc).
extern const OpTraits kOpTable[kNumOps];
/// The row of `op`.
inline const OpTraits& Traits(Op op) { return kOpTable[static_cast<int>(op)]; }

/// Evaluates one instruction (the interpreter).
inline void Exec(const Instr& in, const ExecArgs& a) { Traits(in.op).exec(in, a); }
/// Writes one instruction as C++ (the code generator).
inline void Emit(const Instr& in, const EmitArgs& a) { Traits(in.op).emit(in, a); }

/// What the tangent rule of an instruction reads and writes: the derivative of its output along
/// a direction, from its inputs' derivatives. `xdot` is the direction of the state (dx/dt in the
/// constraints' tangent pass), `w` the plain evaluation's slots, `d` the derivatives of the slots
/// (read and written), `tmp` scratch of the slots' size that must be zero and is left zero,
/// `dmod` the moduli's derivatives along xdot (CompiledModel::EvalModuli with derivative).
struct TangentArgs {
  double t;
  const double* x;
  const double* xdot;
  const double* w;
  double* d;
  double* tmp;
  const double* mod;
  const double* dmod;
  const double* lambda;
  Tables tables;
  const ModulusEval* moduli;
  /// Sources (kSourceRate): their time derivatives (the tangent pass), or zero (a direction of
  /// the state only; the caller adds an input's direction).
  bool source_rate = true;
};
/// Applies the tangent rule of `in` (its row's Tangent; a formula's, kNone, is FormulaTangent).
void ExecTangent(const Instr& in, const TangentArgs& a);
/// The tangent of a formula (kExpr, kSolve) by forward-mode differentiation of its programs
/// (tables.programs; expr::RunTangent): the time enters at rate 1 when source_rate, else 0; a
/// law used backwards (kSolve) by the implicit function theorem.
void FormulaTangent(const Instr& in, const TangentArgs& a);

/// What the second-order rule of an instruction reads and writes (the linearisation of ideal
/// constraints, compile/tangent.cc): the mixed second derivative of its output along two
/// directions v and F of the state, from its inputs' first derivatives along each (dv, df) and
/// their mixed second derivatives (dd, read and written). The directions are constant (no second
/// derivative of the state itself); dmod_v and dmod_f are the moduli's derivatives along each.
struct SecondTangentArgs {
  double t;
  const double* x;
  const double* xv;
  const double* xf;
  const double* w;
  const double* dv;
  const double* df;
  double* dd;
  double* tmp;  ///< zero, of the slots' size; left zero
  const double* mod;
  const double* dmod_v;
  const double* dmod_f;
  const double* lambda;
  Tables tables;
  const ModulusEval* moduli;
};
/// Applies the second-order rule of `in` (a formula's: expr::RunSecondTangent, the time moving
/// along F at rate 1; not a law used backwards).
void ExecSecondTangent(const Instr& in, const SecondTangentArgs& a);

/// Appends m to a coefficient table, row-major (the layout every kernel reads).
inline void AppendRowMajor(std::vector<double>& pool, const Eigen::MatrixXd& m) {
  for (int r = 0; r < m.rows(); ++r)
    for (int c = 0; c < m.cols(); ++c) pool.push_back(m(r, c));
}

/// The specialisation pass: rewrites generic instructions into fixed-size kernels (see Op),
/// appending the diagonals and lever arms they need to `coef`, and marks in `moduli` the ones
/// a generic kModulated still reads. Returns the indices of those moduli (EvalModuli's list).
std::vector<int> Specialize(std::vector<Instr>& plan, std::vector<double>& coef, const std::vector<int>& sum_terms,
                            const std::vector<double>& sum_signs, std::vector<ModulusEval>& moduli);

}  // namespace multibond::plan
