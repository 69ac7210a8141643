// The study reader: a study file (YAML, read through the model loader's document reader, so its
// limits, syntax errors and duplicate keys are said the same way) or command-line specs into a
// Study. Numbers may be formulas of constants ("2*pi"), as in a model file.

#include "multibond/sweep/study.h"

#include <charconv>
#include <cmath>
#include <filesystem>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "multibond/core/identifier.h"
#include "multibond/core/diagnostic_codes.h"
#include "multibond/io/did_you_mean.h"
#include "multibond/io/load_context.h"
#include "multibond/io/yaml_document.h"
#include "multibond/io/yaml_values.h"
#include "multibond/sweep/samples.h"

#include <algorithm>

namespace multibond::sweep {

namespace {

const std::vector<std::string> kTopKeys = {"study", "description", "model", "set", "sweep", "method", "samples", "seed",
                                           "keep", "simulation", "results"};
const std::vector<std::string> kTakes = {"final", "max", "min", "mean", "rms", "settling_time", "crossing_time", "event_time"};
const std::vector<std::string> kDistributions = {"uniform", "loguniform", "normal", "lognormal"};
const std::vector<std::string> kMethods = {"grid", "monte_carlo", "latin_hypercube"};

/// Gives the study's code (a usage error, exit 64) to what the model readers' helpers say in the
/// words of a model file (an unknown, missing or conflicting key, an unknown word).
void CodeUncoded(DiagnosticSink& sink) {
  std::vector<Diagnostic> ds = sink.diagnostics();
  sink = DiagnosticSink();
  for (Diagnostic& d : ds) {
    if (d.code.empty() || d.code == codes::kKeyUnknown || d.code == codes::kKeyMissing || d.code == codes::kKeyConflict ||
        d.code == codes::kValueUnknown)
      d.code = codes::kSweepStudy;
    sink.Add(std::move(d));
  }
}

std::string OneOf(const std::vector<std::string>& words) {
  std::string s;
  for (const auto& w : words) s += (s.empty() ? "" : ", ") + w;
  return s;
}

std::string Hint(const std::string& word, const std::vector<std::string>& words) {
  const std::string guess = DidYouMean(word, words);
  return guess.empty() ? "one of " + OneOf(words) : fmt::format("did you mean '{}'?", guess);
}

/// Checks an axis's numbers (grid range, list, distribution); problems to `sink`.
void CheckAxis(const Axis& a, DiagnosticSink& sink) {
  if (a.refused) return;  // said once, where it was read
  switch (a.kind) {
    case Axis::Kind::kGrid:
      if (a.count < 2)
        sink.Error(codes::kSweepRange, a.where, a.name, fmt::format("a grid of {} point(s)", a.count), "give at least 2 points");
      if (!(a.from < a.to))
        sink.Error(codes::kSweepRange, a.where, a.name,
                   fmt::format("the range {} to {} is {}", a.from, a.to, a.from == a.to ? "empty" : "reversed"),
                   "give the smaller value first (from < to)");
      else if (a.scale == Axis::Scale::kLog && !(a.from > 0.0))
        sink.Error(codes::kSweepRange, a.where, a.name, fmt::format("a log scale from {}", a.from),
                   "a log scale needs a range of positive values");
      break;
    case Axis::Kind::kList:
      if (a.values.empty()) sink.Error(codes::kSweepRange, a.where, a.name, "an empty list of values", "give at least one value");
      break;
    case Axis::Kind::kDistribution: {
      const bool range = a.distribution == Axis::Distribution::kUniform || a.distribution == Axis::Distribution::kLogUniform;
      if (range && !(a.a < a.b))
        sink.Error(codes::kSweepDistribution, a.where, a.name, fmt::format("the range {} to {} is {}", a.a, a.b, a.a == a.b ? "empty" : "reversed"),
                   "give low < high");
      else if (a.distribution == Axis::Distribution::kLogUniform && !(a.a > 0.0))
        sink.Error(codes::kSweepDistribution, a.where, a.name, fmt::format("a log-uniform distribution from {}", a.a),
                   "a log-uniform distribution needs positive bounds");
      if (!range && !(a.b > 0.0))
        sink.Error(codes::kSweepDistribution, a.where, a.name, fmt::format("a standard deviation of {}", a.b),
                   "the standard deviation (sd) must be positive");
      break;
    }
  }
}

class StudyReader : public ValueReader {
 public:
  using ValueReader::ValueReader;

