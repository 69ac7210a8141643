#pragma once
/// \file
/// How both engines sum, so that the interpreter gives the bits of the generated code
/// (codegen.cc). A sum of products is a chain: the first product rounded (c0 v0), then each
/// further term fused into the running sum with one rounding, fma(ck, vk, s). The generated code
/// writes the chain with __builtin_fma and the interpreter with std::fma (AddTerm, AddProduct):
/// a fused multiply-add is correctly rounded by definition, so the FMA instruction (the JIT is
/// built with -march=native), glibc's fma (an FMA instruction chosen at run time, or exact
/// software) and the compiler's constant folding all give the same bits. Everything else is
/// compiled with -ffp-contract=off in both engines (src/CMakeLists.txt, jit.cc), so that no other
/// product and sum is contracted on one side only. A product that is not added to anything
/// (s * y, c * v) stays a plain multiplication on both sides.
///
/// Sums of terms with coefficients +-1 (the junctions' sums) are plain additions on both sides:
/// fma(+-1, v, s) is s +- v exactly.

#include <cmath>

namespace multibond {

/// Where every sum of the evaluation starts: -0.0, the exact identity of addition (-0 + x is x
/// for every x, while +0 + -0 is +0), so that a sum has the bits of its terms written out one
/// after the other; starting from +0.0 would turn a sum that is -0 into +0 in one engine only.
/// A sum of no terms is -0.0 in both engines. fma(c, v, -0.0) is the rounded product c v, the
/// first term of the generated chain.
constexpr double kSumStart = -0.0;

/// s + a b with one rounding: a term of a chain whose factors are both variables (the generated
/// code writes every such term).
inline double AddProduct(double s, double a, double b) { return std::fma(a, b, s); }

/// s + c v with one rounding, where a coefficient that is exactly zero adds nothing (the
/// generated code leaves its term out: 0 * v could otherwise change the sign of a zero sum, or
/// be a NaN for an infinite v).
inline double AddTerm(double s, double c, double v) { return c == 0.0 ? s : std::fma(c, v, s); }

/// a0 b0 + a1 b1 + a2 b2 as the chain fma(a2, b2, fma(a1, b1, a0 b0)).
inline double Dot3(double a0, double b0, double a1, double b1, double a2, double b2) {
  return std::fma(a2, b2, std::fma(a1, b1, a0 * b0));
}

}  // namespace multibond
