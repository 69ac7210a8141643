#include "multibond/io/parameter_reader.h"

#include <map>

#include <fmt/format.h>

#include "multibond/core/diagnostic_codes.h"
#include "multibond/io/did_you_mean.h"

namespace multibond {

TimeFunction ParameterReader::ReadTimeFunction(const YAML::Node& n, const std::string& element, const Env& env) {
  if (n.IsScalar()) return TimeFunction::Constant(Number(n, element, env));
  if (!n.IsMap() || n.size() != 1) {
    sink_.Error(codes::kYamlStructure, Loc(n), element, "expected a number or one of {step: ...}, {ramp: ...}, {sine: ...}, {table: ...}",
                "e.g. effort: {step: {value: 1, at: 0}}");
    return {};
  }
  const std::string kind = n.begin()->first.Scalar();
  const YAML::Node v = n.begin()->second;
  auto get = [&](const char* key, double dflt) { return v[key] ? Number(v[key], element, env) : dflt; };
  // step, ramp and sine take a mapping of settings ({} keeps every default); step also a number.
  auto settings = [&](const char* example) {
    if (v.IsMap()) return true;
    sink_.Error(codes::kYamlStructure, Loc(v), element, fmt::format("'{}' takes a mapping of settings, not {}", kind, Describe(v)),
                fmt::format("write e.g. {{{}: {}}}", kind, example));
    return false;
  };
  if (kind == "step") {
    if (v.IsScalar()) return TimeFunction::Step(Number(v, element, env));
    if (!settings("{value: 5, at: 1}")) return {};
    CheckKeys(v, {"value", "at", "before"}, element);
    return TimeFunction::Step(get("value", 1.0), get("at", 0.0), get("before", 0.0));
  }
  if (kind == "ramp") {
    if (!settings("{slope: 2, start: 1}")) return {};
    CheckKeys(v, {"slope", "start", "offset"}, element);
    return TimeFunction::Ramp(get("slope", 1.0), get("start", 0.0), get("offset", 0.0));
  }
  if (kind == "sine") {
    if (!settings("{amplitude: 0.1, frequency: 50}")) return {};
    CheckKeys(v, {"amplitude", "frequency", "phase", "offset"}, element);
    return TimeFunction::Sine(get("amplitude", 1.0), get("frequency", 1.0), get("phase", 0.0), get("offset", 0.0));
  }
  if (kind == "table") {
    std::vector<double> t, val;
    if (!v.IsSequence() || v.size() < 2) {
      sink_.Error(codes::kParamShape, Loc(v), element, "a table needs at least two [time, value] rows", "write e.g. table: [[0, 0], [1, 5]]");
      return {};
    }
    for (const auto& row : v) {
      if (!row.IsSequence() || row.size() != 2) {
        sink_.Error(codes::kParamShape, Loc(row), element, "a table row is [time, value]");
        return {};
      }
      t.push_back(Number(row[0], element, env));
      val.push_back(Number(row[1], element, env));
      if (t.size() > 1 && !(t.back() > t[t.size() - 2])) sink_.Error(codes::kParamRange, Loc(row), element, "table times must increase strictly");
    }
    return TimeFunction::Table(std::move(t), std::move(val));
  }
  const std::string guess = DidYouMean(kind, {"step", "ramp", "sine", "table"});
  sink_.Error(codes::kValueUnknown, Loc(n.begin()->first), element, fmt::format("unknown time function '{}'", kind),
              guess.empty() ? "use step, ramp, sine or table" : fmt::format("did you mean '{}'?", guess));
  return {};
}

SourceValue ParameterReader::ReadSource(const YAML::Node& n, const std::string& element, const Env& env) {
  SourceValue v;
  if (n.IsSequence())
    for (const auto& c : n) v.components.push_back(ReadTimeFunction(c, element, env));
  else
    v.components.push_back(ReadTimeFunction(n, element, env));
  return v;
}

Eigen::MatrixXd ParameterReader::Selection(const YAML::Node& n, const std::string& element) {
  static const std::map<std::string, int> kAxes = {{"x", 0}, {"y", 1}, {"z", 2}, {"0", 0}, {"1", 1}, {"2", 2}};
  if (!n.IsSequence() || n.size() == 0 || n.size() > 3) {
    sink_.Error(codes::kYamlStructure, Loc(n), element, "rows must be a list of axes", "write e.g. rows: [y, z]");
    return {};
  }
  Eigen::MatrixXd s = Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(n.size()), 3);
  for (size_t i = 0; i < n.size(); ++i) {
    const auto it = kAxes.find(n[i].Scalar());
    if (it == kAxes.end()) {
      sink_.Error(codes::kValueUnknown, Loc(n[i]), element, fmt::format("unknown axis '{}'", n[i].Scalar()), "axes are x, y, z");
      continue;
    }
    s(static_cast<Eigen::Index>(i), it->second) = 1.0;
  }
  return s;
}

