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

std::vector<double> TimeFunction::Breakpoints() const {
  switch (kind) {
    case Kind::kStep: return before != value ? std::vector<double>{start} : std::vector<double>{};
    case Kind::kRamp: return {start};
    case Kind::kTable: return table_t;
    case Kind::kConstant:
    case Kind::kSine: return {};
  }
  return {};
}

}  // namespace multibond
