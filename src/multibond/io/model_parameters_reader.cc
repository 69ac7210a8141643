#include "multibond/io/model_parameters_reader.h"

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <cstdlib>
#include <numbers>
#include <stdexcept>

#include <fmt/format.h>

#include "multibond/core/identifier.h"
#include "multibond/core/units.h"
#include "multibond/core/diagnostic_codes.h"
#include "multibond/io/did_you_mean.h"

namespace multibond {

namespace {

/// One parameter while it is read: its value's node (undefined when set from outside), its tree
/// and the parameters it depends on.
struct Entry {
  ModelParameter p;
  YAML::Node value;
  expr::NodePtr root;               ///< null: a plain number, or not readable
  std::optional<Unit> unit;         ///< its declared unit (none: free in formulas)
  std::vector<std::size_t> deps;    ///< indices of the parameters its formula names
  bool failed = false;
};

/// A plain number ("2.5", "-3e-4"): its value, else nullopt.
std::optional<double> PlainNumber(const std::string& s) {
  if (s.empty()) return std::nullopt;
  const char* begin = s.c_str();
  char* end = nullptr;
  const double v = std::strtod(begin, &end);
  if (end != begin + s.size()) return std::nullopt;
  return v;
}

std::string NameList(const std::vector<Entry>& entries) {
  std::string s;
  for (std::size_t i = 0; i < entries.size() && i < 12; ++i) s += (i ? ", " : "") + entries[i].p.name;
  return entries.size() > 12 ? s + ", ..." : s;
}

}  // namespace

void ModelParametersReader::Read(const YAML::Node& n, const std::vector<ParameterOverride>& overrides) {
  std::vector<Entry> entries;
  std::unordered_map<std::string, std::size_t> index;
  if (n && !n.IsMap()) {
    sink_.Error(codes::kYamlStructure, Loc(n), "parameters", "'parameters' maps each name to its value",
                "write e.g. parameters: {L: 0.5, k: \"4*L\", m: {value: 2.0, unit: kg}}");
  } else if (n) {
    for (const auto& kv : n) {
      const std::string name = kv.first.Scalar();
      const SourceLocation where = Loc(kv.first);
      if (!CheckName(name, where, "a parameter's", false)) continue;
      if (IsReservedInFormulas(name)) {
        sink_.Error(codes::kNameInvalid, where, name,
                    fmt::format("a parameter may not be named '{}': in formulas {}", name,
                                name == "t" ? "'t' is time" : name == "pi" ? "'pi' is 3.14159..." : "it names an element's own variable in its law"),
                    "choose another name");
        continue;
      }
      Entry e;
      e.p.name = name;
      e.p.where = where;
      const YAML::Node v = kv.second;
      if (v.IsMap()) {
        CheckKeys(v, {"value", "unit", "description"}, name);
        if (v["unit"]) {
          e.p.unit = Str(v["unit"], name);
          if (const std::string problem = UnitProblem(e.p.unit); !problem.empty()) {
            sink_.Error(codes::kUnitInvalid, Loc(v["unit"]), name, fmt::format("the unit '{}' is refused: {}", PrintableExcerpt(e.p.unit), problem),
                        "write SI symbols with an optional prefix, separated by spaces or '*', one '/', whole exponents: "
                        "e.g. m, kg m^2, N/m, rad/s; '-' for none");
            e.p.unit.clear();
          } else {
            e.unit = ParseUnit(e.p.unit);
          }
        }
        if (v["description"]) e.p.description = Str(v["description"], name);
        if (!v["value"]) {
          sink_.Error(codes::kKeyMissing, where, name, "a parameter given as a mapping needs 'value'", "write e.g. {value: 0.5, unit: m}");
          e.failed = true;
        } else {
          e.value = v["value"];
        }
      } else {
        e.value = v;
      }
      if (!e.failed && !e.value.IsScalar()) {
        sink_.Error(codes::kYamlStructure, Loc(e.value), name, fmt::format("a parameter is a number or a formula, not {}", Describe(e.value)),
                    "write e.g. L: 0.5 or k: \"4*L\"");
        e.failed = true;
      }
      if (!e.failed) e.p.text = e.value.Scalar();
      index[name] = entries.size();  // a name given twice is a YAML error (yaml.duplicate_key)
      entries.push_back(std::move(e));
    }
  }

  // Values from outside the file replace the file's; a problem with one is the caller's.
  for (const ParameterOverride& o : overrides) {
    const auto it = index.find(o.name);
    if (it == index.end()) {
      std::vector<std::string> names;
      for (const Entry& e : entries) names.push_back(e.p.name);
      const std::string guess = DidYouMeanName(o.name, names);
      throw std::invalid_argument(fmt::format(
          "the model has no parameter '{}'{}", PrintableExcerpt(o.name),
          !guess.empty() ? fmt::format(": did you mean '{}'?", guess)
          : entries.empty() ? " (it declares no parameters)" : fmt::format(" (its parameters: {})", NameList(entries))));
    }
    Entry& e = entries[it->second];
    e.p.text = o.value;
    e.p.set = true;
    e.value.reset();  // rebinds the handle: assigning would set the document's node to null
    e.failed = false;
  }

  // Each value: a plain number, or a formula whose names are other parameters.
  auto set_error = [](const Entry& e, const std::string& what) {
    throw std::invalid_argument(fmt::format("parameter '{}' set to '{}': {}", e.p.name, PrintableExcerpt(e.p.text), what));
  };
  for (Entry& e : entries) {
    if (e.failed) continue;
    if (const std::optional<double> v = PlainNumber(e.p.text)) {
      if (e.p.set) {
        if (!std::isfinite(*v) || (*v != 0.0 && std::abs(*v) < DBL_MIN)) set_error(e, "not a finite, normal number");
        e.p.value = *v;
      } else {
        bool ok = true;
        e.p.value = Number(e.value, e.p.name, Env{}, &ok);  // NaN, infinities and subnormals are reported there
        e.failed = !ok;
      }
      continue;
    }
    if (e.p.set) {
      const expr::ParseResult r = expr::Parse(e.p.text);
      if (!r.root) {
        const expr::ParseError err = r.error.value_or(expr::ParseError{0, "not a formula", ""});
        set_error(e, fmt::format("{} (at character {})", err.message, err.offset + 1));
      }
      e.root = r.root;
    } else {
      e.root = Parse(e.value, e.p.text, e.p.name, false);
      if (!e.root) {
        e.failed = true;
        continue;
      }
    }
    for (const expr::Node* name : expr::Names(*e.root)) {
      const std::string& id = name->name;
      if (id == "pi") continue;
      if (const auto it = index.find(id); it != index.end()) {
        e.deps.push_back(it->second);
        continue;
      }
      const bool variable = id == "t" || id.find('.') != std::string::npos || IsReservedInFormulas(id) || cx_.signal_names.count(id);
      std::vector<std::string> names;
      for (const Entry& x : entries) names.push_back(x.p.name);
      const std::string guess = DidYouMeanName(id, names);
      if (e.p.set)
        set_error(e, variable ? fmt::format("'{}' is {}: a parameter is a constant", id, id == "t" ? "time" : "a variable of the model")
                              : fmt::format("the model has no parameter '{}'{}", id, guess.empty() ? "" : fmt::format(": did you mean '{}'?", guess)));
      e.failed = true;
      if (variable)
        sink_.Error(codes::kExprNotConstant, At(e.value, name->offset), e.p.name,
                    id == "t" ? std::string("a parameter is a constant: it cannot depend on 't' (time)")
                              : fmt::format("a parameter is a constant: it cannot depend on '{}', a variable of the model", PrintableExcerpt(id)),
                    "a quantity that changes in time is a signal (under 'signals:') or a formula in an element's law");
      else
        sink_.Error(codes::kParamUnknown, At(e.value, name->offset), e.p.name, fmt::format("unknown parameter '{}'", PrintableExcerpt(id)),
                    !guess.empty() ? fmt::format("did you mean '{}'?", guess) : fmt::format("the model's parameters are: {}", NameList(entries)));
    }
  }

  // Units, where declared (docs/model-format.md, "Units in formulas"): the formula of a parameter
  // is consistent, and gives the unit declared for it. Checked once its dependencies have values
  // (the exponent of a power is one). A mismatch does not make the value unusable: what depends on
  // the parameter is still evaluated and checked.
  // A frequency declared in Hz whose formula takes a square root without a 2 pi: sqrt(k/m) is an
  // angular frequency, in rad/s, and has the dimension of Hz (1/s: the radian is a number), so
  // the units agree and a 2 pi error would pass: refused, with the fix. Only when no name it
  // reads is declared in Hz (a square root of products of frequencies, sqrt(f1*f2), is one).
  auto is_hz = [](const std::string& unit) { return unit.size() >= 2 && unit.compare(unit.size() - 2, 2, "Hz") == 0; };
  auto RefuseAngularFrequencyInHz = [&](const Entry& e, const FormulaUnit& got, const std::vector<Entry>& all) {
    static const Dimension kPerSecond = ParseUnit("1/s")->dim;
    if (!is_hz(e.p.unit) || !e.unit || e.unit->dim != kPerSecond || got.kind != FormulaUnit::Kind::kUnit || !e.root) return;
    const std::string& text = e.p.text;
    if (text.find("sqrt") == std::string::npos && text.find('^') == std::string::npos) return;
    if (text.find("pi") != std::string::npos) return;
    for (const std::size_t d : e.deps)
      if (is_hz(all[d].p.unit)) return;
    if (e.p.set) set_error(e, fmt::format("'{}' in {} takes a square root and no 2*pi: an angular frequency is in rad/s", e.p.name, e.p.unit));
    sink_.Error(codes::kExprAngularFrequencyInHz, At(e.value, 0), e.p.name,
                fmt::format("'{}' is declared in {}, but its formula '{}' takes a square root and no 2*pi: a natural frequency "
                            "sqrt(k/m) is an angular frequency, in rad/s (both are 1/s to the units, so they cannot tell)",
                            e.p.name, e.p.unit, PrintableExcerpt(text)),
                fmt::format("declare it rad/s, or divide by 2*pi for {}: {}", e.p.unit, PrintableExcerpt("(" + text + ")/(2*pi)")));
  };

  auto check_units = [&](const Entry& e) {
    const FormulaUnits u = CheckFormulaUnits(
        *e.root, e.p.text,
        [&](const std::string& id) -> std::optional<DeclaredUnit> {
          const auto it = index.find(id);
          if (it == index.end() || !entries[it->second].unit) return std::nullopt;
          return DeclaredUnit{*entries[it->second].unit, entries[it->second].p.unit};
        },
        [&](const std::string& id) -> std::optional<double> {
          const auto it = index.find(id);
          if (it == index.end()) return std::nullopt;
          return entries[it->second].p.value;
        });
    if (u.mismatch) {
      if (e.p.set) set_error(e, fmt::format("{} (at character {})", u.mismatch->message, u.mismatch->offset + 1));
      sink_.Error(codes::kExprUnits, At(e.value, u.mismatch->offset), e.p.name, u.mismatch->message, u.mismatch->hint);
      return;
    }
    if (!e.unit) return;
    const UnitMatch match = MatchUnit(u.unit, *e.unit);
    if (match == UnitMatch::kSame) {
      RefuseAngularFrequencyInHz(e, u.unit, entries);
      return;
    }
    const std::string declared = e.p.unit == "-" || e.p.unit == "1" ? fmt::format("{} (a number)", e.p.unit) : e.p.unit;
    const std::string what =
        match == UnitMatch::kDimension
            ? fmt::format("its formula '{}' gives {}, not the unit declared for it, {}", PrintableExcerpt(e.p.text), DescribeUnit(u.unit), declared)
            : fmt::format("its formula '{}' gives {}: the dimension of the unit declared for it, {}, but another size (values are not converted)",
                          PrintableExcerpt(e.p.text), DescribeUnit(u.unit), declared);
    if (e.p.set) set_error(e, what);
    sink_.Error(codes::kExprUnits, At(e.value, 0), e.p.name, what,
                match == UnitMatch::kDimension
                    ? "check the formula and the units of the parameters it uses, or declare the unit it gives"
                    : "multiply the formula by its conversion factor (a number times a quantity takes the unit it needs), or "
                      "declare the unit it gives");
  };

  // Evaluated in the order of their dependencies: a depth-first walk with its own stack (a chain
  // of a hundred thousand parameters is no deeper on the machine's stack than one). A cycle is
  // reported once, at its first parameter in the file, and its members are not evaluated.
  auto evaluate = [&](Entry& e) {
    if (e.failed || !e.root) return;
    for (const std::size_t d : e.deps)
      if (entries[d].failed) {
        e.failed = true;  // said at d
        return;
      }
    const double v = expr::Evaluate(*e.root, [&](const std::string& id) -> std::optional<double> {
      if (const auto it = index.find(id); it != index.end()) return entries[it->second].p.value;
      if (id == "pi") return std::numbers::pi;
      return std::nullopt;
    });
    if (!std::isfinite(v) || (v != 0.0 && std::abs(v) < DBL_MIN)) {
      const std::string what = fmt::format("its formula gives {:g}: {}", v, std::isfinite(v) ? "too small to compute with (a subnormal number)" : "not a finite number");
      if (e.p.set) set_error(e, what);
      sink_.Error(codes::kParamRange, At(e.value, 0), e.p.name, what,
                  "check the formula and the parameters it uses (a division by zero, the root or logarithm of a negative number?)");
      e.failed = true;
      return;
    }
    e.p.value = v;
    check_units(e);
  };
  auto report_cycle = [&](std::vector<std::size_t> cycle) {
    std::string chain;
    bool set = false;
    std::size_t first = cycle.front();
    for (const std::size_t c : cycle) {
      chain += entries[c].p.name + (entries[c].p.set ? " (set)" : "") + " -> ";
      set = set || entries[c].p.set;
      first = std::min(first, c);
      entries[c].failed = true;
    }
    chain += entries[cycle.front()].p.name;
    if (set) throw std::invalid_argument(fmt::format("the parameters set make a cycle: {}", chain));
    sink_.Error(codes::kParamCycle, entries[first].p.where, entries[first].p.name, fmt::format("parameters that depend on themselves: {}", chain),
                "give one of them a value that does not depend on the others");
  };
  enum class Mark { kNew, kOpen, kDone };
  std::vector<Mark> mark(entries.size(), Mark::kNew);
  std::vector<std::pair<std::size_t, std::size_t>> stack;  // (parameter, its next dependency to visit)
  for (std::size_t start = 0; start < entries.size(); ++start) {
    if (mark[start] != Mark::kNew) continue;
    stack.emplace_back(start, 0);
    mark[start] = Mark::kOpen;
    while (!stack.empty()) {
      auto& [i, next] = stack.back();
      if (next < entries[i].deps.size()) {
        const std::size_t d = entries[i].deps[next++];
        if (mark[d] == Mark::kNew) {
          mark[d] = Mark::kOpen;
          stack.emplace_back(d, 0);
        } else if (mark[d] == Mark::kOpen) {
          std::vector<std::size_t> cycle;
          for (auto it = std::find_if(stack.begin(), stack.end(), [&](const auto& s) { return s.first == d; }); it != stack.end(); ++it)
            cycle.push_back(it->first);
          report_cycle(std::move(cycle));
        }
        continue;
      }
      mark[i] = Mark::kDone;
      evaluate(entries[i]);
      stack.pop_back();
    }
  }

  for (Entry& e : entries) {
    e.p.ok = !e.failed;
    cx_.parameter_index[e.p.name] = cx_.parameters.size();
    cx_.parameters.push_back(std::move(e.p));
  }
}

}  // namespace multibond
