#pragma once
/// \file
/// The compile/run contract (docs/design.md):
///   BondGraph (editable)  --Compile()-->  CompiledModel (immutable: state layout, evaluation plan)
///   CompiledModel::MakeWorkspace()  -->  Workspace (every effort/flow slot, allocated once)
///   GeneratedRhs::Start(model)  -->  the model's generated code, outside it (compile/generated_rhs.h);
///                                    MakeWorkspace(code) evaluates with it
///   CompiledModel::CalcDerivatives(t, x, xdot, workspace): the right-hand side; allocates nothing.
/// Efforts at a 0-junction and flows at a 1-junction share one workspace slot, so junctions cost
/// nothing but their sums. Every other computed variable is one instruction of the plan, in an
/// order found by topological sort of the causal dependencies (a cycle is an algebraic loop).

#include <cstddef>
#include <functional>
#include <memory>
#include <mutex>  // std::once_flag: the Jacobian pattern is found on first use
#include <optional>
#include <set>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include <Eigen/Dense>

#include "multibond/causality/causality.h"
#include "multibond/compile/constraint_solver.h"
#include "multibond/compile/energy_account.h"
#include "multibond/compile/operations.h"
#include "multibond/compile/plan.h"
#include "multibond/compile/slot_table.h"
#include "multibond/compile/state_layout.h"
#include "multibond/compile/switch_set.h"
#include "multibond/compile/torn_loops.h"
#include "multibond/core/graph.h"
#include "multibond/core/ode_system.h"
#include "multibond/core/structure.h"

namespace multibond {

class GeneratedRhs;
struct GeneratedCode;

struct CompileOptions {
  std::string default_domain;  ///< domain of bonds that no element names
  bool energy_account = true;  ///< integrate each source's work and each resistor's dissipation
  /// Solve algebraic loops instead of refusing them: each loop is torn at one variable, which
  /// every evaluation solves for from a small linear system (see docs/design.md).
  bool solve_algebraic_loops = false;
  bool ideal_constraints = false;  ///< accept derivative causality: dependent storage handled exactly by constraint efforts (see docs/design.md)
};

/// Scratch of one evaluation: every effort and flow, and the moduli of the MTF/MGY. Made by
/// CompiledModel::MakeWorkspace; the right-hand side writes here and nowhere else.
struct Workspace {
  /// The generated code that evaluates into this workspace once it is loaded (compile/
  /// generated_rhs.h); null: the interpreter. Not owned: the run's system object keeps it alive.
  const GeneratedRhs* code = nullptr;
  std::vector<double> slots;
  std::vector<double> moduli;
  /// Ideal constraints only (empty otherwise): the constraint efforts (multipliers) of the last
  /// evaluation, and the scratch that solving for them needs (compile/constraint_factor.h).
  std::vector<double> lambda;
  ConstraintScratch con;
  /// Switching elements only (empty otherwise): each one's discrete mode (SwitchTable::Mode). A
  /// part of the run's state rather than scratch, kept here because every evaluation reads it
  /// and the simulator changes it only at events (docs/events.md).
  std::vector<signed char> modes;
  /// Formulas with kinks only (empty otherwise): dx/dt of the evaluation behind their event
  /// functions (CompiledModel::CalcEventFunctions).
  std::vector<double> event_xdot;
  /// Signs of the state only (compile/sliding.cc; empty otherwise): each one's mode, a part of
  /// the run's state like `modes` (kFree, the default: the formula's sign; kLocked: held at the
  /// branch of its side, changed at its events; kSliding: held at its equivalent value), and the
  /// hysteresis of a locked sign's event function (the run's absolute tolerance).
  enum KinkMode : signed char { kFree = 0, kLocked, kSliding };
  std::vector<signed char> kink_modes;
  double kink_hysteresis = 0.0;
  /// Sliding signs only (compile/sliding.cc): the scratch of their equivalent values' solve.
  struct SlideScratch {
    std::vector<double> xdot, rate, d_slots, d_moduli, tmp;
    std::vector<int> active;
    Eigen::VectorXd r0, r1, sigma;
    Eigen::MatrixXd b;
  } slide;
  /// Algebraic loops only (empty otherwise): the affine map of the torn variables and its solve;
  /// for a nonlinear loop, Newton's iterates (started from the last evaluation's solution) and the
  /// tangent pass's scratch over the slots and moduli (a zero direction of the state).
  struct TearScratch {
    Eigen::MatrixXd a;  ///< A, then I - A (a nonlinear loop: the Jacobian I - dc/dz)
    Eigen::VectorXd c0, z;
    Eigen::PartialPivLU<Eigen::MatrixXd> lu;
    Eigen::VectorXd last, r, dz, trial;
    double scale = 0.0;  ///< the largest |z| or |c(z)| solved in this run
    std::vector<double> d, tmp, dx, dmod;
  } tear;
};

class CompiledModel {
 public:
  /// Analyses structure and causality and builds the plan. Throws ModelError with every problem
  /// found (structure, causality conflicts, derivative causality, algebraic loops).
  static std::shared_ptr<const CompiledModel> Compile(BondGraph graph, const CompileOptions& options = {});

