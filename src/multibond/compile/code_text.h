#pragma once
/// \file
/// Pieces of generated C++ text shared by the code generator (codegen.cc) and the operation
/// table's emitters (op_emit.cc). Every sum is written as exact_sum.h forms it in the
/// interpreter, so that both give the same numbers.

#include <bit>
#include <cmath>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include <fmt/format.h>

#include "multibond/compile/exact_sum.h"

namespace multibond::code {

/// An exact literal (hexadecimal floating point round-trips every double).
inline std::string Lit(double v) { return fmt::format("({:a})", v); }

/// An exact literal of any double: hexadecimal for finite values, the bits for infinities and
/// NaNs (a folded 1/0 or 0/0 keeps its sign and payload).
inline std::string ExactLit(double v) {
  if (std::isfinite(v)) return Lit(v);
  return fmt::format("(__builtin_bit_cast(double, 0x{:016x}ULL))", std::bit_cast<std::uint64_t>(v));
}

/// The table of numbers that the generated code being written on this thread reads at run time
/// (`val[k]`), or null: numbers are literals. See ValueScope.
inline thread_local std::vector<double>* value_table = nullptr;

/// While it lives, the numbers the emitters write (Num) go to `table` and the text reads them as
/// `val[k]`: the text then depends on the model's structure only, not on its parameter values
/// (docs/design.md, "Generated code at scale"). One entry per use, never shared between equal
/// values: equal values must not give a text different from unequal ones.
class ValueScope {
 public:
  explicit ValueScope(std::vector<double>* table) : before_(value_table) { value_table = table; }
  ~ValueScope() { value_table = before_; }
  ValueScope(const ValueScope&) = delete;
  ValueScope& operator=(const ValueScope&) = delete;

 private:
  std::vector<double>* before_;
};

/// A number of the model (a coefficient, a source's value, a scale, a formula's constant) as
/// generated code reads it: from the value table when one is open (ValueScope), else a literal.
inline std::string Num(double v) {
  if (!value_table) return ExactLit(v);
  value_table->push_back(v);
  return fmt::format("val[{}]", value_table->size() - 1);
}

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

/// sum_k coef_k * term_k as a chain (the coefficients through Num) (AddTerm in the interpreter), leaving out exact zeros (a
/// compiler may not drop 0.0 * x itself: x could be an infinity or a NaN) and writing +-1 as a
/// plain sum (fma(+-1, t, s) is s +- t exactly); the first term is the rounded product, which
/// MulAdd(c, t, -0.0) is. A sum with no term is -0.0, where the interpreter's sums start.
inline std::string LinComb(const std::vector<std::pair<double, std::string>>& terms) {
  std::string e;
  for (const auto& [c, t] : terms) {
    if (c == 0.0) continue;
    const bool unit = std::abs(c) == 1.0;
    if (e.empty()) e = (c < 0 ? "-" : "") + (unit ? t : Num(std::abs(c)) + " * " + t);
    else if (unit) e += (c < 0 ? " - " : " + ") + t;
    else e = Fma(Num(c), t, e);
  }
  return e.empty() ? "(-0.0)" : e;
}

}  // namespace multibond::code
