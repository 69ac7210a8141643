#pragma once
/// \file
/// The Jacobian I - dc/dz of the torn variables of solved algebraic loops (docs/design.md,
/// "Algebraic loops"), shared by Newton's method in EvalTorn (evaluation.cc) and the tangent
/// pass through the loops (tangent.cc): column j is the closure's tangent pass along the j-th
/// unknown, the state and the sources held.

#include <algorithm>
#include <cstddef>
#include <vector>

#include <Eigen/Dense>

namespace multibond {

/// `tears`: each torn variable's slot (the unknown), size and shadow (its writer's slot);
/// `tangent_closure()` runs the tangent rule of every instruction of the closure on `d` (the
/// slots' derivatives, all of them zeroed here before each column). `a` is n x n, n the unknowns.
template <class Tears, class TangentClosure>
void TornJacobian(const Tears& tears, std::vector<double>& d, Eigen::MatrixXd& a, TangentClosure&& tangent_closure) {
  for (Eigen::Index j = 0; j < a.cols(); ++j) {
    std::fill(d.begin(), d.end(), 0.0);
    Eigen::Index k = 0;
    for (const auto& tr : tears)
      for (int i = 0; i < tr.size; ++i, ++k) d[static_cast<std::size_t>(tr.slot + i)] = k == j ? 1.0 : 0.0;
    tangent_closure();
    k = 0;
    for (const auto& tr : tears)
      for (int i = 0; i < tr.size; ++i, ++k) a(k, j) = (k == j ? 1.0 : 0.0) - d[static_cast<std::size_t>(tr.shadow + i)];
  }
}

}  // namespace multibond