  Study Read(const std::string& file) {
    Study s;
    s.file = file;
    const YAML::Node root = YamlDocument(cx_).Parse();
    CheckKeys(root, kTopKeys, "");
    if (root["study"]) s.name = Str(root["study"], "study");
    if (!root["model"]) {
      sink_.Error(codes::kSweepStudy, {file, 1, 1}, "", "the study names no model", "name the model file: 'model: path/to/model.yaml'");
    } else {
      s.model_where = Loc(root["model"]);
      const std::string m = Str(root["model"], "model");
      const std::filesystem::path base = std::filesystem::path(file).parent_path();
      s.model = m.empty() || std::filesystem::path(m).is_absolute() ? m : (base / m).string();
    }
    if (const YAML::Node set = root["set"]) {
      if (!set.IsMap()) sink_.Error(codes::kSweepStudy, Loc(set), "set", "'set' is " + Describe(set), "a mapping: parameter: value");
      else
        for (const auto& kv : set) s.set.push_back({kv.first.Scalar(), kv.second.IsScalar() ? kv.second.Scalar() : ""});
      if (set.IsMap())
        for (const auto& kv : set) s.set_where.push_back(Loc(kv.first));
    }
    if (const YAML::Node sw = root["sweep"]) {
      if (!sw.IsMap())
        sink_.Error(codes::kSweepStudy, Loc(sw), "sweep", "'sweep' is " + Describe(sw), "a mapping: parameter: {from, to, count} ...");
      else
        for (const auto& kv : sw) ReadAxis(s, kv.first, kv.second);
    }
    if (root["method"]) {
      const std::string m = Str(root["method"], "method");
      if (m == "grid") s.method = Study::Method::kGrid;
      else if (m == "monte_carlo") s.method = Study::Method::kMonteCarlo;
      else if (m == "latin_hypercube") s.method = Study::Method::kLatinHypercube;
      else sink_.Error(codes::kSweepStudy, Loc(root["method"]), "method", fmt::format("unknown method '{}'", m), Hint(m, kMethods));
    } else {
      for (const Axis& a : s.axes)
        if (a.kind == Axis::Kind::kDistribution) s.method = Study::Method::kMonteCarlo;
    }
    if (root["samples"]) s.samples = WholeNumber(root["samples"], "samples", false);
    if (root["seed"]) {
      s.seed = static_cast<std::uint64_t>(WholeNumber(root["seed"], "seed", true));
      s.seed_given = true;
    }
    if (const YAML::Node keep = root["keep"]) {
      if (!keep.IsMap())
        sink_.Error(codes::kSweepStudy, Loc(keep), "keep", "'keep' is " + Describe(keep), "a mapping: name: {max: column} ...");
      else
        for (const auto& kv : keep) ReadKeep(s, kv.first, kv.second);
    }
    if (const YAML::Node sim = root["simulation"]) ReadSimulation(s, sim);
    if (root["results"]) s.keep_results = Bool(root["results"], "results");
    return s;
  }

 private:
  double Num(const YAML::Node& n, const std::string& element) { return Number(n, element, Env{}); }

  /// A whole number >= 0 (seed: up to 2^64-1; samples: > 0), written as digits.
  unsigned long long WholeNumber(const YAML::Node& n, const char* what, bool seed) {
    const std::string text = n.IsScalar() ? n.Scalar() : "";
    unsigned long long v = 0;
    const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
    if (text.empty() || ec != std::errc() || end != text.data() + text.size() || (!seed && v == 0) || (!seed && v > 100000000ULL)) {
      sink_.Error(codes::kSweepSeed, Loc(n), what, fmt::format("the {} is {}", what, Describe(n)),
                  seed ? "a whole number from 0 to 18446744073709551615, e.g. 'seed: 1'" : "a whole number of runs from 1 to 10^8, e.g. 'samples: 100'");
      return seed ? 0 : 1;
    }
    return v;
  }

