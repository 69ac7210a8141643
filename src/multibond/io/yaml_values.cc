#include "multibond/io/yaml_values.h"

#include <algorithm>
#include <cctype>
#include <cfloat>
#include <cmath>
#include <cstdlib>

#include <fmt/format.h>

#include "multibond/core/expression.h"
#include "multibond/core/identifier.h"
#include "multibond/core/structure.h"
#include "multibond/core/diagnostic_codes.h"
#include "multibond/io/did_you_mean.h"

namespace multibond {

/// Names become column headers, file names of figures and comments in generated code: every
/// name follows the identifier grammar (core/identifier.h, docs/model-format.md "Names and
/// units"). Reports the problem at `where` and returns false.
/// `names_columns`: the name heads result columns (all but the model's), so 'time' and 'energy' are taken.
bool ValueReader::CheckName(const std::string& name, const SourceLocation& where, const char* what, bool names_columns) {
  if (names_columns && (name == "time" || name == "energy")) {
    // The results' own columns: time, and the energy account energy.work, energy.stored, ...
    sink_.Error(codes::kNameInvalid, where, name, fmt::format("{} name '{}' is reserved for the results' {} column{}", what, name, name,
                                                        name == "energy" ? "s (energy.work, energy.stored, ...)" : ""),
                "choose another name");
    return false;
  }
  if (expr::IsReservedWord(name)) {
    sink_.Error(codes::kNameInvalid, where, name,
                fmt::format("{} name '{}' is a word of formulas: 'and', 'or' and 'not' are operators there", what, name),
                "choose another name");
    return false;
  }
  const std::string problem = IdentifierProblem(name);
  if (problem.empty()) return true;
  const std::string better = SuggestIdentifier(name);
  sink_.Error(codes::kNameInvalid, where, PrintableExcerpt(name), fmt::format("{} name {}", what, problem),
              fmt::format("a name is a letter or '_', then letters, digits and '_' (at most {} characters){}", kMaxNameLength,
                          better.empty() || better == name ? "" : fmt::format(": e.g. '{}'", better)));
  return false;
}

/// Component names head columns too ("<name>.<component>"): identifiers, a leading digit allowed.
std::vector<std::string> ValueReader::Components(const YAML::Node& n, const std::string& element) {
  std::vector<std::string> out = Words(n, element, "components");
  if (!n.IsSequence()) return out;
  for (size_t i = 0; i < out.size() && i < n.size(); ++i)
    if (const std::string problem = IdentifierProblem(out[i], true); !problem.empty())
      sink_.Error(codes::kNameInvalid, Loc(n[i]), element, fmt::format("component name '{}' {}", PrintableExcerpt(out[i]), problem),
                  "a component name is letters, digits and '_', e.g. x, y, z or 1, 2, 3");
    else if (std::find(out.begin(), out.begin() + static_cast<long>(i), out[i]) != out.begin() + static_cast<long>(i))
      sink_.Error(codes::kNameDuplicate, Loc(n[i]), element, fmt::format("component name '{}' is given twice", PrintableExcerpt(out[i])),
                  "give each component its own name");
  return out;
}

void ValueReader::CheckKeys(const YAML::Node& map, const std::vector<std::string>& allowed, const std::string& element) {
  if (!map.IsMap()) return;
  for (const auto& kv : map) {
    const std::string key = kv.first.Scalar();
    if (std::find(allowed.begin(), allowed.end(), key) != allowed.end()) continue;
    if (key == "<<") continue;  // said by CheckDuplicateKeys
    const std::string guess = DidYouMean(key, allowed);
    std::string allowed_list;
    for (const auto& a : allowed) allowed_list += (allowed_list.empty() ? "" : ", ") + a;
    sink_.Error(codes::kKeyUnknown, Loc(kv.first), element, fmt::format("unknown key '{}'", key),
                guess.empty() ? "known keys here: " + allowed_list : fmt::format("did you mean '{}'?", guess));
  }
}

/// What a node is, for messages: "a number", "a list", "nothing"...
std::string ValueReader::Describe(const YAML::Node& n) {
  if (n.IsNull()) return "nothing";
  if (n.IsSequence()) return "a list";
  if (n.IsMap()) return "a mapping";
  return fmt::format("'{}'", n.Scalar());
}

/// A list of words (component names, ports); anything else is reported.
std::vector<std::string> ValueReader::Words(const YAML::Node& n, const std::string& element, const char* what) {
  std::vector<std::string> out;
  if (!n.IsSequence()) {
    sink_.Error(codes::kYamlStructure, Loc(n), element, fmt::format("'{}' must be a list", what), fmt::format("write e.g. {}: [x, y]", what));
    return out;
  }
  for (const auto& w : n) {
    if (!w.IsScalar()) {
      sink_.Error(codes::kYamlStructure, Loc(w), element, fmt::format("each entry of '{}' is a single word", what));
      continue;
    }
    out.push_back(w.Scalar());
  }
  return out;
}

std::string ValueReader::Str(const YAML::Node& n, const std::string& element) {
  if (!n.IsScalar()) {
    sink_.Error(codes::kYamlStructure, Loc(n), element, "expected a text value", "write a single word or a quoted string");
    return {};
  }
  return n.Scalar();
}

std::string ValueReader::Domain(const YAML::Node& n, const std::string& element) {
  const std::string d = Str(n, element);
  const auto& known = KnownDomains();
  if (!d.empty() && std::find(known.begin(), known.end(), d) == known.end()) {
    const std::string guess = DidYouMean(d, known);
    sink_.Error(codes::kValueUnknown, Loc(n), element, fmt::format("unknown domain '{}'", d),
                guess.empty() ? "use translation, rotation, electrical, hydraulic or generic" : fmt::format("did you mean '{}'?", guess));
  }
  return d == "generic" ? "" : d;
}

/// A finite number, a $parameter of the enclosing submodel, or a formula of parameters.
double ValueReader::Number(const YAML::Node& n, const std::string& element, const Env& env, bool* ok) {
  auto fail = [&](const char* code, const std::string& msg, const std::string& hint) {
    sink_.Error(code, Loc(n), element, msg, hint);
    cx_.unread_numbers.insert(element);
    if (ok) *ok = false;
    return 0.0;
  };
  if (!n.IsScalar()) return fail(codes::kYamlStructure, "expected a number", "write a plain number such as 1.5 or 2e-3");
  const std::string s = n.Scalar();
  if (!s.empty() && s[0] == '$') {
    const auto it = env.find(s.substr(1));
    if (it == env.end()) return fail(codes::kParamUnknown, fmt::format("unknown parameter '{}'", s), "declare it under the submodel's 'parameters'");
    return it->second;
  }
  if (s == ".nan" || s == ".NaN" || s == ".NAN" || s == ".inf" || s == ".Inf" || s == "-.inf" || s == "+.inf" || s == "-.Inf")
    return fail(codes::kParamRange, fmt::format("'{}' is not a finite number", s), "NaN and infinities are not allowed in a model");
  const char* begin = s.c_str();
  char* end = nullptr;
  const double v = std::strtod(begin, &end);
  if (s.empty()) return fail(codes::kYamlStructure, "expected a number, got ''", "write a plain number such as 1.5 or 2e-3");
  if (end != begin + s.size()) return Constant(n, s, element, env, ok);  // a formula of parameters
  if (!std::isfinite(v)) return fail(codes::kParamRange, fmt::format("'{}' is not a finite number", s), "NaN and infinities are not allowed in a model");
  // A subnormal number (0 < |v| < 2.2e-308) is no physical quantity: its inverse is infinite,
  // and arithmetic on it loses its digits.
  if (v != 0.0 && std::abs(v) < DBL_MIN)
    return fail(codes::kParamRange, fmt::format("'{}' is too small to compute with (a subnormal number, below {:g} in magnitude)", s, DBL_MIN),
                "write 0, or a value of a sensible size in SI units");
  return v;
}

Eigen::VectorXd ValueReader::Vector(const YAML::Node& n, const std::string& element, const Env& env) {
  if (n.IsScalar()) return Eigen::VectorXd::Constant(1, Number(n, element, env));
  if (!n.IsSequence()) {
    sink_.Error(codes::kYamlStructure, Loc(n), element, "expected a list of numbers", "write e.g. [0, 0, 1]");
    return {};
  }
  Eigen::VectorXd v(static_cast<Eigen::Index>(n.size()));
  for (size_t i = 0; i < n.size(); ++i) v(static_cast<Eigen::Index>(i)) = Number(n[i], element, env);
  return v;
}

Eigen::MatrixXd ValueReader::Matrix(const YAML::Node& n, const std::string& element, const Env& env) {
  if (!n.IsSequence() || n.size() == 0 || !n[0].IsSequence()) {
    sink_.Error(codes::kYamlStructure, Loc(n), element, "expected a matrix (a list of rows)", "write e.g. [[1, 0], [0, 1]]");
    return {};
  }
  const size_t rows = n.size(), cols = n[0].size();
  Eigen::MatrixXd m(rows, cols);
  for (size_t r = 0; r < rows; ++r) {
    if (!n[r].IsSequence() || n[r].size() != cols) {
      sink_.Error(codes::kParamShape, Loc(n[r]), element, fmt::format("matrix row {} has {} entries, the first row {}", r + 1, n[r].IsSequence() ? n[r].size() : 1, cols),
                  "every row of a matrix has the same length");
      return {};
    }
    for (size_t c = 0; c < cols; ++c) m(r, c) = Number(n[r][c], element, env);
  }
  return m;
}

/// A scalar, a diagonal given as a list, or a full matrix.
Param ValueReader::ReadParam(const YAML::Node& n, const std::string& element, const Env& env) {
  if (n.IsScalar()) return Param::Scalar(Number(n, element, env));
  if (n.IsSequence() && n.size() > 0 && n[0].IsSequence()) return Param::Matrix(Matrix(n, element, env));
  if (n.IsSequence()) {
    const Eigen::VectorXd d = Vector(n, element, env);
    return Param::Matrix(d.asDiagonal());
  }
  sink_.Error(codes::kYamlStructure, Loc(n), element, "expected a number, a list (diagonal) or a matrix", "write e.g. 2.0, [1, 2, 3] or [[1, 0], [0, 1]]");
  return Param::Scalar(1.0);
}

bool ValueReader::Bool(const YAML::Node& n, const std::string& element) {
  const std::string s = n.IsScalar() ? n.Scalar() : "";
  if (s == "true" || s == "True" || s == "TRUE" || s == "yes") return true;
  if (s == "false" || s == "False" || s == "FALSE" || s == "no") return false;
  sink_.Error(codes::kYamlStructure, Loc(n), element, "expected true or false");
  return false;
}

std::string ValueReader::Qualify(const std::string& prefix, const std::string& local) {
  return prefix.empty() ? local : prefix + "." + local;
}

bool ValueReader::IsPlainValue(const YAML::Node& n) {
  if (!n.IsScalar()) return true;
  const std::string& s = n.Scalar();
  if (s.empty() || s[0] == '$') return true;
  std::string word = s.substr(s[0] == '-' || s[0] == '+' ? 1 : 0);
  for (char& c : word) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (word == ".nan" || word == ".inf") return true;
  const char* begin = s.c_str();
  char* end = nullptr;
  (void)std::strtod(begin, &end);
  return end == begin + s.size();
}

}  // namespace multibond
