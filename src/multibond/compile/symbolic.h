#pragma once
/// \file
/// Symbolic work on expression trees, done by GiNaC (no algebra system of our own): a law
/// derived from an energy function, an energy from a law, the derivative a Newton solve needs.
/// Trees go in and trees come out (core/expression.h); GiNaC stays behind this header.
///
/// A number enters GiNaC as the decimal it is written as (0.1 is 1/10, exactly) and comes back
/// exactly when it can (an integer or p/q with p and q doubles: `q/10`), else as its nearest
/// double. Terms and factors come back in the order of their text, so a result reads the same in
/// every run. GiNaC is not thread-safe: the functions here take one lock. A result GiNaC gives
/// that formulas cannot express (a complex number, an unknown function) is a std::domain_error.

#include <functional>
#include <optional>
#include <string>

#include "multibond/core/expression.h"

namespace multibond::expr {

/// d(root)/d(name), simplified (GiNaC's normal form), as a tree. Names other than `name` are
/// kept as names. sign and abs differentiate as GiNaC does (abs' = sign where x != 0).
NodePtr Differentiate(const Node& root, const std::string& name);

/// The integral of root over `name` from 0 to the name itself, as a tree, when GiNaC finds it in
/// closed form (polynomials, and what GiNaC's integral::eval_integ handles); nullopt otherwise.
std::optional<NodePtr> IntegrateFromZero(const Node& root, const std::string& name);

/// True if the tree refers to `name` (after simplification: x - x does not).
bool DependsOn(const Node& root, const std::string& name);

/// The tree simplified by GiNaC, as a tree.
NodePtr Simplify(const Node& root);

}  // namespace multibond::expr