  void ReadAxis(Study& s, const YAML::Node& key, const YAML::Node& v) {
    const size_t said = sink_.diagnostics().size();
    Axis a;
    a.name = key.Scalar();
    a.where = Loc(key);
    if (v.IsSequence()) {
      a.kind = Axis::Kind::kList;
      for (const auto& x : v) a.values.push_back(Num(x, a.name));
    } else if (!v.IsMap()) {
      sink_.Error(codes::kSweepStudy, Loc(v), a.name, fmt::format("'{}' is {}", a.name, Describe(v)),
                  "{from: 10, to: 1000, count: 20, scale: log}, a list of values, or {distribution: uniform, low: 1, high: 2}");
      return;
    } else if (v["values"]) {
      CheckKeys(v, {"values"}, a.name);
      a.kind = Axis::Kind::kList;
      if (v["values"].IsSequence())
        for (const auto& x : v["values"]) a.values.push_back(Num(x, a.name));
      else
        sink_.Error(codes::kSweepStudy, Loc(v["values"]), a.name, "'values' is " + Describe(v["values"]), "a list of numbers");
    } else if (v["distribution"]) {
      a.kind = Axis::Kind::kDistribution;
      const std::string d = Str(v["distribution"], a.name);
      if (d == "uniform" || d == "loguniform") {
        CheckKeys(v, {"distribution", "low", "high"}, a.name);
        a.distribution = d == "uniform" ? Axis::Distribution::kUniform : Axis::Distribution::kLogUniform;
        a.a = Required(v, "low", a.name, kSweepDistribution());
        a.b = Required(v, "high", a.name, kSweepDistribution());
      } else if (d == "normal" || d == "lognormal") {
        CheckKeys(v, {"distribution", "mean", "sd"}, a.name);
        a.distribution = d == "normal" ? Axis::Distribution::kNormal : Axis::Distribution::kLogNormal;
        a.a = Required(v, "mean", a.name, kSweepDistribution());
        a.b = Required(v, "sd", a.name, kSweepDistribution());
      } else {
        sink_.Error(codes::kSweepDistribution, Loc(v["distribution"]), a.name, fmt::format("unknown distribution '{}'", d),
                    Hint(d, kDistributions));
        return;
      }
    } else {
      CheckKeys(v, {"from", "to", "count", "scale"}, a.name);
      a.kind = Axis::Kind::kGrid;
      a.from = Required(v, "from", a.name, codes::kSweepRange);
      a.to = Required(v, "to", a.name, codes::kSweepRange);
      a.count = v["count"] ? static_cast<int>(WholeNumber(v["count"], "count", false)) : 0;
      if (!v["count"]) sink_.Error(codes::kSweepRange, Loc(v), a.name, "the grid has no 'count'", "the number of points: 'count: 20'");
      if (v["scale"]) {
        const std::string sc = Str(v["scale"], a.name);
        if (sc == "log") a.scale = Axis::Scale::kLog;
        else if (sc != "linear")
          sink_.Error(codes::kSweepRange, Loc(v["scale"]), a.name, fmt::format("unknown scale '{}'", sc), Hint(sc, {"linear", "log"}));
      }
    }
    a.refused = sink_.diagnostics().size() > said;
    s.axes.push_back(std::move(a));
  }
  static const char* kSweepDistribution() { return codes::kSweepDistribution; }

  double Required(const YAML::Node& map, const char* key, const std::string& element, const char* code) {
    if (!map[key]) {
      sink_.Error(code, Loc(map), element, fmt::format("'{}' is missing", key), fmt::format("give '{}: <number>'", key));
      return 0.0;
    }
    return Num(map[key], element);
  }

