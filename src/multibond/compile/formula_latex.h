#pragma once
/// \file
/// A formula typeset as LaTeX mathematics for `multibond equations --format latex`: functions as
/// operators (\max, \sin, \sqrt{}, |x|), quotients as fractions, powers as superscripts, Greek
/// names as letters, a number in scientific notation as m \cdot 10^{e}, if(c, a, b) as cases, and
/// the fewest parentheses the precedence needs. Only the formula's own characters are read: every
/// name is escaped, so no text of a model can inject LaTeX.

#include <optional>
#include <string>
#include <string_view>

namespace multibond {

/// The LaTeX of a formula's text (core/expression.h's grammar); nullopt when it does not parse
/// (a description such as "x solved from ..." rather than a formula).
std::optional<std::string> FormulaLatex(std::string_view text);

}  // namespace multibond