  int num_states() const { return layout_.num_states(); }
  /// The right-hand side: fills `ws` with every effort and flow and writes dx/dt. No allocation.
  void CalcDerivatives(double t, const double* x, double* xdot, Workspace& ws) const;
  /// The same, for integrators: writes dx/dt and may leave `ws` unfilled (generated code then
  /// keeps the efforts and flows in registers). No allocation.
  void CalcStateDerivatives(double t, const double* x, double* xdot, Workspace& ws) const;

  /// True if the state holds orientation matrices (which Project keeps orthonormal).
  bool has_invariants() const;
  /// Replaces every orientation matrix in x by the nearest rotation (Bjorck iterations,
  /// R <- R (3 I - R^T R) / 2, quadratically convergent near SO(3): one when the deviation is
  /// below 1e-6, two otherwise). No allocation.
  void Project(double* x) const;
  /// The same, then (ideal constraints) the momenta onto the constraints' velocity manifold by
  /// the kinetic-energy metric: p += B mu with W mu = -g(x). No allocation.
  void Project(double t, double* x, Workspace& ws) const;

  // --- ideal constraints (docs/design.md): constraint efforts solved at every evaluation ---
  bool has_constraints() const { return !constraints_.empty(); }
  int num_multipliers() const { return constraints_.num_multipliers(); }
  /// Velocity-level residual of every constraint at (t, x), |g - target| (max norm); fills ws.
  double ConstraintResidual(double t, const double* x, Workspace& ws) const;
  /// Per multiplier component: the rate of its constraint along the derivatives of the slots
  /// `d_slots` (CalcTangent's): the rows of the constraints' Jacobian, for the linearisation.
  void ConstraintRates(const double* d_slots, double* out) const { constraints_.ConstraintRates(d_slots, out); }
  /// Names of the constraints ("S1_held.rigid", "J2.cut"), one per constraint group.
  std::vector<std::string> constraint_names() const;

  /// A workspace of this model; evaluations into it run `code` once it is loaded (which must be
  /// this model's and outlive the workspace), else the interpreter: the same bits either way.
  Workspace MakeWorkspace(const GeneratedRhs* code = nullptr) const;
  Eigen::VectorXd MakeInitialState() const;

  /// C++ source of the right-hand side, generated from the plan: one straight-line function
  /// `multibond_rhs(t, x, xdot, w, moduli, ctx)` with every offset a literal and every number
  /// through code::Num (a literal unless a code::ValueScope is open).
  std::string GenerateSource(bool with_fast = true) const;
  std::string GenerateBody() const;
  /// The right-hand side as the JIT compiles it: its numbers in `values` (which the code reads
  /// as src->values), so that the text depends only on the model's structure (and on which
  /// coefficients are exactly 0 or +-1). One unit (`multibond_rhs` and `multibond_rhs_fast`)
  /// when the body is one function (GenerateBodies), else units at instruction boundaries, each
  /// `multibond_part(t, x, xdot, w, moduli, ctx)`, to be called in order. One function keeps
  /// its numbers as literals unless `value_table` (GenerateOptions::value_table).
  struct GeneratedUnits {
    std::vector<std::string> units;
    std::vector<double> values;
  };
  GeneratedUnits GenerateUnits(std::size_t unit_chars, bool value_table = false) const;
  /// The body of the right-hand side (GenerateBody); when it is longer than kOneFunctionChars
  /// (the differential's is 33 KB; with values from a table GCC takes 1.5 times as long on one
  /// function as with literals) or than `unit_chars`, cut into units of about `unit_chars`, each into functions of about
  /// kFunctionChars.
  std::vector<std::vector<std::string>> GenerateBodies(std::size_t unit_chars) const;
  static constexpr std::size_t kOneFunctionChars = 40 * 1024, kFunctionChars = 8 * 1024;
  /// C++ source of the constraint system's sparse L D L^T for the pattern fixed at compile time
  /// (ConstraintFactor::GenerateSource): `multibond_ldlt_factor(b, v, factor)` (1 on success)
  /// and `multibond_ldlt_solve(rhs, lambda, factor, y)`.
  std::string GenerateFactorSource() const;
  /// C++ source of B's columns (ConstraintSolver's AssembleConstraintMatrix):
  /// `multibond_bcols(x, lin, mod, b, v)`.
  std::string GenerateColumnsSource() const;
  /// C++ source of the constraints' tangent pass and of what the multipliers reach (steps 2 and 4
  /// of ConstraintSolver::Solve): `multibond_tangent` and `multibond_react`.
  std::string GenerateTangentSource() const;
  std::string GenerateReactSource() const;
  /// Why generated code cannot evaluate this model ("" when it can): algebraic loops solved
  /// around the plan, or a law used backwards that reaches the ideal constraints.
  std::string GeneratedCodeRefusal() const;
  /// With ideal constraints: the constraint system has an L D L^T of its own (GenerateFactorSource).
  bool has_constraint_factor() const { return constraints_.factor().factor_size() > 0; }
  CompiledModel(const CompiledModel&) = delete;
  CompiledModel& operator=(const CompiledModel&) = delete;

