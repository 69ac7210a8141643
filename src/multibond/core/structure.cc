#include "multibond/core/diagnostic_codes.h"
#include "multibond/core/structure.h"

#include "multibond/core/union_find.h"

#include <cmath>
#include <numeric>

#include <fmt/format.h>

namespace multibond {

namespace {

bool AllFinite(const Eigen::MatrixXd& m) { return m.allFinite(); }

bool IsPositiveSemiDefinite(const Eigen::MatrixXd& m) {
  if (m.rows() != m.cols()) return false;
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(0.5 * (m + m.transpose()));
  return es.eigenvalues().minCoeff() >= -1e-12 * (1.0 + m.norm());
}

/// The dimension an element's own parameters fix for its bond (0 = none).
int OwnDim(const Element& e) {
  if (e.dim > 0) return e.dim;
  if (IsOnePort(e.kind)) {
    if (e.kind == ElementKind::kI && !e.rotation.empty()) return 3;
    if (!e.param.is_scalar) return e.param.rows();
    if (IsSource(e.kind) && e.source.components.size() > 1) return static_cast<int>(e.source.components.size());
    if (IsSource(e.kind) && e.value.size() > 1) return static_cast<int>(e.value.size());
    if (e.initial.size() > 1) return static_cast<int>(e.initial.size());
  }
  return 0;
}

}  // namespace

bool IsPositiveDefinite(const Eigen::MatrixXd& m) {
  if (m.rows() != m.cols()) return false;
  if (!m.isApprox(m.transpose(), 1e-12 * (1.0 + m.norm()))) return false;
  Eigen::LLT<Eigen::MatrixXd> llt(m);
  return llt.info() == Eigen::Success;
}

DomainUnits UnitsOf(const std::string& domain) {
  if (domain == "translation") return {"N", "m/s", "N s", "m"};
  if (domain == "rotation") return {"N m", "rad/s", "N m s", "rad"};
  if (domain == "electrical") return {"V", "A", "V s", "C"};
  if (domain == "hydraulic") return {"Pa", "m^3/s", "Pa s", "m^3"};
  return {"-", "-", "-", "-"};
}

const std::vector<std::string>& KnownDomains() {
  static const std::vector<std::string> kDomains = {"translation", "rotation", "electrical", "hydraulic", "generic"};
  return kDomains;
}

int Structure::dim_of(const BondGraph& g, int element) const {
  const Element& e = g.element(element);
  return e.bonds.empty() ? 1 : bond_dim[e.bonds.front()];
}

Structure AnalyzeStructure(const BondGraph& g, const std::string& default_domain, DiagnosticSink& sink) {
  const int nb = g.num_bonds();
  Structure s;
  s.port_in.assign(g.num_elements(), -1);
  s.port_out.assign(g.num_elements(), -1);
  ValueUnion<int> dims(nb);
  ValueUnion<std::string> domains(nb);

  auto dim_conflict = [&](const Element& e, const std::string& what) {
    sink.Error(codes::kStructureDimension, e.where, e.name, "bond dimension mismatch: " + what,
               "check the sizes of the matrices and vectors given for the connected elements");
  };

  for (int b = 0; b < nb; ++b)
    if (g.bond(b).dim > 0) dims.Set(b, g.bond(b).dim);

  for (int i = 0; i < g.num_elements(); ++i) {
    const Element& e = g.element(i);
    const int n = static_cast<int>(e.bonds.size());
    // Ports.
    if (n == 0) {
      sink.Error(codes::kStructureDangling, e.where, e.name, fmt::format("dangling element: {} '{}' has no bond", KindName(e.kind), e.name),
                 "connect it with a bond, or remove it");
      continue;
    }
    if (IsOnePort(e.kind) && n != 1) {
      sink.Error(codes::kStructurePorts, e.where, e.name, fmt::format("{} is a one-port element but has {} bonds", KindName(e.kind), n),
                 "connect several bonds through a 0- or 1-junction");
      continue;
    }
    if (IsTwoPort(e.kind)) {
      for (int b : e.bonds) {
        if (g.bond(b).to == i) {
          if (s.port_in[i] >= 0) sink.Error(codes::kStructurePorts, e.where, e.name, "two-port element has more than one bond pointing in", "a two-port has one bond in (port 1) and one out (port 2)");
          s.port_in[i] = b;
        } else {
          if (s.port_out[i] >= 0) sink.Error(codes::kStructurePorts, e.where, e.name, "two-port element has more than one bond pointing out", "a two-port has one bond in (port 1) and one out (port 2)");
          s.port_out[i] = b;
        }
      }
      if (n != 2 || s.port_in[i] < 0 || s.port_out[i] < 0) {
        sink.Error(codes::kStructurePorts, e.where, e.name, fmt::format("{} needs exactly one bond in (port 1) and one bond out (port 2), has {}", KindName(e.kind), n),
                   "orient the bonds through the transformer or gyrator: in on one side, out on the other");
        continue;
      }
    }
    // Dimensions.
    if (IsOnePort(e.kind) || IsJunction(e.kind)) {
      const int own = OwnDim(e);
      for (int b : e.bonds) {
        if (own > 0 && !dims.Set(b, own)) dim_conflict(e, fmt::format("its parameters are {}-dimensional but bond '{}' is {}-dimensional", own, g.bond(b).name, dims.Get(b)));
        if (b != e.bonds.front() && !dims.Merge(e.bonds.front(), b)) dim_conflict(e, "bonds of different dimensions meet here");
      }
    } else {
      const int in = s.port_in[i], out = s.port_out[i];
      int rows = 0, cols = 0;
      if (e.kind == ElementKind::kMTF || e.kind == ElementKind::kMGY) {
        rows = e.modulus.rows();
        cols = e.modulus.cols();
      } else if (!e.param.is_scalar) {
        rows = e.param.rows();
        cols = e.param.cols();
      }
      if (rows > 0) {
        if (!dims.Set(in, cols)) dim_conflict(e, fmt::format("port 1 (in) needs dimension {}, bond '{}' has {}", cols, g.bond(in).name, dims.Get(in)));
        if (!dims.Set(out, rows)) dim_conflict(e, fmt::format("port 2 (out) needs dimension {}, bond '{}' has {}", rows, g.bond(out).name, dims.Get(out)));
      } else if (!dims.Merge(in, out)) {
        dim_conflict(e, "a scalar ratio needs the same dimension on both ports");
      }
    }
    // Domains.
    if (!IsTwoPort(e.kind)) {
      for (int b : e.bonds) {
        if (!e.domain.empty() && !domains.Set(b, e.domain))
          sink.Error(codes::kDomainConflict, e.where, e.name, fmt::format("domain '{}' conflicts with '{}' of bond '{}'", e.domain, domains.Get(b), g.bond(b).name),
                     "elements joined by junctions share one physical domain");
        if (b != e.bonds.front() && !domains.Merge(e.bonds.front(), b))
          sink.Error(codes::kDomainConflict, e.where, e.name, "bonds of different domains meet here", "change domains only through a TF or GY");
      }
    }
  }

  s.bond_dim.resize(nb);
  s.bond_domain.resize(nb);
  for (int b = 0; b < nb; ++b) {
    s.bond_dim[b] = dims.Has(b) ? dims.Get(b) : 1;
    s.bond_domain[b] = domains.Has(b) ? domains.Get(b) : default_domain;
  }

  // Parameters, now that dimensions are known.
  for (int i = 0; i < g.num_elements(); ++i) {
    const Element& e = g.element(i);
    if (e.bonds.empty() || (IsOnePort(e.kind) && e.bonds.size() != 1)) continue;
    const int n = s.dim_of(g, i);
    const Eigen::MatrixXd* m = e.param.is_scalar ? nullptr : &e.param.matrix;
    const double v = e.param.scalar;
    auto bad = [&](const std::string& what, const std::string& hint) { sink.Error(codes::kParamRange, e.where, e.name, what, hint); };
    // An empty list or matrix (`inertia: []`, `ratio: [[]]`) reached the range checks below and
    // the compiler as a 0x0 matrix: Eigen asserts on it (minCoeff of no eigenvalues), LLT calls
    // it positive definite, and the plan read its missing entries (found by fuzzing).
    if (m && m->size() == 0) {
      bad("parameter is an empty list", "give a number, a list of numbers (diagonal) or a matrix (list of rows)");
      continue;
    }
    if ((m && !AllFinite(*m)) || (!m && !std::isfinite(v))) {
      bad("parameter is not a finite number", "give a finite value");
      continue;
    }
    const bool formulas = e.law_effort.given() || e.law_flow.given() || e.energy.given() || !e.value.empty();
    if (formulas && IsSource(e.kind) && e.value.size() != 1 && static_cast<int>(e.value.size()) != n)
      bad(fmt::format("source has {} formulas but its bond is {}-dimensional", e.value.size(), n), "give one formula per component, or one for all");
    switch (formulas ? ElementKind::kOne : e.kind) {  // an element given by formulas has no parameters to check
      case ElementKind::kI:
        if (m ? !IsPositiveDefinite(*m) : !(v > 0))
          bad(m ? "inertia matrix must be symmetric positive definite" : fmt::format("inertia must be > 0 (got {:g})", v),
              "an inertia (mass, moment of inertia, inductance) is positive");
        if (!e.rotation.empty() && (g.FindAux(e.rotation) < 0 || g.aux_states()[g.FindAux(e.rotation)].kind != AuxState::Kind::kOrientation))
          bad(fmt::format("rotation '{}' is not an orientation state", e.rotation), "declare it under states with kind: orientation");
        if (!e.rotation.empty() && n != 3) bad("an inertia that turns with an orientation must be 3-dimensional", "give a 3x3 body inertia");
        break;
      case ElementKind::kC:
        if (m ? !IsPositiveDefinite(*m) : !(v > 0))
          bad(m ? "stiffness matrix must be symmetric positive definite" : fmt::format("stiffness must be > 0 (got {:g})", v),
              "a compliance stores energy only with a positive stiffness");
        break;
      case ElementKind::kR:
        if (m ? !IsPositiveSemiDefinite(*m) : !(v >= 0))
          bad(m ? "resistance matrix must be positive semi-definite" : fmt::format("resistance must be >= 0 (got {:g})", v),
              "a negative resistance would create energy");
        break;
      case ElementKind::kSe:
      case ElementKind::kSf: {
        const size_t nc = e.source.components.size();
        if (nc != 1 && static_cast<int>(nc) != n)
          bad(fmt::format("source has {} components but its bond is {}-dimensional", nc, n), "give one value per component, or a single value for all");
        break;
      }
      case ElementKind::kMTF:
      case ElementKind::kMGY:
        if (e.modulus.kind != Modulus::Kind::kConstant &&
            (g.FindAux(e.modulus.rotation) < 0 || g.aux_states()[g.FindAux(e.modulus.rotation)].kind != AuxState::Kind::kOrientation))
          bad(fmt::format("modulus refers to '{}', which is not an orientation state", e.modulus.rotation),
              "declare it under states with kind: orientation");
        break;
      default:
        break;
    }
    if (!e.components.empty() && !IsTwoPort(e.kind) && static_cast<int>(e.components.size()) != n)
      bad(fmt::format("{} component names given for a {}-dimensional bond", e.components.size(), n), "give one name per component");
    if (IsStorage(e.kind) && e.initial.size() > 0 && e.initial.size() != n)
      bad(fmt::format("initial value has {} components, the bond {}", e.initial.size(), n), "give one initial value per component");
  }
  for (const AuxState& a : g.aux_states()) {
    if (a.kind == AuxState::Kind::kLag || a.kind == AuxState::Kind::kPid || a.rate.given()) continue;  // signal states integrate formulas
    const int of = g.Find(a.of);
    if (of < 0) {
      sink.Error(codes::kStateOf, a.where, a.name, fmt::format("state integrates the flow of '{}', which does not exist", a.of), "name a 1-junction or a one-port element");
      continue;
    }
    const Element& e = g.element(of);
    if (e.kind == ElementKind::kZero || IsTwoPort(e.kind)) {
      sink.Error(codes::kStateOf, a.where, a.name, fmt::format("'{}' is a {}: it has no single flow to integrate", a.of, KindName(e.kind)), "name a 1-junction or a one-port element");
      continue;
    }
    if (e.bonds.empty()) continue;
    const int n = s.dim_of(g, of);
    if (a.kind == AuxState::Kind::kOrientation && n != 3)
      sink.Error(codes::kStateOf, a.where, a.name, fmt::format("an orientation integrates a 3-dimensional angular velocity; '{}' is {}-dimensional", a.of, n));
    // An integral's `initial` needs one entry per component; the compiler silently replaced a
    // list of another length by zeros (as the storage elements' check above does for p0/q0).
    if (a.kind == AuxState::Kind::kIntegral && a.initial.size() > 0 && a.initial.size() != n)
      sink.Error(codes::kParamRange, a.where, a.name, fmt::format("initial value has {} components, the flow of '{}' {}", a.initial.size(), a.of, n),
                 "give one initial value per component");
  }
  return s;
}

}  // namespace multibond
