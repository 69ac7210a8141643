#pragma once
/// \file
/// Structural analysis of a bond graph before causality: port counts, bond dimensions (inferred
/// through junctions and transformers), physical domains and units, and parameter sanity
/// (finite numbers, positive-definite inertia and stiffness, non-negative resistance).

#include <string>
#include <vector>

#include "multibond/core/graph.h"

namespace multibond {

/// Units of a domain's power variables and their integrals.
struct DomainUnits {
  std::string effort, flow, momentum, displacement;
};

/// Units of "translation", "rotation", "electrical", "hydraulic"; "-" for anything else.
DomainUnits UnitsOf(const std::string& domain);
/// The domains multibond knows units for.
const std::vector<std::string>& KnownDomains();

/// Square, symmetric (to 1e-12 relative) and with a Cholesky factor: what an inertia, a stiffness
/// or a compliance matrix must be.
bool IsPositiveDefinite(const Eigen::MatrixXd& m);

struct Structure {
  std::vector<int> bond_dim;              ///< per bond
  std::vector<std::string> bond_domain;   ///< per bond ("" = generic)
  std::vector<int> port_in, port_out;     ///< per element: two-ports' bond in (port 1) and out (port 2)
  int dim_of(const BondGraph& g, int element) const;  ///< a one-port's or junction's bond dimension
};

/// Checks the graph's structure and infers dimensions and domains. Every problem found goes to
/// `sink` (with the element's location); the returned Structure is only meaningful when the sink
/// has no errors.
Structure AnalyzeStructure(const BondGraph& g, const std::string& default_domain, DiagnosticSink& sink);

}  // namespace multibond
