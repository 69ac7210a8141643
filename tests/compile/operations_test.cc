// The operation table (compile/operations.h): one complete row per opcode, in enum order, and the
// specialisation pass on its own.

#include "multibond/compile/operations.h"

#include <set>
#include <string>

#include <gtest/gtest.h>

namespace multibond::plan {
namespace {

TEST(OperationTable, EveryOpcodeHasACompleteRowInEnumOrder) {
  std::set<std::string> names;
  for (int i = 0; i < kNumOps; ++i) {
    const OpTraits& row = kOpTable[i];
    SCOPED_TRACE(i);
    EXPECT_EQ(static_cast<int>(row.op), i);
    EXPECT_EQ(&Traits(static_cast<Op>(i)), &row);
    ASSERT_NE(row.name, nullptr);
    EXPECT_TRUE(names.insert(row.name).second) << "name used twice: " << row.name;
    EXPECT_NE(row.exec, nullptr) << row.name;
    EXPECT_NE(row.emit, nullptr) << row.name;
    // Exactly the state-reading rows have a state kernel, for the interpreter and the code.
    const bool state = row.reads == Reads::kState;
    EXPECT_EQ(row.state != nullptr, state) << row.name;
    EXPECT_EQ(row.emit_state != nullptr, state) << row.name;
    EXPECT_EQ(row.tangent == Tangent::kStateRate || row.tangent == Tangent::kRotatedInertia, state) << row.name;
    // Each row's generic opcode is a generic row (its own).
    EXPECT_EQ(Traits(row.generic).generic, row.generic) << row.name;
    // Only multipliers read multipliers; only rows that read a modulus have the modulated rule.
    EXPECT_EQ(row.reads == Reads::kMultipliers, row.op == Op::kMultiplier) << row.name;
    EXPECT_EQ(row.modulus, row.tangent == Tangent::kModulated) << row.name;
    EXPECT_GE(row.n, 0);
    EXPECT_GE(row.m, 0);
  }
  EXPECT_EQ(Traits(Op::kMultiplier).op, Op::kMultiplier);  // the last row
}

TEST(OperationTable, InterpreterKernelsEvaluateTheirRows) {
  // dst = diag(2, 3, 4) src; a 1x3 row; a copy; a two-term sum; a scaled momentum.
  const double coef[] = {2.0, 3.0, 4.0, 1.0, -1.0, 0.5};
  const int sum_terms[] = {0, 3};
  const double sum_signs[] = {1.0, -1.0};
  const double x[] = {10.0, 20.0, 30.0};
  double w[16] = {1.0, 2.0, 3.0, 5.0};
  const ExecArgs args{0.0, x, w, w, nullptr, nullptr, {coef, sum_terms, sum_signs, nullptr}};
  Instr diag{Op::kDiag3};
  diag.src = 0, diag.dst = 4, diag.coef = 0, diag.n = diag.m = 3;
  Exec(diag, args);
  EXPECT_EQ(w[4], 2.0);
  EXPECT_EQ(w[5], 6.0);
  EXPECT_EQ(w[6], 12.0);
  Instr row{Op::kMat13};
  row.src = 0, row.dst = 7, row.coef = 3, row.n = 1, row.m = 3;
  Exec(row, args);
  EXPECT_EQ(w[7], 1.0 - 2.0 + 1.5);
  Instr sum{Op::kSum1};
  sum.dst = 8, sum.coef = 0, sum.count = 2;
  Exec(sum, args);
  EXPECT_EQ(w[8], 1.0 - 5.0);
  Instr momentum{Op::kStateScale3};
  momentum.src = 0, momentum.dst = 9, momentum.coef = 5, momentum.n = 3;
  Exec(momentum, args);
  EXPECT_EQ(w[9], 5.0);
  EXPECT_EQ(w[11], 15.0);
}

TEST(OperationTable, EmittersWriteLiteralCode) {
  const double coef[] = {2.0};
  std::string code;
  std::set<std::string> levers;
  Instr scale{Op::kScale1};
  scale.src = 2, scale.dst = 5, scale.coef = 0;
  Emit(scale, EmitArgs{{coef, nullptr, nullptr, nullptr}, CodeNames{}, &levers, &code});
  EXPECT_EQ(code, "  w[5] = (0x1p+1) * w[2];\n");
  code.clear();
  Instr multiplier{Op::kMultiplier};
  multiplier.dst = 1, multiplier.coef = 4, multiplier.n = 1;
  CodeNames names;
  Emit(multiplier, EmitArgs{{coef, nullptr, nullptr, nullptr}, names, &levers, &code});
  EXPECT_EQ(code, "  w[1] = 0.0;\n");
  names.multipliers = true;
  code.clear();
  Emit(multiplier, EmitArgs{{coef, nullptr, nullptr, nullptr}, names, &levers, &code});
  EXPECT_EQ(code, "  w[1] = lam[4];\n");
}

TEST(Specialize, RewritesGenericInstructionsIntoFixedSizeRows) {
  std::vector<double> coef = {2.0, 0.0, 0.0, 0.0, 3.0, 0.0, 0.0, 0.0, 4.0,  // diagonal 3x3
                              1.0, 2.0, 3.0,                                // 1x3
                              7.0};                                         // scalar
  const std::vector<int> sum_terms = {6};
  const std::vector<double> sum_signs = {1.0};
  ModulusEval constant{Modulus::Kind::kConstant, 2, 2, 0, -1, -1, -1, -1, 0, 1.0, false, Eigen::Vector3d::Zero()};
  std::vector<ModulusEval> moduli = {constant};
  std::vector<Instr> plan(5);
  plan[0].op = Op::kMatrix, plan[0].n = plan[0].m = 3, plan[0].coef = 0;
  plan[1].op = Op::kMatrix, plan[1].n = 1, plan[1].m = 3, plan[1].coef = 9;
  plan[2].op = Op::kScale, plan[2].n = plan[2].m = 1, plan[2].coef = 12;
  plan[3].op = Op::kSum, plan[3].n = 3, plan[3].count = 1, plan[3].coef = 0;
  plan[4].op = Op::kModulated, plan[4].n = plan[4].m = 2, plan[4].modulus = 0;
  const std::vector<int> needed = Specialize(plan, coef, sum_terms, sum_signs, moduli);

  EXPECT_EQ(plan[0].op, Op::kDiag3);
  ASSERT_EQ(coef.size(), 16u);  // the diagonal appended
  EXPECT_EQ(plan[0].coef, 13);
  EXPECT_EQ(coef[13], 2.0);
  EXPECT_EQ(coef[15], 4.0);
  EXPECT_EQ(plan[1].op, Op::kMat13);
  EXPECT_EQ(plan[2].op, Op::kScale1);
  EXPECT_EQ(plan[3].op, Op::kCopy3);  // one term of sign +1: a copy of that term
  EXPECT_EQ(plan[3].src, 6);
  EXPECT_EQ(plan[4].op, Op::kModulated);  // a constant modulus stays generic and is evaluated
  EXPECT_EQ(needed, std::vector<int>{0});
  EXPECT_TRUE(moduli[0].needed);
  for (const Instr& in : plan) {
    const OpTraits& row = Traits(in.op);
    if (row.n > 0) {
      EXPECT_EQ(in.n, row.n) << row.name;
    }
    if (row.m > 0) {
      EXPECT_EQ(in.m, row.m) << row.name;
    }
  }
}

}  // namespace
}  // namespace multibond::plan