  const BondGraph& graph() const { return graph_; }
  // --- the parts, read-only (docs/design.md, "The compiled model's parts and passes") ---
  const SlotTable& slot_table() const { return slots_; }
  const plan::Plan& plan() const { return plan_; }
  const TornLoops& torn_loops() const { return loops_; }
  const SwitchSet& switch_set() const { return events_; }
  const Structure& structure() const { return structure_; }
  const CausalAssignment& causality() const { return causality_; }
  // --- the state layout (compile/state_layout.h) ---
  const std::vector<std::string>& state_names() const { return layout_.state_names(); }
  const std::vector<std::string>& state_units() const { return layout_.state_units(); }
  const std::vector<StateBlock>& state_blocks() const { return layout_.blocks(); }
  int num_instructions() const { return plan_.size(); }
  /// Which state derivatives can depend on which states, from the plan (an instruction's outputs
  /// depend on all its inputs, component by component for sums, copies and diagonal
  /// coefficients): the structure of the Jacobian, never missing an entry that the numbers can
  /// make nonzero. Null for a model with ideal constraints (the multipliers couple everything
  /// they reach) or with solved algebraic loops (so do the torn unknowns).
  /// Found on the first call, not at compile time: only the Newton matrix of an implicit solver
  /// needs it (and a constrained model's is dense, n x n: not for `check`, nor an explicit run).
  const JacobianPattern* jacobian_pattern() const;
  /// The wall time of each compile pass, in order [s]: causality (structure, causality, the
  /// constraint graph), compile_plan (slots, layout, energy account, plan), constraints (the
  /// ideal-constraint solver's tables, switching elements, the independent set), generate_code.
  const std::vector<std::pair<std::string, double>>& compile_seconds() const { return compile_seconds_; }
  /// The algebraic loops solved at every evaluation (CompileOptions::solve_algebraic_loops): each
  /// by its elements and the variable it is torn at, the unknown of its linear system.
  using AlgebraicLoop = TornLoops::Loop;
  const std::vector<AlgebraicLoop>& algebraic_loops() const { return loops_.loops; }
  /// How many of the plan's instructions depend on the loops' unknowns: each evaluation runs the
  /// plan once and these once more per unknown, plus once.
  int num_loop_instructions() const { return static_cast<int>(loops_.closure.size()); }
  /// A solved loop runs through a formula: each evaluation solves it by Newton's method.
  bool has_nonlinear_loops() const { return loops_.nonlinear; }

  /// Looks up "<element>.e|f|e1|f1|e2|f2|p|q" or an auxiliary state's name (StateLayout::FindVariable).
  std::optional<VariableRef> FindVariable(const std::string& name) const { return layout_.FindVariable(name); }
  /// Reads a variable after CalcDerivatives has filled `ws` at state x.
  void Read(const VariableRef& v, const double* x, const Workspace& ws, double* out) const {
    StateLayout::Read(v, x, ws.slots.data(), out);
  }

