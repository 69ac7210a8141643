// Kept quantities: compiled expressions over result rows, and their running reductions.

#include "multibond/sweep/kept.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <fmt/format.h>

#include "multibond/core/diagnostic_codes.h"
#include "multibond/io/did_you_mean.h"

namespace multibond::sweep {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

/// Thrown by the resolver for a name of no column (caught below, reported at its character).
struct UnknownColumn {
  const expr::Node* node;
};

SourceLocation Shift(const SourceLocation& at, int offset) { return {at.file, at.line, at.column + offset}; }

}  // namespace

KeptQuantities::KeptQuantities(const std::vector<Keep>& keep, const std::vector<std::string>& columns,
                               const std::vector<std::string>& all_columns, DiagnosticSink& sink)
    : keep_(keep), columns_(columns) {
  // Names in all_columns beyond the default columns need the run's every-variable columns.
  for (const Keep& k : keep_) {
    if (k.take != Keep::Take::kEventTime) {
      const expr::ParseResult parsed = expr::Parse(k.of);
      if (!parsed.root) continue;
      for (const expr::Node* n : expr::Names(*parsed.root))
        if (n->name != "t" && n->name != "pi" && std::find(columns.begin(), columns.end(), n->name) == columns.end() &&
            std::find(all_columns.begin(), all_columns.end(), n->name) != all_columns.end())
          all_variables_ = true;
    }
  }
  if (all_variables_) columns_ = all_columns;
  for (const Keep& k : keep_) {
    programs_.emplace_back();
    if (k.take == Keep::Take::kEventTime) continue;  // `of` is an event kind
    const expr::ParseResult parsed = expr::Parse(k.of);
    if (!parsed.root) {
      const expr::ParseError& e = *parsed.error;
      sink.Error(codes::kSweepKeep, Shift(k.expression, e.offset), k.name, fmt::format("the expression '{}': {}", k.of, e.message), e.hint);
      continue;
    }
    try {
      programs_.back() = expr::CompileProgram(*parsed.root, [&](const expr::Node& n) -> expr::Input {
        if (n.name == "t") return {expr::Input::In::kTime, 0, 0.0};
        if (n.name == "pi") return {expr::Input::In::kConstant, 0, M_PI};
        const auto it = std::find(columns_.begin(), columns_.end(), n.name);
        if (it == columns_.end()) throw UnknownColumn{&n};
        return {expr::Input::In::kSlot, static_cast<int>(it - columns_.begin()), 0.0};
      });
    } catch (const UnknownColumn& u) {
      const std::string guess = DidYouMeanName(u.node->name, all_columns);
      sink.Error(codes::kSweepKeep, Shift(k.expression, u.node->offset), k.name, fmt::format("'{}' names no result column", u.node->name),
                 guess.empty() ? "a column of results.csv (multibond run), e.g. a state such as spring.q or a declared output"
                               : fmt::format("did you mean '{}'?", guess));
    }
  }
}

KeptObserver::KeptObserver(const KeptQuantities& q) : q_(q), acc_(q.keep().size()) { Reset(); }

void KeptObserver::Reset() {
  for (Accumulator& a : acc_) {
    a.t.clear();
    a.v.clear();
    a.event = kNaN;
    a.crossing = kNaN;
    a.samples = 0;
  }
  summary_ = RunSummary{};
  column_problem_.clear();
}

void KeptObserver::OnStart(const std::vector<Column>& columns) {
  const std::vector<std::string>& want = q_.columns();
  bool same = columns.size() == want.size();
  for (size_t i = 0; same && i < columns.size(); ++i) same = columns[i].name == want[i];
  if (!same) column_problem_ = "the run's result columns differ from the nominal model's (a parameter changed the model's structure)";
}