  void ReadKeep(Study& s, const YAML::Node& key, const YAML::Node& v) {
    Keep k;
    k.name = key.Scalar();
    k.where = Loc(key);
    if (v.IsScalar()) {  // an expression: its final value
      k.of = v.Scalar();
      k.expression = At(v, 0);
      s.keep.push_back(std::move(k));
      return;
    }
    if (!v.IsMap()) {
      sink_.Error(codes::kSweepKeep, Loc(v), k.name, fmt::format("'{}' is {}", k.name, Describe(v)),
                  "an expression of result columns, or {max: spring.q}, {settling_time: x, band: 0.02} ...");
      return;
    }
    int takes = 0;
    for (const auto& kv : v) {
      const std::string w = kv.first.Scalar();
      for (size_t i = 0; i < kTakes.size(); ++i)
        if (w == kTakes[i]) {
          ++takes;
          k.take = static_cast<Keep::Take>(i);
          k.of = kv.second.IsScalar() ? kv.second.Scalar() : "";
          k.expression = kv.second.IsScalar() ? At(kv.second, 0) : Loc(kv.second);
        }
    }
    std::vector<std::string> allowed = kTakes;
    allowed.push_back("from");
    allowed.push_back("to");
    if (k.take == Keep::Take::kSettlingTime) allowed.push_back("band");
    if (k.take == Keep::Take::kCrossingTime) allowed.push_back("level");
    if (k.take == Keep::Take::kEventTime) allowed.push_back("element");
    CheckKeys(v, allowed, k.name);
    if (takes != 1) {
      sink_.Error(codes::kSweepKeep, Loc(v), k.name, takes == 0 ? "nothing says what to keep" : "more than one way to keep it",
                  "one of " + OneOf(kTakes) + ", e.g. {max: spring.q}");
      return;
    }
    if (v["band"]) {
      k.band = Num(v["band"], k.name);
      if (!(k.band > 0.0 && k.band < 1.0))
        sink_.Error(codes::kSweepKeep, Loc(v["band"]), k.name, fmt::format("a band of {}", k.band), "a fraction of the final value, e.g. 0.02");
    }
    if (v["level"]) k.level = Num(v["level"], k.name);
    else if (k.take == Keep::Take::kCrossingTime)
      sink_.Error(codes::kSweepKeep, Loc(v), k.name, "the crossing has no 'level'", "give the value crossed: 'level: 0.5'");
    if (v["element"]) k.element = Str(v["element"], k.name);
    if (v["from"]) k.from = Num(v["from"], k.name);
    if (v["to"]) k.to = Num(v["to"], k.name);
    if (v["from"] && v["to"] && !(k.from < k.to))
      sink_.Error(codes::kSweepKeep, Loc(v["to"]), k.name, fmt::format("the window from {:g} s to {:g} s is empty", k.from, k.to),
                  "'to' after 'from', e.g. {max: spring.q, from: 0.5, to: 2}");
    s.keep.push_back(std::move(k));
  }