  // --- formulas (compile/formulas.cc) ---
  bool has_formulas() const { return !plan_.programs.empty(); }
  /// Evaluates the plan at (t, x) with the interpreter and names the first formula whose value is
  /// not finite although what it reads is: "the formula of spring (effort law) `k/q` gives inf at
  /// t = 1.5 s (reads spring.q = 0)". Empty if none (the cause is elsewhere). Allocates: for the
  /// failure path only.
  std::string DiagnoseFormulas(double t, const double* x, Workspace& ws) const;
  /// After an evaluation filled `ws`: the first resistor given by a formula and not marked
  /// `active` that delivers power (sigma e f < 0), as a message naming it; empty if none.
  std::string FindActiveResistor(const Workspace& ws) const;

  // --- switching elements and events (compile/switching.cc; docs/events.md) ---
  const SwitchTable& switches() const { return events_.switches; }
  /// The event functions: the switching elements' (SwitchTable::Roots, 2 per element, events
  /// where they cross downwards), then the switching functions of formulas that are not of time
  /// alone (KinkTable::Roots, events where they cross either way).
  int num_event_functions() const { return events_.switches.num_roots() + events_.kinks.num_roots(); }
  int num_switch_event_functions() const { return events_.switches.num_roots(); }
  /// Their values at (t, x) in the modes of `ws` (an evaluation fills ws).
  void CalcEventFunctions(double t, const double* x, Workspace& ws, double* g) const;
  /// The kinks and switches of formulas (compile/kinks.h; docs/events.md).
  const KinkTable& kinks() const { return events_.kinks; }
  /// The kinks whose switching function is zero (within 1e-12) at (t, x), each described (the
  /// formula, where it is, the switching function): an operating point on a kink, where a
  /// tangent is the mean of the one-sided slopes. Evaluates ws at (t, x); allocates.
  std::vector<std::string> KinksAt(double t, const double* x, Workspace& ws) const;
  /// At an event where the kink root `r` (KinkTable::root_kink) crossed: a `sign` of the state
  /// that the motion drives back to its surface from both sides starts to slide (kind `slide`),
  /// one that slides leaves (`leave`), any other kink is a change of branch (`kink`).
  EventRecord HandleKink(double t, const double* x, Workspace& ws, int r) const;
  /// The modes of the signs of the state at the start of a run (x at t0): locked at the side of
  /// their switching function, sliding if it is zero there and the motion holds it, else free;
  /// `hysteresis`: how far beyond its surface a locked sign's switching function goes before its
  /// event (the run's absolute tolerance: noise of the integration does not flip the branch).
  void InitializeKinks(double t, const double* x, Workspace& ws, double hysteresis) const;
  /// The modes at the start: contacts open where their gap is > 0; frictions slip where their
  /// relative flow is not zero, else stick if the static limit holds.
  void InitializeModes(double t, double* x, Workspace& ws) const;
  /// At an event at (t, x), where the event functions `roots` (1 = crossed) crossed zero: the
  /// elements' new modes, impacts (x jumps; what they dissipate goes to the element's
  /// dissipation state), appended to `log`. `rest_time`: a rebound whose flight would be
  /// shorter stays in contact (impacts accumulating). x is left on the constraints that hold.
  void HandleEvents(double t, double* x, Workspace& ws, const int* roots, double rest_time, std::vector<EventRecord>& log) const;
  /// The times in (t0, t1) where a source or a friction's normal force jumps or kinks, or a
  /// formula's switching function of time alone changes sign (sampled at most `resolution`
  /// apart, KinkTable::TimeEvents): the time events, ascending.
  std::vector<TimeEvent> TimeEvents(double t0, double t1, double resolution) const;
  /// The times in (t0, t1] of the sources' gentle table corners (TimeFunction::Waypoints), and
  /// t1 itself if a source has a corner there, ascending and once each: a step ends there and the
  /// integration goes on, no restart.
  std::vector<double> Waypoints(double t0, double t1) const;

  // --- directional derivatives (compile/tangent.cc), for the linearisation ---
  /// One component of a source (Se, Sf, a mechanism's drive): an input of the linear model.
  struct SourceInput {
    std::string name;  ///< the element's name, with ".x" / ".1" for a component of a vector source
    std::string unit;
    int element;
    int instruction;  ///< in the plan
    int component;
  };
  /// Every source component, in plan order (the order of CalcTangent's du).
  std::vector<SourceInput> SourceInputs() const;
  /// False (and why) for what CalcTangent does not derive: ideal constraints whose equations read
  /// a law used backwards (its second derivative). Everything else is derived (solved algebraic
  /// loops too, by the implicit function theorem).
  bool can_linearize(std::string* why) const;
  /// The derivative of every effort and flow (dws.slots) and of dx/dt (dxdot) along a direction
  /// dx of the state and du of the inputs (SourceInputs' order; null: zero), at (t, x), where
  /// CalcDerivatives has filled `ws`; `dws` from MakeWorkspace (its moduli receive dM). Exact:
  /// the plan's tangent rules, formulas differentiated step by step; with ideal constraints the
  /// multipliers' derivative too (the constraint equations differentiated once more, by the
  /// plan's second-order rules). Allocates (not the hot path). `ws` is evaluated again at (t, x).
  void CalcTangent(double t, const double* x, const double* dx, const double* du, double* dxdot, Workspace& ws,
                   Workspace& dws) const;

