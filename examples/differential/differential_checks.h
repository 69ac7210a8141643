#pragma once
// The validation of the paper's differential (docs/differential.md): the values
// any correct implementation shows after the start transient, computed from a run's results and
// compared with the spec's analytic values. Used by the report the README's main command prints
// and by tests/physics/differential_test.cc, so that what is printed is what is tested.

#include <cmath>
#include <numbers>
#include <string>
#include <vector>

#include <Eigen/Dense>
#include <fmt/format.h>

#include "multibond/io/results_reader.h"

namespace differential {

struct Check {
  std::string what;
  double value;
  double expected;
  double tolerance;  ///< on |value - expected|
  std::string unit;
  bool ok() const { return std::abs(value - expected) <= tolerance; }
};

// Table I and the spec: planets are discs of 2700 kg/m3, d = 0.1 m, t = 0.01 m.
inline double PlanetMass() { return 2700 * std::numbers::pi * 0.05 * 0.05 * 0.01; }
inline double PlanetAxialInertia() { return PlanetMass() * 0.05 * 0.05 / 2; }

inline Eigen::Vector3d Vec(const multibond::ResultsTable& t, size_t row, const std::string& name) {
  return {t.At(row, name + ".x"), t.At(row, name + ".y"), t.At(row, name + ".z")};
}

inline Eigen::Matrix3d Rot(const multibond::ResultsTable& t, size_t row, const std::string& body) {
  Eigen::Matrix3d r;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) r(i, j) = t.At(row, fmt::format("{}.R.{}{}", body, i + 1, j + 1));
  return r;
}

/// Every check of docs/differential.md at the last row (t = 5 s), plus the whole-run ones.
inline std::vector<Check> Checks(const multibond::ResultsTable& t) {
  std::vector<Check> c;
  const size_t last = t.rows.size() - 1;
  const double w_g = t.Last("G.omega.x"), w_a = t.Last("A.omega.z"), w_s1 = t.Last("S1.omega.z"), w_s2 = t.Last("S2.omega.z");
  c.push_back({"w_G about x", w_g, 50.0, 1e-6 * 50, "rad/s"});
  c.push_back({"w_A about z", w_a, -12.5, 1e-6 * 12.5, "rad/s"});
  c.push_back({"w_S1 about z (held)", w_s1, 0.0, 1e-6, "rad/s"});
  c.push_back({"w_S2 about z", w_s2, -25.0, 1e-6 * 25, "rad/s"});
  c.push_back({"Willis w_S1 + w_S2 - 2 w_A", w_s1 + w_s2 - 2 * w_a, 0.0, 1e-6, "rad/s"});
  const Eigen::Matrix3d ra = Rot(t, last, "A");
  const Eigen::Vector3d axis = ra.col(2), centre_a = Vec(t, last, "A.r"), w_a_vec = Vec(t, last, "A.omega");
  const char* planets[] = {"P1", "P2"};
  const double outward[] = {1.0, -1.0};  // P1 sits on +x of A, P2 on -x
  for (int k = 0; k < 2; ++k) {
    const std::string p = planets[k];
    const double spin = (Vec(t, last, p + ".omega") - w_a_vec).dot(outward[k] * ra.col(0));
    c.push_back({p + " spin relative to A", spin, 25.0, 1e-6 * 25, "rad/s"});
    // Centripetal bearing force m w_A^2 rho, pointing at A's axis.
    const Eigen::Vector3d pc = Vec(t, last, p + ".r");
    const Eigen::Vector3d foot = centre_a + axis * axis.dot(pc - centre_a);
    const double rho = (pc - foot).norm();
    const Eigen::Vector3d f = Vec(t, last, p + "_bearing.F");
    const double f_expected = PlanetMass() * w_a * w_a * rho;
    c.push_back({p + " bearing force |F| (m w_A^2 rho)", f.norm(), f_expected, 1e-4 * f_expected, "N"});
    c.push_back({p + " bearing force direction (1 - cos to the axis)", 1.0 - f.normalized().dot((foot - pc).normalized()), 0.0, 1e-4, "-"});
    // Gyroscopic bearing moment I_axial s w_A.
    const double m_expected = PlanetAxialInertia() * 25.0 * 12.5;
    c.push_back({p + " bearing moment |M| (I_axial s w_A)", Vec(t, last, p + "_bearing.M").norm(), m_expected, 1e-3 * m_expected, "N m"});
    // Over the last second: the centre on a circle of radius rho about A's axis, at A's rate.
    double rmin = 1e9, rmax = 0;
    const size_t from = t.rows.size() * 4 / 5;
    double turned = 0, prev = 0;
    for (size_t row = from; row < t.rows.size(); ++row) {
      const Eigen::Matrix3d r_a = Rot(t, row, "A");
      const Eigen::Vector3d ca = Vec(t, row, "A.r"), ax = r_a.col(2), pr = Vec(t, row, p + ".r");
      const Eigen::Vector3d radial = pr - ca - ax * ax.dot(pr - ca);
      rmin = std::min(rmin, radial.norm());
      rmax = std::max(rmax, radial.norm());
      const double angle = std::atan2(radial.y(), radial.x());
      if (row > from) turned += std::remainder(angle - prev, 2 * std::numbers::pi);
      prev = angle;
    }
    const double seconds = t.rows.back()[0] - t.rows[from][0];
    c.push_back({p + " centre: circle radius spread", rmax - rmin, 0.0, 1e-6, "m"});
    c.push_back({p + " centre: period (2 pi / 12.5)", 2 * std::numbers::pi * seconds / std::abs(turned), 2 * std::numbers::pi / 12.5,
                 1e-6 * 2 * std::numbers::pi / 12.5, "s"});
  }
  for (const char* b : {"G", "A", "S1", "S2"}) {
    const Eigen::Vector3d moved = Vec(t, last, std::string(b) + ".r") - Vec(t, 0, std::string(b) + ".r");
    c.push_back({std::string(b) + " centre of mass stays put", moved.norm(), 0.0, 1e-5, "m"});
  }
  double worst_orth = 0, worst_res = 0;
  for (size_t row = 0; row < t.rows.size(); ++row) {
    for (const char* b : {"H", "G", "A", "P1", "P2", "S1", "S2"})
      worst_orth = std::max(worst_orth, t.At(row, std::string(b) + ".orthonormality"));
    if (t.rows[row][0] >= 0.5) worst_res = std::max(worst_res, std::abs(t.At(row, "energy.residual")));
  }
  c.push_back({"energy residual at t_end", t.Last("energy.residual"), 0.0, 1e-6, "-"});
  c.push_back({"energy residual, worst after 0.5 s", worst_res, 0.0, 1e-6, "-"});
  c.push_back({"max |R^T R - I| over the run", worst_orth, 0.0, 1e-9, "-"});
  return c;
}

}  // namespace differential
