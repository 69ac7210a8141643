// ValueReader's formulas (docs/model-format.md, "Expressions"): a number written as a formula of
// parameters, evaluated where it is read, and the formulas that may change in time (laws, sources,
// signals, states), read as trees with their parameters replaced by numbers. Every problem is
// reported at the character of the formula where it is: the scalar's place in the file, plus the
// offset in its text (past the opening quote of a quoted scalar).

#include <algorithm>
#include <cctype>
#include <cfloat>
#include <cmath>
#include <functional>
#include <numbers>
#include <set>
#include <stdexcept>
#include <string_view>

#include <fmt/format.h>

#include "multibond/core/identifier.h"
#include "multibond/core/units.h"
#include "multibond/core/diagnostic_codes.h"
#include "multibond/io/did_you_mean.h"
#include "multibond/io/yaml_values.h"

namespace multibond {

namespace {

bool IsIdentChar(char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_'; }

/// The code of a parse error: a call of a function the grammar does not have, a call with the
/// wrong number of arguments, or any other syntax error. The parser reports the first two at the
/// function's name.
const char* ParseErrorCode(const std::string& text, const expr::ParseError& e) {
  size_t i = static_cast<size_t>(std::max(e.offset, 0));
  if (i >= text.size() || !(std::isalpha(static_cast<unsigned char>(text[i])) || text[i] == '_')) return codes::kExprSyntax;
  size_t j = i;
  while (j < text.size() && (IsIdentChar(text[j]) || text[j] == '.')) ++j;
  const std::string name = text.substr(i, j - i);
  if (expr::IsReservedWord(name)) return codes::kExprSyntax;  // "not (a < b)" where 'not' cannot stand
  while (j < text.size() && (text[j] == ' ' || text[j] == '\t')) ++j;
  if (j >= text.size() || text[j] != '(') return codes::kExprSyntax;
  return expr::FindFunction(name) ? codes::kExprArity : codes::kExprUnknownFunction;
}

/// A variable of the model rather than a parameter: time, `spring.q`, an element's own variable,
/// a signal or a state.
bool NamesAVariable(const std::string& id, const LoadContext& cx) {
  return id == "t" || id.find('.') != std::string::npos || IsReservedInFormulas(id) || cx.signal_names.count(id) ||
         cx.state_names.count(id);
}

expr::NodePtr NumberAt(double v, int offset) {
  auto n = std::make_shared<expr::Node>();
  n->kind = expr::Node::Kind::kNumber;
  n->value = v;
  n->offset = offset;
  return n;
}

expr::NodePtr NameAt(std::string name, int offset) {
  auto n = std::make_shared<expr::Node>();
  n->kind = expr::Node::Kind::kName;
  n->name = std::move(name);
  n->offset = offset;
  return n;
}

/// The unit declared for a parameter of the model, if any (a name without one is free).
std::optional<DeclaredUnit> DeclaredUnitOf(const ModelParameter* p) {
  if (!p || p->unit.empty()) return std::nullopt;
  const std::optional<Unit> u = ParseUnit(p->unit);  // a unit refused was cleared where it was said
  if (!u) return std::nullopt;
  return DeclaredUnit{*u, p->unit};
}

const char* kConstantHint =
    "a value here is a number or a formula of parameters; what changes in time is a law (C 'effort'/'energy', "
    "I 'flow'/'energy', R 'effort'/'flow'), a source's formula, a signal or a state's 'rate'/'input'";

}  // namespace

SourceLocation ValueReader::At(const YAML::Node& n, int offset) const {
  // The place of the formula's byte `offset` in the file: where the scalar's text stands in the
  // file as it is (a plain scalar, a quoted one without escapes, a literal block `|`), else the
  // start of the value (escapes, folding and '' change the text, and a column inside it would
  // point at the wrong character).
  const YAML::Mark m = n.Mark();
  SourceLocation where = cx_.Loc(m);
  if (!where.known() || m.pos < 0 || !n.IsScalar()) return where;
  const std::string& scalar = n.Scalar();
  const std::string& raw = cx_.text;
  const size_t pos = static_cast<size_t>(m.pos);
  if (offset < 0 || static_cast<size_t>(offset) > scalar.size() || pos >= raw.size()) return where;
  // The text up to and including the character stands in the file as it is (escapes, folding
  // or '' further on do not matter).
  const size_t upto = std::min(scalar.size(), static_cast<size_t>(offset) + 1);
  auto stands_at = [&](size_t at) { return at <= raw.size() && raw.compare(at, upto, scalar, 0, upto) == 0; };
  if (stands_at(pos)) return cx_.Location(pos + offset);
  if ((raw[pos] == '"' || raw[pos] == '\'') && stands_at(pos + 1)) return cx_.Location(pos + 1 + offset);
  if (raw[pos] == '|') {
    // A literal block: its lines follow the indicator's line, each indented alike.
    const size_t first = raw.find('\n', pos);
    if (first == std::string::npos) return where;
    size_t line = first + 1;
    while (line < raw.size() && raw[line] == '\n') ++line;  // blank lines before the content
    const size_t indent = raw.find_first_not_of(' ', line) - line;
    size_t at = 0;  // offset in the scalar of the current line's start
    for (;;) {
      const size_t end = scalar.find('\n', at);
      const size_t len = (end == std::string::npos ? scalar.size() : end) - at;
      if (raw.compare(line + indent, len, scalar, at, len) != 0) return where;
      if (static_cast<size_t>(offset) <= at + len) return cx_.Location(line + indent + (offset - at));
      if (end == std::string::npos) return where;
      at = end + 1;
      line = raw.find('\n', line) + 1;
      if (line == 0 || line >= raw.size()) return where;
    }
  }
  return where;
}

expr::NodePtr ValueReader::Parse(const YAML::Node& n, const std::string& text, const std::string& element, bool number) {
  const expr::ParseResult r = expr::Parse(text);
  if (r.root) return r.root;
  const expr::ParseError e = r.error.value_or(expr::ParseError{0, "not a formula", ""});
  const std::string shown = PrintableExcerpt(text);
  const std::string message = number ? fmt::format("expected a number, got '{}': as a formula, {}", shown, e.message)
                                     : fmt::format("the formula '{}' does not read: {}", shown, e.message);
  const char* code = ParseErrorCode(text, e);
  // A number with a unit ("2 kg") is the likelier mistake where a number is expected.
  std::string hint = e.hint;
  if (number && std::string_view(code) == codes::kExprSyntax)
    hint = "write a plain number such as 1.5 or 2e-3 (in SI units, without the unit), or a formula of parameters such as 2*L";
  else if (hint.empty())
    hint = "see the grammar of formulas in docs/model-format.md, 'Expressions'";
  if (static_cast<size_t>(e.offset) < text.size() && text[e.offset] == '$')
    hint = "in a formula, a submodel's parameter is named without '$' (2*m, not 2*$m)";
  sink_.Error(code, At(n, e.offset), element, message, hint);
  return nullptr;
}

void ValueReader::UnknownName(const YAML::Node& n, const expr::Node& name, const std::string& element,
                              const std::vector<std::string>& more, const std::string& own_hint) {
  std::vector<std::string> candidates;
  for (const ModelParameter& p : cx_.parameters) candidates.push_back(p.name);
  candidates.insert(candidates.end(), more.begin(), more.end());
  const std::string guess = DidYouMeanName(name.name, candidates);
  std::string hint;
  if (!guess.empty()) hint = fmt::format("did you mean '{}'?", guess);
  else if (!own_hint.empty()) hint = own_hint;
  else if (cx_.parameters.empty()) hint = "declare it under 'parameters:' at the top of the model file";
  else {
    std::string names;
    for (size_t i = 0; i < cx_.parameters.size() && i < 12; ++i) names += (i ? ", " : "") + cx_.parameters[i].name;
    hint = fmt::format("the model's parameters are: {}{}", names, cx_.parameters.size() > 12 ? ", ..." : "");
  }
  sink_.Error(codes::kParamUnknown, At(n, name.offset), element, fmt::format("unknown parameter '{}'", PrintableExcerpt(name.name)), hint);
}

double ValueReader::Constant(const YAML::Node& n, const std::string& text, const std::string& element, const Env& env, bool* ok) {
  auto failed = [&] {
    cx_.unread_numbers.insert(element);
    if (ok) *ok = false;
    return 0.0;
  };
  const expr::NodePtr root = Parse(n, text, element, true);
  if (!root) return failed();
  bool good = true;
  std::vector<std::string> env_names;
  for (const auto& [k, v] : env) env_names.push_back(k);
  for (const expr::Node* name : expr::Names(*root)) {
    const std::string& id = name->name;
    if (id == "pi" || env.count(id)) continue;
    if (const ModelParameter* p = cx_.FindParameter(id)) {
      good = good && p->ok;  // a parameter that could not be computed was reported where it is
      continue;
    }
    good = false;
    if (NamesAVariable(id, cx_) && !constant_rule_.empty())
      sink_.Error(codes::kExprNotConstant, At(n, name->offset), element,
                  fmt::format("{} ({})", constant_rule_,
                              id == "t" ? std::string("'t' is time") : fmt::format("'{}' is a variable of the model", PrintableExcerpt(id))),
                  law_keys_hint_.empty() ? kConstantHint : law_keys_hint_);
    else if (NamesAVariable(id, cx_))
      sink_.Error(codes::kExprNotConstant, At(n, name->offset), element,
                  id == "t" ? std::string("'t' (time) in a value that is a constant")
                            : fmt::format("'{}' is a variable of the model, in a value that is a constant", PrintableExcerpt(id)),
                  law_keys_hint_.empty() ? kConstantHint : law_keys_hint_);
    else
      UnknownName(n, *name, element, env_names, "");
  }
  if (!good) return failed();
  // Units where they are declared: a mismatch is said, and the value is still read (it is a
  // number; what follows from it is checked as usual).
  const FormulaUnits units = CheckFormulaUnits(
      *root, text,
      [&](const std::string& id) -> std::optional<DeclaredUnit> {
        if (env.count(id)) return std::nullopt;  // a submodel's parameter: no unit
        return DeclaredUnitOf(cx_.FindParameter(id));
      },
      [&](const std::string& id) -> std::optional<double> {
        if (const auto it = env.find(id); it != env.end()) return it->second;
        if (const ModelParameter* p = cx_.FindParameter(id)) return p->value;
        return std::nullopt;
      });
  if (units.mismatch) sink_.Error(codes::kExprUnits, At(n, units.mismatch->offset), element, units.mismatch->message, units.mismatch->hint);
  double v = 0.0;
  try {
    v = expr::Evaluate(*root, [&](const std::string& id) -> std::optional<double> {
      if (const auto it = env.find(id); it != env.end()) return it->second;
      if (const ModelParameter* p = cx_.FindParameter(id)) return p->value;
      if (id == "pi") return std::numbers::pi;
      return std::nullopt;
    });
  } catch (const std::domain_error& e) {  // every name was checked above
    sink_.Error(codes::kParamUnknown, At(n, 0), element, e.what());
    return failed();
  }
  if (!std::isfinite(v) || (v != 0.0 && std::abs(v) < DBL_MIN)) {
    sink_.Error(codes::kParamRange, At(n, 0), element,
                fmt::format("the formula '{}' gives {:g}: {}", PrintableExcerpt(text), v,
                            std::isfinite(v) ? "too small to compute with (a subnormal number)" : "not a finite number"),
                "check the formula and the parameters it uses (a division by zero, the root or logarithm of a negative number?)");
    return failed();
  }
  return v;
}

std::optional<Formula> ValueReader::ReadFormula(const YAML::Node& n, const std::string& element, const FormulaScope& scope) {
  if (!n.IsScalar() || n.Scalar().empty()) {
    sink_.Error(codes::kYamlStructure, Loc(n), element, fmt::format("expected a formula, got {}", Describe(n)),
                "write a formula in quotes, e.g. \"k*q + k3*q^3\" (docs/model-format.md, 'Expressions')");
    return std::nullopt;
  }
  const std::string text = n.Scalar();
  const expr::NodePtr root = Parse(n, text, element, false);
  if (!root) return std::nullopt;
  const Env no_env;
  const Env& env = scope.env ? *scope.env : no_env;
  // The names a bare word may be besides a parameter, for did-you-mean.
  std::vector<std::string> more = scope.own;
  for (const auto& [k, v] : env) more.push_back(k);
  for (const std::string& s : cx_.signal_names) more.push_back(s);
  std::sort(more.begin() + static_cast<long>(scope.own.size() + env.size()), more.end());  // not in a hash order
  std::string own_list;
  for (const std::string& o : scope.own) own_list += (own_list.empty() ? "'" : ", '") + o + "'";
  bool good = true;
  std::set<std::string> reported;
  std::function<expr::NodePtr(const expr::NodePtr&)> resolve = [&](const expr::NodePtr& node) -> expr::NodePtr {
    if (node->kind == expr::Node::Kind::kName) {
      const std::string& id = node->name;
      if (id == "t" || id == "pi" || std::find(scope.own.begin(), scope.own.end(), id) != scope.own.end()) return node;
      if (const auto it = env.find(id); it != env.end()) return NumberAt(it->second, node->offset);
      if (const ModelParameter* p = cx_.FindParameter(id)) {
        good = good && p->ok;
        return NumberAt(p->value, node->offset);
      }
      // A variable of an element or a state: local to the instance.
      if (id.find('.') != std::string::npos) return scope.prefix.empty() ? node : NameAt(Qualify(scope.prefix, id), node->offset);
      if (cx_.state_names.count(Qualify(scope.prefix, id))) return scope.prefix.empty() ? node : NameAt(Qualify(scope.prefix, id), node->offset);
      if (cx_.signal_names.count(id)) return node;
      good = false;
      if (reported.insert(id).second) {
        std::string own_hint;
        if (IsReservedInFormulas(id))
          own_hint = scope.own.empty()
                         ? fmt::format("'{}' names an element's own variable in its law only; here name the variable with its element, e.g. "
                                       "'spring.{}'", id, id)
                         : fmt::format("in a {} the element's own variable is {}", scope.what, own_list);
        UnknownName(n, *node, element, more, own_hint);
      }
      return node;
    }
    if (node->args.empty()) return node;
    std::vector<expr::NodePtr> args;
    bool changed = false;
    for (const expr::NodePtr& a : node->args) {
      args.push_back(resolve(a));
      changed = changed || args.back() != a;
    }
    if (!changed) return node;
    auto copy = std::make_shared<expr::Node>(*node);
    copy->args = std::move(args);
    return copy;
  };
  expr::NodePtr resolved = resolve(root);
  if (!good) return std::nullopt;
  // Units where they are declared: the parameters with one; time, variables, signals, states and
  // a submodel's parameters are free. A mismatch is said; the formula is still read.
  const FormulaUnits units = CheckFormulaUnits(
      *root, text,
      [&](const std::string& id) -> std::optional<DeclaredUnit> {
        if (std::find(scope.own.begin(), scope.own.end(), id) != scope.own.end() || env.count(id)) return std::nullopt;
        return DeclaredUnitOf(cx_.FindParameter(id));
      },
      [&](const std::string& id) -> std::optional<double> {
        if (std::find(scope.own.begin(), scope.own.end(), id) != scope.own.end()) return std::nullopt;
        if (const auto it = env.find(id); it != env.end()) return it->second;
        if (const ModelParameter* p = cx_.FindParameter(id)) return p->value;
        return std::nullopt;
      });
  if (units.mismatch) sink_.Error(codes::kExprUnits, At(n, units.mismatch->offset), element, units.mismatch->message, units.mismatch->hint);
  return Formula{text, std::move(resolved), At(n, 0)};
}

std::optional<double> ValueReader::ConstantValue(const Formula& f) {
  if (!f.root) return std::nullopt;
  for (const expr::Node* name : expr::Names(*f.root))
    if (name->name != "pi") return std::nullopt;
  try {
    return expr::Evaluate(*f.root, [](const std::string& id) -> std::optional<double> {
      if (id == "pi") return std::numbers::pi;
      return std::nullopt;
    });
  } catch (const std::domain_error&) {
    return std::nullopt;
  }
}

}  // namespace multibond
