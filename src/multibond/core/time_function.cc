#include "multibond/core/time_function.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include <fmt/format.h>

namespace multibond {

TimeFunction TimeFunction::Constant(double v) {
  TimeFunction f;
  f.value = v;
  return f;
}

TimeFunction TimeFunction::Step(double height, double at, double before) {
  TimeFunction f;
  f.kind = Kind::kStep;
  f.value = height;
  f.start = at;
  f.before = before;
  return f;
}

TimeFunction TimeFunction::Ramp(double slope, double start, double offset) {
  TimeFunction f;
  f.kind = Kind::kRamp;
  f.slope = slope;
  f.start = start;
  f.value = offset;
  return f;
}

TimeFunction TimeFunction::Sine(double amplitude, double frequency_hz, double phase, double offset) {
  TimeFunction f;
  f.kind = Kind::kSine;
  f.amplitude = amplitude;
  f.frequency = frequency_hz;
  f.phase = phase;
  f.value = offset;
  return f;
}

TimeFunction TimeFunction::Table(std::vector<double> t, std::vector<double> v) {
  TimeFunction f;
  f.kind = Kind::kTable;
  f.table_t = std::move(t);
  f.table_v = std::move(v);
  return f;
}

double TimeFunction::operator()(double t) const {
  switch (kind) {
    case Kind::kConstant:
      return value;
    case Kind::kStep:
      // A step "at t0" is on from t0 on, so a step at 0 acts from the first instant.
      return t >= start ? value : before;
    case Kind::kRamp:
      return t <= start ? value : value + slope * (t - start);
    case Kind::kSine:
      return value + amplitude * std::sin(2.0 * std::numbers::pi * frequency * t + phase);
    case Kind::kTable: {
      if (t <= table_t.front()) return table_v.front();
      if (t >= table_t.back()) return table_v.back();
      const auto it = std::upper_bound(table_t.begin(), table_t.end(), t);
      const size_t i = static_cast<size_t>(it - table_t.begin());
      const double w = (t - table_t[i - 1]) / (table_t[i] - table_t[i - 1]);
      return table_v[i - 1] + w * (table_v[i] - table_v[i - 1]);
    }
  }
  return 0.0;
}

double TimeFunction::Derivative(double t) const {
  switch (kind) {
    case Kind::kConstant:
    case Kind::kStep:  // zero away from the step itself (an impulse there is not representable)
      return 0.0;
    case Kind::kRamp:
      return t <= start ? 0.0 : slope;
    case Kind::kSine:
      return amplitude * 2.0 * std::numbers::pi * frequency * std::cos(2.0 * std::numbers::pi * frequency * t + phase);
    case Kind::kTable: {
      if (t < table_t.front() || t >= table_t.back()) return 0.0;
      const auto it = std::upper_bound(table_t.begin(), table_t.end(), t);
      const size_t i = static_cast<size_t>(it - table_t.begin());
      return (table_v[i] - table_v[i - 1]) / (table_t[i] - table_t[i - 1]);
    }
  }
  return 0.0;
}

TimeFunction TimeFunction::Scaled(double factor) const {
  TimeFunction f = *this;
  f.value *= factor;
  f.before *= factor;
  f.slope *= factor;
  f.amplitude *= factor;
  for (double& v : f.table_v) v *= factor;
  return f;
}

std::string TimeFunction::ToString() const {
  switch (kind) {
    case Kind::kConstant: return fmt::format("{:g}", value);
    case Kind::kStep: return fmt::format("step({:g} at t={:g})", value, start);
    case Kind::kRamp: return fmt::format("ramp({:g}/s from t={:g})", slope, start);
    case Kind::kSine: return fmt::format("{:g} sin(2 pi {:g} t + {:g})", amplitude, frequency, phase);
    case Kind::kTable: return fmt::format("table({} points)", table_t.size());
  }
  return "?";
}

namespace {

/// The vertices of a table (indices into it): its first and last rows, and the vertices of a
/// polyline through its own points that stays within `tolerance` of every point (the "swinging
/// door" of process historians, one pass): from each vertex, the cone of slopes whose line from
/// it passes within the tolerance of every point after it narrows point by point; where it
/// closes, the point before becomes the next vertex. Between two vertices the table is within
/// the tolerance of a straight line from the first, so a step between them misses no feature
/// larger than that, and a sharp corner is a vertex (the point after it leaves the cone).
std::vector<size_t> TableVertices(const std::vector<double>& t, const std::vector<double>& v, double tolerance) {
  std::vector<size_t> out;
  const size_t n = t.size();
  if (n == 0) return out;
  out.push_back(0);
  size_t a = 0;
  double lo = -HUGE_VAL, hi = HUGE_VAL;
  for (size_t i = 1; i < n; ++i) {
    const double dt = t[i] - t[a];
    const double l = (v[i] - tolerance - v[a]) / dt, h = (v[i] + tolerance - v[a]) / dt;
    if (std::max(lo, l) > std::min(hi, h)) {  // the cone closed at i: the vertex is i - 1
      a = i - 1;
      out.push_back(a);
      const double da = t[i] - t[a];
      lo = (v[i] - tolerance - v[a]) / da;
      hi = (v[i] + tolerance - v[a]) / da;
    } else {
      lo = std::max(lo, l);
      hi = std::min(hi, h);
    }
  }
  if (out.back() != n - 1) out.push_back(n - 1);
  return out;
}

}  // namespace

TimeFunction::Corners TimeFunction::TableCorners() const {
  Corners out;
  if (kind != Kind::kTable || table_t.empty()) return out;
  const auto [lo, hi] = std::minmax_element(table_v.begin(), table_v.end());
  const std::vector<size_t> vertex = TableVertices(table_t, table_v, kTableCornerTolerance * (*hi - *lo));
  // The polyline's slope on each side of a vertex (0 before the first row and after the last,
  // where the table holds its end values): a turn sharper than kSharpTurn of the steeper side
  // restarts the integration, a gentler one only ends a step.
  auto slope = [&](size_t k) {  // of the segment from vertex k - 1 to vertex k; 0 outside
    if (k == 0 || k >= vertex.size()) return 0.0;
    return (table_v[vertex[k]] - table_v[vertex[k - 1]]) / (table_t[vertex[k]] - table_t[vertex[k - 1]]);
  };
  for (size_t k = 0; k < vertex.size(); ++k) {
    const double left = slope(k), right = slope(k + 1);
    const bool sharp = std::abs(right - left) > kSharpTurn * std::max(std::abs(left), std::abs(right));
    (sharp ? out.restarts : out.waypoints).push_back(table_t[vertex[k]]);
  }
  return out;
}

std::vector<double> TimeFunction::Breakpoints() const {
  switch (kind) {
    case Kind::kStep: return before != value ? std::vector<double>{start} : std::vector<double>{};
    case Kind::kRamp: return {start};
    case Kind::kTable: return TableCorners().restarts;
    case Kind::kConstant:
    case Kind::kSine: return {};
  }
  return {};
}

std::vector<double> TimeFunction::Waypoints() const { return kind == Kind::kTable ? TableCorners().waypoints : std::vector<double>{}; }

}  // namespace multibond
