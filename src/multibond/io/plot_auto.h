#pragma once
/// \file
/// The general figures of any results.csv: every output against time, grouped by element and by
/// unit. A column "spring.q" belongs to the element "spring" (the name up to its first dot; names
/// without a dot, a model's named outputs, to "outputs"); each element gets one figure per unit
/// ("spring-m": all of spring.* in m), so that the x, y and z of a vector and the nine R.ij of an
/// orientation matrix are drawn together. The energy.* columns make one figure, the energy
/// account (work, kinetic, potential, dissipated in J; the residual in its own panel), first.
///
/// Bounded: a figure has at most kMaxCurvesPerFigure curves (a larger group is split), and at
/// most `max_figures` figures are made (the rest are left out with a warning).

#include <cstddef>
#include <string>
#include <vector>

#include "multibond/io/plot_figures.h"

namespace multibond {

constexpr std::size_t kMaxCurvesPerFigure = 12;

/// The figures for the columns `names` with `units` (results.csv's header; "time" is the
/// x axis, not a figure). Every name and unit is file text: it reaches the figures' markup
/// escaped (GnuplotLiteralText). Figure names are made of the element and the unit
/// ("spring-m", "outputs-rad_s", "energy-account"), each unique. Sections: one per element.
FigureList AutoFigures(const std::vector<std::string>& names, const std::vector<std::string>& units, std::size_t max_figures,
                       std::vector<std::string>& warnings);

}  // namespace multibond