/// A modulus' matrix whose entries are numbers or formulas: the formulas that change (of time or
/// model variables) go to `entries` (row-major; all not given when none changes), their places
/// in the constant matrix 0.
Eigen::MatrixXd ParameterReader::ModulusMatrix(const YAML::Node& n, const std::string& element, const std::string& prefix,
                                               const Env& env, std::vector<Formula>* entries) {
  if (!n.IsSequence() || n.size() == 0 || !n[0].IsSequence()) return Matrix(n, element, env);  // reports the shape
  const size_t rows = n.size(), cols = n[0].size();
  bool varies = false;
  for (size_t r = 0; r < rows; ++r)
    for (size_t c = 0; n[r].IsSequence() && c < n[r].size(); ++c)
      varies = varies || !IsPlainValue(n[r][c]);
  if (!varies) return Matrix(n, element, env);
  Eigen::MatrixXd m = Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(rows), static_cast<Eigen::Index>(cols));
  std::vector<Formula> out(rows * cols);
  bool any = false;
  for (size_t r = 0; r < rows; ++r) {
    if (!n[r].IsSequence() || n[r].size() != cols) return Matrix(n, element, env);  // reports the ragged row
    for (size_t c = 0; c < cols; ++c) {
      const std::optional<Formula> f = ReadFormula(n[r][c], element, FormulaScope{&env, prefix, {}, "modulus entry"});
      if (!f) continue;
      if (const std::optional<double> v = ConstantValue(*f)) {
        m(static_cast<Eigen::Index>(r), static_cast<Eigen::Index>(c)) = *v;
      } else {
        out[r * cols + c] = *f;
        any = true;
      }
    }
  }
  if (any) *entries = std::move(out);
  return m;
}

Modulus ParameterReader::ReadModulus(const YAML::Node& n, const std::string& element, const std::string& prefix, const Env& env) {
  Modulus m;
  if (!n.IsMap()) {
    sink_.Error(codes::kYamlStructure, Loc(n), element, "modulus must be a mapping",
                "e.g. {rotation: A.R, transpose: true}, {lever: A.R, r: [0.1, 0, 0]} or {matrix: [[...]]}");
    return m;
  }
  CheckKeys(n, {"rotation", "transpose", "lever", "r", "matrix", "rows", "left", "right", "scale"}, element);
  const int forms = (n["matrix"] ? 1 : 0) + (n["rotation"] ? 1 : 0) + (n["lever"] ? 1 : 0);
  if (forms > 1) sink_.Error(codes::kKeyConflict, Loc(n), element, "give exactly one of 'matrix', 'rotation' and 'lever'");
  if (n["rows"] && n["left"]) sink_.Error(codes::kKeyConflict, Loc(n), element, "give either 'rows' or 'left', not both");
  if (n["transpose"] && !n["rotation"]) sink_.Error(codes::kKeyConflict, Loc(n["transpose"]), element, "'transpose' goes with 'rotation'");
  if (n["r"] && !n["lever"]) sink_.Error(codes::kKeyConflict, Loc(n["r"]), element, "'r' goes with 'lever'");
  if (n["right"] && !n["rotation"]) sink_.Error(codes::kKeyConflict, Loc(n["right"]), element, "'right' goes with 'rotation'");
  if (n["scale"]) m.scale = Number(n["scale"], element, env);
  if (n["rows"]) m.left = Selection(n["rows"], element);
  if (n["left"]) m.left = Matrix(n["left"], element, env);
  if (n["right"]) {
    m.right = Matrix(n["right"], element, env);
    if (m.right.size() > 0 && (m.right.rows() != 3 || m.right.cols() > 3))
      sink_.Error(codes::kParamShape, Loc(n["right"]), element, "'right' must be a 3 x n matrix with n <= 3");
  }
  if (n["matrix"]) {
    m.kind = Modulus::Kind::kConstant;
    m.constant = ModulusMatrix(n["matrix"], element, prefix, env, &m.entries);
    if (!m.entries.empty() && (n["left"] || n["rows"]))
      sink_.Error(codes::kKeyConflict, Loc(n["left"] ? n["left"] : n["rows"]), element, "a modulus whose entries are formulas takes no 'left' or 'rows'",
                  "put the selection into the matrix itself");
  } else if (n["rotation"]) {
    m.kind = Modulus::Kind::kRotation;
    m.rotation = Qualify(prefix, Str(n["rotation"], element));
    if (n["transpose"]) m.transpose = Bool(n["transpose"], element);
  } else if (n["lever"]) {
    m.kind = Modulus::Kind::kLever;
    m.rotation = Qualify(prefix, Str(n["lever"], element));
    if (!n["r"]) sink_.Error(codes::kKeyMissing, Loc(n), element, "a lever modulus needs 'r', the point in the body frame", "add r: [x, y, z]");
    else {
      const Eigen::VectorXd r = Vector(n["r"], element, env);
      if (r.size() == 3) m.lever = r;
      else sink_.Error(codes::kParamShape, Loc(n["r"]), element, "r must have 3 components");
    }
  } else {
    sink_.Error(codes::kKeyMissing, Loc(n), element, "modulus needs one of 'rotation', 'lever' or 'matrix'");
  }
  if (m.left.size() > 0 && m.kind == Modulus::Kind::kConstant && m.left.cols() != m.constant.rows())
    sink_.Error(codes::kParamShape, Loc(n), element, "left matrix and modulus matrix do not fit together");
  if (m.left.size() > 0 && m.kind != Modulus::Kind::kConstant && m.left.cols() != 3)
    sink_.Error(codes::kParamShape, Loc(n), element, fmt::format("'left' must have 3 columns here (got {})", m.left.cols()));
  return m;
}

}  // namespace multibond
