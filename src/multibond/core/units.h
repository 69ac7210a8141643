#pragma once
/// \file
/// The one grammar of units a model file may write (a parameter's or an auxiliary state's
/// `unit:`), see docs/model-format.md, "Names and units"; what a unit of it means (a dimension
/// over the SI base units and a scale); and the dimension analysis of formulas that checks them
/// (docs/model-format.md, "Units in formulas"). A unit labels result columns and reaches
/// gnuplot scripts and HTML: only what this grammar accepts may pass.
///
///   unit    = "-" | "1" | product [ "/" product ]
///   product = factor { (" " | "*") factor }          (the numerator may be "1": "1/s")
///   factor  = [prefix] symbol [ "^" ["-"] digit [digit] ]
///   prefix  = Y Z E P T G M k h da d c m u µ n p f a z y
///   symbol  = m g s A K mol cd rad sr Hz N Pa J W C V F ohm Ω S Wb T H lm lx Bq Gy Sv kat
///             L bar eV deg min h rev
/// e.g. "N m", "kg m^2", "rad/s", "N m s/rad", "Pa s/m^3", "m s^-2", "1/F", "µm", "kohm".
///
/// The meaning of the symbols is a table here rather than a units library: the grammar is the
/// format's own (everything after the '/' is the denominator, `rev` and `deg` are angles, rad and
/// sr are numbers), so a library's parser would accept another language, and the table is the
/// SI's definitions, each one line.

#include <array>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <string_view>

#include "multibond/core/expression.h"

namespace multibond {

/// The longest unit accepted, in bytes.
constexpr std::size_t kMaxUnitLength = 64;

/// "" when `unit` follows the grammar above; otherwise what is wrong, as a clause naming the first
/// part that is not understood ("'furlong' is not a unit symbol ...", "it holds '`' ...").
std::string UnitProblem(const std::string& unit);

/// A power of a base unit: a fraction in lowest terms, den > 0 (a root makes m^(1/2)).
struct Exponent {
  std::int64_t num = 0;
  std::int64_t den = 1;
  friend bool operator==(const Exponent&, const Exponent&) = default;
};

/// The SI base units, in the order of a Dimension: m, kg, s, A, K, mol, cd. The radian and the
/// steradian are numbers (m/m, m^2/m^2), as in the SI.
inline constexpr int kBaseUnits = 7;
inline constexpr std::array<const char*, kBaseUnits> kBaseUnitSymbols = {"m", "kg", "s", "A", "K", "mol", "cd"};
using Dimension = std::array<Exponent, kBaseUnits>;

/// What a unit means: its dimension and the value in SI base units of 1 of it (mm: 0.001 m,
/// min: 60 s, deg: pi/180, kohm: 1000 kg m^2/(s^3 A^2)).
struct Unit {
  Dimension dim{};
  double scale = 1.0;
};

/// The meaning of a unit of the grammar ("-" and "1": a number, scale 1); nullopt when
/// UnitProblem(unit) is not "".
std::optional<Unit> ParseUnit(const std::string& unit);

/// True when every exponent is 0.
bool IsDimensionless(const Dimension& d);

/// The unit of the integral over time of a quantity in `unit` (a unit of the grammar): "rad/s"
/// -> "rad", "1/s" -> "-", "V" -> "V s", "N/m" -> "N s/m", "-" -> "s"; "" for "".
std::string TimeIntegralUnit(const std::string& unit);

/// A dimension in SI base units, as the grammar writes a unit: "kg m^2/s^2", "1/s", "m"; "1" for
/// none. A fractional exponent is written m^(1/2) (outside the grammar: for messages).
std::string FormatDimension(const Dimension& d);

// ---------------------------------------------------------------------------------------------
// Dimension analysis of a formula (docs/model-format.md, "Units in formulas"). The rules:
//  * a name with a declared unit has that unit; any other name (a parameter without a unit, a
//    submodel's parameter, time, a variable of the model) is free: it takes whatever unit its
//    place needs, and nothing is checked through it;
//  * a number (and pi) has no dimension in a product and takes the unit of the other side in a
//    sum (L + 0.5 is a length: numbers are SI values); a number multiplying a quantity may be a
//    conversion factor (d/1000 for a d in mm is taken as metres), so it forgets the scale;
//  * the sides of + and -, and the arguments of min, max, clamp, hypot, atan2, smoothabs and
//    smoothsign have one dimension; when both scales are known they are equal too (m + mm is an
//    error: values are not converted);
//  * * and / combine dimensions and scales; abs and - keep them;
//  * sin, cos, tan, asin, acos, atan, sinh, cosh, tanh, exp and log take a number (an angle in
//    rad); their value, and that of sign, atan2 and smoothsign, is a number;
//  * x^y: y has no dimension; when x has a dimension, y is a constant whose value is a fraction
//    with a denominator of at most 100 (sqrt(x) is x^(1/2));
//  * the sides of a comparison (<, <=, >, >=, ==, !=) have one dimension (and scale, as a sum's);
//    the operands of and, or, not and the condition of if are truth values: comparisons or
//    values without dimension (of any scale); the value of each of these is a number;
//  * the two branches of if have one dimension (and scale), which is the value's.

/// What the analysis knows of the value of a formula or of a part of it.
struct FormulaUnit {
  enum class Kind : unsigned char {
    kFree,    ///< any unit: nothing is known (a name without a unit, a variable)
    kNumber,  ///< a plain number: no dimension in a product, the other side's unit in a sum
    kUnit,    ///< `unit`
  };
  Kind kind = Kind::kFree;
  Unit unit;
  bool scale_known = true;  ///< kUnit: false once a number multiplied or divided it
  std::string label;        ///< the unit as the file writes it, when it is one name's ("" else)
};

/// "m", "kg m^2/s^2", "0.001 m", "a number" (without dimension), "any unit" (free): for messages.
/// A name's unit is written as declared ("mm", "N m/rad").
std::string DescribeUnit(const FormulaUnit& u);

/// Whether a formula's unit `got` can be labelled `want`: kSame also when it is free, a number or
/// of an unknown scale with want's dimension; kDimension: another dimension; kScale: one
/// dimension, another scale (values are not converted).
enum class UnitMatch : unsigned char { kSame, kDimension, kScale };
UnitMatch MatchUnit(const FormulaUnit& got, const Unit& want);

/// The first unit mismatch of a formula: the byte offset in its text of the operator or
/// function where it is, what and how to fix it.
struct UnitMismatch {
  int offset = 0;
  std::string message;
  std::string hint;
};

/// A name's declared unit: its meaning and its text as written.
struct DeclaredUnit {
  Unit unit;
  std::string text;
};

struct FormulaUnits {
  FormulaUnit unit;                      ///< of the whole formula (kFree after a mismatch)
  std::optional<UnitMismatch> mismatch;  ///< the first mismatch, if any
};

/// The unit of the formula `root` parsed from `text` (its text locates operators and names the
/// operands in messages). `unit_of(name)`: the declared unit of a name, nullopt when it is free
/// (`pi` is a number and is not asked). `value_of(name)`: the value of a name that is a constant
/// (for the exponent of a power), nullopt otherwise.
FormulaUnits CheckFormulaUnits(const expr::Node& root, std::string_view text,
                               const std::function<std::optional<DeclaredUnit>(const std::string&)>& unit_of,
                               const std::function<std::optional<double>(const std::string&)>& value_of);

}  // namespace multibond
