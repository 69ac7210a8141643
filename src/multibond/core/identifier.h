#pragma once
/// \file
/// The one grammar of the names a model file gives (elements, bonds, states, bodies, joints, gear
/// meshes, drives, points, submodels, their parameters, outputs, the model): see
/// docs/model-format.md, "Names and units". A name heads result columns ("spring.q", "G.omega.x"),
/// figure files and generated code, so it is an identifier: it cannot hold the '.' that joins the
/// parts of a column name, the '->' of a bond, a space, a quote or anything a shell, gnuplot or
/// HTML would read.

#include <cstddef>
#include <string>

namespace multibond {

/// The longest name accepted, in characters.
constexpr std::size_t kMaxNameLength = 64;

/// "" when `name` is an identifier: an ASCII letter or '_', then ASCII letters, digits and '_', at
/// most kMaxNameLength characters. Otherwise what is wrong with it, e.g. "holds '.' (it separates
/// the parts of result column names, as in spring.q)".
/// `digit_first`: a leading digit is allowed too (component names: "1", "2", "x").
std::string IdentifierProblem(const std::string& name, bool digit_first = false);

/// An identifier close to `name` for a hint: every other character replaced by '_', a leading
/// digit prefixed by '_', cut to kMaxNameLength ("" if nothing of it is left).
std::string SuggestIdentifier(const std::string& name);

/// `text` as it may be printed in a message: control characters and bytes >= 0x80 shown as '?',
/// cut to `max` characters with "...".
std::string PrintableExcerpt(const std::string& text, std::size_t max = 80);

}  // namespace multibond
