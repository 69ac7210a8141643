#include "multibond/io/mechanism_reader.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <functional>
#include <map>
#include <numbers>
#include <optional>

#include <fmt/format.h>

#include "multibond/core/identifier.h"
#include "multibond/core/diagnostic_codes.h"
#include "multibond/io/did_you_mean.h"
#include "multibond/mech/assembly.h"

namespace multibond {

namespace {

/// A drive's value that is text but no number: a formula (a number, YAML's .nan and .inf, and a
/// mapping such as {step: 50} are time functions).
bool IsFormulaText(const YAML::Node& n) { return n.IsScalar() && !n.Scalar().empty() && !ValueReader::IsPlainValue(n); }

/// The 'assembly' section (docs/mechanisms.md, "Assembly"): `given` (joint angles, slides and
/// their rates, bodies' positions, orientations and velocities, velocity drives' speeds, each
/// held exactly) and `tolerance`.
std::optional<mech::AssemblySpec> ReadAssembly(MechanismValues& v, DiagnosticSink& sink, const YAML::Node& root, const mech::Mechanism& m) {
  const std::string element = "assembly";
  const YAML::Node a = root[element];
  mech::AssemblySpec spec;
  spec.where = v.Loc(a);
  for (const auto& kv : root)
    if (kv.first.Scalar() == element) spec.where = v.Loc(kv.first);  // the key, where a report about the whole belongs
  if (!a.IsMap()) {
    sink.Error(codes::kYamlStructure, v.Loc(a), element, "'assembly' is a mapping: {given: {...}, tolerance: ...}",
               "e.g. assembly: {given: {crank_pivot: {degrees: 30, rate: 10}}}");
    return std::nullopt;
  }
  v.CheckKeys(a, {"given", "tolerance", "description"}, element);
  if (const YAML::Node t = a["tolerance"]) {
    spec.tolerance = v.Number(t, element, Env{});
    if (!(spec.tolerance > 0.0 && spec.tolerance < 1.0))
      sink.Error(codes::kParamRange, v.Loc(t), element, fmt::format("the assembly's tolerance must be in (0, 1) (got {:g})", spec.tolerance),
                 "the largest violation of a joint accepted, in m or rad: 1e-10 by default");
  }
  const YAML::Node given = a["given"];
  if (!given) return spec;
  if (!given.IsMap()) {
    sink.Error(codes::kYamlStructure, v.Loc(given), element, "'given' maps joints, bodies and drives to their coordinates",
               "e.g. given: {crank_pivot: {degrees: 30, rate: 10}, piston: {velocity: [0, 0, 0]}}");
    return std::nullopt;
  }
  std::map<std::string, const mech::Joint*> joints;
  std::map<std::string, const mech::Body*> bodies;
  std::map<std::string, const mech::Drive*> drives;
  std::vector<std::string> names;
  for (const auto& j : m.joints()) joints[j.name] = &j, names.push_back(j.name);
  for (const auto& b : m.bodies()) bodies[b.name] = &b, names.push_back(b.name);
  for (const auto& d : m.drives()) drives[d.name] = &d, names.push_back(d.name);
  using Kind = mech::AssemblySpec::Given::Kind;
  for (const auto& kv : given) {
    const std::string name = kv.first.Scalar();
    const YAML::Node g = kv.second;
    auto add = [&](Kind kind, const char* key) -> mech::AssemblySpec::Given& {
      mech::AssemblySpec::Given x;
      x.kind = kind;
      x.part = name;
      x.where = v.Loc(g[key]);
      spec.given.push_back(x);
      return spec.given.back();
    };
    if (!g.IsMap()) {
      sink.Error(codes::kYamlStructure, v.Loc(g), name, fmt::format("what is given of '{}' is a mapping", name),
                 "e.g. crank_pivot: {degrees: 30, rate: 10}, or piston: {position: [0.4, 0, 0]}");
      continue;
    }
    if (const auto j = joints.find(name); j != joints.end()) {
      const std::string& kind = j->second->kind;
      // Revolute: the turn about the axis; prismatic: the slide along it; cylindrical and screw: both.
      const bool turns = kind == "revolute" || kind == "cylindrical" || kind == "screw";
      const bool slides = kind == "prismatic" || kind == "cylindrical" || kind == "screw";
      if (turns || slides) {
        std::vector<std::string> keys;
        if (turns) keys.insert(keys.end(), {"angle", "degrees", "rate"});
        if (slides) keys.insert(keys.end(), {"slide", "speed"});
        v.CheckKeys(g, keys, name);
      }
      if (turns) {
        if (g["angle"] && g["degrees"]) sink.Error(codes::kKeyConflict, v.Loc(g["degrees"]), name, "give the angle once: 'angle' (rad) or 'degrees'");
        if (g["angle"]) add(Kind::kJointAngle, "angle").value = v.Number(g["angle"], name, Env{});
        else if (g["degrees"]) add(Kind::kJointAngle, "degrees").value = v.Number(g["degrees"], name, Env{}) * std::numbers::pi / 180.0;
        if (g["rate"]) add(Kind::kJointRate, "rate").value = v.Number(g["rate"], name, Env{});
      }
      if (slides) {
        if (g["slide"]) add(Kind::kJointSlide, "slide").value = v.Number(g["slide"], name, Env{});
        if (g["speed"]) add(Kind::kJointSpeed, "speed").value = v.Number(g["speed"], name, Env{});
      }
      if (!turns && !slides) {
        sink.Error(codes::kMechAssembly, v.Loc(kv.first), name,
                   fmt::format("joint '{}' is a {} joint: only revolute, prismatic, cylindrical and screw joints have a coordinate to give",
                               name, kind),
                   "give the bodies' positions, orientations or velocities instead");
      }
    } else if (bodies.count(name)) {
      v.CheckKeys(g, {"position", "orientation", "velocity", "omega"}, name);
      if (g["position"]) add(Kind::kBodyPosition, "position").vector = v.Vec3(g["position"], name);
      if (g["orientation"]) add(Kind::kBodyOrientation, "orientation").matrix = v.Orientation(g["orientation"], name);
      if (g["velocity"]) add(Kind::kBodyVelocity, "velocity").vector = v.Vec3(g["velocity"], name);
      if (g["omega"]) add(Kind::kBodyOmega, "omega").vector = v.Vec3(g["omega"], name);
    } else if (const auto d = drives.find(name); d != drives.end()) {
      v.CheckKeys(g, {"speed"}, name);
      const bool velocity = d->second->kind == mech::Drive::Kind::kAngularVelocity || d->second->kind == mech::Drive::Kind::kVelocity;
      if (!velocity)
        sink.Error(codes::kMechAssembly, v.Loc(kv.first), name, fmt::format("drive '{}' applies a torque or force: it has no speed to give", name),
                   "give the speed of the joint or body it drives");
      else if (g["speed"])
        add(Kind::kDriveSpeed, "speed").value = v.Number(g["speed"], name, Env{});
    } else {
      const std::string guess = DidYouMean(name, names);
      sink.Error(codes::kMechReference, v.Loc(kv.first), name, fmt::format("'{}' is no joint, body or drive of the mechanism", name),
                 guess.empty() ? "name a revolute, prismatic, cylindrical or screw joint, a body or a velocity drive" : fmt::format("did you mean '{}'?", guess));
    }
  }
  return spec;
}

}  // namespace

std::shared_ptr<const mech::Mechanism> MechanismReader::ReadMechanism(const YAML::Node& root) {
  ReadPartList(root, rigid_);
  ReadPartList(root, sensors_);
  mech::Mechanism m;
  if (root["gravity"]) m.SetGravity(Vec3(root["gravity"], "gravity"));
  if (!ReadBodies(root, m)) return nullptr;
  if (const YAML::Node joints = root["joints"]) ReadJoints(joints, m);
  if (const YAML::Node gears = root["gears"]) ReadGears(gears, m);
  // A drive's formula may name the model's states bare, as elements' formulas do: their names
  // first (the elements' reader adds them again).
  if (const YAML::Node states = root["states"]; states && states.IsMap())
    for (const auto& kv : states) cx_.state_names.insert(kv.first.Scalar());
  if (const YAML::Node drives = root["drives"]) ReadDrives(drives, m);
  if (const YAML::Node points = root["points"]) ReadPoints(points, m);
  CheckPartNames(m, rigid_);
  CheckPartNames(m, sensors_);
  if (sink_.has_errors()) return nullptr;
  if (root["assembly"]) {
    // Assembly (docs/mechanisms.md, "Assembly"): the bodies' state at t = 0 made consistent with
    // the joints before the expansion takes it; on an error the bodies stay as written.
    if (const std::optional<mech::AssemblySpec> spec = ReadAssembly(*this, sink_, root, m); spec && !sink_.has_errors())
      mech::Assemble(m, *spec, sink_);
  }
  m.ExpandInto(graph_, sink_);
  return std::make_shared<mech::Mechanism>(std::move(m));
}

/// A model-wide 'rigid' or 'sensors' key: 'all' (every joint and gear mesh) or a list of their names.
void MechanismReader::ReadPartList(const YAML::Node& root, PartList& list) {
  if (const YAML::Node r = root[list.key]) {
    if (r.IsScalar() && (r.Scalar() == "all" || r.Scalar() == "true")) {
      list.all = true;
    } else if (r.IsSequence()) {
      for (const auto& n : r) {
        list.names.push_back(n.Scalar());
        list.where.push_back(Loc(n));
        list.set.insert(n.Scalar());
      }
    } else {
      sink_.Error(codes::kYamlStructure, Loc(r), list.key, fmt::format("'{}' is 'all' or a list of joint and gear mesh names", list.key),
                  fmt::format("write e.g. '{0}: all' or '{0}: [G_bearing, mesh_GA]'", list.key));
    }
  }
}

/// Every name in 'rigid: [...]' or 'sensors: [...]' must be a joint or a gear mesh (a misspelt one
/// would leave that part as it was without a word).
void MechanismReader::CheckPartNames(const mech::Mechanism& m, const PartList& list) {
  if (list.names.empty()) return;
  std::vector<std::string> parts;
  for (const auto& j : m.joints()) parts.push_back(j.name);
  for (const auto& g : m.gears()) parts.push_back(g.name);
  const std::unordered_set<std::string> known(parts.begin(), parts.end());
  for (size_t k = 0; k < list.names.size(); ++k)
    if (!known.count(list.names[k])) {
      const std::string guess = DidYouMean(list.names[k], parts);
      sink_.Error(codes::kMechReference, list.where[k], list.names[k],
                  fmt::format("'{}' names no joint or gear mesh of that name", list.key),
                  guess.empty() ? fmt::format("list the joints and gear meshes for '{}'", list.key) : fmt::format("did you mean '{}'?", guess));
    }
}

bool MechanismReader::ReadBodies(const YAML::Node& root, mech::Mechanism& m) {
  const YAML::Node bodies = root["bodies"];
  if (!bodies.IsMap()) {
    sink_.Error(codes::kYamlStructure, Loc(bodies), "bodies", "'bodies' is a mapping of names to bodies");
    return false;
  }
  // Positions may be given relative to another body: resolve in dependency order.
  std::unordered_map<std::string, YAML::Node> spec;
  std::vector<std::string> order;
  for (const auto& kv : bodies) {
    if (!CheckName(kv.first.Scalar(), Loc(kv.first), "a body's")) continue;
    spec[kv.first.Scalar()] = kv.second;
    order.push_back(kv.first.Scalar());
  }
  std::unordered_set<std::string> in_progress;
  std::function<const mech::Body*(const std::string&, const YAML::Node&)> make = [&](const std::string& name,
                                                                                     const YAML::Node& at) -> const mech::Body* {
    if (made_.count(name)) return &made_[name];
    if (!spec.count(name)) {
      sink_.Error(codes::kMechReference, Loc(at), name, fmt::format("no body called '{}'", name), "define it under 'bodies'");
      return nullptr;
    }
    if (in_progress.count(name)) {
      sink_.Error(codes::kMechReference, Loc(at), name, "body positions refer to each other in a circle");
      return nullptr;
    }
    in_progress.insert(name);
    const YAML::Node b = spec[name];
    mech::Body body;
    body.name = name;
    body.where = Loc(b);
    if (!b.IsMap()) {
      sink_.Error(codes::kYamlStructure, Loc(b), name, "a body is a mapping with shape/density or mass/inertia, position, ...");
      made_[name] = body;
      return &made_[name];
    }
    CheckKeys(b, {"shape", "density", "mass", "inertia", "position", "orientation", "velocity", "omega", "description"}, name);
    body.mass = Mass(b, name);
    if (b["orientation"]) body.orientation = Orientation(b["orientation"], name);
    if (const YAML::Node p = b["position"]) {
      if (p.IsMap()) {
        CheckKeys(p, {"relative_to", "offset"}, name);
        const mech::Body* ref = p["relative_to"] ? make(p["relative_to"].Scalar(), p["relative_to"]) : nullptr;
        const Eigen::Vector3d off = p["offset"] ? Vec3(p["offset"], name) : Eigen::Vector3d::Zero();
        if (ref) body.position = ref->position + ref->orientation * off;
        else if (!p["relative_to"]) sink_.Error(codes::kKeyMissing, Loc(p), name, "a relative position needs 'relative_to' (a body) and 'offset' (in its frame)");
      } else {
        body.position = Vec3(p, name);
      }
    }
    if (b["velocity"]) body.velocity = Vec3(b["velocity"], name);
    if (b["omega"]) body.omega = Vec3(b["omega"], name);
    in_progress.erase(name);
    made_[name] = body;
    return &made_[name];
  };
  for (const std::string& name : order) {
    make(name, spec[name]);
    m.AddBody(made_[name]);
  }
  return true;
}

const mech::Body* MechanismReader::BodyOrGround(const std::string& name) const {
  const auto it = made_.find(name);
  return it == made_.end() ? nullptr : &it->second;
}

void MechanismReader::ReadJoints(const YAML::Node& joints, mech::Mechanism& m) {
  for (const auto& kv : joints) {
    const std::string name = kv.first.Scalar();
    const YAML::Node j = kv.second;
    if (!CheckName(name, Loc(kv.first), "a joint's")) continue;
    mech::Joint joint;
    joint.name = name;
    joint.where = Loc(kv.first);
    if (!j.IsMap()) {
      sink_.Error(codes::kYamlStructure, joint.where, name, "a joint is a mapping with type, parent, child, ...");
      continue;
    }
    const std::string type = j["type"] ? j["type"].Scalar() : "coupling";
    const std::vector<std::string> types = {"coupling",  "revolute",    "fixed",  "weld",  "spherical", "prismatic",
                                            "held",      "cylindrical", "planar", "screw", "universal"};
    if (std::find(types.begin(), types.end(), type) == types.end()) {
      const std::string guess = DidYouMean(type, types);
      sink_.Error(codes::kMechJointType, Loc(j["type"]), name, fmt::format("unknown joint type '{}'", type),
                  guess.empty() ? "use coupling, revolute, fixed, spherical, prismatic, held, cylindrical, planar, screw or universal"
                                : fmt::format("did you mean '{}'?", guess));
      continue;
    }
    std::vector<std::string> keys = {"type", "parent", "child", "at", "child_at", "axis", "translation", "rotation", "rigid", "limits", "friction", "sensors", "description"};
    if (type == "planar") keys.push_back("normal");
    if (type == "universal") keys.push_back("child_axis");
    if (type == "screw") keys.insert(keys.end(), {"pitch", "lead", "helix"});
    CheckKeys(j, keys, name);
    // 'rigid: true' on the joint (or the model's 'rigid: all' / list) makes each of its
    // couplings an ideal constraint; the named kinds then need no coupling sections.
    rigid_joint_ = (j["rigid"] && Bool(j["rigid"], name)) || RigidByModel(name);
          joint.kind = type;
    joint.parent = j["parent"] ? j["parent"].Scalar() : std::string(mech::kGround);
    if (type == "held" && joint.parent != mech::kGround) sink_.Error(codes::kKeyConflict, Loc(j["parent"]), name, "a 'held' joint holds its child to the ground", "remove 'parent'");
    if (!j["child"]) {
      sink_.Error(codes::kKeyMissing, joint.where, name, "a joint needs a 'child' body");
      continue;
    }
    joint.child = j["child"].Scalar();
    if (j["child_at"]) joint.child_point = Vec3(j["child_at"], name);
    const mech::Body* parent = BodyOrGround(joint.parent);
    const mech::Body* child = BodyOrGround(joint.child);
    if (j["at"]) {
      joint.parent_point = Vec3(j["at"], name);
    } else if (child && (parent || joint.parent == mech::kGround)) {
      // By default the joint sits where the child's attachment is at t = 0: undeflected.
      const Eigen::Vector3d p = child->position + child->orientation * joint.child_point;
      joint.parent_point = parent ? Eigen::Vector3d(parent->orientation.transpose() * (p - parent->position)) : p;
    }
    const bool needs_axis = type == "revolute" || type == "prismatic";
    if (needs_axis && !j["axis"]) sink_.Error(codes::kKeyMissing, joint.where, name, fmt::format("a {} joint needs an 'axis' (in the parent's frame)", type));
    const YAML::Node axis_node = type == "planar" && j["normal"] ? j["normal"] : j["axis"];
    const Eigen::Vector3d axis = axis_node ? Axis(axis_node, name) : Eigen::Vector3d::UnitZ();
    if (needs_axis) joint.axis = axis;  // the joint sensor's axis (docs/mechanisms.md, "Joint sensors")
    using F = mech::Coupling::Frame;
    if (type == "cylindrical" || type == "planar" || type == "screw" || type == "universal") {
      ReadJointKind(j, name, type, axis_node ? &axis : nullptr, joint);
      rigid_joint_ = false;
      joint.sensors = (j["sensors"] && Bool(j["sensors"], name)) || sensors_.Has(name);
      if (j["limits"] || j["friction"]) ReadAxialSwitches(j, name, type, axis, joint);
      m.AddJoint(joint);
      continue;
    }
    const Eigen::MatrixXd all = Eigen::Matrix3d::Identity();
    const Eigen::MatrixXd perp = mech::Perpendicular(axis);
    if (type == "coupling") {
      joint.translation = ReadCoupling(j["translation"], name, "translation", nullptr, F::kWorld);
      joint.rotation = ReadCoupling(j["rotation"], name, "rotation", nullptr, F::kParent);
    } else {
      const bool trans = type != "prismatic", rot_all = type == "fixed" || type == "weld" || type == "held" || type == "prismatic";
      if (j["translation"] || rigid_joint_)
        joint.translation = ReadCoupling(j["translation"] ? j["translation"] : rigid_section_, name, "translation",
                                         trans ? &all : &perp, trans ? F::kWorld : F::kParent);
      else sink_.Error(codes::kKeyMissing, joint.where, name, fmt::format("a {} joint needs 'translation: {{K: ..., R: ...}}' (or 'rigid: true')", type));
      if (type != "spherical") {
        if (j["rotation"] || rigid_joint_)
          joint.rotation = ReadCoupling(j["rotation"] ? j["rotation"] : rigid_section_, name, "rotation", rot_all ? &all : &perp, F::kParent);
        else sink_.Error(codes::kKeyMissing, joint.where, name, fmt::format("a {} joint needs 'rotation: {{K: ..., R: ...}}' (or 'rigid: true')", type));
      } else if (j["rotation"]) {
        sink_.Error(codes::kKeyConflict, Loc(j["rotation"]), name, "a spherical joint leaves every rotation free", "remove 'rotation', or use type: coupling");
      }
    }
    rigid_joint_ = false;
    // The joint sensor (docs/mechanisms.md, "Joint sensors"): off unless asked for, each is a state.
    joint.sensors = (j["sensors"] && Bool(j["sensors"], name)) || sensors_.Has(name);
    if (j["limits"] || j["friction"]) ReadAxialSwitches(j, name, type, axis, joint);
    m.AddJoint(joint);
  }
}

void MechanismReader::ReadJointKind(const YAML::Node& j, const std::string& name, const std::string& type, const Eigen::Vector3d* given_axis,
                                    mech::Joint& joint) {
  const char* axis_key = type == "planar" ? "normal" : "axis";
  if (type == "planar" && j["normal"] && j["axis"])
    sink_.Error(codes::kMechJointAxis, Loc(j["axis"]), name, "a planar joint takes its normal once: 'normal' or 'axis'", "remove 'axis'");
  if (!given_axis) {
    sink_.Error(codes::kMechJointAxis, joint.where, name, fmt::format("a {} joint needs '{}' (in the parent's frame)", type, axis_key),
                type == "planar" ? "e.g. normal: z (the plane's normal, in the parent's frame)" : "e.g. axis: z");
    return;
  }
  const Eigen::Vector3d axis = *given_axis;
  Eigen::Vector3d child_axis = Eigen::Vector3d::Zero();
  if (type == "universal") {
    if (!j["child_axis"]) {
      sink_.Error(codes::kMechJointAxis, joint.where, name, "a universal joint needs 'child_axis' (the child's yoke axis, in its frame)",
                  "e.g. axis: y, child_axis: z: two axes perpendicular as the bodies start");
      return;
    }
    child_axis = Axis(j["child_axis"], name);
  }
  double lead = 0.0;
  if (type == "screw") {
    if (j["pitch"] && j["lead"]) sink_.Error(codes::kMechJointAxis, Loc(j["lead"]), name, "give the screw's 'pitch' or its 'lead', not both", "remove one");
    const YAML::Node l = j["pitch"] ? j["pitch"] : j["lead"];
    if (!l) {
      sink_.Error(codes::kMechJointAxis, joint.where, name, "a screw joint needs its 'pitch' (the advance per turn, m)",
                  "e.g. pitch: 0.005; negative for a left-hand thread");
      return;
    }
    lead = Number(l, name, Env{});
  }
  if (!rigid_joint_ && (!j["translation"] || !j["rotation"] || (type == "screw" && !j["helix"]))) {
    sink_.Error(codes::kKeyMissing, joint.where, name,
                fmt::format("a {} joint needs 'translation: {{K: ..., R: ...}}' and 'rotation: {{K: ..., R: ...}}'{} (or 'rigid: true')", type,
                            type == "screw" ? " and 'helix: {K: ..., R: ...}' (N/m along the axis)" : ""));
    return;
  }
  // Each section's K and R, for every coupled direction; a rigid joint needs none.
  auto section = [&](const char* key) { return j[key] ? j[key] : rigid_section_; };
  const std::string parent = joint.parent, child = joint.child;
  const Eigen::Vector3d at = joint.parent_point, child_at = joint.child_point;
  const SourceLocation where = joint.where;
  const Eigen::MatrixXd perp = mech::Perpendicular(axis);
  const Eigen::MatrixXd along = axis.transpose();
  using F = mech::Coupling::Frame;
  const Eigen::MatrixXd all = Eigen::Matrix3d::Identity();
  if (type == "cylindrical" || type == "screw") {
    joint = mech::MakeCylindrical(name, parent, child, at, axis, 1, 0, 1, 0);
    joint.translation = ReadCoupling(section("translation"), name, "translation", &perp, F::kParent);
    joint.rotation = ReadCoupling(section("rotation"), name, "rotation", &perp, F::kParent);
    if (type == "screw") {
      joint.kind = "screw";
      joint.lead = lead;
      joint.helix = ReadCoupling(section("helix"), name, "helix", &along, F::kParent);
    }
  } else if (type == "planar") {
    joint = mech::MakePlanar(name, parent, child, at, axis, 1, 0, 1, 0);
    joint.translation = ReadCoupling(section("translation"), name, "translation", &along, F::kParent);
    joint.rotation = ReadCoupling(section("rotation"), name, "rotation", &perp, F::kParent);
  } else {  // universal
    joint = mech::MakeUniversal(name, parent, child, at, axis, child_axis, 1, 0, 1, 0);
    const Eigen::MatrixXd row = joint.rotation->directions;
    joint.translation = ReadCoupling(section("translation"), name, "translation", &all, F::kWorld);
    joint.rotation = ReadCoupling(section("rotation"), name, "rotation", &row, F::kParent);
  }
  joint.child_point = child_at;
  joint.where = where;
}

void MechanismReader::ReadAxialSwitches(const YAML::Node& j, const std::string& name, const std::string& type,
                                         const Eigen::Vector3d& axis, mech::Joint& joint) {
  if (type != "revolute" && type != "prismatic") {
    sink_.Error(codes::kEventUnsupported, Loc(j["limits"] ? j["limits"] : j["friction"]), name,
                "end stops and friction act on a revolute or prismatic joint's free axis (the turn about it or the slide along it)",
                "use type: revolute or type: prismatic with its axis");
    return;
  }
  // A revolute joint's stops are angles and its friction a torque; a prismatic joint's, lengths and a force.
  const bool slide = type == "prismatic";
  const char* unit = slide ? "m" : "rad";
  joint.axis = axis;
  if (const YAML::Node l = j["limits"]) {
    CheckKeys(l, {"lower", "upper", "restitution"}, name);
    mech::Joint::Stops stops;
    stops.where = Loc(l);
    if (!l["lower"] || !l["upper"]) {
      sink_.Error(codes::kKeyMissing, Loc(l), name, fmt::format("end stops need 'lower' and 'upper' ({}, from the assembled position)", unit),
                  slide ? "e.g. limits: {lower: -0.05, upper: 0.05}" : "e.g. limits: {lower: -0.5, upper: 0.5}");
      return;
    }
    stops.lower = Number(l["lower"], name, Env{});
    stops.upper = Number(l["upper"], name, Env{});
    if (!(stops.lower < 0.0 && stops.upper > 0.0))
      sink_.Error(codes::kParamRange, Loc(l), name,
                  fmt::format("the assembled position must lie between the stops: lower < 0 < upper (got {:g} and {:g}), in {} from it",
                              stops.lower, stops.upper, unit),
                  slide ? "slides are measured in m along the axis from the position the model starts in"
                        : "angles are measured in rad from the position the model starts in");
    if (l["restitution"]) {
      stops.restitution = Number(l["restitution"], name, Env{});
      if (!(stops.restitution >= 0.0 && stops.restitution <= 1.0))
        sink_.Error(codes::kParamRange, Loc(l["restitution"]), name, fmt::format("restitution must be in [0, 1] (got {:g})", stops.restitution),
                    "0: the stop absorbs the impact, 1: elastic");
    }
    joint.stops = stops;
  }
  if (const YAML::Node f = j["friction"]) {
    mech::Joint::Friction fr;
    fr.where = Loc(f);
    // A number, a time function or a model parameter's name; any other name is a signal's.
    if (IsPlainValue(f) || f.IsMap() || (f.IsScalar() && cx_.FindParameter(f.Scalar()))) {
      fr.torque = ReadTimeFunction(f, name, Env{});
      if (fr.torque.is_constant() && !(fr.torque.value >= 0.0))
        sink_.Error(codes::kParamRange, Loc(f), name,
                    fmt::format("a friction {} must be >= 0 (got {:g})", slide ? "force [N]" : "torque [N m]", fr.torque.value));
    } else {
      fr.signal = Str(f, name);  // a signal's name: a torque or force the model computes (a brake's command)
    }
    joint.friction = fr;
  }
}

void MechanismReader::ReadGears(const YAML::Node& gears, mech::Mechanism& m) {
  for (const auto& kv : gears) {
    const std::string name = kv.first.Scalar();
    const YAML::Node g = kv.second;
    if (!CheckName(name, Loc(kv.first), "a gear mesh's")) continue;
    mech::GearMesh gm;
    gm.name = name;
    gm.where = Loc(kv.first);
    CheckKeys(g, {"carrier", "a", "b", "K", "R", "stiffness", "damping", "rigid", "backlash", "restitution", "contact", "sensors",
                  "pressure_angle_deg", "helix_angle_deg", "flank", "internal", "pitch_point", "description"},
              name);
    gm.rigid = (g["rigid"] && Bool(g["rigid"], name)) || RigidByModel(name);
    gm.sensors = (g["sensors"] && Bool(g["sensors"], name)) || sensors_.Has(name);
    gm.carrier = g["carrier"] ? g["carrier"].Scalar() : std::string(mech::kGround);
    if (const YAML::Node c = g["contact"]) {
      const std::string v = c.Scalar();
      if (v == "pitch") gm.contact = mech::GearMesh::Contact::kPitch;
      else if (v != "spin")
        sink_.Error(codes::kValueUnknown, Loc(c), name, fmt::format("'contact' is 'spin' or 'pitch' (got '{}')", v),
                    "spin: a torque between the spins (the paper's model); pitch: a force at the pitch point that the bearings carry");
    }
    if (g["pressure_angle_deg"]) gm.pressure_angle = Number(g["pressure_angle_deg"], name, Env{}) * std::numbers::pi / 180;
    if (g["helix_angle_deg"]) gm.helix_angle = Number(g["helix_angle_deg"], name, Env{}) * std::numbers::pi / 180;
    if (g["internal"]) gm.internal = Bool(g["internal"], name);
    if (const YAML::Node f = g["flank"]) {
      gm.coast_flank = f.Scalar() == "coast";
      if (f.Scalar() != "coast" && f.Scalar() != "drive")
        sink_.Error(codes::kValueUnknown, Loc(f), name, fmt::format("'flank' is 'drive' or 'coast' (got '{}')", f.Scalar()),
                    "drive: the flank that carries F_t > 0 (gear a pushing b along t); coast: the other");
    }
    if (g["pitch_point"]) gm.pitch_point = Vec3(g["pitch_point"], name);
    const bool rack = g["b"] && g["b"].IsMap() && g["b"]["rack"] && Bool(g["b"]["rack"], name);
    gm.rack_b = rack;
    if (gm.contact != mech::GearMesh::Contact::kPitch)
      for (const char* key : {"pressure_angle_deg", "helix_angle_deg", "flank", "internal", "pitch_point"})
        if (g[key]) sink_.Error(codes::kKeyConflict, Loc(g[key]), name, fmt::format("'{}' belongs to a mesh through its pitch point", key), "add 'contact: pitch'");
    auto side = [&](const char* key, std::string* body, Eigen::Vector3d* axis, double* teeth) {
      const YAML::Node s = g[key];
      if (!s || !s.IsMap()) {
        sink_.Error(codes::kKeyMissing, gm.where, name, fmt::format("a gear mesh needs '{}: {{body: ..., axis: ..., teeth: ...}}'", key));
        return;
      }
      CheckKeys(s, {"body", "axis", "teeth", "radius", "rack"}, name);
      if (s["radius"]) {
        if (std::string(key) != "a") sink_.Error(codes::kKeyConflict, Loc(s["radius"]), name, "'radius' is given for gear a (the pinion of a rack)");
        else gm.radius_a = Number(s["radius"], name, Env{});
      }
      if (s["rack"] && std::string(key) != "b") sink_.Error(codes::kKeyConflict, Loc(s["rack"]), name, "the rack is gear b");
      if (s["body"]) *body = s["body"].Scalar();
      else sink_.Error(codes::kKeyMissing, Loc(s), name, fmt::format("gear '{}' needs a 'body'", key));
      if (rack && std::string(key) == "b") {
        if (s["axis"] || s["teeth"]) sink_.Error(codes::kKeyConflict, Loc(s), name, "a rack has no axis or teeth (it translates)", "remove them");
        return;
      }
      if (s["axis"]) *axis = Axis(s["axis"], name);
      else sink_.Error(codes::kKeyMissing, Loc(s), name, fmt::format("gear '{}' needs an 'axis' (in the carrier's frame)", key));
      if (s["teeth"]) *teeth = Number(s["teeth"], name, Env{});  // a whole number in range: mech::Mechanism
      else sink_.Error(codes::kKeyMissing, Loc(s), name, fmt::format("gear '{}' needs 'teeth'", key));
    };
    side("a", &gm.body_a, &gm.axis_a, &gm.teeth_a);
    side("b", &gm.body_b, &gm.axis_b, &gm.teeth_b);
    {  // a rigid mesh uses K, if given, only to share a load with redundant constraints
      Eigen::VectorXd k, r;
      Gains(g, name, 1, &k, &r, gm.rigid);
      gm.stiffness = k[0];
      gm.damping = gm.rigid ? 0.0 : r[0];
    }
    if (g["backlash"]) {
      gm.backlash = Number(g["backlash"], name, Env{});
      if (!(gm.backlash >= 0.0))
        sink_.Error(codes::kParamRange, Loc(g["backlash"]), name, fmt::format("backlash must be >= 0 (got {:g})", gm.backlash),
                    "the total free play of the teeth, in rad referred to gear a");
    }
    if (g["restitution"]) {
      gm.restitution = Number(g["restitution"], name, Env{});
      if (!(gm.restitution >= 0.0 && gm.restitution <= 1.0))
        sink_.Error(codes::kParamRange, Loc(g["restitution"]), name, fmt::format("restitution must be in [0, 1] (got {:g})", gm.restitution),
                    "0: plastic tooth impacts, 1: elastic");
      if (!gm.rigid || !(gm.backlash > 0.0))
        sink_.Error(codes::kKeyConflict, Loc(g["restitution"]), name, "'restitution' belongs to a rigid mesh with backlash (its tooth impacts)",
                    "add 'rigid: true' and 'backlash', or remove it");
    }
    m.AddGear(gm);
  }
}

void MechanismReader::ReadDrives(const YAML::Node& drives, mech::Mechanism& m) {
  // A drive's value: a time function, or a formula of time, parameters and model variables (into
  // *formula; one of parameters only is a constant time function).
  auto read_value = [&](const YAML::Node& n, const std::string& name, Formula* formula) -> TimeFunction {
    if (!IsFormulaText(n)) return ReadTimeFunction(n, name, Env{});
    std::optional<Formula> f = ReadFormula(n, name, FormulaScope{nullptr, "", {}, "drive's value"});
    if (!f) return {};
    if (const std::optional<double> v = ConstantValue(*f)) {
      if (std::isfinite(*v)) return TimeFunction::Constant(*v);
      sink_.Error(codes::kParamRange, f->where, name, fmt::format("the formula '{}' gives {:g}: not a finite number", PrintableExcerpt(f->text), *v),
                  "check the formula and the parameters it uses");
      return {};
    }
    *formula = std::move(*f);
    return {};
  };
  for (const auto& kv : drives) {
    const std::string name = kv.first.Scalar();
    const YAML::Node d = kv.second;
    if (!CheckName(name, Loc(kv.first), "a drive's")) continue;
    mech::Drive drive;
    drive.name = name;
    drive.where = Loc(kv.first);
    const std::string type = d["type"] ? d["type"].Scalar() : "";
    const std::map<std::string, mech::Drive::Kind> kinds = {{"angular_velocity", mech::Drive::Kind::kAngularVelocity},
                                                            {"velocity", mech::Drive::Kind::kVelocity},
                                                            {"torque", mech::Drive::Kind::kTorque},
                                                            {"force", mech::Drive::Kind::kForce}};
    if (!kinds.count(type)) {
      sink_.Error(codes::kValueUnknown, d["type"] ? Loc(d["type"]) : drive.where, name, fmt::format("unknown drive type '{}'", type),
                  "use angular_velocity, velocity, torque or force");
      continue;
    }
    drive.kind = kinds.at(type);
    const bool velocity = drive.kind == mech::Drive::Kind::kAngularVelocity || drive.kind == mech::Drive::Kind::kVelocity;
    std::vector<std::string> keys = {"type", "body", "axis", "value", "description"};
    if (velocity) keys.insert(keys.end(), {"reference", "K", "R", "stiffness", "damping", "rigid"});
    if (drive.kind == mech::Drive::Kind::kForce) keys.push_back("at");
    CheckKeys(d, keys, name);
    if (d["body"]) drive.body = d["body"].Scalar();
    else sink_.Error(codes::kKeyMissing, drive.where, name, "a drive needs a 'body'");
    if (d["reference"]) drive.reference = d["reference"].Scalar();
    if (d["axis"]) drive.axis = Axis(d["axis"], name);
    else sink_.Error(codes::kKeyMissing, drive.where, name, "a drive needs an 'axis'");
    if (d["value"]) drive.value = read_value(d["value"], name, &drive.formula);
    else sink_.Error(codes::kKeyMissing, drive.where, name, "a drive needs a 'value' (a number, a time function or a formula)");
    if (d["at"]) drive.point = Vec3(d["at"], name);
    if (velocity && d["rigid"]) drive.rigid = Bool(d["rigid"], name);
    if (velocity && !drive.rigid) {
      Eigen::VectorXd k, r;
      Gains(d, name, 1, &k, &r);
      drive.stiffness = k[0];
      drive.damping = r[0];
    }
    m.AddDrive(drive);
  }
}

void MechanismReader::ReadPoints(const YAML::Node& points, mech::Mechanism& m) {
  for (const auto& kv : points) {
    mech::Point p;
    p.name = kv.first.Scalar();
    p.where = Loc(kv.first);
    if (!CheckName(p.name, p.where, "a point's")) continue;
    CheckKeys(kv.second, {"body", "at", "description"}, p.name);
    if (kv.second["body"]) p.body = kv.second["body"].Scalar();
    else sink_.Error(codes::kKeyMissing, p.where, p.name, "a point needs a 'body'");
    if (kv.second["at"]) p.at = Vec3(kv.second["at"], p.name);
    m.AddPoint(p);
  }
}

}  // namespace multibond
