/// \file
/// The contact geometry of a gear mesh through its pitch point.

#include <cmath>

#include <fmt/format.h>

#include "multibond/mech/expander.h"

namespace multibond::mech {

MeshGeometry Mechanism::GeometryOf(const GearMesh& gm) const {
  MeshGeometry out;
  auto find = [&](const std::string& n) -> const Body* {
    for (const Body& b : bodies_)
      if (b.name == n) return &b;
    return nullptr;
  };
  const Body* carrier = gm.carrier == kGround ? nullptr : find(gm.carrier);
  const Body* ga = find(gm.body_a);
  const Body* gb = find(gm.body_b);
  if (!ga || !gb || (gm.carrier != kGround && !carrier)) {
    out.error = "the mesh names a body that does not exist";
    return out;
  }
  // The gears' centres in the carrier's frame (its CoM the origin; the ground: absolute).
  auto local = [&](const Body* b) -> Eigen::Vector3d {
    return carrier ? Eigen::Vector3d(carrier->orientation.transpose() * (b->position - carrier->position)) : b->position;
  };
  const Eigen::Vector3d ca = local(ga), cb = local(gb);
  const Eigen::Vector3d a = gm.axis_a.normalized();
  const double scale = std::max({(cb - ca).norm(), gm.radius_a, 1e-3});
  const double tol = 1e-9 * scale;
  auto perp = [](const Eigen::Vector3d& v, const Eigen::Vector3d& axis) -> Eigen::Vector3d { return v - axis * axis.dot(v); };
  const Eigen::Vector3d b = gm.rack_b ? Eigen::Vector3d::Zero() : Eigen::Vector3d(gm.axis_b.normalized());
  const bool parallel = gm.rack_b || a.cross(b).norm() < 1e-9;
  Eigen::Vector3d line = a;  // the pitch element: along the axes, or from a bevel pair's apex
  Eigen::Vector3d p;
  if (gm.rack_b) {
    const Eigen::Vector3d u = perp(cb - ca, a);
    const double r = gm.radius_a;
    if (gm.pitch_point) {
      p = *gm.pitch_point;
    } else if (!(r > 0) || u.norm() < tol) {
      out.error = "a rack and pinion needs the pinion's pitch radius ('radius' of gear a) and the rack's centre off the pinion's axis";
      out.hint = "give a: {..., radius: r} (module x teeth / 2) or the mesh's 'pitch_point'";
      return out;
    } else {
      p = ca + r * u.normalized();
    }
  } else if (gm.pitch_point) {
    p = *gm.pitch_point;
    if (!parallel) {
      // The apex: where the axes meet (the point of a's axis closest to b's).
      const Eigen::Vector3d w = ca - cb;
      const double ab = a.dot(b), den = 1 - ab * ab;
      const double sa = (ab * b.dot(w) - a.dot(w)) / den;
      line = perp(p - (ca + sa * a), Eigen::Vector3d(a.cross(b).normalized()));
      if (line.norm() < tol) {
        out.error = "the pitch point is at the apex of the bevel pair";
        out.hint = "give a point on the pitch cones, away from where the axes meet";
        return out;
      }
      line.normalize();
    }
  } else if (parallel) {
    const Eigen::Vector3d d = perp(cb - ca, a);
    const double dist = d.norm();
    if (dist < tol) {
      out.error = "the gears' centres are on one axis: there is no pitch point between them";
      out.hint = "place the gears' centres one centre distance apart, or give the mesh's 'pitch_point'";
      return out;
    }
    const Eigen::Vector3d u = d / dist;  // from a's axis towards b's
    if (!gm.internal) {
      p = ca + dist * gm.teeth_a / (gm.teeth_a + gm.teeth_b) * u;
    } else if (gm.teeth_a == gm.teeth_b) {
      out.error = "an internal mesh needs a ring with more teeth than its pinion";
      out.hint = "check the teeth (the ring's count is the larger)";
      return out;
    } else if (gm.teeth_a > gm.teeth_b) {
      p = ca + dist * gm.teeth_a / (gm.teeth_a - gm.teeth_b) * u;  // a is the ring: beyond the pinion
    } else {
      p = cb - dist * gm.teeth_b / (gm.teeth_b - gm.teeth_a) * u;  // b is the ring
    }
  } else {
    // Bevel: the point where both gears' mid-planes meet the plane of the axes.
    const Eigen::Vector3d nrm = a.cross(b).normalized();
    const Eigen::Vector3d w = ca - cb;
    const double ab = a.dot(b), den = 1 - ab * ab;
    const double sa = (ab * b.dot(w) - a.dot(w)) / den, sb = (b.dot(w) - ab * a.dot(w)) / den;
    const Eigen::Vector3d apex_a = ca + sa * a, apex_b = cb + sb * b;
    if ((apex_a - apex_b).norm() > 1e-6 * scale) {
      out.error = fmt::format("the gears' axes do not meet (they pass {:.3g} m apart): a bevel pair's axes intersect", (apex_a - apex_b).norm());
      out.hint = "check the gears' positions and axes (crossed and worm gears are not modelled)";
      return out;
    }
    Eigen::Matrix3d m;
    m.row(0) = a.transpose();
    m.row(1) = b.transpose();
    m.row(2) = nrm.transpose();
    p = m.fullPivLu().solve(Eigen::Vector3d(a.dot(ca), b.dot(cb), nrm.dot(ca)));
    line = p - apex_a;
    if (line.norm() < tol) {
      out.error = "the gears' mid-planes meet at the apex of the bevel pair";
      out.hint = "place each bevel gear's centre at its mean pitch circle, or give the mesh's 'pitch_point'";
      return out;
    }
    line.normalize();
  }
  out.point = p;
  out.rho_a = p - ca;
  out.rho_b = p - cb;
  // A gear's pitch radius and the unit vector from its axis to P; false if P is on the axis.
  auto radial = [&](const Eigen::Vector3d& rho, const Eigen::Vector3d& axis, const char* gear, double* r, Eigen::Vector3d* unit) {
    const Eigen::Vector3d v = perp(rho, axis);
    *r = v.norm();
    if (*r < tol) {
      out.error = fmt::format("the pitch point is on gear {}'s axis", gear);
      out.hint = "check the gears' positions, or the mesh's 'pitch_point'";
      return false;
    }
    *unit = v / *r;
    return true;
  };
  if (!radial(out.rho_a, a, "a", &out.r_a, &out.radial_a)) return out;
  out.t = a.cross(out.radial_a);
  // The line of action: F_t along t, F_t tan(helix) along a's axis, F_t tan(pressure) / cos(helix)
  // along s, apart (the drive flank) or, for the coast flank, together.
  auto line_of_action = [&] {
    const double cp = std::cos(gm.pressure_angle), sp = std::sin(gm.pressure_angle);
    const double flank = gm.coast_flank ? -1.0 : 1.0;
    out.n = std::cos(gm.helix_angle) * cp * out.t + std::sin(gm.helix_angle) * cp * a + flank * sp * out.s;
  };
  if (gm.rack_b) {
    out.s = out.radial_a;  // the separating force pushes the rack away from the pinion
    line_of_action();
    return out;
  }
  if (!radial(out.rho_b, b, "b", &out.r_b, &out.radial_b)) return out;
  // Rolling: r_a w_a.a + r_b w_b.b = 0 (teeth_a s_a + teeth_b s_b = 0) means b's axis is t x radial_b.
  const Eigen::Vector3d b_expected = out.t.cross(out.radial_b);
  if (std::abs(out.t.dot(b)) > 1e-6 || b.dot(b_expected) < 1 - 1e-6) {
    auto vec = [](const Eigen::Vector3d& v) {
      auto c = [](double x) { return std::abs(x) < 5e-13 ? 0.0 : x; };
      return fmt::format("[{:.6g}, {:.6g}, {:.6g}]", c(v.x()), c(v.y()), c(v.z()));
    };
    out.error = fmt::format(
        "gear b's axis {} does not roll with gear a's: at the pitch point {} (carrier frame) the teeth roll without slip when "
        "teeth_a s_a + teeth_b s_b = 0 with b's axis {}",
        vec(b), vec(p), vec(b_expected));
    out.hint = fmt::format("write b's axis as {} (external spur: the same as a's; internal: the opposite)", vec(b_expected));
    return out;
  }
  if (std::abs(out.r_b / out.r_a - gm.teeth_b / gm.teeth_a) > 1e-6 * gm.teeth_b / gm.teeth_a) {
    out.error = fmt::format("the pitch radii {:.6g} m (a) and {:.6g} m (b) are not in the ratio of the teeth {:g}:{:g}", out.r_a, out.r_b,
                            gm.teeth_a, gm.teeth_b);
    out.hint = "place the gears so that their pitch circles touch (radius = module x teeth / 2), or check the teeth";
    return out;
  }
  if (!parallel && gm.helix_angle != 0.0) {
    out.error = "a helix angle is modelled for parallel axes (helical gears and racks), not for bevel gears";
    out.hint = "remove 'helix_angle_deg' (straight bevel gears)";
    return out;
  }
  // The separating force on b: perpendicular to t and to the pitch element, into b (out of a ring b).
  const bool b_ring = gm.internal && gm.teeth_b > gm.teeth_a;
  const Eigen::Vector3d v = perp(perp(out.rho_b, out.t), line);
  out.s = v.norm() > tol ? Eigen::Vector3d((b_ring ? 1.0 : -1.0) * v.normalized()) : Eigen::Vector3d::Zero();
  line_of_action();
  return out;
}

}  // namespace multibond::mech
