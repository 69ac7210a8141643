// The kinks and switches of formulas (kinks.h; docs/events.md, "Kinks and switches in formulas").

#include "multibond/compile/kinks.h"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

namespace multibond {

using expr::Fn;
using expr::Node;
using expr::NodePtr;

namespace {

/// A comparison or a logical operation: its value is 0 or 1, and its own switching functions
/// say where it changes.
bool IsTruthValue(const Node& n) {
  return n.kind == Node::Kind::kCall && (expr::IsComparison(n.fn) || n.fn == Fn::kAnd || n.fn == Fn::kOr || n.fn == Fn::kNot);
}

}  // namespace

std::vector<NodePtr> SwitchingFunctions(const Node& node) {
  if (node.kind != Node::Kind::kCall) return {};
  auto diff = [&](size_t a, size_t b) { return expr::Binary(Node::Kind::kSub, node.args[a], node.args[b]); };
  // A number used as a truth value (`if(x, a, b)`, `x and y`) changes where it crosses zero.
  auto truth = [&](size_t a) { return IsTruthValue(*node.args[a]) ? std::vector<NodePtr>{} : std::vector<NodePtr>{node.args[a]}; };
  if (expr::IsComparison(node.fn)) return {diff(0, 1)};
  switch (node.fn) {
    case Fn::kAbs:
    case Fn::kSign: return {node.args[0]};
    case Fn::kMin:
    case Fn::kMax: return {diff(0, 1)};
    case Fn::kClamp: return {diff(0, 1), diff(0, 2)};
    case Fn::kIf:
    case Fn::kNot: return truth(0);
    case Fn::kAnd:
    case Fn::kOr: {
      std::vector<NodePtr> out = truth(0);
      for (NodePtr& g : truth(1)) out.push_back(std::move(g));
      return out;
    }
    default: return {};
  }
}

int KinkTable::Add(Kink kink) {
  if (kink.program.inputs.empty()) return -1;  // of numbers and parameters only: one branch for ever
  for (size_t k = 0; k < kinks_.size(); ++k)
    if (kinks_[k].owner == kink.owner && kinks_[k].function == kink.function) return static_cast<int>(k);
  kink.time_only = std::all_of(kink.program.inputs.begin(), kink.program.inputs.end(),
                               [](const expr::Input& in) { return in.in == expr::Input::In::kTime; });
  if (!kink.time_only) roots_.push_back(static_cast<int>(kinks_.size()));
  kinks_.push_back(std::move(kink));
  return static_cast<int>(kinks_.size()) - 1;
}

void KinkTable::Roots(double t, const double* x, const double* w, double* out) const {
  for (size_t r = 0; r < roots_.size(); ++r) out[r] = expr::Run(kinks_[static_cast<size_t>(roots_[r])].program, t, x, w);
}

std::string KinkTable::Describe(const Kink& k) {
  return fmt::format("{} changes sign: {} in {}", k.function, k.formula, k.what);
}

namespace {

int SignOf(double v) { return v > 0.0 ? 1 : (v < 0.0 ? -1 : 0); }

/// The first double in (lo, hi] at which `side(t)` is false, given side(lo) and !side(hi):
/// bisection to adjacent doubles.
template <class Pred>
double Boundary(double lo, double hi, const Pred& side) {
  while (true) {
    const double mid = lo + 0.5 * (hi - lo);
    if (!(mid > lo && mid < hi)) return hi;
    (side(mid) ? lo : hi) = mid;
  }
}

}  // namespace

std::vector<TimeEvent> KinkTable::TimeEvents(double t0, double t1, double resolution) const {
  std::vector<TimeEvent> out;
  if (!(t1 > t0)) return out;
  constexpr double kMinSamples = 4096, kMaxSamples = 4e6;
  const double span = t1 - t0;
  const double wanted = resolution > 0.0 ? std::ceil(span / resolution) : kMinSamples;
  const long n = static_cast<long>(std::clamp(wanted, kMinSamples, kMaxSamples));
  for (const Kink& k : kinks_) {
    if (!k.time_only) continue;
    auto g = [&](double t) { return expr::Run(k.program, t, nullptr, nullptr); };
    auto dg = [&](double t) { return expr::RunTangent(k.program, t, nullptr, nullptr, 1.0, nullptr, nullptr); };
    const std::string description = Describe(k);
    auto event = [&](double t) {
      if (t > t0 && t < t1) out.push_back({t, "kink", k.owner, description});
    };
    // side: the last strict sign seen (0: none yet), at the sample `at`; a zero is no side of its
    // own (a function passing through zero changes sides once).
    int side = SignOf(g(t0));
    double at = t0;
    for (long i = 1; i <= n; ++i) {
      const double tb = i == n ? t1 : t0 + span * (static_cast<double>(i) / static_cast<double>(n));
      const int sb = SignOf(g(tb));
      if (sb == 0) continue;
      if (side == 0) {
        side = sb;
        at = tb;
        continue;
      }
      const int s = side;
      auto on_side = [&](double t) { return SignOf(g(t)) == s; };
      if (sb != side) {
        event(Boundary(at, tb, on_side));
        side = sb;
      } else if (SignOf(dg(at)) == -side && SignOf(dg(tb)) == side) {
        // It turns towards zero and back between two samples: its extremum may cross.
        const double tm = Boundary(at, tb, [&](double t) { return SignOf(dg(t)) == -s; });
        if (SignOf(g(tm)) == -s) {  // crosses (a touch of zero changes no branch)
          event(Boundary(at, tm, on_side));
          event(Boundary(tm, tb, [&](double t) { return !on_side(t); }));
        }
      }
      at = tb;
    }
  }
  std::sort(out.begin(), out.end());
  return out;
}

}  // namespace multibond
