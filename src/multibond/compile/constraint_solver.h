#pragma once
/// \file
/// The ideal-constraint solver (docs/design.md, "Ideal constraints"): the constraint efforts and
/// flows (Lagrange multipliers) of a compiled model, solved at every evaluation around its plan.
///
/// A constraint is a source of unknown value (a multiplier): an effort source of unknown effort
/// lambda, from an Sf marked `constraint` or from the cut of an inertia in derivative causality
/// (two sources, one on each side, sharing lambda); or, dually, a flow source of unknown flow,
/// from the cut of a compliance in derivative causality. Its equation: g = sum_k s_k (y_k -
/// v_k(t)) = 0 over its members' conjugate variables y_k (flows for an effort multiplier,
/// efforts for a flow multiplier): lambda g is the power the constraint delivers. The power
/// balance of the junction structure gives g = B^T H x + (terms without the storage states),
/// with B the storage-state rate per unit multiplier (momenta and displacements) and H the
/// storage elements' energy Hessian (M^-1 for an inertia, K for a compliance). The solver is
/// declared by the graph pass (Add), numbered with the slots (AssignMultipliers, MultiplierOf),
/// built from the ordered plan (Build: every table it needs is its own), then given the initial
/// state (FindIndependent). At every evaluation the model runs its plan at lambda = 0 (step 1)
/// and the solver does the rest (Solve):
///   2. a tangent pass: dg/dt at lambda = 0, exactly (no finite differences);
///   3. B's columns (from each multiplier's closure in the plan), W = B^T H B, and
///      W lambda = dv/dt - dg/dt|lambda=0 (ConstraintFactor);
///   4. what the multipliers reach, again with lambda: dx/dt and every effort and flow.
/// ProjectMomenta removes the drift of g after a step; Residual measures it.
/// The model's parts it reads are named in BuildInput (at compile time) and PlanView (at run
/// time); the workspace it writes is the model's (Workspace::lambda and Workspace::con).

#include <memory>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "multibond/compile/constraint_factor.h"
#include "multibond/compile/expr_program.h"
#include "multibond/compile/operations.h"
#include "multibond/core/time_function.h"

namespace multibond {

class BondGraph;
struct StateBlock;
struct StateGather;
struct Workspace;

class ConstraintSolver {
 public:
  /// An ideal constraint: an Sf marked `constraint` (now an effort source of unknown effort), a
  /// pair of such sources that cut the bond of an inertia in derivative causality, or a pair of
  /// flow sources of unknown flow that cut the bond of a compliance in derivative causality.
  /// Its equation: g = sum over members of s_k (y_k - v_k(t)) = 0, y_k the member's flow (effort
  /// multipliers) or effort (flow multipliers), s_k = +1 if the member's bond points away from it
  /// (lambda g is the power it delivers).
  struct Group {
    std::string name;
    int element = -1;  ///< the constraint source (or, for a cut, the storage element)
    int size = 0;
    int lambda = 0;    ///< offset in Workspace::lambda
    /// The multiplier is a flow (a compliance's cut: its members' efforts are constrained), not
    /// an effort (a rigid coupling, an inertia's cut: their flows are constrained).
    bool imposes_flow = false;
    /// slot: the member's bond until Build, then the slot of its constrained variable (its flow,
    /// or its effort when imposes_flow). target: until Build 0 (the Sf's source functions are the
    /// flow's target) or -1 (none: a cut's sides agree), then the offset of its target functions
    /// in the solver's own table, or -1.
    struct Member {
      int slot;
      double sign;
      int target;
    };
    std::vector<Member> members;
    std::vector<int> starts;    ///< plan indices of its multiplier instructions (two for a cut)
    std::vector<int> closure;   ///< plan indices reached by its multiplier
    /// The storage gathers (indices in the gathers) whose rate it reaches: momenta, and
    /// displacements (a compliance's cut, or an effort through a gyrator); B's rows.
    std::vector<int> momenta;
  };

