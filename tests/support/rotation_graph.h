#pragma once
/// \file
/// A small graph with the state-dependent moduli of the rigid-body library: a body angular
/// velocity w (flow source) with orientation R; MTFs map it to R^T w (rotation) and to the
/// velocity of the body point r (lever arm); resistors absorb both. Shared by the tests of the
/// generated right-hand side and of the Jacobian pattern.

#include <Eigen/Geometry>

#include "multibond/core/graph.h"

namespace multibond {

inline Eigen::Matrix3d SomeRotation() {
  return (Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitX()) * Eigen::AngleAxisd(-1.1, Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(2.0, Eigen::Vector3d::UnitZ())).toRotationMatrix();
}

inline SourceValue Vec(double a, double b, double c) {
  return {{TimeFunction::Constant(a), TimeFunction::Constant(b), TimeFunction::Constant(c)}};
}

/// A body angular velocity w (flow source) with orientation R; MTFs map it to R^T w and to the
/// velocity of the body point r; resistors absorb both.
inline BondGraph RotationGraph(const Eigen::Matrix3d& r0, const Eigen::Vector3d& lever) {
  BondGraph g;
  g.AddSf("w", Vec(0.4, -1.5, 2.5), 3);
  g.AddJunction("wj", ElementKind::kOne);
  g.Connect("w", "wj");
  AuxState orient;
  orient.name = "R";
  orient.kind = AuxState::Kind::kOrientation;
  orient.of = "wj";
  orient.initial = r0;
  g.AddAux(orient);
  Modulus to_body;
  to_body.kind = Modulus::Kind::kRotation;
  to_body.rotation = "R";
  to_body.transpose = true;
  g.AddMTF("to_body", to_body);
  Modulus arm;
  arm.kind = Modulus::Kind::kLever;
  arm.rotation = "R";
  arm.lever = lever;
  g.AddMTF("arm", arm);
  g.AddJunction("wb", ElementKind::kOne);
  g.AddJunction("vq", ElementKind::kOne);
  g.AddR("rb", Param::Scalar(2.0), 3);
  g.AddR("rq", Param::Scalar(3.0), 3);
  g.Connect("wj", "to_body");
  g.Connect("to_body", "wb");
  g.Connect("wb", "rb");
  g.Connect("wj", "arm");
  g.Connect("arm", "vq");
  g.Connect("vq", "rq");
  return g;
}

}  // namespace multibond