void KeptObserver::OnSample(const std::vector<double>& row) {
  if (!column_problem_.empty()) return;
  const double t = row[0];
  const std::vector<Keep>& keep = q_.keep();
  for (size_t k = 0; k < acc_.size(); ++k) {
    if (keep[k].take == Keep::Take::kEventTime || t < keep[k].from || t > keep[k].to) continue;
    Accumulator& a = acc_[k];
    const double v = expr::Run(q_.programs()[k], t, nullptr, row.data());
    if (a.samples == 0) {
      a.max = a.min = v;
      a.integral = a.integral_sq = 0.0;
    } else {
      const double h = t - a.prev_t;
      a.max = std::max(a.max, v);
      a.min = std::min(a.min, v);
      a.integral += 0.5 * h * (v + a.prev_v);
      a.integral_sq += 0.5 * h * (v * v + a.prev_v * a.prev_v);
      const double level = keep[k].level;
      if (std::isnan(a.crossing) && (a.prev_v - level) * (v - level) <= 0.0 && a.prev_v != level)
        a.crossing = v == a.prev_v ? t : a.prev_t + h * (level - a.prev_v) / (v - a.prev_v);
    }
    if (a.samples == 0) {
      a.first_t = t;
      if (v == keep[k].level) a.crossing = t;
    }
    if (keep[k].take == Keep::Take::kSettlingTime) {
      a.t.push_back(t);
      a.v.push_back(v);
    }
    a.last = v;
    a.prev_t = t;
    a.prev_v = v;
    ++a.samples;
  }
}

void KeptObserver::OnEvent(const EventRecord& event) {
  const std::vector<Keep>& keep = q_.keep();
  for (size_t k = 0; k < acc_.size(); ++k) {
    const Keep& kp = keep[k];
    if (kp.take != Keep::Take::kEventTime || !std::isnan(acc_[k].event) || event.time < kp.from || event.time > kp.to) continue;
    if ((kp.of.empty() || kp.of == event.kind) && (kp.element.empty() || kp.element == event.element)) acc_[k].event = event.time;
  }
}

std::vector<double> KeptObserver::Values() const {
  std::vector<double> out;
  const std::vector<Keep>& keep = q_.keep();
  for (size_t k = 0; k < acc_.size(); ++k) {
    const Accumulator& a = acc_[k];
    if (keep[k].take == Keep::Take::kEventTime) {
      out.push_back(a.event);
      continue;
    }
    if (a.samples == 0) {  // no sample in the run (or its window)
      out.push_back(kNaN);
      continue;
    }
    const double span = a.prev_t - a.first_t;
    switch (keep[k].take) {
      case Keep::Take::kFinal: out.push_back(a.last); break;
      case Keep::Take::kMax: out.push_back(a.max); break;
      case Keep::Take::kMin: out.push_back(a.min); break;
      case Keep::Take::kMean: out.push_back(span > 0 ? a.integral / span : a.last); break;
      case Keep::Take::kRms: out.push_back(span > 0 ? std::sqrt(a.integral_sq / span) : std::abs(a.last)); break;
      case Keep::Take::kSettlingTime: out.push_back(SettlingTime(a.t, a.v, keep[k].band)); break;
      case Keep::Take::kCrossingTime: out.push_back(a.crossing); break;
      case Keep::Take::kEventTime: break;
    }
  }
  return out;
}

double SettlingTime(const std::vector<double>& t, const std::vector<double>& v, double band) {
  if (t.empty()) return kNaN;
  const double final = v.back();
  double scale = std::abs(final);
  if (scale == 0.0)
    for (const double x : v) scale = std::max(scale, std::abs(x));
  const double tol = band * scale;
  size_t i = v.size();
  while (i-- > 0)
    if (std::abs(v[i] - final) > tol) break;
  if (i == static_cast<size_t>(-1)) return t.front();  // never left the band
  // v[i] outside, v[i + 1] inside: where |v - final| comes down to tol on that interval.
  const double d0 = std::abs(v[i] - final), d1 = std::abs(v[i + 1] - final);
  return t[i] + (t[i + 1] - t[i]) * (d0 - tol) / (d0 - d1);
}

}  // namespace multibond::sweep
