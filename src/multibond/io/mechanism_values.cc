#include "multibond/io/mechanism_values.h"

#include <cmath>
#include <numbers>

#include <Eigen/Geometry>
#include <fmt/format.h>

#include "multibond/core/diagnostic_codes.h"
#include "multibond/io/did_you_mean.h"

namespace multibond {

Eigen::Vector3d MechanismValues::Vec3(const YAML::Node& n, const std::string& element) {
  const Eigen::VectorXd v = Vector(n, element, Env{});
  if (v.size() != 3) {
    sink_.Error(codes::kYamlStructure, Loc(n), element, fmt::format("expected 3 numbers, got {}", v.size()), "write e.g. [0, 0, 1]");
    return Eigen::Vector3d::Zero();
  }
  return v;
}

/// "x", "-z" or a 3-vector (normalised).
Eigen::Vector3d MechanismValues::Axis(const YAML::Node& n, const std::string& element) {
  if (n.IsScalar()) {
    std::string s = n.Scalar();
    double sign = 1.0;
    if (!s.empty() && (s[0] == '-' || s[0] == '+')) {
      sign = s[0] == '-' ? -1.0 : 1.0;
      s = s.substr(1);
    }
    if (s == "x") return sign * Eigen::Vector3d::UnitX();
    if (s == "y") return sign * Eigen::Vector3d::UnitY();
    if (s == "z") return sign * Eigen::Vector3d::UnitZ();
    sink_.Error(codes::kValueUnknown, Loc(n), element, fmt::format("unknown axis '{}'", n.Scalar()), "write x, y, z, -x, ... or a vector [ax, ay, az]");
    return Eigen::Vector3d::UnitX();
  }
  const Eigen::Vector3d v = Vec3(n, element);
  if (v.norm() < 1e-12) {
    sink_.Error(codes::kParamRange, Loc(n), element, "an axis must be a non-zero vector");
    return Eigen::Vector3d::UnitX();
  }
  return v.normalized();
}

/// Rows of unit vectors: "all", a list of axes, or a matrix.
Eigen::MatrixXd MechanismValues::Directions(const YAML::Node& n, const std::string& element, std::vector<std::string>* names) {
  if (n.IsScalar() && n.Scalar() == "all") {
    *names = {"x", "y", "z"};
    return Eigen::Matrix3d::Identity();
  }
  if (!n.IsSequence() || n.size() == 0 || n.size() > 3) {
    sink_.Error(codes::kYamlStructure, Loc(n), element, "directions are 'all' or a list of 1 to 3 axes", "write e.g. axes: [y, z]");
    return Eigen::Matrix3d::Identity();
  }
  Eigen::MatrixXd rows(static_cast<Eigen::Index>(n.size()), 3);
  bool named = true;
  for (size_t i = 0; i < n.size(); ++i) {
    rows.row(static_cast<Eigen::Index>(i)) = Axis(n[i], element).transpose();
    named = named && n[i].IsScalar();
    if (n[i].IsScalar()) names->push_back(n[i].Scalar()[0] == '-' ? n[i].Scalar().substr(1) : n[i].Scalar());
  }
  if (!named) names->clear();
  return rows;
}

Eigen::Matrix3d MechanismValues::Orientation(const YAML::Node& n, const std::string& element) {
  if (n.IsMap()) {
    CheckKeys(n, {"axis", "angle", "degrees"}, element);
    if (!n["axis"] || (!n["angle"] && !n["degrees"])) {
      sink_.Error(codes::kYamlStructure, Loc(n), element, "an orientation is a 3x3 matrix or {axis: ..., angle: radians | degrees: ...}");
      return Eigen::Matrix3d::Identity();
    }
    const double angle = n["angle"] ? Number(n["angle"], element, Env{}) : Number(n["degrees"], element, Env{}) * std::numbers::pi / 180.0;
    return Eigen::AngleAxisd(angle, Axis(n["axis"], element)).toRotationMatrix();
  }
  const Eigen::MatrixXd m = Matrix(n, element, Env{});
  if (m.rows() != 3 || m.cols() != 3) {
    sink_.Error(codes::kYamlStructure, Loc(n), element, "an orientation matrix is 3x3");
    return Eigen::Matrix3d::Identity();
  }
  return m;
}

/// K (required unless `rigid`) and R of a coupling, one value or one per direction.
void MechanismValues::Gains(const YAML::Node& n, const std::string& element, int k, Eigen::VectorXd* stiff, Eigen::VectorXd* damp,
                            bool rigid) {
  auto read = [&](const char* a, const char* b, Eigen::VectorXd* out, bool required) {
    const YAML::Node v = n[a] ? n[a] : n[b];
    if (!v) {
      if (required) sink_.Error(codes::kKeyMissing, Loc(n), element, fmt::format("coupling needs '{}' (or '{}')", a, b), "e.g. {K: 1.0e6, R: 20}");
      *out = Eigen::VectorXd::Zero(k);
      return;
    }
    const Eigen::VectorXd x = Vector(v, element, Env{});
    if (x.size() == 1) *out = Eigen::VectorXd::Constant(k, x[0]);
    else if (x.size() == k) *out = x;
    else {
      sink_.Error(codes::kParamShape, Loc(v), element, fmt::format("give one value or {} (one per direction), got {}", k, x.size()));
      *out = Eigen::VectorXd::Constant(k, 1.0);
    }
  };
  read("K", "stiffness", stiff, !rigid);
  read("R", "damping", damp, false);
}

mech::Coupling::Frame MechanismValues::Frame(const YAML::Node& n, const std::string& element, mech::Coupling::Frame dflt) {
  if (!n) return dflt;
  const std::string f = n.Scalar();
  if (f == "world") return mech::Coupling::Frame::kWorld;
  if (f == "parent") return mech::Coupling::Frame::kParent;
  if (f == "child") return mech::Coupling::Frame::kChild;
  sink_.Error(codes::kValueUnknown, Loc(n), element, fmt::format("unknown frame '{}'", f), "use world, parent or child");
  return dflt;
}

/// A coupling section: {K, R, directions|axes, frame}. `fixed_rows` (named kinds) gives the
/// directions; otherwise they are read (default: all three).
std::optional<mech::Coupling> MechanismValues::ReadCoupling(const YAML::Node& n, const std::string& element, const char* what,
                                                            const Eigen::MatrixXd* fixed_rows, mech::Coupling::Frame frame) {
  if (!n) return std::nullopt;
  if (!n.IsMap()) {
    sink_.Error(codes::kYamlStructure, Loc(n), element, fmt::format("'{}' is a mapping like {{K: 1.0e6, R: 20}}", what));
    return std::nullopt;
  }
  mech::Coupling c;
  std::vector<std::string> keys = {"K", "R", "stiffness", "damping", "rigid"};
  if (!fixed_rows) keys.insert(keys.end(), {"directions", "axes", "frame"});
  CheckKeys(n, keys, element);
  if (fixed_rows) {
    c.directions = *fixed_rows;
  } else {
    const YAML::Node d = n["directions"] ? n["directions"] : n["axes"];
    c.directions = d ? Directions(d, element, &c.components) : Eigen::MatrixXd(Eigen::Matrix3d::Identity());
    if (!d) c.components = {"x", "y", "z"};
    frame = Frame(n["frame"], element, frame);
  }
  if (fixed_rows && c.directions.rows() == 3 && c.directions.cols() == 3 && c.directions == Eigen::MatrixXd::Identity(3, 3))
    c.components = {"x", "y", "z"};
  c.frame = frame;
  c.rigid = (n["rigid"] && Bool(n["rigid"], element)) || rigid_joint_;
  // A rigid coupling's K and R, if given, are the compliant variant's: R is unused, K only
  // decides how redundant constraints share a load (CompiledModel::ShareRedundantEfforts).
  Gains(n, element, static_cast<int>(c.directions.rows()), &c.stiffness, &c.damping, c.rigid);
  if (c.rigid) c.damping = Eigen::VectorXd::Zero(c.directions.rows());
  return c;
}

mech::MassProperties MechanismValues::Mass(const YAML::Node& b, const std::string& name) {
  if (b["shape"]) {
    const YAML::Node sh = b["shape"];
    for (const char* key : {"mass", "inertia"})
      if (b[key])
        sink_.Error(codes::kKeyConflict, Loc(b[key]), name, fmt::format("a body with a shape takes its {} from the shape and density", key),
                    fmt::format("give either shape and density, or mass and inertia: remove '{}' or 'shape'", key));
    if (!b["density"]) sink_.Error(codes::kKeyMissing, Loc(sh), name, "a shape needs a 'density' [kg/m^3]");
    const double rho = b["density"] ? Number(b["density"], name, Env{}) : 1.0;
    if (!(rho > 0)) sink_.Error(codes::kParamRange, Loc(b["density"]), name, fmt::format("density must be > 0 (got {:g})", rho));
    if (!sh.IsMap() || sh.size() != 1) {
      sink_.Error(codes::kYamlStructure, Loc(sh), name, "shape is one of {disc: ...}, {cylinder: ...}, {box: ...}, {sphere: ...}");
      return mech::MassProperties::PointMass(1.0);
    }
    const std::string kind = sh.begin()->first.Scalar();
    const YAML::Node p = sh.begin()->second;
    if (!p.IsMap()) {
      sink_.Error(codes::kYamlStructure, Loc(p), name, fmt::format("the {} needs its dimensions as a mapping", kind),
                  "write e.g. shape: {disc: {diameter: 0.1, thickness: 0.01, axis: z}}");
      return mech::MassProperties::PointMass(1.0);
    }
    auto num = [&](const char* key) {
      if (!p[key]) {
        sink_.Error(codes::kKeyMissing, Loc(p), name, fmt::format("{} needs '{}'", kind, key));
        return 1.0;
      }
      const double v = Number(p[key], name, Env{});
      if (!(v > 0)) sink_.Error(codes::kParamRange, Loc(p[key]), name, fmt::format("{} must be > 0 (got {:g})", key, v));
      return v;
    };
    auto axis_index = [&]() {
      if (!p["axis"]) return 2;
      const Eigen::Vector3d a = Axis(p["axis"], name);
      int k = 0;
      for (int i = 1; i < 3; ++i)
        if (std::abs(a[i]) > std::abs(a[k])) k = i;
      if (std::abs(std::abs(a[k]) - 1.0) > 1e-12) sink_.Error(codes::kValueUnknown, Loc(p["axis"]), name, "a shape's axis is x, y or z");
      return k;
    };
    if (kind == "disc" || kind == "cylinder") {
      CheckKeys(p, {"diameter", "thickness", "length", "axis"}, name);
      const double len = kind == "disc" ? num("thickness") : num("length");
      return mech::MassProperties::Cylinder(rho, num("diameter"), len, axis_index());
    }
    if (kind == "box") {
      CheckKeys(p, {"size"}, name);
      return mech::MassProperties::Box(rho, p["size"] ? Vec3(p["size"], name) : Eigen::Vector3d::Ones());
    }
    if (kind == "sphere") {
      CheckKeys(p, {"diameter"}, name);
      return mech::MassProperties::Sphere(rho, num("diameter"));
    }
    const std::string guess = DidYouMean(kind, {"disc", "cylinder", "box", "sphere"});
    sink_.Error(codes::kValueUnknown, Loc(sh.begin()->first), name, fmt::format("unknown shape '{}'", kind),
                guess.empty() ? "use disc, cylinder, box or sphere" : fmt::format("did you mean '{}'?", guess));
    return mech::MassProperties::PointMass(1.0);
  }
  if (!b["mass"]) {
    sink_.Error(codes::kKeyMissing, Loc(b), name, "a body needs a 'shape' and 'density', or a 'mass' (and 'inertia')");
    return mech::MassProperties::PointMass(1.0);
  }
  const double m = Number(b["mass"], name, Env{});
  if (!b["inertia"]) return mech::MassProperties::PointMass(m);
  const Param ip = ReadParam(b["inertia"], name, Env{});
  Eigen::Matrix3d inertia = Eigen::Matrix3d::Identity();
  if (ip.is_scalar) inertia *= ip.scalar;
  else if (ip.matrix.rows() == 3 && ip.matrix.cols() == 3) inertia = ip.matrix;
  else sink_.Error(codes::kYamlStructure, Loc(b["inertia"]), name, "inertia is a number, 3 principal moments or a 3x3 matrix");
  // A zero tensor would make a point mass and drop the body's rotation (and its omega columns) silently.
  if (inertia.isZero(0.0))
    sink_.Error(codes::kParamRange, Loc(b["inertia"]), name, "inertia must be positive definite (got 0)", "leave 'inertia' out for a point mass");
  return mech::MassProperties::Given(m, inertia);
}

}  // namespace multibond