  // --- energy account (compile/energy_account.h: from the time and the state) ---
  /// An I's or C's stored energy at (t, x). The time matters to a storage law that reads it
  /// (directly or through a signal); the overloads without it evaluate at t = 0, which is the
  /// same for every other model.
  double StoredEnergy(int element, double t, const double* x) const { return energy_.StoredEnergy(element, t, x); }
  double StoredEnergy(int element, const double* x) const { return StoredEnergy(element, 0.0, x); }
  /// Every I's and C's stored energy in one pass (what an output row needs): per_term receives
  /// num_energy_terms() values, in the order energy_term(element) gives; returns the sums.
  using EnergyTotals = EnergyAccount::Totals;
  EnergyTotals StoredEnergies(double t, const double* x, double* per_term) const { return energy_.StoredEnergies(t, x, per_term); }
  EnergyTotals StoredEnergies(const double* x, double* per_term) const { return StoredEnergies(0.0, x, per_term); }
  int num_energy_terms() const { return energy_.num_terms(); }
  int energy_term(int element) const { return energy_.term(element); }  ///< or -1
  double KineticEnergy(double t, const double* x) const { return energy_.Kinetic(t, x); }
  double PotentialEnergy(double t, const double* x) const { return energy_.Potential(t, x); }
  /// At a time event t (where the integration stops and restarts): adds to each modulated storage
  /// element's modulation_work the jump of its stored energy there, E(t+, x) - E(t-, x) one double
  /// either side (a switch such as sign(t - t1), whose power is a Dirac that no integral sees; 0 to
  /// rounding where E is continuous). compile/modulated_storage.cc; the simulator calls it.
  void BookModulationJumps(double t, double* x) const;
  double KineticEnergy(const double* x) const { return KineticEnergy(0.0, x); }
  double PotentialEnergy(const double* x) const { return PotentialEnergy(0.0, x); }
  double Work(const double* x) const { return energy_.Work(x); }              ///< total work of all sources and modulations so far
  double Dissipated(const double* x) const { return energy_.Dissipated(x); }  ///< total dissipated in all resistors so far
  bool has_energy_account() const { return options_.energy_account; }

  // --- symbolic view of the plan, for `multibond equations` ---
  int slot_class_of_effort(int bond) const { return slots_.effort_class[bond]; }
  int slot_class_of_flow(int bond) const { return slots_.flow_class[bond]; }
  int num_slot_classes() const { return slots_.num_classes(); }
  const Definition& definition(int slot_class) const { return plan_.definitions[slot_class]; }
  /// A readable name for a slot class: "j.f", "spring.e", "gear.f2".
  const std::string& slot_class_name(int slot_class) const { return slots_.class_names[slot_class]; }
  /// The slot class each state block's derivative reads (e for I, f for C and integrals).
  int derivative_source(const StateBlock& b) const { return layout_.derivative_source(b); }
  double derivative_sign(const StateBlock& b) const { return layout_.derivative_sign(b); }

