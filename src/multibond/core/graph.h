#pragma once
/// \file
/// The editable multibond graph: elements, bonds, auxiliary states and declared outputs.
/// It is built by the model loader or through this API, then compiled (compile/compiled_model.h)
/// into an immutable model. Nothing here knows about any particular model.
///
/// Sign conventions (power = e . f flows in the direction of the half-arrow, tail -> head):
///  - I, C, R see the bond's effort with the sign sigma = +1 if the bond points into them and -1
///    if it points out (the flow is shared): I: dp/dt = sigma e, f = I^-1 p;
///    C: dq/dt = f, sigma e = K q; R: sigma e = R f.
///  - TF/MTF (port 1 = the bond pointing in, port 2 = the bond pointing out), modulus M (n2 x n1):
///    f2 = M f1, e1 = M^T e2.   GY/MGY: e2 = M f1, e1 = M^T f2.
///  - 0-junction: common effort, sum of signed flows (in +, out -) = 0;
///    1-junction: common flow, sum of signed efforts = 0.

#include <cmath>
#include <map>
#include <optional>
#include <string>
#include <unordered_map>
#include <vector>

#include <Eigen/Dense>

#include "multibond/core/error.h"
#include "multibond/core/expression.h"
#include "multibond/core/time_function.h"

namespace multibond {

enum class ElementKind { kSe, kSf, kI, kC, kR, kTF, kMTF, kGY, kMGY, kZero, kOne };

/// "Se", "Sf", "I", "C", "R", "TF", "MTF", "GY", "MGY", "0", "1".
const char* KindName(ElementKind k);
std::optional<ElementKind> ParseKind(const std::string& s);
bool IsJunction(ElementKind k);
bool IsTwoPort(ElementKind k);
bool IsOnePort(ElementKind k);
bool IsSource(ElementKind k);
bool IsStorage(ElementKind k);

/// A parameter given either as a scalar (meaning scalar * identity) or as a matrix.
struct Param {
  bool is_scalar = true;
  double scalar = 0.0;
  Eigen::MatrixXd matrix;

  static Param Scalar(double v) { return Param{true, v, {}}; }
  static Param Matrix(Eigen::MatrixXd m) { return Param{false, 0.0, std::move(m)}; }
  /// The parameter as a rows x cols matrix (a scalar becomes scalar * identity).
  Eigen::MatrixXd AsMatrix(int rows, int cols) const;
  int rows() const { return is_scalar ? 0 : static_cast<int>(matrix.rows()); }
  int cols() const { return is_scalar ? 0 : static_cast<int>(matrix.cols()); }
};

/// A formula of a model (docs/model-format.md, "Expressions"): its text as written, its tree and
/// where it stands in the file (the column of its first character). `root` null = not given.
struct Formula {
  std::string text;
  expr::NodePtr root;
  SourceLocation where;
  bool given() const { return root != nullptr; }
};

/// The modulus of an MTF or MGY: a matrix that depends on the state.
///   kConstant: M = scale * left * constant
///   kRotation: M = scale * left * R * right      (or R^T if transpose) with R an orientation state
///   kLever:    M = scale * left * (-[(R r)x])  so that M w = w x (R r): the velocity that a
///              body-fixed point r (body frame) gets from the angular velocity w (paper eq. 1-6)
/// `left` and `right` are empty for the identity; `left` selects directions (e.g. rows y, z),
/// `right` (3 x n, kRotation only) maps body-frame directions (e.g. a drive's axis).
struct Modulus {
  enum class Kind { kConstant, kRotation, kLever };
  Kind kind = Kind::kConstant;
  double scale = 1.0;
  Eigen::MatrixXd left;
  Eigen::MatrixXd right;
  Eigen::MatrixXd constant;
  std::string rotation;  ///< name of the orientation state (kRotation, kLever)
  bool transpose = false;
  Eigen::Vector3d lever = Eigen::Vector3d::Zero();
  /// kConstant whose entries change (formulas of time and model variables): one per entry,
  /// row-major, a not-given one standing for `constant`'s entry; empty for a constant modulus.
  /// Such a modulus works forward only (flow at port 1; an MGY: at both ports) unless it is 1 x 1.
  std::vector<Formula> entries;

