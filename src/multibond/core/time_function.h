#pragma once
/// \file
/// Source values as functions of time: constant, step, ramp, sine, table (linear interpolation).

#include <string>
#include <vector>

namespace multibond {

/// A scalar function of time. Evaluating it never allocates.
struct TimeFunction {
  enum class Kind { kConstant, kStep, kRamp, kSine, kTable };
  Kind kind = Kind::kConstant;
  double value = 0.0;     ///< constant value; step height after the step; ramp offset; sine offset
  double before = 0.0;    ///< step: value before the step
  double start = 0.0;     ///< step/ramp: time of the step or ramp start [s]
  double slope = 0.0;     ///< ramp: slope [unit/s]
  double amplitude = 0.0; ///< sine amplitude
  double frequency = 0.0; ///< sine frequency [Hz]
  double phase = 0.0;     ///< sine phase [rad]
  std::vector<double> table_t, table_v;  ///< table: strictly increasing times and values

  static TimeFunction Constant(double v);
  static TimeFunction Step(double height, double at = 0.0, double before = 0.0);
  static TimeFunction Ramp(double slope, double start = 0.0, double offset = 0.0);
  static TimeFunction Sine(double amplitude, double frequency_hz, double phase = 0.0, double offset = 0.0);
  static TimeFunction Table(std::vector<double> t, std::vector<double> v);

  double operator()(double t) const;
  /// d/dt at t (the right derivative at a ramp's or table's corners; 0 for a step, whose jump
  /// has no derivative). Ideal constraints on prescribed flows need it (their acceleration).
  double Derivative(double t) const;
  /// The same function multiplied by `factor`.
  TimeFunction Scaled(double factor) const;
  bool is_constant() const { return kind == Kind::kConstant; }
  /// The times where the function or its derivative jumps (a step's time, a ramp's start, a
  /// table's sharp corners), ascending: integrators stop there and restart (time events).
  std::vector<double> Breakpoints() const;
  /// A table's gentle corners, ascending: integrators end a step there (they never step across
  /// one) and go on without a restart. With Breakpoints, a table's vertices: its first and last
  /// times and those of its rows where it turns away from a straight line by more than
  /// kTableCornerTolerance of its range (max - min of its values), so that between two of them
  /// it stays that close to a line and no step misses a feature larger than that. A vertex is a
  /// sharp corner (a restart) where the slope of the line through the vertices changes by more
  /// than kSharpTurn of the steeper side's (a ramp that stops, a slope that changes sign, a
  /// table's ends unless it is flat there), else a gentle one. A coarse table's corners are
  /// sharp; a finely sampled smooth curve has about a thousand vertices a period (a sampled
  /// sine), a few of them sharp (at its turning points), however finely it is sampled: not one
  /// restart per row, each of which costs the integrator accuracy as it starts again at first
  /// order.
  std::vector<double> Waypoints() const;
  static constexpr double kTableCornerTolerance = 1e-6;
  static constexpr double kSharpTurn = 0.5;
  struct Corners {
    std::vector<double> restarts, waypoints;
  };
  Corners TableCorners() const;
  /// Human-readable form, e.g. "step(1 at t=0)".
  std::string ToString() const;
};

}  // namespace multibond