  /// What Build reads of the compiled model: the ordered plan with the slot classes each
  /// instruction reads and writes, the state blocks and their gathers (parallel), the slot
  /// classes, and the graph (the constraints' elements: targets, compliances, locations).
  struct BuildInput {
    const BondGraph& graph;
    const std::vector<plan::Instr>& plan;
    const std::vector<std::vector<int>>& plan_reads;  ///< per instruction: the slot classes it reads
    const std::vector<int>& plan_writes;              ///< per instruction: the slot class it writes
    const std::vector<StateBlock>& blocks;
    const std::vector<StateGather>& gathers;          ///< one per state block
    const std::vector<int>& class_offset;             ///< per slot class: its first slot
    const std::vector<int>& class_size;
    const std::vector<std::string>& class_names;
    const std::vector<int>& flow_class;               ///< per bond: its flow's slot class
    const std::vector<int>& effort_class;             ///< per bond: its effort's slot class
    int num_slots;
    const std::vector<expr::Program>& programs;       ///< the formulas' programs (kExpr, kSolve)
    const std::vector<std::string>& state_names;      ///< per state entry
    int num_states;
  };

  /// The generated code of steps 2-4 and of the factor (compiled and owned by the model, which
  /// passes it per call in PlanView::generated; null: interpreted).
  /// tangent: (t, x, xdot, slots, dslots, moduli, dmoduli, sources);
  /// react: (t, x, xdot, slots, moduli, lambda, sources); columns: (t, x, lin, moduli, b, v,
  /// slots, a zero state, sources).
  using GeneratedTangent = void (*)(double, const double*, const double*, const double*, double*, const double*,
                                    const double*, const void*);
  using GeneratedReact = void (*)(double, const double*, double*, double*, const double*, const double*, const void*);
  using GeneratedColumns = void (*)(double, const double*, double*, const double*, double*, double*, const double*, const double*,
                                    const void*);
  struct Generated {
    GeneratedTangent tangent = nullptr;
    GeneratedReact react = nullptr;
    GeneratedColumns columns = nullptr;
    ConstraintFactor::GeneratedFactor factor = nullptr;
    ConstraintFactor::GeneratedSolve solve = nullptr;
  };

  /// What the run-time methods read of the compiled model (made per call: references only).
  struct PlanView {
    const std::vector<plan::Instr>& plan;
    plan::Tables tables;  ///< coefficients, sum terms, the plan's source functions
    const std::vector<plan::ModulusEval>& moduli;
    const std::vector<StateGather>& gathers;
    /// One state block's derivative from the slots w (and x, for orientations).
    void (*gather)(const StateGather& gt, const double* x, const double* w, double* xdot);
    const void* sources;  ///< the source functions as the generated code calls them
    int num_states;
    const Generated* generated = nullptr;  ///< steps 2-4 and the factor as generated code, or null
  };

  // --- declared before the plan ---
  /// A constraint of the graph pass: its name, element and members (bond, sign, target 0 or -1);
  /// imposes_flow: its multiplier is a flow (Group::imposes_flow).
  void Add(std::string name, int element, std::vector<Group::Member> members, bool imposes_flow = false);
  /// One multiplier per dimension of each constraint (its first member's bond's dimension), in
  /// order of declaration.
  void AssignMultipliers(const std::vector<int>& bond_dim);
  /// The offset in Workspace::lambda of the constraint that `bond` is a member of (0 if none).
  int MultiplierOf(int bond) const;

  // --- built from the plan ---
  /// The tables: members' slots and targets, each multiplier's closure and the storage states it
  /// reaches, B's sparsity, the tangent pass, what the multipliers reach. Throws ModelError
  /// (`constraint.unsupported`: a multiplier that reaches a constrained variable (index 1), an
  /// orientation's or integral's rate, or passes a resistor (its B would not be the adjoint of
  /// its constraint's dependence on the states); `param.shape`: compliances that do not match
  /// the constraint's components; `expr.unsupported`: a formula that the constrained variables
  /// depend on or that a multiplier reaches and that the solver cannot take, CheckFormulas).
  void Build(const BuildInput& in);
  /// The constraints independent at the initial state x (the rest are redundant there), and the
  /// factor's pattern. `ws` holds the plan's evaluation at x with lambda = 0.
  void FindIndependent(const PlanView& view, const double* x, Workspace& ws);
  /// Sizes Workspace::lambda and Workspace::con (MakeWorkspace).
  void SizeScratch(Workspace& ws, int num_slots, int num_moduli, int num_states) const;

