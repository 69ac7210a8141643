/// \file
/// A drive's expansion: a velocity drive on a coupling (or ideal), a torque or a force.

#include "multibond/mech/expander.h"

#include <cmath>

#include <fmt/format.h>

namespace multibond::mech::detail {

void Expander::AddDrive(const Drive& d) {
  switch (d.kind) {
    case Drive::Kind::kAngularVelocity:
    case Drive::Kind::kVelocity: {
      const bool angular = d.kind == Drive::Kind::kAngularVelocity;
      const std::string from = angular ? RelativeOmega(d.body, d.reference) : d.body + ".v";
      const std::string axis = d.name + ".axis", diff = d.name + ".diff";
      AddSpin(axis, angular ? d.reference : std::string(kGround), d.axis, 1.0);
      Bond(from, axis, d.name + ".in");
      if (IsGround(d.reference) || !angular) {
        auto& terms = angular ? info_[d.body].moment_terms : info_[d.body].force_terms;
        terms.push_back({d.name + ".in.e", -1.0});
      }
      Element src = Make(d.name + ".source", ElementKind::kSf, 1, angular ? "rotation" : "translation", d.where);
      src.source.components = {d.value};
      if (d.formula.given()) {
        src.source.components = {TimeFunction::Constant(0.0)};  // a placeholder: the formula is the value
        src.value = {d.formula};
      }
      if (d.rigid) {
        // An ideal drive: the source is an ideal constraint on the spin; its effort is the reaction.
        src.constraint = true;
        g_.Add(src);
        Bond(axis, d.name + ".source", d.name + ".source");
        OutputDecl o = SumOutput(d.name + (angular ? ".torque" : ".force"), {{d.name + ".source.e", -1.0}}, angular ? "N m" : "N", d.where);
        o.components.clear();
        AddOutput(o);
        break;
      }
      g_.AddJunction(diff, ElementKind::kZero, 1);
      Bond(axis, diff, d.name + ".spin");
      g_.Add(src);
      Bond(diff, d.name + ".source", d.name + ".source");
      AddCompliance(diff, d.name + ".coupling", Eigen::VectorXd::Constant(1, d.stiffness), Eigen::VectorXd::Constant(1, d.damping),
                    angular ? "rotation" : "translation", {}, d.where);
      // The coupling's effort tau acts on the body as -tau along the axis.
      OutputDecl o = SumOutput(d.name + (angular ? ".torque" : ".force"), {{diff + ".e", -1.0}}, angular ? "N m" : "N", d.where);
      o.components.clear();
      AddOutput(o);
      break;
    }
    case Drive::Kind::kTorque:
    case Drive::Kind::kForce: {
      const bool torque = d.kind == Drive::Kind::kTorque;
      Element src = Make(d.name + ".source", ElementKind::kSe, 3, torque ? "rotation" : "translation", d.where);
      const Eigen::Vector3d a = d.axis.normalized();
      for (int i = 0; i < 3; ++i) src.source.components.push_back(d.value.Scaled(a[i]));
      if (d.formula.given()) {
        // Component k is a[k] * formula; a component the axis does not reach is the constant 0.
        src.value.resize(3);
        for (int i = 0; i < 3; ++i) {
          src.source.components[i] = TimeFunction::Constant(0.0);
          if (a[i] == 0.0) continue;
          Formula& f = src.value[i];
          f = d.formula;
          if (a[i] != 1.0) f.root = expr::Binary(expr::Node::Kind::kMul, expr::Number(a[i]), d.formula.root);
        }
      }
      src.components = kXyz;
      g_.Add(src);
      if (torque) {
        Bond(d.name + ".source", d.body + ".omega", d.name + ".source");
      } else if (d.point.isZero()) {
        Bond(d.name + ".source", d.body + ".v", d.name + ".source");
      } else {
        const std::string at = d.name + ".at";
        g_.AddJunction(at, ElementKind::kZero, 3);
        Bond(d.name + ".source", at, d.name + ".source");
        Bond(at, d.body + ".v", d.name + ".v");
        AddLever(d.name + ".arm", d.body, d.point, -1.0, at);
        info_[d.body].moment_terms.pop_back();  // an applied force is no coupling
      }
      AddVariableOutput(d.name + (torque ? ".torque" : ".force"), d.name + ".source.e", "", d.where);
      break;
    }
  }
}

}  // namespace multibond::mech::detail