  void ReadSimulation(Study& s, const YAML::Node& sim) {
    CheckKeys(sim, {"t_end", "dt", "solver", "rtol", "atol"}, "simulation");
    if (!sim.IsMap()) {
      sink_.Error(codes::kSweepStudy, Loc(sim), "simulation", "'simulation' is " + Describe(sim), "a mapping: {t_end: 10, dt: 0.01}");
      return;
    }
    if (sim["t_end"]) s.t_end = Num(sim["t_end"], "simulation");
    if (sim["dt"]) s.dt = Num(sim["dt"], "simulation");
    if (sim["rtol"]) s.rtol = Num(sim["rtol"], "simulation");
    if (sim["atol"]) s.atol = Num(sim["atol"], "simulation");
    if (sim["solver"]) s.solver = Str(sim["solver"], "simulation");
  }

};

/// The number at `text` (a plain number), else reports it at `column` of the option.
std::optional<double> OptionNumber(const std::string& text, const std::string& option, int column, const std::string& name,
                                   const char* code, DiagnosticSink& sink) {
  double v = 0.0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
  if (text.empty() || ec != std::errc() || end != text.data() + text.size() || !std::isfinite(v)) {
    sink.Error(code, {kCommandLine, 1, column}, name, fmt::format("{}: '{}' is not a number", option, text), "a number such as 1e3 or 0.5");
    return std::nullopt;
  }
  if (std::fpclassify(v) == FP_SUBNORMAL) {
    sink.Error(code, {kCommandLine, 1, column}, name, fmt::format("{}: '{}' is below the smallest normal double (2.2e-308)", option, text),
               "a number such as 1e3 or 0.5, or 0");
    return std::nullopt;
  }
  return v;
}

std::vector<std::string> Split(const std::string& s, char sep) {
  std::vector<std::string> out;
  size_t start = 0;
  for (;;) {
    const size_t i = s.find(sep, start);
    out.push_back(s.substr(start, i == std::string::npos ? std::string::npos : i - start));
    if (i == std::string::npos) return out;
    start = i + 1;
  }
}

}  // namespace

Study ReadStudyString(const std::string& text, const std::string& file, DiagnosticSink* sink) {
  const InputLimits limits;
  LoadContext cx(file, text, limits);
  Study s;
  try {
    s = StudyReader(cx).Read(file);
  } catch (const YAML::Exception& e) {
    cx.sink.Error(codes::kSweepStudy, {file, e.mark.line + 1, e.mark.column + 1}, "", "unexpected structure in the study (" + e.msg + ")",
                  "compare this part of the file with docs/sweeps.md");
  }
  if (!sink) CheckStudy(s, cx.sink);
  CodeUncoded(cx.sink);
  if (sink) {
    for (const Diagnostic& d : cx.sink.diagnostics()) sink->Add(d);
    return s;
  }
  cx.sink.ThrowIfErrors();
  return s;
}

Study ReadStudyFile(const std::string& path, const InputLimits& limits) { return ReadStudyString(ReadModelText(path, limits), path); }

bool LooksLikeStudy(const std::string& text) {
  try {
    const YAML::Node root = YAML::Load(text);
    return root.IsMap() && (root["sweep"] || root["keep"]) && !root["elements"] && !root["bodies"];
  } catch (const YAML::Exception&) {
    return false;
  }
}

void AddAxisSpec(Study& study, const std::string& option, const std::string& spec, DiagnosticSink& sink) {
  const size_t said = sink.diagnostics().size();
  const size_t eq = spec.find('=');
  const int col0 = static_cast<int>(option.size()) + 2;  // "--grid " then the spec
  Axis a;
  a.name = spec.substr(0, eq);
  a.where = {kCommandLine, 1, col0};
  if (eq == std::string::npos || a.name.empty()) {
    sink.Error(codes::kSweepStudy, a.where, "", fmt::format("{} '{}' has no NAME=", option, spec),
               option == "--grid" ? "--grid k=10:1000:log:20" : option == "--list" ? "--list k=1,2,5" : "--sample k=uniform:1:2");
    return;
  }
  const std::string rest = spec.substr(eq + 1);
  const int col = col0 + static_cast<int>(eq) + 1;
  std::vector<std::string> f = Split(rest, option == "--list" ? ',' : ':');
  auto num = [&](size_t i, const char* code) {
    int c = col;
    for (size_t j = 0; j < i; ++j) c += static_cast<int>(f[j].size()) + 1;
    return OptionNumber(f[i], option, c, a.name, code, sink).value_or(0.0);
  };
  if (option == "--grid") {
    a.kind = Axis::Kind::kGrid;
    if (f.size() == 4) {
      if (f[2] == "log") a.scale = Axis::Scale::kLog;
      else if (f[2] != "lin" && f[2] != "linear")
        sink.Error(codes::kSweepRange, {kCommandLine, 1, col}, a.name, fmt::format("unknown scale '{}'", f[2]), "lin or log");
      f.erase(f.begin() + 2);
    }
    if (f.size() != 3) {
      sink.Error(codes::kSweepRange, {kCommandLine, 1, col}, a.name, fmt::format("--grid '{}' is not FROM:TO[:lin|log]:COUNT", rest),
                 "e.g. --grid k=10:1000:log:20");
      return;
    }
    a.from = num(0, codes::kSweepRange);
    a.to = num(1, codes::kSweepRange);
    const double n = num(2, codes::kSweepRange);
    if (sink.diagnostics().size() == said && !(n >= 0 && n == std::floor(n) && n <= static_cast<double>(kMaxRuns))) {
      int c = col;
      for (size_t j = 0; j < 2; ++j) c += static_cast<int>(f[j].size()) + 1;
      sink.Error(codes::kSweepRange, {kCommandLine, 1, c}, a.name,
                 n == std::floor(n) && n > 0 ? fmt::format("a grid of {:.0f} points asked for: more than the {} runs a sweep may have", n, kMaxRuns)
                                             : fmt::format("the count '{}' is not a whole number of points", f[2]),
                 fmt::format("give from 2 to {} points", kMaxRuns));
    }
    a.count = n >= 0 && n <= static_cast<double>(kMaxRuns) && n == std::floor(n) ? static_cast<int>(n) : 0;
  } else if (option == "--list") {
    a.kind = Axis::Kind::kList;
    for (size_t i = 0; i < f.size(); ++i) a.values.push_back(num(i, codes::kSweepRange));
  } else {
    a.kind = Axis::Kind::kDistribution;
    const auto it = std::find(kDistributions.begin(), kDistributions.end(), f[0]);
    if (it == kDistributions.end() || f.size() != 3) {
      sink.Error(codes::kSweepDistribution, {kCommandLine, 1, col}, a.name,
                 it == kDistributions.end() ? fmt::format("unknown distribution '{}'", f[0]) : fmt::format("--sample '{}' is not DIST:A:B", rest),
                 it == kDistributions.end() ? Hint(f[0], kDistributions) : "uniform:LOW:HIGH, normal:MEAN:SD, ...");
      return;
    }
    a.distribution = static_cast<Axis::Distribution>(it - kDistributions.begin());
    a.a = num(1, codes::kSweepDistribution);
    a.b = num(2, codes::kSweepDistribution);
    study.method = study.method == Study::Method::kGrid ? Study::Method::kMonteCarlo : study.method;
  }
  a.refused = sink.diagnostics().size() > said;
  study.axes.push_back(std::move(a));
}

void AddKeepSpec(Study& study, const std::string& spec, DiagnosticSink& sink) {
  const size_t eq = spec.find('=');
  Keep k;
  k.name = spec.substr(0, eq);
  k.where = {kCommandLine, 1, 8};  // "--keep " then the spec
  if (eq == std::string::npos || k.name.empty()) {
    sink.Error(codes::kSweepKeep, k.where, "", fmt::format("--keep '{}' has no NAME=", spec), "e.g. --keep x_max=max:spring.q");
    return;
  }
  std::string rest = spec.substr(eq + 1);
  int col = 8 + static_cast<int>(eq) + 1;
  const size_t colon = rest.find(':');
  if (colon != std::string::npos) {
    std::string take = rest.substr(0, colon);
    // A window: TAKE[FROM,TO] (either bound may be left out), after the take and its @ARG.
    if (const size_t open = take.find('['); open != std::string::npos) {
      const int window_col = col + static_cast<int>(open);
      const size_t comma = take.find(',', open), close = take.find(']', open);
      if (comma == std::string::npos || close == std::string::npos || close != take.size() - 1 || comma > close) {
        sink.Error(codes::kSweepKeep, {kCommandLine, 1, window_col}, k.name, fmt::format("the window '{}' is not [FROM,TO]", take.substr(open)),
                   "e.g. --keep x=max[0.5,2]:spring.q (seconds; a bound may be left out: [0.5,])");
        return;
      }
      const std::string lo = take.substr(open + 1, comma - open - 1), hi = take.substr(comma + 1, close - comma - 1);
      if (!lo.empty()) k.from = OptionNumber(lo, "--keep", window_col + 1, k.name, codes::kSweepKeep, sink).value_or(-HUGE_VAL);
      if (!hi.empty()) k.to = OptionNumber(hi, "--keep", window_col + 2 + static_cast<int>(lo.size()), k.name, codes::kSweepKeep, sink).value_or(HUGE_VAL);
      if (!(k.from < k.to))
        sink.Error(codes::kSweepKeep, {kCommandLine, 1, window_col}, k.name, fmt::format("the window from {:g} s to {:g} s is empty", k.from, k.to),
                   "TO after FROM, e.g. max[0.5,2]");
      take = take.substr(0, open);
    }
    const size_t at = take.find('@');
    std::string level;
    if (at != std::string::npos) {
      level = take.substr(at + 1);
      take = take.substr(0, at);
    }
    const auto it = std::find(kTakes.begin(), kTakes.end(), take);
    if (it == kTakes.end()) {
      sink.Error(codes::kSweepKeep, {kCommandLine, 1, col}, k.name, fmt::format("unknown way to keep '{}'", take), Hint(take, kTakes));
      return;
    }
    k.take = static_cast<Keep::Take>(it - kTakes.begin());
    if (!level.empty()) {
      const auto v = OptionNumber(level, "--keep", col + static_cast<int>(at) + 1, k.name, codes::kSweepKeep, sink);
      if (k.take == Keep::Take::kSettlingTime) k.band = v.value_or(0.02);
      else k.level = v.value_or(0.0);
    } else if (k.take == Keep::Take::kCrossingTime) {
      sink.Error(codes::kSweepKeep, {kCommandLine, 1, col}, k.name, "the crossing has no level", "crossing_time@LEVEL:EXPRESSION");
    }
    rest = rest.substr(colon + 1);
    col += static_cast<int>(colon) + 1;
  }
  k.of = rest;
  k.expression = {kCommandLine, 1, col};
  study.keep.push_back(std::move(k));
}

void CheckStudy(const Study& s, DiagnosticSink& sink) {
  const SourceLocation top{s.file.empty() ? kCommandLine : s.file, 1, 1};
  if (s.axes.empty())
    sink.Error(codes::kSweepStudy, top, "", "nothing is swept", "name the parameters under 'sweep:' (or --grid, --list, --sample)");
  if (s.keep.empty())
    sink.Error(codes::kSweepStudy, top, "", "nothing is kept", "name the quantities under 'keep:' (or --keep), e.g. x_max: {max: spring.q}");
  std::vector<std::string> names;
  for (const Axis& a : s.axes) {
    if (std::find(names.begin(), names.end(), a.name) != names.end())
      sink.Error(codes::kSweepStudy, a.where, a.name, fmt::format("'{}' is swept twice", a.name), "sweep each parameter once");
    names.push_back(a.name);
    CheckAxis(a, sink);
    if (s.method == Study::Method::kGrid && a.kind == Axis::Kind::kDistribution)
      sink.Error(codes::kSweepDistribution, a.where, a.name, "a distribution in a grid study",
                 "method: monte_carlo or latin_hypercube samples distributions");
    if (s.method != Study::Method::kGrid && a.kind != Axis::Kind::kDistribution)
      sink.Error(codes::kSweepDistribution, a.where, a.name, "a grid or list in a sampled study",
                 "give a distribution: {distribution: uniform, low: 1, high: 2}");
  }
  for (const Keep& k : s.keep) {
    if (!IdentifierProblem(k.name).empty() || k.name == "status" || k.name == "run" || k.name == "reason" ||
        std::find(names.begin(), names.end(), k.name) != names.end())
      sink.Error(codes::kSweepKeep, k.where, k.name, fmt::format("'{}' cannot name a column of sweep.csv", k.name),
                 "a name of letters, digits and '_', other than run, status, reason and the swept parameters");
    names.push_back(k.name);
  }
  for (const auto& [value, key] : {std::pair{s.t_end, "t_end"}, {s.dt, "dt"}, {s.rtol, "rtol"}, {s.atol, "atol"}})
    if (value && !(*value > 0.0 && std::isfinite(*value)))
      sink.Error(codes::kSweepStudy, top, "simulation", fmt::format("simulation: {} is {}", key, *value), "a positive number");
  if (s.method != Study::Method::kGrid) {
    if (s.samples <= 0)
      sink.Error(codes::kSweepSeed, top, "", "a sampled study without a number of samples", "give 'samples: 100' (or --samples)");
    if (!s.seed_given) sink.Error(codes::kSweepSeed, top, "", "a sampled study without a seed", "give 'seed: 1' (or --seed): the runs are then reproducible");
  }
}

Study StudyFromArguments(const StudyArguments& a, const InputLimits& limits, DiagnosticSink& sink, std::string& model_text) {
  const std::string text = ReadModelText(a.path, limits);
  Study s;
  if (LooksLikeStudy(text)) s = ReadStudyString(text, a.path, &sink);
  else s.model = a.path;  // a model file: the study is in the arguments
  for (const auto& g : a.grids) AddAxisSpec(s, "--grid", g, sink);
  for (const auto& l : a.lists) AddAxisSpec(s, "--list", l, sink);
  for (const auto& d : a.samples_of) AddAxisSpec(s, "--sample", d, sink);
  for (const auto& k : a.keeps) AddKeepSpec(s, k, sink);
  if (a.method) {
    const auto it = std::find(kMethods.begin(), kMethods.end(), *a.method);
    if (it == kMethods.end()) sink.Error(codes::kSweepStudy, {kCommandLine, 1, 1}, "", fmt::format("unknown method '{}'", *a.method), Hint(*a.method, kMethods));
    else s.method = static_cast<Study::Method>(it - kMethods.begin());
  }
  if (a.samples) s.samples = *a.samples;
  if (a.seed) {
    s.seed = *a.seed;
    s.seed_given = true;
  }
  for (const auto& kv : a.set) {
    s.set.push_back(kv);
    s.set_where.push_back({kCommandLine, 1, 1});
  }
  s.keep_results = s.keep_results || a.results;
  CheckStudy(s, sink);
  if (s.model.empty()) sink.ThrowIfErrors();
  model_text = ReadModelText(s.model, limits);
  return s;
}

const char* TakeName(Keep::Take t) { return kTakes[static_cast<size_t>(t)].c_str(); }

std::string CanonicalText(const Study& s) {
  std::string o = fmt::format("model {}\nmethod {}\nsamples {}\nseed {}\n", std::filesystem::path(s.model).filename().string(),
                              kMethods[static_cast<size_t>(s.method)], s.samples, s.seed);
  for (const auto& [n, v] : s.set) o += fmt::format("set {}={}\n", n, v);
  for (const Axis& a : s.axes)
    o += fmt::format("axis {} {} {} {} {} {} {} {} [{}]\n", a.name, static_cast<int>(a.kind), a.from, a.to, a.count, static_cast<int>(a.scale),
                     static_cast<int>(a.distribution), fmt::format("{} {}", a.a, a.b), fmt::join(a.values, ","));
  for (const Keep& k : s.keep) {
    o += fmt::format("keep {} {} {} {} {} {}", k.name, TakeName(k.take), k.of, k.band, k.level, k.element);
    if (k.windowed()) o += fmt::format(" window {} {}", k.from, k.to);  // only then: a journal of before resumes
    o += "\n";
  }
  o += fmt::format("t_end {} dt {} rtol {} atol {} solver {}\n", s.t_end.value_or(-1), s.dt.value_or(-1), s.rtol.value_or(-1),
                   s.atol.value_or(-1), s.solver.value_or(""));
  return o;
}

}  // namespace multibond::sweep