  int rows() const;  ///< output dimension (n2)
  int cols() const;  ///< input dimension (n1)
  /// True when M can be inverted whatever the state (square and, for kLever, never).
  bool invertible() const;
  std::string ToString() const;
};


/// A source value: one time function per component (a single function is broadcast).
struct SourceValue {
  std::vector<TimeFunction> components;
};

/// A switching element: an Sf constraint on a relative flow g (target 0) that holds only in some
/// of its modes (docs/events.md). A contact: the constraint holds while it is closed; g is the
/// separation velocity, the multiplier the compressive force (>= 0); it closes when its gap
/// reaches zero, with an impact of restitution e, or for good when the impacts accumulate
/// (Zeno), and opens when the force would pull. Coulomb friction: stick holds the constraint
/// while |lambda| <= mu_s N; slip prescribes lambda = -mu_k N sign(g) until g returns to zero. A
/// clutch or brake is a friction element with a capacity (mu_s = mu_k = 1, N = the capacity).
struct Switching {
  enum class Kind { kNone, kContact, kFriction };
  Kind kind = Kind::kNone;
  std::string gap;            ///< contact: the variable that measures the gap (open while > 0)
  double gap_scale = 1.0, gap_offset = 0.0;  ///< contact: the gap is gap_scale * gap + gap_offset
  double restitution = 0.0;   ///< contact: e in [0, 1]
  double mu_s = 1.0, mu_k = 1.0;  ///< friction: static and kinetic coefficients, mu_s >= mu_k >= 0
  TimeFunction normal = TimeFunction::Constant(0.0);  ///< friction: N (or the capacity), of time
  std::string normal_signal;  ///< friction: or a signal's name (then `normal` is unused)
  bool capacity = false;      ///< a clutch or brake (its events are lock and unlock, not stick and slip)
  bool limit = false;         ///< a contact that is a joint's end stop (its events are `limit`)
  SourceLocation where;
};

struct Element {
  std::string name;
  ElementKind kind = ElementKind::kOne;
  SourceLocation where;
  int dim = 0;  ///< bond dimension at this element (one-ports, junctions); 0 = infer
  /// I: inertia; C: stiffness K (effort = K q); R: resistance (effort = R f); TF, GY: ratio.
  Param param;
  /// I only: if non-empty, the inertia is R Ib R^T with Ib = param (3x3) and R this orientation.
  std::string rotation;
  Modulus modulus;            ///< MTF, MGY
  SourceValue source;         ///< Se, Sf
  /// Sf only: an ideal constraint. Its flow is imposed exactly by an unknown effort (the
  /// reaction), solved at every evaluation instead of being propagated causally, so it may act
  /// through transformers that cannot invert (a 2 x 3 selection) and on storage elements that
  /// would otherwise be in derivative causality (see docs/design.md, "Ideal constraints").
  bool constraint = false;
  /// A source whose work is a potential energy (gravity on a body: its work is -m g . (r - r0)):
  /// the energy account counts minus its work as stored potential energy, not as work.
  bool potential_work = false;
  /// Constraint only: the compliance (1/K, > 0) of each component (one value: all of them), the
  /// coupling it stands for. With redundant constraints the reaction is then shared as that
  /// elastic structure would share it (least complementary energy); without, by W's diagonal.
  Eigen::VectorXd compliance;
  /// Constraint only: a switching element (docs/events.md), or kNone.
  Switching switching;
  Eigen::VectorXd initial;    ///< I: p(0); C: q(0) (empty = zero)
  // --- Expressions (scalar bonds). In a law, the element's own variables are named `q`, `p`,
  // `e`, `f` (its effort is sigma e, its flow f: see the sign rules above); a law may also use
  // parameters (already folded into numbers by the loader), `t` and other model variables. ---
  /// C: effort of q; I: flow of p; R: effort of f.
  Formula law_effort;
  /// R: flow of e. (An R given both ways uses the one its causality needs.)
  Formula law_flow;
  /// C: stored energy of q; I: of p. The law is its derivative (compile/symbolic.h).
  Formula energy;
  /// Se, Sf: the value as a formula of `t` and model variables, one per component (one: every
  /// component); replaces `source`. TF, GY: the scalar ratio as a formula (replaces `param`).
  std::vector<Formula> value;
  /// R only: may deliver power (e f < 0 allowed); otherwise e f < 0 during a run is an error.
  bool active = false;
  /// I, C: the name of the state (default "<name>.p" for I, "<name>.q" for C). The rigid-body
  /// library names a body's momenta "B.p" and "B.h" this way.
  std::string state_name;
  std::string domain;         ///< "translation", "rotation", "electrical", "hydraulic", ... ("" = infer)
  std::vector<std::string> components;  ///< component names of a multi-dimensional bond
  /// I, C: the unit of each component's state (`units:`), for a vector bond whose components
  /// belong to different domains (a multiport's charge and gap); empty: the bond's domain's.
  std::vector<std::string> state_units;
  std::vector<int> bonds;     ///< filled by BondGraph::Connect, in order of connection
};

/// The names of a storage element's own variables in its law or energy: "q" (C) or "p" (I); for
/// a multiport, a vector bond (dim > 1) given one `energy:` formula, q1 ... qn (p1 ... pn), whose
/// efforts (flows) are the energy's gradient (docs/model-format.md, "Multiport storage").
std::vector<std::string> OwnVariables(const Element& e);
/// The same for a C or I whose energy has n components (n <= 1: a scalar law).
std::vector<std::string> OwnVariables(ElementKind kind, int n);
/// A C or I of dim > 1 given by one energy function of its vector state.
bool IsMultiportEnergy(const Element& e);

struct Bond {
  std::string name;
  int from = -1;  ///< tail element
  int to = -1;    ///< head element (the half-arrow points here)
  int dim = 0;    ///< 0 = infer
  SourceLocation where;
};

/// A state integrated from a flow that is not a power variable: an orientation matrix or a
/// position. `of` names a 1-junction (its common flow) or a one-port element (its bond's flow).
struct AuxState {
  enum class Kind {
    kOrientation,  ///< dR/dt = [w x] R, w = the 3-dimensional flow of `of`; R stored as 9 entries
    kIntegral,     ///< dx/dt = f, the flow of `of`; or, with `rate` given, dx/dt = rate
    kLag,          ///< time_constant dx/dt = input - x (a first-order lag of a signal)
    kPid,          ///< a PID controller of the signal `input` (the error): see Pid
  };
  /// kIntegral with a formula (a signal state): the rate; kLag, kPid: the input signal.
  Formula rate, input;
  double time_constant = 0.0;  ///< kLag
  /// kPid, with e the input: u_raw = kp e + ki i + kd (e - d) / tf, u = clamp(u_raw, u_min, u_max);
  /// states i (`<name>.i`): di/dt = e + (u - u_raw) / (ki tt) (back-calculation anti-windup;
  /// tt = 0 picks sqrt(kd / ki) with a D part, else kp / ki, else 1 s) and, with kd > 0 (then
  /// tf > 0), d (`<name>.d`): dd/dt = (e - d) / tf, the derivative filter. The output is read
  /// as `<name>.u`. Without ki the i state stays 0.
  struct Pid {
    double kp = 0.0, ki = 0.0, kd = 0.0, tf = 0.0, tt = 0.0;
    double u_min = -HUGE_VAL, u_max = HUGE_VAL;
  } pid;
  std::string name;
  Kind kind = Kind::kIntegral;
  std::string of;
  Eigen::MatrixXd initial;  ///< kOrientation: 3x3 (default identity); kIntegral: n x 1 (default 0)
  std::vector<std::string> components;
  std::string unit;  ///< kIntegral: unit of the integral (e.g. "m"); "" = from the domain
  /// kOrientation: gain g > 0 adds -g (R R^T - I) R to dR/dt, which vanishes on the rotation
  /// group and pulls a drifting R back to it (0 = plain integration).
  double stabilization = 0.0;
  SourceLocation where;
};

/// A signal: a named variable without power, defined by a formula of model variables, time and
/// other signals (sensors, set-points, control laws). Read by its name, like `j.f`.
struct Signal {
  std::string name;
  Formula value;
  std::string unit;  ///< "" = dimensionless or unknown
  SourceLocation where;
};

/// A declared output (see docs/model-format.md). Variables are named "<element>.e", "<element>.f",
/// "<two-port>.e1|f1|e2|f2", "<bond>.e|f" for named bonds, or a state ("mass.p", "A.R").
struct OutputDecl {
  enum class Kind {
    kVariable,       ///< the variable `variable`
    kSum,            ///< sum of coefficient * variable over `terms` (all of one size)
    kPoint,          ///< position + rotation * point: a body-fixed point in the inertial frame
    kOrthonormality  ///< |R^T R - I| (Frobenius) of the orientation state `rotation`
  };
  Kind kind = Kind::kVariable;
  std::string name;
  std::string variable;
  std::vector<std::pair<std::string, double>> terms;
  std::string position, rotation;  ///< kPoint: integral state of the position; orientation state
  Eigen::Vector3d point = Eigen::Vector3d::Zero();
  std::string unit;                ///< "" = the unit of the (first) variable
  std::vector<std::string> components;  ///< "" = those of the variable
  SourceLocation where;
};

class BondGraph {
 public:
  explicit BondGraph(std::string name = "model") : name_(std::move(name)) {}

