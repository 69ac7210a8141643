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

namespace {

/// Component `row` (0-2) of R v as a formula of the orientation state `body`.R, v constant.
std::string Turned(const std::string& body, const Eigen::Vector3d& v, int row) {
  std::string out;
  for (int m = 0; m < 3; ++m)
    if (v[m] != 0.0) out += fmt::format("{}{:.17g}*{}.R.{}{}", out.empty() ? "" : " + ", v[m], body, row + 1, m + 1);
  return fmt::format("({})", out.empty() ? std::string("0") : out);
}

}  // namespace

void Expander::AddPitchTransport(const std::string& sum, const GearMesh& gm, const MeshGeometry& geo) {
  // D = (r_a - r_b) - R_c (c_a - c_b): how far the gears' actual centres are from their places in
  // the carrier (c_a - c_b = rho_b - rho_a), in the inertial frame.
  const Eigen::Vector3d nominal = geo.rho_b - geo.rho_a;
  std::string d[3];
  for (int k = 0; k < 3; ++k) {
    const char axis = "xyz"[k];
    d[k] = fmt::format("({}.r.{} - {}.r.{} - {})", gm.body_a, axis, gm.body_b, axis, Turned(gm.carrier, nominal, k));
  }
  // M w_c = D x w_c = -w_c x D: what the carrier's rotation adds to v_a - v_b at the pitch point
  // beyond the nominal arms' share (M = [D x], a skew matrix of formulas of the states).
  Modulus m;
  m.kind = Modulus::Kind::kConstant;
  m.constant = Eigen::MatrixXd::Zero(3, 3);
  m.entries.resize(9);
  for (int i = 0; i < 3; ++i) {
    const int j = (i + 1) % 3, k = (i + 2) % 3;  // [D x]_ik = D_j, [D x]_ij = -D_k
    m.entries[static_cast<size_t>(3 * i + k)] = LawOf(d[j], gm.where);
    m.entries[static_cast<size_t>(3 * i + j)] = LawOf("-" + d[k], gm.where);
  }
  const std::string name = gm.name + ".transport";
  Element mtf = Make(name, ElementKind::kMTF, 0, "", gm.where);
  mtf.modulus = m;
  g_.Add(mtf);
  Bond(gm.carrier + ".omega", name, name + ".w");
  Bond(name, sum, name + ".v");
  info_[gm.carrier].moment_terms.push_back({name + ".w.e", -1.0});
}

void Expander::AddPitchTilt(const std::string& rate, const GearMesh& gm, const MeshGeometry& geo) {
  const Eigen::Matrix3d& carrier = FindBody(gm.carrier)->orientation;  // a body: AddPitchGear checked
  const struct {
    const std::string& body;
    Eigen::Vector3d rho, axis;
    double sign;
    const char* tag;
  } sides[] = {{gm.body_a, geo.rho_a, gm.axis_a.normalized(), 1.0, "a"},
               {gm.body_b, geo.rho_b, gm.rack_b ? Eigen::Vector3d::Zero() : Eigen::Vector3d(gm.axis_b.normalized()), -1.0, "b"}};
  for (const auto& side : sides) {
    const Body* gear = FindBody(side.body);
    if (!gear->mass.has_rotation() || side.axis.isZero()) continue;
    // The arm's moment per unit normal force, c = rho x n (carrier frame), off the gear's axis.
    const Eigen::Vector3d c = side.rho.cross(geo.n);
    const Eigen::Vector3d tilt = c - side.axis * side.axis.dot(c);
    if (tilt.norm() <= 1e-12 * c.norm()) continue;  // spur and internal gears: the arm is about the axis
    // The gear's spin about its own axis a' = R_g a_g relative to the carrier, s = a' . (w_g - w_c),
    // times -(tilt_w . a'): what the arm fixed in the carrier takes for a tilting rate of a gear
    // that spins about a tilted axis (tilt_w = R_c tilt).
    const Eigen::Vector3d own = gear->orientation.transpose() * carrier * side.axis;  // a_g, in the gear's frame
    const std::string spin = gm.name + "." + side.tag + "_spin", factor = gm.name + "." + side.tag + "_tilt";
    Modulus axial;
    axial.kind = Modulus::Kind::kRotation;
    axial.rotation = side.body + ".R";
    axial.transpose = true;
    axial.left = own.transpose();
    Element e = Make(spin, ElementKind::kMTF, 0, "", gm.where);
    e.modulus = axial;
    g_.Add(e);
    std::string dot;
    for (int k = 0; k < 3; ++k) dot += fmt::format("{}{}*{}", k ? " + " : "", Turned(gm.carrier, tilt, k), Turned(side.body, own, k));
    Modulus m;
    m.kind = Modulus::Kind::kConstant;
    m.constant = Eigen::MatrixXd::Zero(1, 1);
    m.entries = {LawOf(fmt::format("{:.17g}*({})", -side.sign, dot), gm.where)};
    Element f = Make(factor, ElementKind::kMTF, 0, "", gm.where);
    f.modulus = m;
    g_.Add(f);
    Bond(RelativeOmega(side.body, gm.carrier), spin, spin + ".w");
    Bond(spin, factor, spin + ".s");
    Bond(factor, rate, factor + ".v");
  }
}

void Expander::AddPitchGear(const GearMesh& gm) {
  const MeshGeometry& geo = geometry_.at(gm.name);
  const std::string vp = gm.name + ".vp", line = gm.name + ".line";
  AddPitchVelocities(vp, gm, geo, "");
  AddFrameElement(line, Coupling::Frame::kParent, gm.carrier, gm.carrier, geo.n.transpose(), gm.where);
  Bond(vp, line, line);
  // On a turning carrier the gears' actual centres and axes enter the contact's rate (docs/design.md,
  // "Gear meshes through the contact"); ideal constraints take no formulas that reach them yet (HasIdealConstraints),
  // so such a model keeps the arms fixed in the carrier.
  std::string rate = line;
  if (!IsGround(gm.carrier) && !HasIdealConstraints()) {
    AddPitchTransport(vp, gm, geo);
    rate = gm.name + ".rate";
    g_.AddJunction(rate, ElementKind::kZero, 1);
    Bond(line, rate, rate + ".line");
    AddPitchTilt(rate, gm, geo);
  }
  const double tangential = std::cos(gm.helix_angle) * std::cos(gm.pressure_angle);  // F_t per unit F_n
  const double arm = geo.r_a * tangential;  // torque on a per unit normal force
  const double k = gm.stiffness / (arm * arm), r = gm.damping / (arm * arm);
  const std::string mesh = gm.name + ".mesh";
  if (gm.backlash > 0.0 && gm.rigid) {
    AddBacklashContacts(rate, gm, arm, "translation");
  } else {
    AddCompliance(rate, mesh, Eigen::VectorXd::Constant(1, k), Eigen::VectorXd::Constant(1, r), "translation", {}, gm.where, gm.rigid);
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
  AddVariableOutput(gm.name + ".torque", sum + ".e", "", gm.where);
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
