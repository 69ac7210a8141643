#pragma once
/// \file
/// Assembly of a mechanism (docs/mechanisms.md, "Assembly"): initial positions, orientations and
/// velocities of the bodies that satisfy every joint, the gear meshes' rolling and the given
/// coordinates, as close as possible to what the model file says.
///
/// Position level: unknowns per body a displacement dr and a rotation vector dtheta (R = exp([dtheta x]) R0,
/// inertial frame). Constraints: each translation coupling's directions . (child point - parent
/// point) = 0 in its frame; each rotation coupling's directions . (the rotation vector of the
/// joint's relative rotation since the bodies as written) = 0; the given coordinates. Gauss-Newton
/// with minimum-norm steps: the given coordinates are held first (a minimum-norm step onto them),
/// the joints are solved in what they leave free (again minimum-norm), so the bodies move as little
/// as the joints allow. Velocity level: one linear least-squares problem of the same shape for
/// every body's v and omega: every coupling's rate zero, every gear mesh rolling
/// (teeth_a s_a + teeth_b s_b = 0), the given rates held, the change from the file's velocities minimal.

#include <string>
#include <vector>

#include <Eigen/Dense>

#include "multibond/core/error.h"
#include "multibond/mech/mechanism.h"

namespace multibond::mech {

/// What the model's `assembly` section asks for.
struct AssemblySpec {
  /// One given coordinate: held exactly by the assembly.
  struct Given {
    enum class Kind {
      kJointAngle,       ///< revolute: the turn about its axis from the bodies as written [rad]
      kJointRate,        ///< revolute: a . R_p^T (w_c - w_p) [rad/s]
      kJointSlide,       ///< prismatic: a . R_p^T (x_child point - x_parent point) [m]
      kJointSpeed,       ///< prismatic: (R_p a) . (v_child point - v_parent point) [m/s]
      kBodyPosition,     ///< the body's CoM [m] (vector)
      kBodyOrientation,  ///< the body's R (matrix)
      kBodyVelocity,     ///< the body's CoM velocity [m/s] (vector)
      kBodyOmega,        ///< the body's angular velocity [rad/s] (vector)
      kDriveSpeed,       ///< a velocity drive's speed about (along) its axis, relative to its reference
    };
    Kind kind = Kind::kJointAngle;
    std::string part;  ///< the joint, body or drive
    double value = 0.0;
    Eigen::Vector3d vector = Eigen::Vector3d::Zero();
    Eigen::Matrix3d matrix = Eigen::Matrix3d::Identity();
    SourceLocation where;
  };
  std::vector<Given> given;
  /// The largest violation of a joint or a given coordinate accepted [m, rad; m/s, rad/s].
  double tolerance = 1e-10;
  int max_iterations = 50;
  SourceLocation where;  ///< the 'assembly' key
};

/// What the assembly did.
struct AssemblyReport {
  struct Move {
    std::string body;
    double displacement = 0.0;  ///< |dr| [m]
    double rotation = 0.0;      ///< the angle of R R0^T [rad]
    double velocity = 0.0;      ///< |v - v0| [m/s]
    double omega = 0.0;         ///< |w - w0| [rad/s]
  };
  std::vector<Move> moves;  ///< one per body, in the mechanism's order
  int iterations = 0;       ///< Gauss-Newton iterations of the position level
  double position_residual = 0.0;  ///< the largest violation left [m or rad]
  double velocity_residual = 0.0;  ///< the largest violation left [m/s or rad/s]
  bool ok = false;
};

/// Assembles `m` in place (bodies' position, orientation, velocity, omega) and says in `sink` what
/// moved (a `mech.assembled` warning with one line per body that moved) or, when no assembly
/// satisfies the joints and the given coordinates to the tolerance, a `mech.assembly` error naming
/// the violated joint or the contradictory given coordinates, by how much. The mechanism's
/// references (bodies, joints, drives) must have been checked. Unchanged on error.
AssemblyReport Assemble(Mechanism& m, const AssemblySpec& spec, DiagnosticSink& sink);

}  // namespace multibond::mech