 private:
  CompiledModel() = default;
  /// The passes below, in order (docs/design.md, "The compiled model's parts and passes").
  void Build();
  /// Slot classes: the efforts and flows that share a workspace slot (0- and 1-junctions,
  /// identity transformers), their offsets, sizes, units and names; the multipliers' offsets.
  void AssignSlots();
  /// The moduli of the MTF and MGY; returns per element its index in plan_.moduli or -1 (plan_builder.cc).
  std::vector<int> PlanModuli();
  /// One instruction per computed slot class, unordered, with the classes each reads and the
  /// instruction that writes each class (plan_builder.cc); fills plan_.definitions.
  struct Draft {
    std::vector<plan::Instr> instrs;
    std::vector<std::vector<int>> reads;
    std::vector<int> writer;
  };
  Draft EmitInstructions(const std::vector<int>& modulus_of);
  /// Orders a draft by the causal dependencies into plan_.instrs (throws on an algebraic loop, or tears
  /// it with solve_algebraic_loops: loops_.tears, loops_.closure, loops_.loops). Returns per plan
  /// instruction the slot classes it reads and the one it writes (plan_builder.cc).
  struct PlanDeps {
    std::vector<std::vector<int>> reads;
    std::vector<int> writes;
  };
  PlanDeps OrderPlan(const Draft& draft);
  // --- Formulas (compile/formulas.cc; docs/model-format.md, "Expressions") ---
  /// Slot classes of one slot beyond the bonds': each signal, and the rates and outputs of the
  /// signal states (`pid.u`); made at the end of AssignSlots.
  void AssignSignalSlots();
  int AddSignalClass(const std::string& name, const std::string& unit, bool visible);
  /// The unit of a formula from the units its names have among the slot classes made so far
  /// (signals, efforts and flows; core/units.h's analysis), "" when it cannot be told (a name of
  /// no unit, a state, a unit mismatch, a scale that a number changed).
  std::string FormulaUnitText(const Formula& f) const;
  /// A formula's own names (an element's law: q, p, e, f) and what it is, for messages.
  struct FormulaScope {
    const Formula* formula = nullptr;  ///< where it stands in the file
    int element = -1;
    std::string what;  ///< "the effort law of spring"
  };
  /// Compiles a tree (own names already substituted) into a program reading what the resolver
  /// of formulas' names finds; CompileFormula appends it to plan_.programs and returns its index.
  expr::Program CompileFormulaProgram(const expr::NodePtr& root, const FormulaScope& scope) const;
  int CompileFormula(const expr::NodePtr& root, const FormulaScope& scope);
  /// The switching functions of the tree's kinks into events_.kinks (compile/kinks.h); returns the tree
  /// to compile, its `sign`s of the state reading their slide slots (compile/sliding.cc).
  expr::NodePtr CollectKinks(const expr::NodePtr& root, const FormulaScope& scope);
  /// A name of the engine's trees ("#x3", "#w12") as the variable it is, for messages.
  std::string InternalName(const std::string& internal) const;
  /// The instruction that computes one slot class from formulas, with the classes it reads.
  struct FormulaInstr {
    plan::Instr in;
    int out_class;
    std::vector<int> reads;
    Definition def;
  };
  /// True if the element's equations are formulas (then FormulaInstructions makes them).
  static bool HasFormulas(const Element& e);
  std::vector<FormulaInstr> FormulaInstructions(int element);
  /// The signals' and signal states' instructions.
  std::vector<FormulaInstr> SignalInstructions();
  /// kExpr over programs `first` .. `first + n` into class `out`.
  FormulaInstr MakeFormulaInstr(int element, int out_class, int first, int n);
  /// The stored energy of a storage element given by formulas, whose state starts at `state`:
  /// its `energy:` formula or its law's closed-form integral as a program of x, else its law as
  /// a program of x[0] (EnergyAccount integrates it); nullopt if its parameter gives its energy.
  std::optional<EnergyAccount::FormulaEnergy> StoredEnergyFormula(int element, int state) const;
  // --- Storage modulated by time, signals or other states (compile/modulated_storage.cc) ---
  /// The stored energy E(q, s) of a C or I whose law reads t, signals or states other than its
  /// own (s), and the power its modulation puts in, dE/dt at fixed q = sum_s dE/ds ds/dt: the
  /// derivative of E in each name it reads times that name's rate (a state's derivative is a
  /// slot of the plan; a signal's rate is its own such sum), so that the energy account books
  /// it as work (`<element>.modulation_work`).
  struct Modulation {
    expr::NodePtr energy;  ///< E in the model's names (own state `q`/`p`), signals written out: a function of t and x
    expr::NodePtr power;   ///< dE/dt at fixed own state, reading states and the slots of their rates
    std::optional<Diagnostic> refusal;  ///< why its work cannot be booked; thrown after OrderPlan (loops first)
  };
  /// True if the law or energy of a C or I given by formulas reads anything but its own state
  /// (`q`/`p` or its state's full name), pi and numbers.
  static bool IsModulated(const Element& e);
  /// The slot class of each modulated storage element's power (with the energy account), made
  /// after the signals' (AssignSlots); the layout gives each a modulation_work state.
  void AssignModulationSlots();
  /// modulation_: each modulated element's energy and power (after the layout, before the
  /// energy account).
  void AnalyzeModulatedStorage();
  /// The power's instruction of a modulated element, if it has a power class (the kC/kI case of
  /// FormulaInstructions; a refused one computes 0 until RefuseUnbookedModulation throws).
  std::optional<FormulaInstr> ModulationPowerInstr(int element, int state, const Formula& given);
  /// Throws the first refusal of modulation_ (after OrderPlan, which reports algebraic loops).
  void RefuseUnbookedModulation() const;
  std::unordered_map<int, Modulation> modulation_;  ///< per modulated C or I

