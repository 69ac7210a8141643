#pragma once
/// \file
/// Private to solve/: the ARKODE ERKStep-backed integrator (Method::kDormandPrince,
/// Method::kBogackiShampine, Method::kRk4).

#include <memory>

#include "multibond/solve/integrator.h"

namespace multibond {

/// Expects options already validated by MakeIntegrator and system.num_states() > 0.
std::unique_ptr<Integrator> MakeArkodeIntegrator(OdeSystem& system, const IntegratorOptions& options);

}  // namespace multibond
