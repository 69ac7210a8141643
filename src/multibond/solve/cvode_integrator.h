#pragma once
/// \file
/// Private to solve/: the CVODE-backed integrator (Method::kBdf, Method::kAdams).

#include <memory>

#include "multibond/solve/integrator.h"

namespace multibond {

/// Expects options already validated by MakeIntegrator and system.num_states() > 0.
std::unique_ptr<Integrator> MakeCvodeIntegrator(OdeSystem& system, const IntegratorOptions& options);

}  // namespace multibond
