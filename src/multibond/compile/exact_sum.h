#pragma once
/// \file
/// How the interpreter sums, so that it gives the bits of the generated code (codegen.cc), which
/// writes each sum out as c0 * v0 + c1 * v1 + ..., leaving out coefficients that are exactly
/// zero. Both sides are compiled with -ffp-contract=off (no fused multiply-add).

namespace multibond {

/// Where every sum of the evaluation starts: -0.0, the exact identity of addition (-0 + x is x
/// for every x, while +0 + -0 is +0), so that a sum has the bits of its terms written out one
/// after the other; starting from +0.0 would turn a sum that is -0 into +0 in one engine only.
/// A sum of no terms is -0.0 in both engines.
constexpr double kSumStart = -0.0;

/// s + c v, where a coefficient that is exactly zero adds nothing (the generated code leaves its
/// term out: 0 * v could otherwise change the sign of a zero sum, or be a NaN for an infinite v).
inline double AddTerm(double s, double c, double v) { return c == 0.0 ? s : s + c * v; }

}  // namespace multibond
