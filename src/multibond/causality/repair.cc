#include "multibond/causality/repair.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include <fmt/format.h>

#include "multibond/core/structure.h"

namespace multibond {

namespace {


std::string Show(const Eigen::MatrixXd& m) { return MatrixText(m, false); }

std::string UniqueName(const BondGraph& g, const std::string& base) {
  std::string name = base;
  for (int k = 2; g.Find(name) >= 0 || g.FindAux(name) >= 0; ++k) name = fmt::format("{}_{}", base, k);
  return name;
}

/// A bond joining elements a and b, or -1.
int BondBetween(const BondGraph& g, int a, int b) {
  for (int bond : g.element(a).bonds)
    if (g.Other(bond, a) == b) return bond;
  return -1;
}

/// The reduced inertia of I_dep (element `dep`, bond dimension n) and what fixed its flow.
void ReducedInertia(const BondGraph& g, const Structure& s, const CausalAssignment& c, int dep, SuggestedCoupling& out) {
  const Element& d = g.element(dep);
  const int n = s.bond_dim[d.bonds.front()];
  const Eigen::MatrixXd i_dep = d.param.AsMatrix(n, n);
  out.m_eff = i_dep;
  out.reflected = false;
  std::vector<int> path = c.PathTo(d.bonds.front());
  path.push_back(dep);
  const int origin = path.front();
  out.path = FormatPath(g, path);
  if (origin < 0 || origin == dep) {
    out.m_eff_note = fmt::format("{} alone: nothing on the causal path to reflect", Describe(g, dep));
    return;
  }
  out.reference = Describe(g, origin);
  const std::string alone = fmt::format("{} alone", Describe(g, dep));
  const std::string rotated =
      d.rotation.empty() ? "" : "; its inertia depends on the orientation, the body-frame value is used";
  const Element& o = g.element(origin);
  auto fallback = [&](const std::string& why) {
    out.m_eff_note = fmt::format("{}: {}; the coupling's frequency will be higher than the target{}", alone, why, rotated);
  };
  if (o.kind == ElementKind::kSf) {
    // A flow source does not yield: an infinite inertia on the other side, also seen through
    // transformers, m_eff -> I_dep. Through a 0-junction other flows add to the source's.
    for (size_t k = 1; k + 1 < path.size(); ++k) {
      const ElementKind kind = g.element(path[k]).kind;
      if (kind != ElementKind::kOne && kind != ElementKind::kTF && kind != ElementKind::kMTF)
        return fallback(fmt::format("its flow comes from {} through {}, which mixes or converts flows", Describe(g, origin),
                                    Describe(g, path[k])));
    }
    out.reflected = true;
    out.m_eff_note = fmt::format("{}: its flow is imposed by {} (an infinite inertia on the other side){}", alone,
                                 Describe(g, origin), rotated);
    return;
  }
  if (o.kind != ElementKind::kI) return fallback(fmt::format("its flow comes from {}, not from an inertia", Describe(g, origin)));
  if (!o.rotation.empty() || !d.rotation.empty())
    return fallback("the reference inertia cannot be reflected: an inertia on the path depends on the orientation");
  // f_dep = T f_ref, T the product of the transformer ratios passed along the path.
  const int n_ref = s.bond_dim[o.bonds.front()];
  Eigen::MatrixXd t = Eigen::MatrixXd::Identity(n_ref, n_ref);
  std::string via;
  for (size_t k = 1; k + 1 < path.size(); ++k) {
    const int e = path[k];
    const Element& x = g.element(e);
    if (x.kind == ElementKind::kOne) continue;  // one common flow
    if (x.kind != ElementKind::kTF)
      return fallback(fmt::format("the reference inertia cannot be reflected through {}", Describe(g, e)));
    const int in = BondBetween(g, e, path[k - 1]);
    const int n1 = s.bond_dim[s.port_in[e]], n2 = s.bond_dim[s.port_out[e]];
    const Eigen::MatrixXd m = x.param.AsMatrix(n2, n1);  // f2 = M f1
    if (in == s.port_in[e] && m.cols() == t.rows()) {
      t = m * t;
      via += fmt::format(", {} (ratio {}, port 1 to 2)", Describe(g, e), Show(m));
    } else if (in == s.port_out[e] && m.rows() == t.rows() && m.rows() == m.cols() &&
               Eigen::FullPivLU<Eigen::MatrixXd>(m).isInvertible()) {
      t = m.inverse() * t;
      via += fmt::format(", {} (ratio {}, port 2 to 1)", Describe(g, e), Show(m));
    } else {
      return fallback(fmt::format("the flow map of {} cannot be inverted", Describe(g, e)));
    }
  }
  if (t.rows() != n || t.cols() != n || !Eigen::FullPivLU<Eigen::MatrixXd>(t).isInvertible())
    return fallback("the flow map along the path is not square and invertible");
  const Eigen::MatrixXd t_inv = t.inverse();
  const Eigen::MatrixXd i_ref = t_inv.transpose() * o.param.AsMatrix(n_ref, n_ref) * t_inv;
  const Eigen::MatrixXd m_eff = (i_dep.inverse() + i_ref.inverse()).inverse();
  out.m_eff = 0.5 * (m_eff + m_eff.transpose());
  out.reflected = true;
  const std::string reflection =
      via.empty() ? "on the same flow" : fmt::format("reflected through {}: {}", via.substr(2), Show(i_ref));
  out.m_eff_note = fmt::format("I_dep I_ref / (I_dep + I_ref) with I_dep = {} ({}) and I_ref = {} ({}) {}",
                               Describe(g, dep), Show(i_dep), Describe(g, origin),
                               Show(o.param.AsMatrix(n_ref, n_ref)), reflection);
}

}  // namespace

BondGraph CausalView(BondGraph g) {
  for (int i = 0; i < g.num_elements(); ++i)
    if (g.element(i).kind == ElementKind::kSf && g.element(i).constraint) g.element(i).kind = ElementKind::kSe;
  return g;
}

InCausalView::InCausalView(BondGraph& g) : g_(g) {
  for (int i = 0; i < g.num_elements(); ++i)
    if (g.element(i).kind == ElementKind::kSf && g.element(i).constraint) {
      g.element(i).kind = ElementKind::kSe;
      turned_.push_back(i);
    }
}

InCausalView::~InCausalView() {
  for (int i : turned_) g_.element(i).kind = ElementKind::kSf;
}

CouplingUnits CouplingUnitsOf(const std::string& domain) {
  if (domain == "translation") return {"kg", "N/m", "N s/m"};
  if (domain == "rotation") return {"kg m^2", "N m/rad", "N m s/rad"};
  if (domain == "electrical") return {"H", "1/F", "ohm"};
  if (domain == "hydraulic") return {"Pa s^2/m^3", "Pa/m^3", "Pa s/m^3"};
  return {"-", "-", "-"};
}

std::string MatrixText(const Eigen::MatrixXd& m, bool full_precision) {
  auto num = [&](double v) { return full_precision ? fmt::format("{}", v) : fmt::format("{:.6g}", v); };
  const Param p = ParamOf(m);
  if (p.is_scalar) return num(p.scalar);
  const bool diagonal = m.isDiagonal(0.0);
  std::string s = "[";
  for (int i = 0; i < m.rows(); ++i) {
    if (i) s += ", ";
    if (diagonal) {
      s += num(m(i, i));
      continue;
    }
    s += "[";
    for (int j = 0; j < m.cols(); ++j) s += (j ? ", " : "") + num(m(i, j));
    s += "]";
  }
  return s + "]";
}

Param ParamOf(const Eigen::MatrixXd& m) {
  const double d = m.rows() > 0 ? m(0, 0) : 0.0;
  const Eigen::MatrixXd scaled = d * Eigen::MatrixXd::Identity(m.rows(), m.cols());
  if (m.rows() == m.cols() && (m - scaled).norm() <= 1e-14 * std::max(1.0, m.norm())) return Param::Scalar(d);
  return Param::Matrix(m);
}

BondGraph InsertCoupling(const BondGraph& g, int bond, const SuggestedCoupling& c) {
  BondGraph out(g.name());
  out.set_source_file(g.source_file());
  for (Element e : g.elements()) {
    e.bonds.clear();
    out.Add(std::move(e));
  }
  const Bond& replaced = g.bond(bond);
  auto add = [&](const std::string& name, ElementKind kind, Param p = {}) {
    Element e;
    e.name = name;
    e.kind = kind;
    e.param = std::move(p);
    e.where = replaced.where;  // diagnostics about the new elements point at the bond they replace
    out.Add(std::move(e));
  };
  add(c.zero, ElementKind::kZero);
  add(c.one, ElementKind::kOne);
  add(c.spring, ElementKind::kC, ParamOf(c.stiffness));
  add(c.damper, ElementKind::kR, ParamOf(c.damping));
  const int storage = g.Find(c.storage);
  for (int b = 0; b < g.num_bonds(); ++b) {
    const Bond& x = g.bond(b);
    const std::string from = g.element(x.from).name, to = g.element(x.to).name;
    if (b != bond) {
      out.Connect(from, to, x.dim, x.name, x.where);
      continue;
    }
    // A bond name the user gave stays with the storage element's side: at the 0-junction both
    // new bonds carry the same effort, and that side carries the storage element's flow.
    const bool user_named = x.name != fmt::format("{}->{}", from, to);
    out.Connect(from, c.zero, x.dim, user_named && x.from == storage ? x.name : std::string{}, x.where);
    out.Connect(c.zero, to, x.dim, user_named && x.to == storage ? x.name : std::string{}, x.where);
  }
  out.Connect(c.zero, c.one, 0, {}, replaced.where);
  out.Connect(c.one, c.spring, 0, {}, replaced.where);
  out.Connect(c.one, c.damper, 0, {}, replaced.where);
  for (const AuxState& a : g.aux_states()) out.AddAux(a);
  for (const OutputDecl& o : g.outputs()) out.AddOutput(o);
  return out;
}

RepairResult SuggestCouplings(const BondGraph& g, const std::string& default_domain, const CouplingTarget& target) {
  const double w = 2.0 * std::numbers::pi * target.frequency_hz;
  RepairResult r{{}, g, {}, false, {}};
  std::vector<int> original(g.num_bonds());  // per bond of r.repaired: its index in g (-1 = new)
  for (int b = 0; b < g.num_bonds(); ++b) original[b] = b;
  int before = -1;  // derivative causalities before the last coupling
  for (int guard = 0; guard <= g.num_elements(); ++guard) {
    DiagnosticSink sink;
    const BondGraph view = CausalView(r.repaired);
    const Structure s = AnalyzeStructure(view, default_domain, sink);
    sink.ThrowIfErrors();
    r.causality = AssignCausality(view, s);
    const int now = static_cast<int>(r.causality.derivative.size());
    if (!r.couplings.empty()) {
      SuggestedCoupling& last = r.couplings.back();
      last.removed = before - now;
      const bool still = std::any_of(r.causality.derivative.begin(), r.causality.derivative.end(),
                                     [&](int e) { return r.repaired.element(e).name == last.storage; });
      if (still || last.removed < 1) {
        r.not_repaired.push_back(fmt::format("I '{}': the coupling on bond '{}' did not remove its derivative causality; "
                                             "the method stops here",
                                             last.storage, last.bond));
        break;
      }
    }
    int dep = -1;
    for (int e : r.causality.derivative) {
      const Element& x = r.repaired.element(e);
      if (x.kind == ElementKind::kI) {
        dep = e;
        break;
      }
    }
    if (dep < 0) break;
    const Element& d = r.repaired.element(dep);
    const int b = d.bonds.front();
    SuggestedCoupling c;
    c.storage = d.name;
    c.other_end = r.repaired.element(r.repaired.Other(b, dep)).name;
    const Bond& bond = r.repaired.bond(b);
    c.bond = bond.name;
    c.tail = r.repaired.element(bond.from).name;
    c.head = r.repaired.element(bond.to).name;
    c.where = bond.where;
    c.original_bond = original[b];
    c.dim = s.bond_dim[b];
    c.domain = s.bond_domain[b];
    ReducedInertia(r.repaired, s, r.causality, dep, c);
    c.stiffness = w * w * c.m_eff;
    c.damping = 2.0 * target.damping_ratio * w * c.m_eff;  // = 2 zeta sqrt(K m_eff)
    std::string base = d.name;
    std::replace(base.begin(), base.end(), '.', '_');  // a dotted name would read as a submodel instance's
    c.zero = UniqueName(r.repaired, base + "_coupling");
    c.one = UniqueName(r.repaired, base + "_deflection");
    c.spring = UniqueName(r.repaired, base + "_K");
    c.damper = UniqueName(r.repaired, base + "_R");
    r.repaired = InsertCoupling(r.repaired, b, c);
    std::vector<int> next;
    for (int k = 0; k < static_cast<int>(original.size()); ++k) {
      if (k == b) {
        next.push_back(original[k]), next.push_back(-1);  // the two halves of the replaced bond
        continue;
      }
      next.push_back(original[k]);
    }
    next.insert(next.end(), 3, -1);
    original = std::move(next);
    r.couplings.push_back(std::move(c));
    before = now;
  }
  for (int e : r.causality.derivative) {
    const Element& x = r.repaired.element(e);
    if (x.kind == ElementKind::kC)
      r.not_repaired.push_back(fmt::format("{} is in derivative causality: a compliance needs the dual repair (a resistor or an "
                                           "inertia between it and what fixes its effort), which --suggest does not propose",
                                           Describe(r.repaired, e)));
  }
  r.integral = r.causality.derivative.empty();
  return r;
}

}  // namespace multibond
