/// \file
/// The structural Jacobian of the plan (CompiledModel::jacobian_pattern): which states each
/// state derivative can depend on, found by following the plan's reads and writes, the way the
/// numbers flow, with sets of states instead of numbers.

#include <algorithm>
#include <iterator>
#include <vector>

#include "multibond/compile/compiled_model.h"
#include "multibond/core/error.h"

namespace multibond {
namespace {

using Deps = std::vector<int>;  ///< sorted, unique state indices

void Merge(Deps& into, const Deps& more) {
  if (more.empty()) return;
  Deps out;
  out.reserve(into.size() + more.size());
  std::set_union(into.begin(), into.end(), more.begin(), more.end(), std::back_inserter(out));
  into.swap(out);
}

Deps Range(int first, int count) {
  Deps d(count);
  for (int k = 0; k < count; ++k) d[k] = first + k;
  return d;
}

}  // namespace

const JacobianPattern* CompiledModel::jacobian_pattern() const {
  std::call_once(jacobian_once_, [this] { BuildJacobianPattern(); });
  return jacobian_pattern_.n > 0 ? &jacobian_pattern_ : nullptr;
}

void CompiledModel::BuildJacobianPattern() const {
  jacobian_pattern_ = JacobianPattern{};
  const int n = num_states();
  // A multiplier's value depends on the whole constrained system, and a torn variable on
  // everything its loop's linear system reads: no structure worth tracing, every state may depend
  // on every other, except the energy account's integrals (a source's work, a resistor's
  // dissipation), which the plan writes and never reads: their columns are their diagonal alone
  // (a dense Jacobian then evaluates them all at once, and the linear solver leaves them out of
  // its factorisation). Without such integrals there is no pattern.
  if (!constraints_.empty() || !loops_.tears.empty()) {
    std::vector<bool> alone(n, false);
    bool any = false;
    for (const StateBlock& b : layout_.blocks())
      if (b.kind == StateBlock::Kind::kWork || b.kind == StateBlock::Kind::kDissipation)
        for (int k = 0; k < b.size; ++k) alone[b.offset + k] = any = true;
    if (!any) return;
    JacobianPattern& p = jacobian_pattern_;
    p.n = n;
    p.col_start.assign(1, 0);
    for (int j = 0; j < n; ++j) {
      if (alone[j]) p.row_index.push_back(j);
      else
        for (int i = 0; i < n; ++i) p.row_index.push_back(i);
      p.col_start.push_back(static_cast<int>(p.row_index.size()));
    }
    return;
  }
  std::vector<Deps> slot(slots_.num_slots);  // what each slot depends on, once written
  auto slots = [&](int first, int count) {
    Deps d;
    for (int k = 0; k < count; ++k) Merge(d, slot[first + k]);
    return d;
  };
  auto modulus = [&](int index) {
    const ModulusEval& me = plan_.moduli[index];
    return me.kind == Modulus::Kind::kConstant ? Deps{} : Range(me.rotation, 9);
  };
  // What each instruction's outputs depend on, from its row of the operation table: its inputs
  // (a state block, slots, a junction's terms; a source reads none), component by component or
  // all of them, plus the orientation or modulus it reads.
  for (const Instr& in : plan_.instrs) {
    const plan::OpTraits& op = plan::Traits(in.op);
    MB_ASSERT(op.reads != plan::Reads::kMultipliers, "multipliers in a plan without constraints");
    auto input = [&](int k) {  // input component k
      Deps d;
      if (op.reads == plan::Reads::kState) d = {in.src + k};
      else if (op.reads == plan::Reads::kSlots) d = slot[in.src + k];
      else if (op.reads == plan::Reads::kSumTerms)
        for (int j = 0; j < in.count; ++j) Merge(d, slot[plan_.sum_terms[in.coef + j] + k]);
      return d;
    };
    if (op.coupling == plan::Coupling::kComponentwise && op.reads != plan::Reads::kNothing) {
      for (int k = 0; k < in.n; ++k) slot[in.dst + k] = input(k);
      continue;
    }
    Deps all;  // every output reads every input
    if (op.reads == plan::Reads::kState) all = Range(in.src, in.n);
    else if (op.reads == plan::Reads::kSlots) all = slots(in.src, in.m);
    else if (op.reads == plan::Reads::kSolve) {  // a law solved for its input: what it reads, and its target
      Merge(all, slot[in.src]);
      for (const expr::Input& put : plan_.programs[in.coef].inputs) {
        if (put.in == expr::Input::In::kState) Merge(all, {put.offset});
        else if (put.in == expr::Input::In::kSlot) Merge(all, slot[put.offset]);
      }
    } else if (op.reads == plan::Reads::kProgram)  // a formula: every state and slot it reads
      for (int k = 0; k < in.n; ++k)
        for (const expr::Input& put : plan_.programs[in.coef + k].inputs) {
          if (put.in == expr::Input::In::kState) Merge(all, {put.offset});
          else if (put.in == expr::Input::In::kSlot) Merge(all, slot[put.offset]);
        }
    if (op.rotation) Merge(all, Range(in.aux, 9));
    if (op.modulus) Merge(all, modulus(in.modulus));
    for (int k = 0; k < in.n; ++k) slot[in.dst + k] = all;
  }

  std::vector<Deps> row(n);  // what each state derivative depends on
  for (const Gather& gt : layout_.gathers()) {
    switch (gt.kind) {
      case StateBlock::Kind::kMomentum:
      case StateBlock::Kind::kDisplacement:
        for (int k = 0; k < gt.size; ++k) row[gt.state + k] = slot[gt.effort + k];
        break;
      case StateBlock::Kind::kIntegral:
        for (int k = 0; k < gt.size; ++k) row[gt.state + k] = slot[gt.flow + k];
        break;
      case StateBlock::Kind::kOrientation: {
        Deps d = slots(gt.flow, 3);
        Merge(d, Range(gt.state, 9));
        for (int k = 0; k < 9; ++k) row[gt.state + k] = d;
        break;
      }
      case StateBlock::Kind::kWork:
      case StateBlock::Kind::kDissipation: {
        Deps d = slots(gt.effort, gt.size);
        Merge(d, slots(gt.flow, gt.size));
        row[gt.state] = std::move(d);
        break;
      }
    }
  }
  // Rows to columns, with the diagonal.
  std::vector<int> count(n, 1);
  for (int i = 0; i < n; ++i)
    for (int j : row[i])
      if (j != i) ++count[j];
  JacobianPattern& p = jacobian_pattern_;
  p.n = n;
  p.col_start.assign(n + 1, 0);
  for (int j = 0; j < n; ++j) p.col_start[j + 1] = p.col_start[j] + count[j];
  p.row_index.assign(p.col_start[n], 0);
  std::vector<int> next(p.col_start.begin(), p.col_start.end() - 1);
  for (int i = 0; i < n; ++i) {  // rows in ascending order: each column comes out sorted
    if (!std::binary_search(row[i].begin(), row[i].end(), i)) p.row_index[next[i]++] = i;
    for (int j : row[i]) p.row_index[next[j]++] = i;
  }
}

}  // namespace multibond