  // --- run time (no allocation) ---
  /// Steps 2-4, after the model's step 1: ws holds the plan at (t, x) with lambda = 0, xdot its
  /// dx/dt, ws.con.dmoduli the moduli's time derivatives. Writes lambda, the slots they reach
  /// and dx/dt. `share`: split a statically indeterminate reaction between redundant
  /// constraints as an elastic structure would (ConstraintFactor::Share); the motion does not
  /// depend on it, so the integrator's evaluations skip it and the output times' do it.
  void Solve(const PlanView& view, double t, const double* x, double* xdot, Workspace& ws, bool share) const;
  /// The storage states of x onto the constraints by the energy metric H: x += B mu with
  /// W mu = -g(t, x), exact in one solve (g is affine in the storage states along B): momenta
  /// onto the velocity constraints, displacements onto a compliance's cut. ws holds the plan at
  /// (t, x) with lambda = 0; lambda is left zero.
  void ProjectMomenta(const PlanView& view, double t, double* x, Workspace& ws) const;
  /// An impact's impulse (switching elements, docs/events.md): the storage states jump by B mu,
  /// with W mu = -g on the constraints that hold and target - g on multiplier `index` (whose
  /// relative flow jumps to `target`), the other prescribed ones left out. ws holds an
  /// evaluation at (t, x); lambda is left zero.
  void ApplyImpulse(const PlanView& view, double t, double* x, Workspace& ws, int index, double target) const;
  /// g - target(t) per multiplier from filled slots (the constraints' values), into `out`.
  void Values(double t, const double* w, double* out) const { ConstraintValues(t, w, out); }
  /// |g - target| (max norm) from ws, which holds the plan at (t, x) with lambda = 0.
  double Residual(double t, Workspace& ws) const;

  // --- the linearisation (compile/tangent.cc) ---
  /// Per multiplier component: sum over its members of s_k d[slot_k], the rate of its constraint
  /// along the derivatives `d` of the slots (no targets).
  void ConstraintRates(const double* d, double* out) const;
  /// The multipliers' response to a change r of the constraint equations' right-hand side at
  /// (t, x), where the last Solve ran: dlambda = W^-1 r, then what it reaches: the slots' response
  /// into `lin` (zero on entry, the slots' size) and the storage rates' response added to dxdot.
  /// ws.lambda is left as it was. Allocates (not the hot path).
  void Respond(const PlanView& view, double t, const double* x, const double* r, Workspace& ws, double* dlambda, double* lin,
               double* dxdot) const;

  // --- what it holds ---
  bool empty() const { return groups_.empty(); }
  /// Whether formulas reach the constraints (their tangent plan or closures: CheckFormulas), and
  /// whether generated code can do their part (it calls the interpreter's RunTangent back).
  bool reads_formulas() const { return formulas_; }
  bool formulas_emittable() const { return emittable_; }
  int num_multipliers() const { return num_lambda_; }
  std::vector<std::string> names() const;  ///< one per constraint
  const std::vector<Group>& groups() const { return groups_; }
  const ConstraintFactor& factor() const { return factor_; }
  /// Per multiplier: the offset of its compressed column in ConstraintScratch::b and v (m + 1).
  const std::vector<int>& column_offset() const { return factor_.column_offset(); }
  /// Per storage gather: the plan index of the instruction of its co-energy variable, the state
  /// kernel that gives V = H B from B: an inertia's flow f = M^-1 p; a compliance's effort
  /// e = sigma K q (sigma = -1 when its bond points away from it: V is then minus the kernel's
  /// result, which AssembleConstraintMatrix applies after the columns); else -1.
  const std::vector<int>& flow_instr_of_block() const { return flow_instr_of_block_; }
  const std::vector<int>& tangent_plan() const { return tangent_plan_; }        ///< plan indices, in order
  const std::vector<int>& reaction_plan() const { return reaction_plan_; }      ///< plan indices, in order
  const std::vector<int>& reaction_gathers() const { return reaction_gathers_; }  ///< gather indices

