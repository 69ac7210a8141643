/// \file
/// The junction structures shared by joints, gears and drives: relative angular velocity, frame
/// TF/MTFs, lever arms and the compliant (or rigid) C and R of a coupling.

#include "multibond/mech/expander.h"

#include <cmath>

#include <fmt/format.h>

namespace multibond::mech::detail {

std::string Expander::RelativeOmega(const std::string& child, const std::string& parent) {
  if (IsGround(parent)) return child + ".omega";
  const std::string key = child + "~" + parent;
  if (relative_.count(key)) return relative_[key];
  const std::string diff = key + ".w_diff", rel = key + ".w";
  g_.AddJunction(diff, ElementKind::kZero, 3);
  Element r = Make(rel, ElementKind::kOne, 3, "rotation", {});
  r.components = kXyz;
  g_.Add(r);
  Bond(child + ".omega", diff, key + ".child");
  Bond(diff, parent + ".omega", key + ".parent");
  Bond(diff, rel, key + ".rel");
  info_[child].moment_terms.push_back({key + ".child.e", -1.0});
  info_[parent].moment_terms.push_back({key + ".parent.e", +1.0});
  relative_[key] = rel;
  return rel;
}

void Expander::AddFrameElement(const std::string& name, Coupling::Frame frame, const std::string& parent, const std::string& child,
                     const Eigen::MatrixXd& rows, const SourceLocation& where) {
  const std::string body = frame == Coupling::Frame::kChild ? child : parent;
  if (frame == Coupling::Frame::kWorld || IsGround(body)) {
    Element tf = Make(name, ElementKind::kTF, 0, "", where);
    tf.param = Param::Matrix(rows);
    g_.Add(tf);
    return;
  }
  Modulus m;
  m.kind = Modulus::Kind::kRotation;
  m.rotation = body + ".R";
  m.transpose = true;
  // (sizes first: comparing matrices of different sizes is undefined in Eigen's release builds)
  const bool identity = rows.rows() == 3 && rows.cols() == 3 && rows == Eigen::MatrixXd::Identity(3, 3);
  if (!identity) m.left = rows;
  Element mtf = Make(name, ElementKind::kMTF, 0, "", where);
  mtf.modulus = m;
  g_.Add(mtf);
}

void Expander::AddCompliance(const std::string& from, const std::string& name, const Eigen::VectorXd& k, const Eigen::VectorXd& r,
                   const std::string& domain, const std::vector<std::string>& comps, const SourceLocation& where,
                   bool rigid) {
  const int n = static_cast<int>(k.size());
  Element j = Make(name, ElementKind::kOne, n, domain, where);
  j.components = comps;
  g_.Add(j);
  if (rigid) {
    Element c = Make(name + ".rigid", ElementKind::kSf, n, domain, where);
    c.source.components = {TimeFunction::Constant(0.0)};
    c.constraint = true;
    c.components = comps;
    // The stiffness it stands for, if given, shares a redundant reaction as the compliant
    // coupling would (CompiledModel::ShareRedundantEfforts).
    if (n > 0 && k.size() == n && (k.array() > 0.0).all() && k.allFinite()) c.compliance = k.cwiseInverse();
    g_.Add(c);
    Bond(from, name, name + ".in");
    Bond(name + ".rigid", name, name + ".rigid");
    return;
  }
  Element c = Make(name + ".K", ElementKind::kC, n, domain, where);
  c.param = n == 1 ? Param::Scalar(k[0]) : Param::Matrix(k.asDiagonal());
  c.components = comps;
  g_.Add(c);
  Element d = Make(name + ".R", ElementKind::kR, n, domain, where);
  d.param = n == 1 ? Param::Scalar(r[0]) : Param::Matrix(r.asDiagonal());
  d.components = comps;
  g_.Add(d);
  Bond(from, name, name + ".in");
  Bond(name, name + ".K", name + ".K");
  Bond(name, name + ".R", name + ".R");
}

std::vector<std::string> Expander::DirectionNames(const Coupling& c) {
  if (!c.components.empty()) return c.components;
  const int k = static_cast<int>(c.directions.rows());
  if (k == 1) return {};
  std::vector<std::string> out;
  for (int i = 0; i < k; ++i) {
    int axis = -1;
    for (int a = 0; a < 3; ++a)
      if (c.directions.row(i).isApprox(Eigen::RowVector3d::Unit(a))) axis = a;
    out.push_back(axis >= 0 ? kXyz[axis] : std::to_string(i + 1));
  }
  return out;
}

void Expander::AddLever(const std::string& name, const std::string& body, const Eigen::Vector3d& point, double scale,
              const std::string& sum) {
  Modulus m;
  m.kind = Modulus::Kind::kLever;
  m.rotation = body + ".R";
  m.lever = point;
  m.scale = scale;
  Element e = Make(name, ElementKind::kMTF, 0, "", {});
  e.modulus = m;
  g_.Add(e);
  Bond(body + ".omega", name, name + ".w");
  Bond(name, sum, name + ".v");
  info_[body].moment_terms.push_back({name + ".w.e", -1.0});
}

}  // namespace multibond::mech::detail