  /// Adds an element and returns its index. Throws ModelError on a duplicate name.
  int Add(Element e);
  int AddSe(const std::string& name, SourceValue v, int dim = 1);
  int AddSf(const std::string& name, SourceValue v, int dim = 1);
  int AddI(const std::string& name, Param inertia, int dim = 1);
  int AddC(const std::string& name, Param stiffness, int dim = 1);
  int AddR(const std::string& name, Param resistance, int dim = 1);
  int AddTF(const std::string& name, Param ratio);
  int AddGY(const std::string& name, Param ratio);
  int AddMTF(const std::string& name, Modulus m);
  int AddMGY(const std::string& name, Modulus m);
  int AddJunction(const std::string& name, ElementKind zero_or_one, int dim = 0);

  /// Connects `from` -> `to` (half-arrow at `to`). Throws ModelError for unknown names.
  int Connect(const std::string& from, const std::string& to, int dim = 0, std::string bond_name = {},
              SourceLocation where = {});
  /// Appends a bond as given, without adding it to its elements' lists of bonds (for rewiring
  /// passes that place it themselves, e.g. the cut of an ideal constraint). Returns its index.
  int AppendBond(Bond b) {
    bonds_.push_back(std::move(b));
    return static_cast<int>(bonds_.size()) - 1;
  }
  /// Room for `elements` elements and `bonds` bonds in all, for a builder that knows how many it
  /// will add (an expansion): the lists then do not grow step by step, each step moving every
  /// element (a kilobyte each) to memory never touched before.
  void Reserve(int elements, int bonds);
  int AddAux(AuxState a);
  void AddOutput(OutputDecl o) { outputs_.push_back(std::move(o)); }
  /// Adds a signal; throws ModelError on a duplicate name.
  int AddSignal(Signal s);
  const std::vector<Signal>& signals() const { return signals_; }
  int FindSignal(const std::string& name) const;

