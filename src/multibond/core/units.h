#pragma once
/// \file
/// The one grammar of units a model file may write (an auxiliary state's `unit:`), see
/// docs/model-format.md, "Names and units". A unit labels result columns and reaches gnuplot
/// scripts and HTML: only what this grammar accepts may pass.
///
///   unit    = "-" | "1" | product [ "/" product ]
///   product = factor { (" " | "*") factor }          (the numerator may be "1": "1/s")
///   factor  = [prefix] symbol [ "^" ["-"] digit [digit] ]
///   prefix  = Y Z E P T G M k h da d c m u µ n p f a z y
///   symbol  = m g s A K mol cd rad sr Hz N Pa J W C V F ohm Ω S Wb T H lm lx Bq Gy Sv kat
///             L bar eV deg min h rev
/// e.g. "N m", "kg m^2", "rad/s", "N m s/rad", "Pa s/m^3", "m s^-2", "1/F", "µm", "kohm".

#include <string>

namespace multibond {

/// The longest unit accepted, in bytes.
constexpr std::size_t kMaxUnitLength = 64;

/// "" when `unit` follows the grammar above; otherwise what is wrong, as a clause naming the first
/// part that is not understood ("'furlong' is not a unit symbol ...", "it holds '`' ...").
std::string UnitProblem(const std::string& unit);

}  // namespace multibond
