#pragma once
/// \file
/// One set of defaults for a run: the options given (SimulationOptions, the public API's; the
/// command line can fill the same fields) over the model file's `simulation:` section over the
/// built-in defaults.

#include "multibond/io/limits.h"
#include "multibond/io/model_loader.h"
#include "multibond/sim/simulator.h"
#include "multibond/multibond.h"

namespace multibond {

/// The built-in defaults (docs/api.md, `multibond run --help`).
inline constexpr double kDefaultEndTime = 1.0, kDefaultOutputInterval = 1e-3, kDefaultRtol = 1e-8, kDefaultAtol = 1e-10;
inline constexpr const char* kDefaultSolver = "bdf";

/// The run options for `lm`. Throws std::invalid_argument for an unknown solver, Jacobian kind or
/// coordinates, or joint coordinates for a model without bodies. The run itself checks the rest
/// (CheckRunOptions).
RunOptions ResolveRunOptions(const LoadedModel& lm, const SimulationOptions& given, const InputLimits& limits);

}  // namespace multibond
