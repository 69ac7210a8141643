#include "multibond/io/bond_reader.h"

#include <cmath>
#include <utility>

#include <fmt/format.h>

#include "multibond/core/diagnostic_codes.h"
#include "multibond/io/did_you_mean.h"

namespace multibond {

/// Resolves a bond end: a local name in this scope, or "instance.port" of a submodel instance.
std::string BondReader::Endpoint(const std::string& local, const std::string& prefix, const YAML::Node& at) {
  const std::string full = Qualify(prefix, local);
  const auto dot = full.rfind('.');
  if (dot != std::string::npos) {
    const std::string inst = full.substr(0, dot);
    const auto it = cx_.instance_ports.find(inst);
    const bool inside = prefix == inst || prefix.rfind(inst + ".", 0) == 0;  // the instance's own bonds
    if (!inside && it != cx_.instance_ports.end() && !it->second.count(full.substr(dot + 1)) && graph_.Find(full) >= 0) {
      std::string ports;
      for (const auto& p : it->second) ports += (ports.empty() ? "" : ", ") + p;
      sink_.Error(codes::kBondUnknownEnd, Loc(at), full, fmt::format("'{}' is not a port of submodel instance '{}'", full.substr(dot + 1), inst),
                  ports.empty() ? "the submodel exposes no ports" : "its ports are: " + ports);
    }
  }
  return full;
}

void BondReader::ReadBond(const YAML::Node& b, const std::string& prefix, const Env& env) {
  std::string from, to, name;
  int dim = 0;
  if (b.IsScalar()) {
    const std::string s = b.Scalar();
    const auto arrow = s.find("->");
    if (arrow == std::string::npos) {
      sink_.Error(codes::kBondSyntax, Loc(b), s, "a bond is written 'from -> to'", "e.g. '- force -> j1' (the half-arrow points to 'to')");
      return;
    }
    auto trim = [](std::string x) {
      const auto a = x.find_first_not_of(" \t"), z = x.find_last_not_of(" \t");
      return a == std::string::npos ? std::string() : x.substr(a, z - a + 1);
    };
    from = trim(s.substr(0, arrow));
    to = trim(s.substr(arrow + 2));
    if (from.empty() || to.empty()) {
      sink_.Error(codes::kBondSyntax, Loc(b), s, fmt::format("the bond has no '{}' end", from.empty() ? "from" : "to"),
                  "write it 'from -> to', e.g. '- force -> j1'");
      return;
    }
  } else if (b.IsSequence() && b.size() == 2) {
    from = b[0].Scalar();
    to = b[1].Scalar();
  } else if (b.IsMap()) {
    CheckKeys(b, {"from", "to", "name", "dim"}, "bond");
    if (!b["from"] || !b["to"]) {
      sink_.Error(codes::kBondSyntax, Loc(b), "bond", "a bond needs 'from' and 'to'");
      return;
    }
    from = b["from"].Scalar();
    to = b["to"].Scalar();
    if (b["name"]) {
      if (!CheckName(b["name"].Scalar(), Loc(b["name"]), "a bond's")) return;
      name = Qualify(prefix, b["name"].Scalar());
      // Its variables (name.e, name.f) must name one thing: not another bond, not an element.
      if (const SourceLocation* first = cx_.bond_names.Find(name)) {
        Diagnostic d;
        d.where = Loc(b["name"]);
        d.element = name;
        d.code = codes::kNameDuplicate;
        d.message = "duplicate bond name";
        d.details.push_back("first given at " + first->ToString());
        d.hint = "give every named bond a unique name";
        sink_.Add(d);
        return;
      }
      if (graph_.Find(name) >= 0) {
        sink_.Error(codes::kNameDuplicate, Loc(b["name"]), name, "a bond may not be named like an element",
                    "rename the bond: its variables would read like the element's");
        return;
      }
      cx_.bond_names.Add(name, Loc(b["name"]));
    }
    if (b["dim"]) {
      const double d = Number(b["dim"], "bond", env);
      if (d < 1 || d > 64 || d != std::floor(d))
        sink_.Error(codes::kParamRange, Loc(b["dim"]), "bond", fmt::format("dim must be a whole number from 1 to 64 (got {:g})", d));
      else
        dim = static_cast<int>(d);
    }
  } else {
    sink_.Error(codes::kBondSyntax, Loc(b), "bond", "a bond is 'from -> to', [from, to] or {from: ..., to: ...}");
    return;
  }
  const std::string f = Endpoint(from, prefix, b), t = Endpoint(to, prefix, b);
  bool ok = true;
  for (const auto& [end, local] : {std::pair{f, from}, std::pair{t, to}}) {
    if (graph_.Find(end) >= 0) continue;
    ok = false;
    if (cx_.refused_elements.count(end)) continue;
    std::vector<std::string> names;
    for (const auto& e : graph_.elements()) names.push_back(e.name);
    const std::string guess = DidYouMean(end, names);
    sink_.Error(codes::kBondUnknownEnd, Loc(b), end, "bond refers to an element that does not exist",
                guess.empty() ? "define it under 'elements'" : fmt::format("did you mean '{}'?", guess));
  }
  if (!ok) return;
  if (f == t) {
    sink_.Error(codes::kBondSelf, Loc(b), f, "bond connects an element to itself");
    return;
  }
  graph_.Connect(f, t, dim, name, Loc(b));
}

}  // namespace multibond
