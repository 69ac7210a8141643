#pragma once
/// \file
/// Pieces of generated C++ text shared by the code generator (codegen.cc) and the operation
/// table's emitters (op_emit.cc). Every sum is written as exact_sum.h forms it in the
/// interpreter, so that both give the same numbers.

#include <cmath>
#include <string>
#include <utility>
#include <vector>

#include <fmt/format.h>

#include "multibond/compile/exact_sum.h"

namespace multibond::code {

/// An exact literal (hexadecimal floating point round-trips every double).
inline std::string Lit(double v) { return fmt::format("({:a})", v); }

inline std::string W(int i) { return fmt::format("w[{}]", i); }

/// A user's name as the text of a // comment in generated code: printable ASCII except the
/// backslash, anything else as '?'. A line break in a name would end the comment and let the
/// rest of the name run as code, and a backslash at the end of the line would splice the next
/// line of code into the comment; names are checked by the loader, but the C++ API takes any.
inline std::string CommentText(const std::string& name) {
  std::string out = name;
  for (char& ch : out)
    if (ch < 0x20 || ch > 0x7e || ch == '\\') ch = '?';
  return out;
}

/// s + a b, one term of a chain: fused where the process fuses its sums (exact_sum.h: MulAdd in
/// the interpreter, read from the same flag).
inline std::string Fma(const std::string& a, const std::string& b, const std::string& s) {
  return fused_sums ? "__builtin_fma(" + a + ", " + b + ", " + s + ")" : "(" + s + " + " + a + " * " + b + ")";
}

/// -a for a name or a literal (a function: GCC 12 warns, wrongly, on "-" + std::string&&).
inline std::string Neg(const std::string& a) { return fmt::format("-{}", a); }

/// The chain a0 b0 + a1 b1 + ...: the first product rounded, each next one fused into the running
/// sum (exact_sum.h); an empty chain is -0.0. The interpreter: AddProduct from kSumStart.
inline std::string Chain(const std::vector<std::pair<std::string, std::string>>& products) {
  std::string e;
  for (const auto& [a, b] : products) e = e.empty() ? a + " * " + b : Fma(a, b, e);
  return e.empty() ? "(-0.0)" : e;
}

/// sum_k coef_k * term_k as a chain (AddTerm in the interpreter), leaving out exact zeros (a
/// compiler may not drop 0.0 * x itself: x could be an infinity or a NaN) and writing +-1 as a
/// plain sum (fma(+-1, t, s) is s +- t exactly); the first term is the rounded product, which
/// MulAdd(c, t, -0.0) is. A sum with no term is -0.0, where the interpreter's sums start.
inline std::string LinComb(const std::vector<std::pair<double, std::string>>& terms) {
  std::string e;
  for (const auto& [c, t] : terms) {
    if (c == 0.0) continue;
    const bool unit = std::abs(c) == 1.0;
    if (e.empty()) e = (c < 0 ? "-" : "") + (unit ? t : Lit(std::abs(c)) + " * " + t);
    else if (unit) e += (c < 0 ? " - " : " + ") + t;
    else e = Fma(Lit(c), t, e);
  }
  return e.empty() ? "(-0.0)" : e;
}

}  // namespace multibond::code
