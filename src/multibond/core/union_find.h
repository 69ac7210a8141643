#pragma once
/// \file
/// Disjoint sets over 0..n-1 (path halving; the smaller root becomes the root of a union, so the
/// classes and their representatives do not depend on the order of the unions' arguments), and the
/// same with one value per class, reporting a union of classes whose values differ.

#include <numeric>
#include <vector>

namespace multibond {

class UnionFind {
 public:
  explicit UnionFind(int n) : parent_(n) { std::iota(parent_.begin(), parent_.end(), 0); }
  int Root(int i) {
    while (parent_[i] != i) i = parent_[i] = parent_[parent_[i]];
    return i;
  }
  /// Joins the classes of a and b; returns the root of the union.
  int Unite(int a, int b) {
    a = Root(a), b = Root(b);
    if (a > b) std::swap(a, b);
    parent_[b] = a;
    return a;
  }

 private:
  std::vector<int> parent_;
};

/// UnionFind with an optional value per class (a dimension, a domain).
template <typename T>
class ValueUnion {
 public:
  explicit ValueUnion(int n) : sets_(n), value_(n), has_(n, false) {}
  int Root(int i) { return sets_.Root(i); }
  /// Joins the classes of a and b. Returns false when both have values and they differ; the union
  /// then keeps a's value.
  bool Merge(int a, int b) {
    a = Root(a), b = Root(b);
    if (a == b) return true;
    const bool conflict = has_[a] && has_[b] && !(value_[a] == value_[b]);
    const int source = has_[a] ? a : b;
    const bool has = has_[a] || has_[b];
    T value = value_[source];
    const int root = sets_.Unite(a, b);
    value_[root] = std::move(value);
    has_[root] = has;
    return !conflict;
  }
  /// Gives i's class the value v; false when it has another one (kept).
  bool Set(int i, const T& v) {
    i = Root(i);
    if (has_[i]) return value_[i] == v;
    value_[i] = v;
    has_[i] = true;
    return true;
  }
  bool Has(int i) { return has_[Root(i)]; }
  const T& Get(int i) { return value_[Root(i)]; }

 private:
  UnionFind sets_;
  std::vector<T> value_;
  std::vector<bool> has_;
};

}  // namespace multibond