 private:
  /// d/dt along (xdot, d/dt sources) of the slots the constraints' flows depend on
  /// (tangent_plan_), into ws.con.dslots; the other entries are not written.
  void Tangent(const PlanView& view, double t, const double* x, const double* xdot, Workspace& ws) const;
  /// Build's last check, of the formulas in the tangent plan and in the multipliers' closures
  /// (what is accepted: constraint_solver.cc); a formula refused throws ModelError
  /// (`expr.unsupported`, located at the formula, naming the constraint it reaches). Sets
  /// formulas_ and emittable_. `reached_slot`: per slot, whether a multiplier reaches it.
  void CheckFormulas(const BuildInput& in, const std::vector<char>& reached_slot);
  /// B (storage-rate response to each unit multiplier) and V = H B at x, into ws.con.b, v.
  void AssembleConstraintMatrix(const PlanView& view, double t, const double* x, Workspace& ws) const;
  /// B's columns at (t, x) and lambda from W lambda = ws.con.rhs: the sparse L D L^T on the
  /// independent set, else the pivoted solve. When ws holds B and the factor for this very x
  /// (ConstraintScratch::factored_at), the solve only.
  /// With prescribed multipliers (ConstraintScratch::any_fixed), SolveWithFixed; `fixed_values`:
  /// they take their values (an evaluation), else zero (a projection, a response).
  void SolveAt(const PlanView& view, double t, const double* x, Workspace& ws, bool fixed_values) const;
  /// The solve with some multipliers prescribed: the others from W_aa lambda_a = rhs_a - W_ap lambda_p.
  void SolveWithFixed(const PlanView& view, double t, const double* x, Workspace& ws, bool fixed_values) const;
  /// g(x) - target(t) of every multiplier component, from filled slots, into `out`.
  void ConstraintValues(double t, const double* w, double* out) const;
  /// One instruction of B's columns or of the linear response, on `lin` (the response of the
  /// slots; zero outside what the multipliers reach): the instruction itself, or for a formula
  /// its derivative along lin at the point ws.slots.
  void ExecLinear(const PlanView& view, const plan::Instr& in, double t, const double* x, double* lin, const double* lambda,
                  const Workspace& ws) const;
  /// x += B mu, mu = ws.lambda (B's columns in ws.con.b, as the last solve assembled them).
  void MoveAlongB(double* x, const Workspace& ws) const;

  std::vector<Group> groups_;
  int num_lambda_ = 0;
  std::unordered_map<int, int> lambda_of_bond_;  ///< a member's bond -> its constraint's offset (MultiplierOf)
  std::vector<TimeFunction> targets_;  ///< the prescribed flows' functions (Member::target)
  std::vector<int> reaction_plan_;     ///< plan indices the multipliers reach (their instructions too), in order
  std::vector<int> reaction_gathers_;  ///< gathers that read a slot the multipliers reach
  std::vector<int> tangent_plan_;      ///< plan indices the constraints' flows depend on, in order
  std::vector<int> flow_instr_of_block_;
  /// Ranges (offset, size) of V's compressed columns that are minus their state kernel's result:
  /// the rows of compliances whose bond points away from them.
  std::vector<std::pair<int, int>> negated_v_;
  ConstraintFactor factor_;            ///< B's sparsity, W and its solves
  /// Formulas in the tangent plan or a closure (differentiated by forward mode); all of them
  /// kExpr, which generated code can call back for (a law used backwards, kSolve, cannot).
  bool formulas_ = false;
  bool emittable_ = true;
};

}  // namespace multibond