  // The plan's data and its operation table (operations.h).
  using Op = plan::Op;
  using Instr = plan::Instr;
  using ModulusEval = plan::ModulusEval;
  using CodeNames = plan::CodeNames;
  using Gather = StateGather;

  /// The moduli at x; with `derivative`, their time derivatives dM/dt given x = dx/dt (every
  /// modulus is linear in its orientation state; constants give zero; no inverses).
  void EvalModuli(const double* x, double* moduli, bool derivative = false) const;
  /// The plain evaluation of the plan (interpreter or generated code) and the gathers.
  void EvalPlan(double t, const double* x, double* xdot, Workspace& ws) const;
  /// One state block's derivative from the slots `w` (and x, for orientations).
  static void EvalGather(const Gather& gt, const double* x, const double* w, double* xdot);
  /// The tangent pass with the multipliers held (compile/tangent.cc): the slots' derivatives into
  /// d_slots, the moduli's into d_moduli, dx/dt's into dxdot; `time`: the direction includes
  /// d/dt of the sources (the constraints' own tangent pass), else a state and input direction.
  void TangentPass(double t, const double* x, const double* dx, bool time, const double* du, double* dxdot, const Workspace& ws,
                   std::vector<double>& d_slots, std::vector<double>& d_moduli, std::vector<double>* scratch = nullptr) const;
  /// One state block's derivative's derivative along dx, from the slots w and their derivatives d.
  static void TangentGather(const Gather& gt, const double* x, const double* dx, const double* w, const double* d, double* dxdot);
  /// The tables the plan's instructions refer to (coefficients, sum terms, source functions).
  plan::Tables tables() const { return plan_.tables(); }
  /// One instruction of the plan (the operation table's interpreter kernel): reads slots from
  /// `win`, writes its output slot in `wout` (the same array in the plain pass).
  void Exec(const Instr& in, double t, const double* x, const double* win, double* wout, const double* mod,
            const double* lambda) const {
    plan::Exec(in, plan::ExecArgs{t, x, win, wout, mod, lambda, tables()});
  }
  /// Ideal constraints (constraints.cc): the graph rewriting before the plan (declares each
  /// constraint to constraints_), then the solver's tables from the ordered plan and its
  /// independent set at the initial state.
  void PrepareConstraintGraph();
  void BuildConstraints(const std::vector<std::vector<int>>& plan_reads, const std::vector<int>& plan_writes);
  void FindIndependentConstraints();
  /// A constrained evaluation: the plan at lambda = 0 (step 1), then the solver (steps 2-4).
  /// `share`: split a statically indeterminate reaction between redundant constraints as an
  /// elastic structure would (ConstraintFactor::Share); the motion does not depend on it, so the
  /// integrator's evaluations skip it and the output times' do it.
  void CalcConstrained(double t, const double* x, double* xdot, Workspace& ws, bool share) const;
  /// What the constraint solver reads of this model at run time; `sources` as Sources() makes it;
  /// the generated steps of `code` when it is loaded.
  struct SourceTable;
  ConstraintSolver::PlanView ConstraintPlan(const SourceTable* sources, const GeneratedCode* code = nullptr) const;
  /// jacobian_pattern_ from the plan's reads and writes (compile/jacobian_pattern.cc).
  void BuildJacobianPattern() const;

  BondGraph graph_;
  CompileOptions options_;
  Structure structure_;
  CausalAssignment causality_;
  SlotTable slots_;  ///< the slot classes (compile/slot_table.h)
  plan::Plan plan_;  ///< the instructions and their tables (compile/plan.h)

  std::vector<std::pair<std::string, double>> compile_seconds_;
  mutable std::once_flag jacobian_once_;
  mutable JacobianPattern jacobian_pattern_;
  /// Algebraic loops torn (solve_algebraic_loops; compile/torn_loops.h).
  using Tear = TornLoops::Tear;
  TornLoops loops_;
  /// The plan with the torn variables solved for (EvalPlan on a model with algebraic loops).
  void EvalTorn(double t, const double* x, Workspace& ws) const;