  const std::string& name() const { return name_; }
  void set_source_file(std::string f) { source_file_ = std::move(f); }
  const std::string& source_file() const { return source_file_; }

  int num_elements() const { return static_cast<int>(elements_.size()); }
  int num_bonds() const { return static_cast<int>(bonds_.size()); }
  const Element& element(int i) const { return elements_.at(i); }
  Element& element(int i) { return elements_.at(i); }
  const Bond& bond(int i) const { return bonds_.at(i); }
  Bond& bond(int i) { return bonds_.at(i); }
  const std::vector<Element>& elements() const { return elements_; }
  const std::vector<Bond>& bonds() const { return bonds_; }
  const std::vector<AuxState>& aux_states() const { return aux_; }
  const std::vector<OutputDecl>& outputs() const { return outputs_; }

  /// Index of the element called `name`, or -1.
  int Find(const std::string& name) const;
  int FindAux(const std::string& name) const;
  /// The element at the other end of bond b from element e.
  int Other(int bond, int element) const;
  /// +1 if bond b points into element e, -1 if it points out.
  int PowerSign(int bond, int element) const;

 private:
  std::string name_;
  std::string source_file_;
  std::vector<Element> elements_;
  std::vector<Bond> bonds_;
  std::vector<AuxState> aux_;
  std::vector<OutputDecl> outputs_;
  std::vector<Signal> signals_;
  std::unordered_map<std::string, int> signal_index_;
  std::unordered_map<std::string, int> index_;      ///< element name -> index (O(1) Find)
  std::unordered_map<std::string, int> aux_index_;  ///< state name -> index
};

/// Adds elements under a name prefix: Scope(g, "A").Name("w") == "A.w". Submodels are built with
/// it: a function that adds a group of elements under a scope and exposes some as its ports.
class Scope {
 public:
  Scope(BondGraph& g, std::string prefix) : g_(g), prefix_(std::move(prefix)) {}
  std::string Name(const std::string& local) const { return prefix_.empty() ? local : prefix_ + "." + local; }
  BondGraph& graph() { return g_; }

 private:
  BondGraph& g_;
  std::string prefix_;
};

}  // namespace multibond
