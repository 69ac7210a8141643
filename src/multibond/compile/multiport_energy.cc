#include "multibond/compile/multiport_energy.h"

#include <algorithm>

#include <fmt/format.h>

#include "multibond/compile/formula_trees.h"
#include "multibond/compile/symbolic.h"
#include "multibond/core/diagnostic_codes.h"
#include "multibond/core/error.h"

namespace multibond {
namespace {

[[noreturn]] void Refuse(const Element& e, std::string message, std::string hint, int column_offset = -1) {
  Diagnostic d;
  d.code = codes::kLawEnergy;
  d.where = e.energy.where;
  if (column_offset >= 0 && d.where.known()) d.where.column += column_offset;
  d.element = e.name;
  d.message = std::move(message);
  d.hint = std::move(hint);
  d.details.push_back("in the stored energy of " + e.name + ": " + e.energy.text);
  throw ModelError(d);
}

}  // namespace

MultiportEnergy BuildMultiportEnergy(const Element& e, const std::vector<std::string>& state_names, int state) {
  const std::vector<std::string> own = OwnVariables(e);
  const int n = static_cast<int>(own.size());
  // Its states by their full names ("plate.q.1") are its own variables too.
  const expr::NodePtr root = formula_trees::Substitute(e.energy.root, [&](const expr::Node& m) -> expr::NodePtr {
    for (int k = 0; k < n; ++k)
      if (m.name == state_names[static_cast<size_t>(state + k)]) return expr::Name(own[static_cast<size_t>(k)]);
    return nullptr;
  });
  for (const expr::Node* m : expr::Names(*root))
    if (m->name != "pi" && std::find(own.begin(), own.end(), m->name) == own.end())
      Refuse(e, fmt::format("a multiport's stored energy reads '{}': only its own variables {} ... {} and parameters", m->name, own.front(), own.back()),
             "a multiport's energy is a function of its own state; model what modulates it as one more component of the state",
             m->offset);
  for (const std::string& v : own)
    if (!expr::DependsOn(*root, v))
      Refuse(e, fmt::format("the stored energy '{}' is not a function of {}", e.energy.text, v),
             fmt::format("every component of a multiport stores energy: {} would have no {}; drop the component or give it its own element", v,
                         e.kind == ElementKind::kI ? "flow" : "effort"));
  auto as_states = [&](const expr::NodePtr& t) {
    return formula_trees::Substitute(t, [&](const expr::Node& m) -> expr::NodePtr {
      const auto at = std::find(own.begin(), own.end(), m.name);
      return at == own.end() ? nullptr : formula_trees::StateRef(state + static_cast<int>(at - own.begin()));
    });
  };
  MultiportEnergy out;
  out.energy = as_states(root);
  for (const std::string& v : own) out.gradient.push_back(as_states(expr::Differentiate(*root, v)));
  return out;
}

}  // namespace multibond
