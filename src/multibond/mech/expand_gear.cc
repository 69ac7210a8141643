/// \file
/// A gear mesh's expansion: a torque between the spins, or a force through the pitch point.

#include "multibond/mech/expander.h"

#include <cmath>

#include <fmt/format.h>

namespace multibond::mech::detail {

void Expander::AddSpin(const std::string& name, const std::string& frame_body, const Eigen::Vector3d& axis, double scale) {
  const Eigen::MatrixXd row = scale * axis.normalized().transpose();
  if (IsGround(frame_body)) {
    Element tf = Make(name, ElementKind::kTF, 0, "", {});
    tf.param = Param::Matrix(row);
    g_.Add(tf);
    return;
  }
  Modulus m;
  m.kind = Modulus::Kind::kRotation;
  m.rotation = frame_body + ".R";
  m.transpose = true;
  m.left = row;
  Element mtf = Make(name, ElementKind::kMTF, 0, "", {});
  mtf.modulus = m;
  g_.Add(mtf);
}

void Expander::AddContactLever(const std::string& name, const std::string& body, const std::string& carrier, const Eigen::Vector3d& rho,
                     double scale, const std::string& sum) {
  Element e;
  if (IsGround(carrier)) {
    Eigen::Matrix3d skew;
    skew << 0, -rho.z(), rho.y(), rho.z(), 0, -rho.x(), -rho.y(), rho.x(), 0;
    e = Make(name, ElementKind::kTF, 0, "", {});
    e.param = Param::Matrix(-scale * skew);
  } else {
    Modulus m;
    m.kind = Modulus::Kind::kLever;
    m.rotation = carrier + ".R";
    m.lever = rho;
    m.scale = scale;
    e = Make(name, ElementKind::kMTF, 0, "", {});
    e.modulus = m;
  }
  g_.Add(e);
  Bond(body + ".omega", name, name + ".w");
  Bond(name, sum, name + ".v");
  info_[body].moment_terms.push_back({name + ".w.e", -1.0});
}

void Expander::AddPitchVelocities(const std::string& sum, const GearMesh& gm, const MeshGeometry& geo, const std::string& tag) {
  g_.AddJunction(sum, ElementKind::kZero, 3);
  Bond(gm.body_a + ".v", sum, sum + ".a");
  info_[gm.body_a].force_terms.push_back({sum + ".a.e", -1.0});
  if (FindBody(gm.body_a)->mass.has_rotation()) AddContactLever(gm.name + ".a_arm" + tag, gm.body_a, gm.carrier, geo.rho_a, +1.0, sum);
  Bond(sum, gm.body_b + ".v", sum + ".b");
  info_[gm.body_b].force_terms.push_back({sum + ".b.e", +1.0});
  if (FindBody(gm.body_b)->mass.has_rotation()) AddContactLever(gm.name + ".b_arm" + tag, gm.body_b, gm.carrier, geo.rho_b, -1.0, sum);
}

void Expander::AddPitchGear(const GearMesh& gm) {
  const MeshGeometry& geo = geometry_.at(gm.name);
  const std::string vp = gm.name + ".vp", line = gm.name + ".line";
  AddPitchVelocities(vp, gm, geo, "");
  AddFrameElement(line, Coupling::Frame::kParent, gm.carrier, gm.carrier, geo.n.transpose(), gm.where);
  Bond(vp, line, line);
  const double tangential = std::cos(gm.helix_angle) * std::cos(gm.pressure_angle);  // F_t per unit F_n
  const double arm = geo.r_a * tangential;  // torque on a per unit normal force
  const double k = gm.stiffness / (arm * arm), r = gm.damping / (arm * arm);
  const std::string mesh = gm.name + ".mesh";
  if (gm.backlash > 0.0 && gm.rigid) {
    AddBacklashContacts(line, gm, arm, "translation");
  } else {
    AddCompliance(line, mesh, Eigen::VectorXd::Constant(1, k), Eigen::VectorXd::Constant(1, r), "translation", {}, gm.where, gm.rigid);
    if (gm.backlash > 0.0) {
      Element& spring = g_.element(g_.Find(mesh + ".K"));
      const double h = gm.backlash / 2 * arm;
      spring.law_effort = LawOf(fmt::format("{:.17g}*(q - clamp(q, {:.17g}, {:.17g}))", k, -h, h), gm.where);
    }
  }
  const std::string f = mesh + ".in.e";  // the normal force on b along n (on a its opposite): the bond into the coupling
  auto scalar = [&](const std::string& name, double c, const char* unit) {
    OutputDecl o = SumOutput(gm.name + "." + name, {{f, c}}, unit, gm.where);
    o.components.clear();
    AddOutput(o);
  };
  const Eigen::Vector3d a = gm.axis_a.normalized();
  scalar("torque", arm, "N m");
  scalar("F_t", tangential, "N");
  scalar("F_n", 1.0, "N");
  scalar("F_r", geo.radial_a.dot(geo.n), "N");  // pushes a towards its axis
  scalar("F_a", -a.dot(geo.n), "N");            // on a, along a's axis
  if (!gm.rack_b) {
    scalar("b.F_r", -geo.radial_b.dot(geo.n), "N");
    scalar("b.F_a", gm.axis_b.normalized().dot(geo.n), "N");
  }
}

void Expander::AddGear(const GearMesh& gm) {
  if (gm.contact == GearMesh::Contact::kPitch) {
    AddPitchGear(gm);
    return;
  }
  const std::string sum = gm.name + ".sum";
  g_.AddJunction(sum, ElementKind::kZero, 1);
  const std::pair<const std::string*, std::pair<Eigen::Vector3d, double>> sides[] = {
      {&gm.body_a, {gm.axis_a, 1.0}}, {&gm.body_b, {gm.axis_b, gm.teeth_b / gm.teeth_a}}};
  const char* tag[] = {"a", "b"};
  for (int i = 0; i < 2; ++i) {
    const std::string& body = *sides[i].first;
    const std::string rel = RelativeOmega(body, gm.carrier);
    const std::string spin = gm.name + "." + tag[i];
    AddSpin(spin, gm.carrier, sides[i].second.first, sides[i].second.second);
    Bond(rel, spin, spin + ".in");
    Bond(spin, sum, spin + ".out");
    if (IsGround(gm.carrier)) info_[body].moment_terms.push_back({spin + ".in.e", -1.0});
  }
  if (gm.backlash > 0.0 && gm.rigid) {
    AddBacklashContacts(sum, gm);
  } else {
    AddCompliance(sum, gm.name + ".mesh", Eigen::VectorXd::Constant(1, gm.stiffness), Eigen::VectorXd::Constant(1, gm.damping),
                  "rotation", {}, gm.where, gm.rigid);
    if (gm.backlash > 0.0) {
      // A dead zone in the spring: no torque while the teeth are within the play.
      Element& spring = g_.element(g_.Find(gm.name + ".mesh.K"));
      spring.law_effort = LawOf(fmt::format("{:.17g}*(q - clamp(q, {:.17g}, {:.17g}))", gm.stiffness, -gm.backlash / 2, gm.backlash / 2),
                                gm.where);
    }
  }
  OutputDecl torque;
  torque.name = gm.name + ".torque";
  torque.variable = sum + ".e";
  torque.where = gm.where;
  AddOutput(torque);
  if (!gm.sensors) return;
  // The mesh phase (with `sensors`): gear a's rolling angle relative to the carrier, the integral
  // of s_a (the 1-junction `<mesh>.rolling`, no other bond: it carries no torque), the state
  // `<mesh>.phase`.
  const std::string rolling = gm.name + ".rolling";
  AddSpin(rolling + "_proj", gm.carrier, gm.axis_a, 1.0);
  Bond(RelativeOmega(gm.body_a, gm.carrier), rolling + "_proj", rolling + ".in");
  if (IsGround(gm.carrier)) info_[gm.body_a].moment_terms.push_back({rolling + ".in.e", -1.0});
  g_.Add(Make(rolling, ElementKind::kOne, 1, "rotation", gm.where));
  Bond(rolling + "_proj", rolling, rolling + ".out");
  AddAngle(gm.name + ".phase", rolling, gm.where);
}

}  // namespace multibond::mech::detail
