// The linearisation (linearize.h): coordinates of the state's manifold, exact Jacobians from the
// tangent pass, the steady state by KINSOL.
//
// Coordinates z (docs/linear-analysis.md): a momentum, displacement or integral entry is its own
// coordinate; an orientation R has three, the angles theta of dR = [theta x] R (the state keeps
// nine entries, the rotation group has three dimensions); the energy account's work and
// dissipation integrals are outputs of the run, not dynamics, and have none. dx = T z. The state
// equation in z: the columns of T move with R (dT_i/dt = [e_i x] dR/dt), so
//   A = T^+ (J T - dT/dt),  B = T^+ J_u,
// exact on the rotation group (T^+ T = I; T^+ J T is what the angles' own equation gives).

#include "multibond/analysis/linearize.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <stdexcept>
#include <vector>

#include <fmt/format.h>
#include <kinsol/kinsol.h>
#include <nvector/nvector_serial.h>
#include <sunlinsol/sunlinsol_dense.h>
#include <sunmatrix/sunmatrix_dense.h>

#include "multibond/compile/compiled_model.h"
#include "multibond/sim/simulator.h"

namespace multibond::linear {

namespace {

using Rm3 = Eigen::Matrix<double, 3, 3, Eigen::RowMajor>;

Eigen::Matrix3d Skew(int axis) {
  Eigen::Vector3d e = Eigen::Vector3d::Zero();
  e[axis] = 1.0;
  Eigen::Matrix3d s;
  s << 0.0, -e[2], e[1], e[2], 0.0, -e[0], -e[1], e[0], 0.0;
  return s;
}

/// The coordinates z: names, units and T at x (one column per coordinate).
struct Coordinates {
  std::vector<std::string> names, units;
  Eigen::MatrixXd basis;
  std::vector<std::pair<int, int>> angles;  ///< (column, orientation state offset) per angle, axis = column order
  std::vector<int> state_of;  ///< per column: the state entry it is (-1: an angle)
  /// T^+ y, exactly: a state entry's own value; an angle's column has the Frobenius norm sqrt(2)
  /// and is orthogonal to the others ([e_i x] R . [e_j x] R = 2 delta_ij), so T_i^T y / 2.
  Eigen::MatrixXd Reduce(const Eigen::MatrixXd& y) const {
    Eigen::MatrixXd z(basis.cols(), y.cols());
    for (Eigen::Index j = 0; j < basis.cols(); ++j)
      z.row(j) = state_of[j] >= 0 ? Eigen::RowVectorXd(y.row(state_of[j])) : Eigen::RowVectorXd(0.5 * basis.col(j).transpose() * y);
    return z;
  }
};

Coordinates MakeCoordinates(const CompiledModel& model, const Eigen::VectorXd& x) {
  Coordinates c;
  std::vector<Eigen::VectorXd> cols;
  const int n = model.num_states();
  for (const StateBlock& b : model.state_blocks()) {
    switch (b.kind) {
      case StateBlock::Kind::kWork:
      case StateBlock::Kind::kDissipation:
        break;
      case StateBlock::Kind::kOrientation: {
        const Rm3 r = Eigen::Map<const Rm3>(x.data() + b.offset);
        static const char* kAxis[] = {"x", "y", "z"};
        for (int i = 0; i < 3; ++i) {
          Eigen::VectorXd col = Eigen::VectorXd::Zero(n);
          Eigen::Map<Rm3>(col.data() + b.offset) = Skew(i) * r;
          c.angles.push_back({static_cast<int>(cols.size()), b.offset});
          c.state_of.push_back(-1);
          cols.push_back(std::move(col));
          c.names.push_back(model.graph().aux_states()[b.owner].name + ".angle." + kAxis[i]);
          c.units.push_back("rad");
        }
        break;
      }
      default:
        for (int k = 0; k < b.size; ++k) {
          Eigen::VectorXd col = Eigen::VectorXd::Zero(n);
          col[b.offset + k] = 1.0;
          c.state_of.push_back(b.offset + k);
          cols.push_back(std::move(col));
          c.names.push_back(model.state_names()[b.offset + k]);
          c.units.push_back(model.state_units()[b.offset + k]);
        }
    }
  }
  c.basis.resize(n, static_cast<Eigen::Index>(cols.size()));
  for (size_t j = 0; j < cols.size(); ++j) c.basis.col(static_cast<Eigen::Index>(j)) = cols[j];
  return c;
}

void Require(const CompiledModel& model, const Eigen::VectorXd& x) {
  std::string why;
  if (!model.can_linearize(&why)) throw std::invalid_argument("cannot linearise a model with " + why);
  if (x.size() != model.num_states() || !x.allFinite()) throw std::invalid_argument("the operating point's state is not finite");
}

/// The Jacobian of dz/dt in z (A) at x: the tangent pass along each column of T.
Eigen::MatrixXd ReducedJacobian(const CompiledModel& model, double t, const Eigen::VectorXd& x, const Coordinates& c,
                                const Eigen::VectorXd& xdot, Workspace& ws, Workspace& dws,
                                std::vector<Eigen::VectorXd>* slot_columns) {
  const Eigen::Index n = x.size(), nz = c.basis.cols();
  Eigen::MatrixXd jt(n, nz);
  Eigen::VectorXd dxdot(n);
  for (Eigen::Index j = 0; j < nz; ++j) {
    model.CalcTangent(t, x.data(), c.basis.col(j).data(), nullptr, dxdot.data(), ws, dws);
    jt.col(j) = dxdot;
    if (slot_columns) slot_columns->push_back(Eigen::Map<const Eigen::VectorXd>(dws.slots.data(), static_cast<Eigen::Index>(dws.slots.size())));
  }
  // dT_i/dt = [e_i x] dR/dt for the angles' columns.
  for (size_t a = 0; a < c.angles.size(); ++a) {
    const auto& [col, offset] = c.angles[a];
    const Rm3 rdot = Eigen::Map<const Rm3>(xdot.data() + offset);
    Eigen::VectorXd dcol = Eigen::VectorXd::Zero(n);
    Eigen::Map<Rm3>(dcol.data() + offset) = Skew(static_cast<int>(a % 3)) * rdot;
    jt.col(col) -= dcol;
  }
  return c.Reduce(jt);
}

/// Ideal constraints: the coordinates of the constraint manifold. The constraints hold the
/// velocities (g(p, R) = 0, linear in the momenta), so m of the storage coordinates depend on the
/// others: G dz = 0 with G = dg/dz (from the tangent pass's slot columns). The dependent ones are
/// chosen among the momenta and displacements by column-pivoted QR of their columns of G
/// (coordinate partitioning); dz = N dz_i with N_i = I, N_d = -G_d^+ G_i, and the flow keeps
/// G dz = 0, so dz_i/dt = (A N)_i z_i, B_i, C N. Redundant constraints (rank < m) drop out.
void ReduceToConstraintManifold(const CompiledModel& model, const std::vector<Eigen::VectorXd>& slot_cols, LinearModel& lm) {
  const Eigen::Index nz = lm.A.cols(), m = model.num_multipliers();
  Eigen::MatrixXd g(m, nz);
  Eigen::VectorXd row(m);
  for (Eigen::Index j = 0; j < nz; ++j) {
    model.ConstraintRates(slot_cols[j].data(), row.data());
    g.col(j) = row;
  }
  std::vector<Eigen::Index> storage;  // candidate dependent coordinates: not the angles
  for (Eigen::Index j = 0; j < nz; ++j)
    if (lm.states[j].find(".angle.") == std::string::npos) storage.push_back(j);
  Eigen::MatrixXd gs(m, static_cast<Eigen::Index>(storage.size()));
  for (size_t k = 0; k < storage.size(); ++k) gs.col(static_cast<Eigen::Index>(k)) = g.col(storage[k]);
  Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(gs);
  qr.setThreshold(1e-10);
  const Eigen::Index rank = qr.rank();
  std::vector<bool> dependent(nz, false);
  for (Eigen::Index k = 0; k < rank; ++k) dependent[storage[qr.colsPermutation().indices()[k]]] = true;
  std::vector<Eigen::Index> dep, ind;
  for (Eigen::Index j = 0; j < nz; ++j) (dependent[j] ? dep : ind).push_back(j);
  Eigen::MatrixXd gd(m, static_cast<Eigen::Index>(dep.size())), gi(m, static_cast<Eigen::Index>(ind.size()));
  for (size_t k = 0; k < dep.size(); ++k) gd.col(static_cast<Eigen::Index>(k)) = g.col(dep[k]);
  for (size_t k = 0; k < ind.size(); ++k) gi.col(static_cast<Eigen::Index>(k)) = g.col(ind[k]);
  const Eigen::MatrixXd nd = -gd.colPivHouseholderQr().solve(gi);
  Eigen::MatrixXd n = Eigen::MatrixXd::Zero(nz, static_cast<Eigen::Index>(ind.size()));
  for (size_t k = 0; k < ind.size(); ++k) n(ind[k], static_cast<Eigen::Index>(k)) = 1.0;
  for (size_t k = 0; k < dep.size(); ++k) n.row(dep[k]) = nd.row(static_cast<Eigen::Index>(k));
  auto rows = [&](const Eigen::MatrixXd& a) {
    Eigen::MatrixXd r(static_cast<Eigen::Index>(ind.size()), a.cols());
    for (size_t k = 0; k < ind.size(); ++k) r.row(static_cast<Eigen::Index>(k)) = a.row(ind[k]);
    return r;
  };
  std::string names;
  for (Eigen::Index j : dep) names += (names.empty() ? "" : ", ") + lm.states[j];
  lm.A = rows(lm.A * n);
  lm.B = rows(lm.B);
  lm.C = lm.C * n;
  lm.motion = lm.motion * n;
  lm.basis = lm.basis * n;
  std::vector<std::string> states, units;
  for (Eigen::Index j : ind) states.push_back(lm.states[j]), units.push_back(lm.state_units[j]);
  lm.states = std::move(states);
  lm.state_units = std::move(units);
  lm.notes.push_back(fmt::format("ideal constraints: {} constraint equations of rank {}; linearised on the constraint manifold in {} "
                                 "independent coordinates, the dependent ones being {}",
                                 m, rank, lm.states.size(), names.empty() ? "none" : names));
}

}  // namespace

LinearModel Linearize(const CompiledModel& model, double t, const Eigen::VectorXd& x) {
  Require(model, x);
  LinearModel lm;
  lm.model = model.graph().name();
  lm.at = t;
  lm.x0 = x;
  lm.full_states = model.state_names();
  const Coordinates c = MakeCoordinates(model, x);
  lm.states = c.names;
  lm.state_units = c.units;
  lm.basis = c.basis;

  Workspace ws = model.MakeWorkspace(), dws = model.MakeWorkspace();
  const Eigen::Index n = x.size(), nz = c.basis.cols();
  Eigen::VectorXd xdot(n);
  // A point on a kink has no tangent: the one-sided models differ, and the tangent's rules take
  // the mean of their slopes (docs/linear-analysis.md).
  for (const std::string& kink : model.KinksAt(t, x.data(), ws))
    lm.notes.push_back(fmt::format("{}: {}; the linear model takes the mean of the slopes on "
                                   "either side, and the model on either side differs from it (linearise about a point off the "
                                   "kink for a one-sided model)", kOnKinkNote, kink));
  model.CalcDerivatives(t, x.data(), xdot.data(), ws);
  std::vector<Eigen::VectorXd> slot_cols;  // d(slots)/dz_j
  lm.A = ReducedJacobian(model, t, x, c, xdot, ws, dws, &slot_cols);

  // Inputs: one tangent pass per source component.
  const std::vector<CompiledModel::SourceInput> inputs = model.SourceInputs();
  const Eigen::Index nu = static_cast<Eigen::Index>(inputs.size());
  Eigen::MatrixXd ju(n, nu);
  std::vector<Eigen::VectorXd> input_slot_cols;
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(n);
  Eigen::VectorXd du(nu), dxdot(n);
  for (Eigen::Index k = 0; k < nu; ++k) {
    du.setZero();
    du[k] = 1.0;
    model.CalcTangent(t, x.data(), zero.data(), du.data(), dxdot.data(), ws, dws);
    ju.col(k) = dxdot;
    input_slot_cols.push_back(Eigen::Map<const Eigen::VectorXd>(dws.slots.data(), static_cast<Eigen::Index>(dws.slots.size())));
    lm.inputs.push_back(inputs[k].name);
    lm.input_units.push_back(inputs[k].unit.empty() ? "-" : inputs[k].unit);
  }
  lm.B = c.Reduce(ju);

  // Outputs: linear combinations of states and slots, so their derivatives are the same
  // combinations of the states' and slots' derivatives.
  std::vector<std::string> left_out;
  const std::vector<OutputCombination> outputs = DeclaredOutputs(model, &left_out);
  lm.C.setZero(static_cast<Eigen::Index>(outputs.size()), nz);
  lm.D.setZero(static_cast<Eigen::Index>(outputs.size()), nu);
  for (size_t r = 0; r < outputs.size(); ++r) {
    lm.outputs.push_back(outputs[r].name);
    lm.output_units.push_back(outputs[r].unit);
    for (const OutputCombination::Term& term : outputs[r].terms) {
      for (Eigen::Index j = 0; j < nz; ++j)
        lm.C(static_cast<Eigen::Index>(r), j) += term.coef * (term.state ? c.basis(term.offset, j) : slot_cols[j][term.offset]);
      for (Eigen::Index k = 0; k < nu; ++k)
        if (!term.state) lm.D(static_cast<Eigen::Index>(r), k) += term.coef * input_slot_cols[k][term.offset];
    }
  }
  for (const std::string& name : left_out)
    lm.notes.push_back(fmt::format("output '{}' (an orthonormality measure, not differentiable) is not among the outputs", name));

  // Storage Hessians (energy participation) and motions (mode shapes), from the slot columns of
  // the storage states' own coordinates (unit columns of T).
  std::vector<int> coordinate_of_state(n, -1);
  for (Eigen::Index j = 0; j < nz; ++j)
    if (c.state_of[j] >= 0) coordinate_of_state[c.state_of[j]] = static_cast<int>(j);
  const BondGraph& g = model.graph();
  std::vector<int> motion_slots;  // per row of lm.motion: the inertia's flow slot
  for (const StateBlock& b : model.state_blocks()) {
    if (b.kind != StateBlock::Kind::kMomentum && b.kind != StateBlock::Kind::kDisplacement) continue;
    const Element& e = g.element(b.owner);
    const bool inertia = b.kind == StateBlock::Kind::kMomentum;
    const auto var = model.FindVariable(e.name + (inertia ? ".f" : ".e"));
    if (!var || var->in != VariableRef::In::kSlot || var->size != b.size) continue;
    const double sigma = inertia ? 1.0 : g.PowerSign(e.bonds.front(), b.owner);
    Storage s{e.name, {}, Eigen::MatrixXd(b.size, b.size)};
    for (int k = 0; k < b.size; ++k) {
      s.states.push_back(b.offset + k);
      const int j = coordinate_of_state[b.offset + k];
      for (int r = 0; r < b.size; ++r) s.hessian(r, k) = sigma * slot_cols[j][var->offset + r];
    }
    s.hessian = 0.5 * (s.hessian + s.hessian.transpose()).eval();
    lm.storages.push_back(std::move(s));
    if (inertia) {
      const std::vector<std::string> comps = ComponentNames(b.size, var->components);
      for (int r = 0; r < b.size; ++r) {
        lm.motion_names.push_back(b.size == 1 ? e.name + ".f" : e.name + ".f." + comps[r]);
        lm.motion_units.push_back(var->unit.empty() ? "-" : var->unit);
        motion_slots.push_back(var->offset + r);
      }
    }
  }
  lm.motion.resize(static_cast<Eigen::Index>(motion_slots.size()), nz);
  for (size_t row = 0; row < motion_slots.size(); ++row)
    for (Eigen::Index j = 0; j < nz; ++j) lm.motion(static_cast<Eigen::Index>(row), j) = slot_cols[j][motion_slots[row]];
  if (model.has_constraints()) ReduceToConstraintManifold(model, slot_cols, lm);
  // Products of signs leave -0 where nothing couples: written as 0.
  for (Eigen::MatrixXd* m : {&lm.A, &lm.B, &lm.C, &lm.D}) m->array() += 0.0;
  if (!c.angles.empty())
    lm.notes.push_back("each orientation matrix is represented by three angles (dR = [theta x] R), not its nine entries: the rotation group adds no spurious modes");
  return lm;
}

namespace {

struct SteadyProblem {
  const CompiledModel& model;
  double t;
  Eigen::VectorXd x0;
  Coordinates c;
  Workspace ws, dws;
  /// The state at z: x0 + T z, each orientation moved along the group (R = exp([theta x]) R0).
  Eigen::VectorXd StateAt(const double* z) const {
    Eigen::VectorXd x = x0;
    std::vector<bool> is_angle(static_cast<size_t>(c.basis.cols()), false);
    for (const auto& [col, offset] : c.angles) is_angle[col] = true;
    for (Eigen::Index j = 0; j < c.basis.cols(); ++j)
      if (!is_angle[j]) x += c.basis.col(j) * z[j];
    for (size_t a = 0; a + 2 < c.angles.size(); a += 3) {
      const int offset = c.angles[a].second;
      const Eigen::Vector3d th(z[c.angles[a].first], z[c.angles[a + 1].first], z[c.angles[a + 2].first]);
      const double angle = th.norm();
      const Eigen::Matrix3d rot = angle > 0.0 ? Eigen::AngleAxisd(angle, th / angle).toRotationMatrix() : Eigen::Matrix3d::Identity();
      const Rm3 r0 = Eigen::Map<const Rm3>(x0.data() + offset);
      Eigen::Map<Rm3>(x.data() + offset) = rot * r0;
    }
    return x;
  }
};

int SteadyResidual(N_Vector zv, N_Vector fv, void* user) {
  auto* p = static_cast<SteadyProblem*>(user);
  const Eigen::VectorXd x = p->StateAt(N_VGetArrayPointer(zv));
  Eigen::VectorXd xdot(x.size());
  p->model.CalcDerivatives(p->t, x.data(), xdot.data(), p->ws);
  if (!xdot.allFinite()) return 1;  // recoverable: the line search steps back
  // dz/dt at x: T^+ dx/dt (the angles' rates are those of dR = [w x] R).
  const Coordinates c = MakeCoordinates(p->model, x);
  const Eigen::VectorXd zdot = c.Reduce(xdot);
  Eigen::Map<Eigen::VectorXd>(N_VGetArrayPointer(fv), zdot.size()) = zdot;
  return 0;
}

int SteadyJacobian(N_Vector zv, N_Vector, SUNMatrix jm, void* user, N_Vector, N_Vector) {
  auto* p = static_cast<SteadyProblem*>(user);
  const Eigen::VectorXd x = p->StateAt(N_VGetArrayPointer(zv));
  Eigen::VectorXd xdot(x.size());
  p->model.CalcDerivatives(p->t, x.data(), xdot.data(), p->ws);
  const Coordinates c = MakeCoordinates(p->model, x);
  const Eigen::MatrixXd a = ReducedJacobian(p->model, p->t, x, c, xdot, p->ws, p->dws, nullptr);
  // The angles of StateAt are taken about R0, those of c about R: equal to first order at a
  // steady state (dR/dt = 0), which is where Newton converges quadratically.
  for (Eigen::Index j = 0; j < a.cols(); ++j)
    for (Eigen::Index i = 0; i < a.rows(); ++i) SM_ELEMENT_D(jm, i, j) = a(i, j);
  return a.allFinite() ? 0 : 1;
}

}  // namespace

RunOptions RunToOperatingPoint(const RunOptions& options, double at, const char* what) {
  if (!(at > options.t_start) || at > options.t_end)
    throw std::invalid_argument(fmt::format("{} {:g} s is outside the run, which goes from {:g} s to {:g} s (t_end: the model's "
                                            "simulation settings, or given)",
                                            what, at, options.t_start, options.t_end));
  RunOptions o = options;
  o.t_end = at;
  o.dt = std::min(o.dt, at - o.t_start);
  return o;
}

Eigen::VectorXd FindSteadyState(const CompiledModel& model, double t, const Eigen::VectorXd& x_start) {
  Require(model, x_start);
  SteadyProblem p{model, t, x_start, MakeCoordinates(model, x_start), model.MakeWorkspace(), model.MakeWorkspace()};
  const sunindextype nz = p.c.basis.cols();
  if (nz == 0) return x_start;
  SUNContext ctx = nullptr;
  if (SUNContext_Create(nullptr, &ctx) != 0) throw std::runtime_error("no steady state found: SUNDIALS could not start");
  N_Vector z = N_VNew_Serial(nz, ctx), scale = N_VNew_Serial(nz, ctx);
  N_VConst(0.0, z);
  N_VConst(1.0, scale);
  SUNMatrix jm = SUNDenseMatrix(nz, nz, ctx);
  SUNLinearSolver ls = SUNLinSol_Dense(z, jm, ctx);
  void* kin = KINCreate(ctx);
  int flag = KINInit(kin, SteadyResidual, z);
  // KINSOL's own messages are replaced by the error below, which says what failed in these terms.
  if (flag == KIN_SUCCESS) flag = KINSetErrHandlerFn(kin, [](int, const char*, const char*, char*, void*) {}, nullptr);
  if (flag == KIN_SUCCESS) flag = KINSetUserData(kin, &p);
  if (flag == KIN_SUCCESS) flag = KINSetLinearSolver(kin, ls, jm);
  if (flag == KIN_SUCCESS) flag = KINSetJacFn(kin, SteadyJacobian);
  if (flag == KIN_SUCCESS) flag = KINSetFuncNormTol(kin, 1e-10);
  if (flag == KIN_SUCCESS) flag = KINSetScaledStepTol(kin, 1e-14);
  if (flag == KIN_SUCCESS) flag = KINSetNumMaxIters(kin, 200);
  if (flag == KIN_SUCCESS) flag = KINSetMaxSetupCalls(kin, 1);  // a fresh exact Jacobian at every iteration
  // KINSOL bounds a step by 1000 |z0|, and at least 1: z starts at 0 (the displacement from
  // x_start), so a steady state more than 1 away (a loop started from rest) was out of reach.
  // The bound is taken from the state's own size instead; the line search guards the step.
  if (flag == KIN_SUCCESS) flag = KINSetMaxNewtonStep(kin, 1000.0 * std::max(1.0, x_start.norm()));
  if (flag == KIN_SUCCESS) flag = KINSol(kin, z, KIN_LINESEARCH, scale, scale);
  Eigen::VectorXd x = p.StateAt(N_VGetArrayPointer(z));
  long iterations = 0;
  KINGetNumNonlinSolvIters(kin, &iterations);
  double fnorm = 0.0;
  KINGetFuncNorm(kin, &fnorm);
  KINFree(&kin);
  SUNLinSolFree(ls);
  SUNMatDestroy(jm);
  N_VDestroy(z);
  N_VDestroy(scale);
  SUNContext_Free(&ctx);
  if (flag < 0) {
    char* name = KINGetReturnFlagName(flag);  // malloc'ed by SUNDIALS
    std::string why = name ? name : "unknown";
    std::free(name);
    if (flag == KIN_LSETUP_FAIL || flag == KIN_LSOLVE_FAIL)
      why = "the Jacobian is singular there: a motion that nothing holds (a free shaft, a body on no spring) has no isolated steady state, "
            "or the sources keep it accelerating; " + why;
    else if (flag == KIN_MAXITER_REACHED)
      why = "no convergence in 200 iterations; " + why;
    else if (flag == KIN_LINESEARCH_NONCONV)
      why = "the line search could not reduce |dz/dt| further; " + why;
    throw std::runtime_error(fmt::format("no steady state found: Newton's method stopped after {} iterations with |dz/dt| = {:.3g} ({})",
                                         iterations, fnorm, why));
  }
  model.Project(x.data());
  return x;
}

}  // namespace multibond::linear