  /// The generated right-hand side at (t, x), the moduli already in ws; `fast`: into registers
  /// where the code has a function for it.
  /// The generated code that evaluates into `ws` now: null while it compiles, or without any.
  static const GeneratedCode* Loaded(const Workspace& ws);
  void RunGenerated(const GeneratedCode& g, bool fast, double t, const double* x, double* xdot, Workspace& ws) const;
  /// A state-reading instruction's kernel (the table's emit_state: the flow M^-1 of a momentum
  /// or displacement) as C++, from the input expressions src(k) to the outputs dst(k).
  void EmitStateKernel(const Instr& in, const std::function<std::string(int)>& src,
                       const std::function<std::string(int)>& dst, std::string& o) const;
  /// One plan instruction as C++, appended to o; levers_done: the lever arms already declared
  /// in the enclosing scope. A rotated inertia's kernel reads its R from x[] whatever names.x.
  void EmitInstr(const Instr& in, std::string& o, std::set<std::string>& levers_done, const CodeNames& names) const;
  void EmitInstr(const Instr& in, std::string& o, std::set<std::string>& levers_done) const {
    EmitInstr(in, o, levers_done, CodeNames{});
  }
  /// The right-hand side's functions around `body` (GenerateSource).
  std::string WrapSource(const std::string& body, bool with_fast) const;
  /// A state block's derivative from the slots (EvalGather) as C++; `reads` gets the slots read.
  void EmitGather(const Gather& gt, std::string& o, std::vector<int>* reads = nullptr) const;
  /// The sources' time functions as generated code calls them (its struct MbSources).
  struct SourceTable {
    const void* fns;
    double (*eval)(const void*, int, double);
    double (*deriv)(const void*, int, double);
    const void* programs;  ///< the formulas' programs and the solver of laws used backwards (kSolve)
    double (*solve)(const void*, int, int, int, double, double, const double*, double*);
    const double* values;  ///< the numbers of generated code (GenerateUnits)
    /// A formula's forward-mode derivative (expr::RunTangentIndexed), for the constraints' passes.
    double (*tangent)(const void*, int, double, const double*, const double*, double, const double*, const double*);
  };
  /// `values`: the numbers of the generated code that calls them (GeneratedCode::values).
  SourceTable Sources(const double* values = nullptr) const;

  /// Switching elements (compile/switching.cc): the table from the constraints (after
  /// BuildConstraints), the modes' prescribed multipliers before each solve, dg/dt along the
  /// motion of one constraint, the stored energy (kinetic + potential) of a state.
  void BuildSwitches();
  void PrescribeSwitches(double t, Workspace& ws) const;
  double ConstraintRate(double t, const double* x, Workspace& ws, int lambda) const;
  double StoredEnergyTotal(const double* x) const;
  /// Sliding (compile/sliding.cc): whether some sign slides in `ws`; the slide slots of one;
  /// the rates of switching functions along the motion; the equivalent values of those that
  /// slide, into their slots.
  bool Sliding(const Workspace& ws) const;
  /// Kink `kink`'s mode and held value (Workspace::kink_modes; its slots m = 0, s = value, or
  /// m = 1, s = 0 when free).
  void SetSlide(Workspace& ws, int kink, Workspace::KinkMode mode, double value) const;
  /// kink < 0: the evaluation and tangent pass along the motion into ws.slide; kink >= 0: its
  /// switching function's rate from the last such pass.
  double SwitchingRate(double t, const double* x, Workspace& ws, int kink) const;
  /// The rates of kink `kink`'s switching function with its sign locked at +1 and at -1 (left
  /// locked at -1).
  std::pair<double, double> RatesEitherSide(double t, const double* x, Workspace& ws, int kink) const;
  void SolveSliding(double t, const double* x, Workspace& ws) const;
  SwitchSet events_;  ///< switching elements, kinks and sliding signs (compile/switch_set.h)

  /// Ideal constraints: their declarations, tables and solver (compile/constraint_solver.h);
  /// empty without constraints. Its generated code (GenerateCode) is its own.
  using ConstraintGroup = ConstraintSolver::Group;
  ConstraintSolver constraints_;

  /// The state vector's blocks, names, units, initial values and gathers, and the lookup of
  /// named variables (compile/state_layout.h); built after the slots.
  StateLayout layout_;
  /// Each I's and C's stored energy, the work and dissipation totals (compile/energy_account.h).
  EnergyAccount energy_;
  struct Passive {
    int element, effort, flow;  ///< effort and flow slots of its bond
    double sigma;
  };
  std::vector<Passive> passive_;  ///< resistors given by formulas that must not deliver power
};

}  // namespace multibond
