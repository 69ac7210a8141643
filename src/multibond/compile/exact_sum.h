#pragma once
/// \file
/// How both engines sum, so that the interpreter gives the bits of the generated code
/// (codegen.cc). A sum of products is a chain: the first product rounded (c0 v0), then each
/// further term added to the running sum, s + ck vk, in the same order on both sides.
///
/// Where the CPU has an FMA instruction, each such term is fused, fma(ck, vk, s), with one
/// rounding: the generated code writes __builtin_fma (the JIT builds with -march=native: one
/// vfmadd) and the interpreter std::fma. A fused multiply-add is correctly rounded by definition,
/// so the instruction, glibc's fma and the compiler's constant folding all give the same bits.
/// Without the instruction a correctly rounded fma is glibc's software routine (about 100 ns a
/// call against 0.3 ns for a multiply and an add, GLIBC 2.36), so there both engines write the
/// term as a multiply and an add. The choice is made once per process (FusedSums) and read by
/// both the code generator and the interpreter: one answer per machine in both engines.
///
/// Everything else is compiled with -ffp-contract=off on both sides (src/CMakeLists.txt,
/// jit.cc), so that no other product and sum is contracted on one side only. A product that is
/// not added to anything (s * y, c * v) stays a plain multiplication on both sides. Sums of terms
/// with coefficients +-1 (the junctions' sums) are plain additions: fma(+-1, v, s) is s +- v.

#include <cmath>

namespace multibond {

/// Where every sum of the evaluation starts: -0.0, the exact identity of addition (-0 + x is x
/// for every x, while +0 + -0 is +0), so that a sum has the bits of its terms written out one
/// after the other; starting from +0.0 would turn a sum that is -0 into +0 in one engine only.
/// A sum of no terms is -0.0 in both engines. -0.0 + c v and fma(c, v, -0.0) are the rounded
/// product c v, the first term of the generated chain.
constexpr double kSumStart = -0.0;

namespace exact_sum_detail {
inline bool DetectFma() {
  __builtin_cpu_init();  // may run before libgcc's own constructor
  return __builtin_cpu_supports("fma");
}
}  // namespace exact_sum_detail

/// Whether this process fuses the terms of its sums (above): where the CPU has FMA. Read by the
/// code generator when it writes a model's code and by the interpreter on every term; a test may
/// set it, before it compiles the models it compares and never while other models are in use.
inline bool fused_sums = exact_sum_detail::DetectFma();

/// s + a b: one term of a chain.
inline double MulAdd(double a, double b, double s) { return fused_sums ? std::fma(a, b, s) : s + a * b; }

/// s + a b for a term whose factors are both variables (the generated code writes every one).
inline double AddProduct(double s, double a, double b) { return MulAdd(a, b, s); }

/// s + c v, where a coefficient that is exactly zero adds nothing (the generated code leaves its
/// term out: 0 * v could otherwise change the sign of a zero sum, or be a NaN for an infinite v).
inline double AddTerm(double s, double c, double v) { return c == 0.0 ? s : MulAdd(c, v, s); }

/// a0 b0 + a1 b1 + a2 b2 as a chain.
inline double Dot3(double a0, double b0, double a1, double b1, double a2, double b2) {
  return MulAdd(a2, b2, MulAdd(a1, b1, a0 * b0));
}

}  // namespace multibond
