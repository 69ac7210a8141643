#pragma once
/// \file
/// The engine's own edits of formula trees (compile/formulas.cc, compile/modulated_storage.cc):
/// its names of slots and states, and substitution of names. The parser reads identifiers only,
/// so no model formula can name "#w12" or "#x3".

#include <functional>
#include <memory>
#include <string>

#include "multibond/core/expression.h"

namespace multibond::formula_trees {

inline expr::NodePtr SlotRef(int offset) { return expr::Name("#w" + std::to_string(offset)); }
inline expr::NodePtr StateRef(int offset) { return expr::Name("#x" + std::to_string(offset)); }

/// The tree with every name that `replace` answers replaced (the rest kept; offsets kept).
inline expr::NodePtr Substitute(const expr::NodePtr& n, const std::function<expr::NodePtr(const expr::Node&)>& replace) {
  if (n->kind == expr::Node::Kind::kName) {
    expr::NodePtr r = replace(*n);
    return r ? r : n;
  }
  if (n->args.empty()) return n;
  auto copy = std::make_shared<expr::Node>(*n);
  bool changed = false;
  for (expr::NodePtr& a : copy->args) {
    expr::NodePtr b = Substitute(a, replace);
    changed = changed || b != a;
    a = std::move(b);
  }
  return changed ? expr::NodePtr(copy) : n;
}

/// `name` in the tree becomes `by`.
inline expr::NodePtr Replace(const expr::NodePtr& n, const std::string& name, const expr::NodePtr& by) {
  return Substitute(n, [&](const expr::Node& m) { return m.name == name ? by : nullptr; });
}

}  // namespace multibond::formula_trees
