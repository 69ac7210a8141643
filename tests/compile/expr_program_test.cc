// Programs of formulas (compile/expr_program.h): the interpreter gives the tree's value to the bit,
// constants are folded without changing a bit, running allocates nothing, and the generated C++
// (compiled by the project's JIT) gives the interpreter's bits for every function and operator;
// the tangent (RunTangent) of each function with a kink, at the kink (the mean of the one-sided
// slopes) and away from it (the branch's slope), against the symbolic derivatives.

#include <stdlib.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <limits>
#include <new>
#include <numbers>
#include <random>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "multibond/compile/expr_program.h"
#include "multibond/compile/jit.h"
#include "multibond/compile/symbolic.h"
#include "multibond/core/error.h"
#include "support/counting_new.h"
#include "support/temp_dir.h"

using multibond::testing::g_allocations;

namespace multibond::expr {
namespace {

using ::testing::HasSubstr;

std::uint64_t Bits(double v) { return std::bit_cast<std::uint64_t>(v); }

/// x0..x2 are states, w0..w1 workspace slots, k a constant parameter (2.5), t the time, pi.
Input Resolve(const Node& n) {
  if (n.name == "t") return {Input::In::kTime, 0, 0.0};
  if (n.name == "pi") return {Input::In::kConstant, 0, std::numbers::pi};
  if (n.name == "k") return {Input::In::kConstant, 0, 2.5};
  if (n.name.size() == 2 && n.name[0] == 'x') return {Input::In::kState, n.name[1] - '0', 0.0};
  if (n.name.size() == 2 && n.name[0] == 'w') return {Input::In::kSlot, n.name[1] - '0', 0.0};
  Diagnostic d;
  d.message = fmt::format("unknown name '{}' at offset {}", n.name, n.offset);
  throw ModelError(d);
}

/// The same, with k as a workspace slot (w[2]) instead of a constant: nothing to fold.
Input ResolveUnfolded(const Node& n) {
  if (n.name == "k") return {Input::In::kSlot, 2, 0.0};
  if (n.name == "pi") return {Input::In::kSlot, 3, 0.0};
  return Resolve(n);
}

NodePtr Tree(const std::string& text) {
  const ParseResult r = Parse(text);
  EXPECT_TRUE(r.root) << text << ": " << (r.error ? r.error->message : "");
  return r.root;
}

/// Every operator and function on values only known at run time, and some laws.
const std::vector<std::string> kFormulas = {
    "x0 + x1", "x0 - x1", "x0*x1", "x0/x1", "-x0", "x0^x1", "abs(x0)^x1", "x0^2", "x0^3", "x0^-1", "x0^0.5", "x0^4",
    "2^x0", "sin(x0)", "cos(x0)", "tan(x0)", "asin(x0)", "acos(x0)", "atan(x0)", "atan2(x0, x1)", "sinh(x0)",
    "cosh(x0)", "tanh(x0)", "exp(x0)", "log(x0)", "sqrt(x0)", "abs(x0)", "sign(x0)", "min(x0, x1)", "max(x0, x1)",
    "hypot(x0, x1)", "clamp(x0, x1, x2)", "smoothabs(x0, w0)", "smoothsign(x0, w0)", "smoothabs(x0, 1e-3)",
    "smoothsign(x0*x1 + x2, 1e-3)",
    // a product and a sum: fused nowhere
    "x0*x1 + x2", "x2 - x0*x1", "x0*x1 + x2*w0 + w1*t",
    // laws and sources
    "1/2*k*x0^2 + 1/4*k*x0^4", "k*x0 + k^2*x0^3", "sin(x0)*cos(x0) + tan(t)", "exp(-t/w1)*cos(2*pi*t)",
    "sqrt(x0*x0 + x1*x1) - hypot(x0, x1)", "clamp(k*x0, -w0, w0) + min(max(x1, -1), 1)",
    "atan2(sin(x0), cos(x1))^2 + log(abs(x2) + 1e-300)", "(x0 - x1)/(x2 + w0)*(t - k)", "-x0^2 - -x1",
    "sign(x0 - x1)*smoothabs(x2, w0)^1.5", "cosh(x0)^2 - sinh(x0)^2",
    // a constant on either side of every operator; an input or a constant alone
    "x0 + 1 - x1*3 + x2/7 - x0^1.5", "1 + x0 - (2 - x1) * (3*x2) + 0.5/x0", "k^x0 - 0.5^x1", "x0", "t", "k*pi",
    // a bound operand on the other side of the input it bounds; arguments that are constants
    "clamp(0.5, x0, x1) + min(-1, x2) + atan2(k, x0) + max(x0, 1)",
    // comparisons, logic and if (kSwitching below: also at NaN, infinite and zero inputs)
    "x0 < x1", "x0 <= x1", "x0 > x1", "x0 >= x1", "x0 == x1", "x0 != x1", "x0 and x1", "x0 or x1", "not x0",
    "if(x0, x1, x2)", "if(x0 > 0, sqrt(x0), sqrt(-x0))", "if(x0 < x1 and not x2 >= 0 or t > 1, log(x0), x1/x2)",
    "k*x0*(x0 > 0) + w0*(x0 <= 0)", "if(x0 == 0, 1, sin(x0)/x0)", "(x0 != x0) + 2*(x1 == x1) - (x0 != x1)",
    "if(k > 2, x0, x1)", "x0 < k", "1 >= x0", "if(x0 > 1, 2, -0)", "not (k < 1) and x0 > 0 or w1", "if(not x0, 1/x1, -x2)",
};

/// The formulas of kFormulas made of comparisons, logic and if: their values are 1, 0 or a branch
/// selected, so the interpreter and generated code agree to the bit at NaNs too.
bool Switching(const std::string& f) {
  return f.find('<') != std::string::npos || f.find('>') != std::string::npos || f.find('=') != std::string::npos ||
         f.find("and") != std::string::npos || f.find("or") != std::string::npos || f.find("not") != std::string::npos ||
         f.find("if(") != std::string::npos;
}

/// Inputs of every kind: ordinary, large, tiny, zeros of both signs, out of the functions' domains.
double RandomValue(std::mt19937_64& rng) {
  switch (std::uniform_int_distribution<int>(0, 9)(rng)) {
    case 0: return 0.0;
    case 1: return -0.0;
    case 2: return std::uniform_real_distribution<double>(-1e3, 1e3)(rng);
    case 3: return std::uniform_real_distribution<double>(-1e-8, 1e-8)(rng);
    case 4: return std::ldexp(std::uniform_real_distribution<double>(-1, 1)(rng), std::uniform_int_distribution<int>(-1000, 1000)(rng));
    case 5: return std::round(std::uniform_real_distribution<double>(-4, 4)(rng));
    default: return std::uniform_real_distribution<double>(-3, 3)(rng);
  }
}

struct Inputs {
  double t = 0.0;
  double x[3] = {};
  double w[4] = {};
};

Inputs RandomInputs(std::mt19937_64& rng) {
  Inputs in;
  in.t = RandomValue(rng);
  for (double& v : in.x) v = RandomValue(rng);
  in.w[0] = RandomValue(rng);
  in.w[1] = RandomValue(rng);
  in.w[2] = 2.5;
  in.w[3] = std::numbers::pi;
  return in;
}

double EvaluateAt(const Node& root, const Inputs& in) {
  return Evaluate(root, [&](const std::string& name) -> std::optional<double> {
    if (name == "t") return in.t;
    if (name == "k") return 2.5;
    if (name[0] == 'x') return in.x[name[1] - '0'];
    if (name[0] == 'w') return in.w[name[1] - '0'];
    return std::nullopt;  // pi
  });
}

TEST(ExprProgram, RunGivesTheTreesValueToTheBit) {
  std::mt19937_64 rng(7);
  for (const std::string& f : kFormulas) {
    const NodePtr tree = Tree(f);
    const Program p = CompileProgram(*tree, Resolve);
    for (int trial = 0; trial < 2000; ++trial) {
      const Inputs in = RandomInputs(rng);
      const double run = expr::Run(p, in.t, in.x, in.w), eval = EvaluateAt(*tree, in);
      ASSERT_EQ(Bits(run), Bits(eval)) << f << ": " << run << " vs " << eval << " at x0 = " << in.x[0];
    }
  }
}

TEST(ExprProgram, ComputesTheAnalyticValue) {
  // A Duffing spring's law, and its energy, at q = 3 with k = 2.5.
  const double x[3] = {3.0, 0.0, 0.0};
  EXPECT_EQ(expr::Run(CompileProgram(*Tree("k*x0 + k^2*x0^3"), Resolve), 0.0, x, nullptr), 2.5 * 3 + 6.25 * 27);
  EXPECT_EQ(expr::Run(CompileProgram(*Tree("1/2*k*x0^2"), Resolve), 0.0, x, nullptr), 11.25);
  EXPECT_EQ(expr::Run(CompileProgram(*Tree("t*x0 - 1"), Resolve), 2.0, x, nullptr), 5.0);
}

TEST(ExprProgram, FoldsConstantsWithoutChangingABit) {
  const Program folded = CompileProgram(*Tree("sin(k*pi/7)*x0 + (2^0.5*k - exp(-k))"), Resolve);
  // sin(k*pi/7) and 2^0.5*k - exp(-k) are constants: one multiply-add of x0 is left.
  int calls = 0, consts = 0, loads = 0;
  for (const Step& s : folded.steps) {
    calls += s.op == Step::Op::kCall || s.op == Step::Op::kPow;
    consts += s.op == Step::Op::kConst;
    loads += s.op == Step::Op::kLoad;
  }
  EXPECT_EQ(calls, 0);
  EXPECT_EQ(consts, 2);
  EXPECT_EQ(loads, 1);
  ASSERT_EQ(folded.inputs.size(), 1u);
  EXPECT_EQ(folded.inputs[0].in, Input::In::kState);
  EXPECT_EQ(folded.inputs[0].offset, 0);
  // Everything constant: one step.
  const Program constant = CompileProgram(*Tree("k*pi + atan2(1, 2)"), Resolve);
  ASSERT_EQ(constant.steps.size(), 1u);
  EXPECT_EQ(constant.steps[0].op, Step::Op::kConst);
  EXPECT_TRUE(constant.inputs.empty());
  EXPECT_EQ(expr::Run(constant, 0, nullptr, nullptr), 2.5 * std::numbers::pi + std::atan2(1.0, 2.0));
  // Comparisons, logic and if of constants are folded too (the unused branch's infinity is not
  // in the value).
  const Program logic = CompileProgram(*Tree("if(k > 2, pi, 1/0) + (k < 3 and not k == 2.5) + (k != k)"), Resolve);
  ASSERT_EQ(logic.steps.size(), 1u);
  EXPECT_EQ(expr::Run(logic, 0, nullptr, nullptr), std::numbers::pi);
  // Folded or computed at run time (k and pi read from slots), every formula gives the same bits.
  std::mt19937_64 rng(11);
  for (const std::string& f : kFormulas) {
    const NodePtr tree = Tree(f);
    const Program a = CompileProgram(*tree, Resolve), b = CompileProgram(*tree, ResolveUnfolded);
    for (int trial = 0; trial < 200; ++trial) {
      const Inputs in = RandomInputs(rng);
      ASSERT_EQ(Bits(expr::Run(a, in.t, in.x, in.w)), Bits(expr::Run(b, in.t, in.x, in.w))) << f;
    }
  }
}

TEST(ExprProgram, RunsOneInstructionPerOperationWithConstantsAndInputsAsOperands) {
  using Op = RunStep::Op;
  auto ops = [](const Program& p) {
    std::vector<Op> o;
    for (const RunStep& s : p.code) o.push_back(s.op);
    return o;
  };
  // A hardening spring: 9 steps (two loads of x0, three constants), 4 instructions.
  const Program spring = CompileProgram(*Tree("k*x0 + k^2*x0^3"), Resolve);
  EXPECT_EQ(spring.steps.size(), 9u);
  EXPECT_EQ(ops(spring), (std::vector<Op>{Op::kKMul, Op::kCube, Op::kKMul, Op::kAdd}));
  EXPECT_EQ(spring.code[0].k, 2.5);
  EXPECT_EQ(spring.code[0].a, MakeOperand(kInState, 0));
  EXPECT_EQ(spring.code[1].a, MakeOperand(kInState, 0));
  EXPECT_EQ(spring.code[2].k, 6.25);
  EXPECT_TRUE(spring.constants.empty());
  // Kept inside the Program too (as it is short), where Run reads it.
  ASSERT_EQ(spring.short_size, 4);
  for (size_t i = 0; i < spring.code.size(); ++i) {
    EXPECT_EQ(spring.short_code[i].op, spring.code[i].op);
    EXPECT_EQ(spring.short_code[i].a, spring.code[i].a);
    EXPECT_EQ(spring.short_code[i].k, spring.code[i].k);
  }
  // A quadratic damper on a slot; the time; each side of each operator.
  EXPECT_EQ(ops(CompileProgram(*Tree("k*w1*abs(w1)"), Resolve)), (std::vector<Op>{Op::kKMul, Op::kCall1, Op::kMul}));
  EXPECT_EQ(CompileProgram(*Tree("k*w1*abs(w1)"), Resolve).code[1].a, MakeOperand(kInSlot, 1));
  EXPECT_EQ(CompileProgram(*Tree("t*2"), Resolve).code[0].a, MakeOperand(kInTime, 0));
  EXPECT_EQ(ops(CompileProgram(*Tree("(x0 + 1)*(1 + x0) - (x0 - 1)/(1 - x0)"), Resolve)),
            (std::vector<Op>{Op::kAddK, Op::kKAdd, Op::kMul, Op::kSubK, Op::kKSub, Op::kDiv, Op::kSub}));
  EXPECT_EQ(ops(CompileProgram(*Tree("x0*2/3 + 2*x0/x1 + 3/x0 + x0^x1 + 2^x0 + x0^0.5 + x0^2 + x0^-1"), Resolve)),
            (std::vector<Op>{Op::kMulK, Op::kDivK, Op::kKMul, Op::kDiv, Op::kAdd, Op::kKDiv, Op::kAdd, Op::kPow, Op::kAdd,
                             Op::kKPow, Op::kAdd, Op::kPowK, Op::kAdd, Op::kSquare, Op::kAdd, Op::kRecip, Op::kAdd}));
  // Constant arguments of a call are read from the program's constants (each once).
  const Program call = CompileProgram(*Tree("clamp(x0, -1, 1) + smoothabs(x1, 1)"), Resolve);
  EXPECT_EQ(ops(call), (std::vector<Op>{Op::kCall3, Op::kCall2, Op::kAdd}));
  EXPECT_EQ(call.constants, (std::vector<double>{-1.0, 1.0}));
  EXPECT_EQ(call.code[0].c, MakeOperand(kInConstants, 1));
  EXPECT_EQ(call.code[1].b, MakeOperand(kInConstants, 1));
  // Nothing to compute: the value is read where it is.
  const Program constant = CompileProgram(*Tree("k*pi"), Resolve), load = CompileProgram(*Tree("x2"), Resolve);
  EXPECT_TRUE(constant.code.empty());
  EXPECT_EQ(constant.value, MakeOperand(kInConstants, 0));
  EXPECT_TRUE(load.code.empty());
  EXPECT_EQ(load.value, MakeOperand(kInState, 2));
  EXPECT_EQ(load.short_size, 0);
  // A longer program is run from `code` (the formulas below have both kinds).
  EXPECT_GT(static_cast<int>(CompileProgram(*Tree("exp(-t/w1)*cos(2*pi*t)*(x0 + x1)"), Resolve).code.size()), kShortCode);
  EXPECT_EQ(CompileProgram(*Tree("exp(-t/w1)*cos(2*pi*t)*(x0 + x1)"), Resolve).short_size, -1);
  // Every instruction, and short and long programs, are among the formulas compared bit for bit
  // with the tree and the generated code.
  std::vector<bool> seen(static_cast<size_t>(Op::kCall3) + 1, false);
  int short_programs = 0, long_programs = 0;
  for (const std::string& f : kFormulas) {
    const Program p = CompileProgram(*Tree(f), Resolve);
    for (const RunStep& s : p.code) seen[static_cast<size_t>(s.op)] = true;
    (p.short_size >= 0 ? short_programs : long_programs) += 1;
  }
  for (size_t op = 0; op < seen.size(); ++op) EXPECT_TRUE(seen[op]) << "instruction " << op << " is not run by any formula";
  EXPECT_GT(short_programs, 0);
  EXPECT_GT(long_programs, 0);
}

TEST(ExprProgram, RegistersAreReusedAndBounded) {
  std::string sum = "x0";
  for (int i = 0; i < 300; ++i) sum += fmt::format(" + x{}*w{}", i % 3, i % 2);  // (within 4096 bytes)
  const Program p = CompileProgram(*Tree(sum), Resolve);
  EXPECT_EQ(p.num_regs, 3);  // the running sum and the two factors of the next product
  EXPECT_EQ(p.inputs.size(), 5u);
  // A sum nested to the right keeps every left operand waiting: beyond kMaxRegs it is refused.
  NodePtr deep = Name("x0");
  for (int i = 0; i < kMaxRegs; ++i) deep = Binary(Node::Kind::kAdd, Name("x1"), deep);
  try {
    CompileProgram(*deep, Resolve);
    ADD_FAILURE() << "no error for " << kMaxRegs + 1 << " registers";
  } catch (const ModelError& e) {
    ASSERT_EQ(e.diagnostics().size(), 1u);
    EXPECT_EQ(e.diagnostics()[0].code, "expr.too_large");
    EXPECT_THAT(e.diagnostics()[0].message, HasSubstr("more than 256 intermediate values"));
  }
  // One fewer fits.
  NodePtr fits = Name("x0");
  for (int i = 0; i < kMaxRegs - 1; ++i) fits = Binary(Node::Kind::kAdd, Name("x1"), fits);
  EXPECT_EQ(CompileProgram(*fits, Resolve).num_regs, kMaxRegs);
}

TEST(ExprProgram, TheResolversErrorComesThrough) {
  try {
    CompileProgram(*Tree("x0 + nope"), Resolve);
    ADD_FAILURE() << "no error";
  } catch (const ModelError& e) {
    EXPECT_THAT(e.what(), HasSubstr("unknown name 'nope' at offset 5"));
  }
}

TEST(ExprProgram, RunningAllocatesNothing) {
  std::vector<Program> programs;
  for (const std::string& f : kFormulas) programs.push_back(CompileProgram(*Tree(f), Resolve));
  const Inputs in{0.5, {0.1, -0.2, 0.3}, {0.4, 0.5, 2.5, std::numbers::pi}};
  double sink = 0.0;
  const long before = g_allocations.load();
  for (const Program& p : programs) sink += expr::Run(p, in.t, in.x, in.w);
  EXPECT_EQ(g_allocations.load() - before, 0);
  EXPECT_FALSE(std::isinf(sink));
}

TEST(ExprProgram, EmitsExactLiteralsAndTheHelpers) {
  std::string out;
  const std::string result = EmitProgram(CompileProgram(*Tree("0.1*x0 + sin(w1)/t"), Resolve), "e7_", EmitNames{}, out);
  EXPECT_EQ(out,
            "  const double e7_0 = x[0];\n"
            "  const double e7_1 = (0x1.999999999999ap-4);\n"  // a constant is written where it is used
            "  const double e7_2 = e7_1 * e7_0;\n"
            "  const double e7_3 = w[1];\n"
            "  const double e7_4 = mb_sin(e7_3);\n"
            "  const double e7_5 = t;\n"
            "  const double e7_6 = e7_4 / e7_5;\n"
            "  const double e7_7 = e7_2 + e7_6;\n");
  EXPECT_EQ(result, "e7_7");
  // Infinities and NaNs as their bits.
  out.clear();
  const std::string inf = EmitProgram(CompileProgram(*Tree("1/0"), Resolve), "c_", EmitNames{"tt", "xs", "ws"}, out);
  EXPECT_EQ(out, "  const double c_0 = (__builtin_bit_cast(double, 0x7ff0000000000000ULL));\n");
  EXPECT_EQ(inf, "c_0");
  const std::string pre = ProgramPreamble();
  EXPECT_THAT(pre, HasSubstr("#include <cmath>"));
  EXPECT_THAT(pre, HasSubstr("static inline double mb_smoothsign(double x, double eps) { return x / std::sqrt(x * x + eps * eps); }"));
}

/// The C++ compiler the JIT would use ($MULTIBOND_CXX, else c++ on the PATH), or "".
std::string Compiler() {
  if (const char* cxx = std::getenv("MULTIBOND_CXX"); cxx && *cxx) return cxx;
  const char* path = std::getenv("PATH");
  std::string dirs = path ? path : "";
  for (size_t start = 0; start <= dirs.size();) {
    const size_t end = std::min(dirs.find(':', start), dirs.size());
    const std::filesystem::path candidate = std::filesystem::path(dirs.substr(start, end - start)) / "c++";
    if (access(candidate.c_str(), X_OK) == 0) return candidate.string();
    start = end + 1;
  }
  return "";
}

TEST(ExprProgram, GeneratedCodeGivesTheInterpretersBits) {
  if (Compiler().empty()) GTEST_SKIP() << "no C++ compiler (c++ on the PATH or $MULTIBOND_CXX): nothing to compare";
  testing::TempDir cache("multibond-expr-jit");
  const char* old = std::getenv("MULTIBOND_CACHE");
  const std::string old_cache = old ? old : "";
  setenv("MULTIBOND_CACHE", cache.path().c_str(), 1);

  std::vector<Program> programs;
  std::string source = ProgramPreamble();
  source += "extern \"C\" void all_formulas(double t, const double* x, const double* w, double* out) {\n";
  for (size_t k = 0; k < kFormulas.size(); ++k) {
    programs.push_back(CompileProgram(*Tree(kFormulas[k]), Resolve));
    const std::string r = EmitProgram(programs.back(), fmt::format("f{}_", k), EmitNames{}, source);
    source += fmt::format("  out[{}] = {};\n", k, r);
  }
  source += "}\n";
  const JitResult jit = CompileAndLoad(source, "all_formulas");
  if (old) setenv("MULTIBOND_CACHE", old_cache.c_str(), 1);
  else unsetenv("MULTIBOND_CACHE");
  ASSERT_NE(jit.symbol, nullptr) << jit.description << "\n" << source;
  const auto all = reinterpret_cast<void (*)(double, const double*, const double*, double*)>(jit.symbol);

  std::mt19937_64 rng(2024);
  std::vector<double> out(kFormulas.size());
  long compared = 0, nans = 0;
  for (int trial = 0; trial < 20000; ++trial) {
    const Inputs in = RandomInputs(rng);
    all(in.t, in.x, in.w, out.data());
    for (size_t k = 0; k < kFormulas.size(); ++k) {
      const double interpreted = expr::Run(programs[k], in.t, in.x, in.w);
      ASSERT_EQ(Bits(out[k]), Bits(interpreted))
          << kFormulas[k] << ": generated " << out[k] << ", interpreted " << interpreted << " at t = " << in.t
          << ", x = " << in.x[0] << " " << in.x[1] << " " << in.x[2] << ", w = " << in.w[0] << " " << in.w[1];
      ++compared;
      nans += std::isnan(interpreted);
    }
  }
  EXPECT_EQ(compared, 20000 * static_cast<long>(kFormulas.size()));
  EXPECT_GT(nans, 0);  // the domains' edges were reached too

  // Comparisons, logic and if at NaN, infinities, zeros of both signs and a NaN of another
  // payload: the same bits (a NaN on a branch not taken never reaches the value).
  const double nan = std::numeric_limits<double>::quiet_NaN(), inf = std::numeric_limits<double>::infinity();
  const double special[] = {nan, -nan, inf, -inf, 0.0, -0.0, 1.0, -1.0, 0.5, std::bit_cast<double>(std::uint64_t{0x7ff8000000000abc})};
  int switching = 0;
  for (const double a : special)
    for (const double b : special)
      for (const double c : special) {
        const Inputs in{a > 0 ? 2.0 : 0.5, {a, b, c}, {b, c, 2.5, std::numbers::pi}};
        all(in.t, in.x, in.w, out.data());
        for (size_t k = 0; k < kFormulas.size(); ++k) {
          if (!Switching(kFormulas[k])) continue;
          const double interpreted = expr::Run(programs[k], in.t, in.x, in.w);
          // A sum or a product of two NaNs may give either's payload (the compiler may swap the
          // operands of + and *): there, NaN is NaN. Everywhere else, the bits.
          const bool commutes = kFormulas[k].find('+') != std::string::npos || kFormulas[k].find('*') != std::string::npos;
          const double evaluated = EvaluateAt(*Tree(kFormulas[k]), in);
          if (commutes && std::isnan(interpreted)) {
            ASSERT_TRUE(std::isnan(out[k]) && std::isnan(evaluated)) << kFormulas[k];
          } else {
            ASSERT_EQ(Bits(out[k]), Bits(interpreted)) << kFormulas[k] << ": generated " << out[k] << ", interpreted " << interpreted
                                                       << " at x = " << a << " " << b << " " << c;
            ASSERT_EQ(Bits(interpreted), Bits(evaluated)) << kFormulas[k];
          }
          ++switching;
        }
      }
  EXPECT_EQ(switching, 1000 * static_cast<int>(std::count_if(kFormulas.begin(), kFormulas.end(), Switching)));
  EXPECT_GE(std::count_if(kFormulas.begin(), kFormulas.end(), Switching), 21);
}

TEST(ExprProgram, ComparisonsLogicAndIfAtNaN) {
  const double nan = std::numeric_limits<double>::quiet_NaN(), inf = std::numeric_limits<double>::infinity();
  const auto run = [](const std::string& f, double x0, double x1 = 0.0, double x2 = 0.0) {
    const double x[3] = {x0, x1, x2};
    return expr::Run(CompileProgram(*Tree(f), Resolve), 0.0, x, nullptr);
  };
  EXPECT_EQ(run("x0 < x1", nan, 1.0), 0.0);
  EXPECT_EQ(run("x0 >= x1", 1.0, nan), 0.0);
  EXPECT_EQ(run("x0 == x1", nan, nan), 0.0);
  EXPECT_EQ(run("x0 != x1", nan, nan), 1.0);
  EXPECT_EQ(run("not x0", nan), 1.0);  // NaN is false
  EXPECT_EQ(run("x0 or x1", nan, 0.0), 0.0);
  EXPECT_EQ(run("x0 and x1", nan, 1.0), 0.0);
  EXPECT_EQ(run("if(x0, 1, 2)", nan), 2.0);
  EXPECT_EQ(run("if(x0 > 0, sqrt(x0), 0)", -1.0), 0.0);     // the NaN of sqrt(-1) is not taken
  EXPECT_EQ(run("if(x0 != 0, 1/x0, 3)", 0.0), 3.0);         // nor the infinity of 1/0
  EXPECT_EQ(run("if(x0 > 0, x1, x2)", 1.0, inf, nan), inf);
  EXPECT_TRUE(std::isnan(run("if(x0 > 0, x1, x2)", -1.0, inf, nan)));
  EXPECT_EQ(run("x0 < x1 and x1 < x2", 0.0, 0.5, 1.0), 1.0);
  EXPECT_EQ(run("x0 < x1 and x1 < x2", 0.0, 1.5, 1.0), 0.0);
}

/// law(u) = target by SolveFor, u read from w[0].
double Solved(const std::string& law, const std::string& slope, double target) {
  const Resolver r = [](const Node& n) {
    return n.name == "u" ? Input{Input::In::kSlot, 0, 0.0} : Input{Input::In::kConstant, 0, 3.141592653589793};
  };
  const Program pl = CompileProgram(*Parse(law).root, r), ps = CompileProgram(*Parse(slope).root, r);
  double w[1] = {0.0};
  const double u = SolveFor(pl, ps, 0, target, 0.0, nullptr, w);
  EXPECT_EQ(Bits(w[0]), Bits(u));  // the scratch slot holds the answer, NaN included
  return u;
}

TEST(ExprProgram, SolveForFindsTheRootToTheLastBitsOrSaysThereIsNone) {
  EXPECT_EQ(Solved("u^3", "3*u^2", 8.0), 2.0);
  EXPECT_EQ(Solved("u^3", "3*u^2", -27.0), -3.0);
  EXPECT_EQ(Solved("2*u", "2", 0.0), 0.0);
  // A law with a kink and no slope at 0 (an orifice), far from 0.
  EXPECT_NEAR(Solved("sign(u)*sqrt(abs(u))", "0.5/sqrt(abs(u))", 1e3), 1e6, 1e6 * 4e-16);
  // Overflow on the way (an exponential): the infinite side still brackets the root.
  EXPECT_NEAR(Solved("1e-12*(exp(u/0.025) - 1)", "exp(40*u)/25000000000", 0.5), 0.025 * std::log1p(0.5e12), 4e-16);
  // No root: u^2 + 1 never reaches -5 (NaN, for the caller to name the formula).
  EXPECT_TRUE(std::isnan(Solved("u^2 + 1", "2*u", -5.0)));
  EXPECT_TRUE(std::isnan(Solved("u", "1", std::numeric_limits<double>::quiet_NaN())));
}


// ---------------------------------------------------------------------------------------------
// Tangents (RunTangent) at and away from kinks.

/// The directional derivative of `text` at the states x along dx (t = 0, no slots).
double TangentAt(const std::string& text, const std::vector<double>& x, const std::vector<double>& dx) {
  const Program p = CompileProgram(*Tree(text), Resolve);
  double v = 0.0;
  const double d = RunTangent(p, 0.0, x.data(), nullptr, 0.0, dx.data(), nullptr, &v);
  EXPECT_EQ(Bits(v), Bits(Run(p, 0.0, x.data(), nullptr))) << text;  // the value is Run's
  return d;
}

/// The partial derivatives of `text` in x0, x1, x2 at x (one tangent pass along each axis).
std::vector<double> Gradient(const std::string& text, const std::vector<double>& x) {
  std::vector<double> g;
  for (int i = 0; i < 3; ++i) {
    std::vector<double> dx(3, 0.0);
    dx[static_cast<size_t>(i)] = 1.0;
    g.push_back(TangentAt(text, x, dx));
  }
  return g;
}

/// The mean of the one-sided slopes of `text` at x along the axis i, by differences that the
/// functions below, piecewise linear, give exactly (h a power of 2, the points small integers).
double MeanOneSidedSlope(const std::string& text, std::vector<double> x, int i) {
  const Program p = CompileProgram(*Tree(text), Resolve);
  const double h = 0x1p-10, x0 = x[static_cast<size_t>(i)];
  x[static_cast<size_t>(i)] = x0 + h;
  const double up = Run(p, 0.0, x.data(), nullptr);
  x[static_cast<size_t>(i)] = x0 - h;
  const double down = Run(p, 0.0, x.data(), nullptr);
  x[static_cast<size_t>(i)] = x0;
  const double at = Run(p, 0.0, x.data(), nullptr);
  return ((up - at) / h + (at - down) / h) / 2.0;
}

using Gradient3 = std::vector<double>;

TEST(ExprTangent, MaxAtATieTakesHalfOfEachArgument) {
  EXPECT_EQ(Gradient("max(x0, x1)", {0.0, 0.0, 0.0}), (Gradient3{0.5, 0.5, 0.0}));
  EXPECT_EQ(Gradient("max(x0, x1)", {-2.0, -2.0, 0.0}), (Gradient3{0.5, 0.5, 0.0}));
  EXPECT_EQ(Gradient("max(x0, 0)", {0.0, 0.0, 0.0}), (Gradient3{0.5, 0.0, 0.0}));  // a constant bound
  EXPECT_EQ(Gradient("max(x0, x1)", {0.0, -0.0, 0.0}), (Gradient3{0.5, 0.5, 0.0}));  // 0 == -0: a tie
  // Along a direction that keeps the tie, both slopes are 1: so is the tangent.
  EXPECT_EQ(TangentAt("max(x0, x1)", {1.0, 1.0, 0.0}, {1.0, 1.0, 0.0}), 1.0);
  EXPECT_EQ(TangentAt("max(3*x0, x0)", {0.0, 0.0, 0.0}, {1.0, 0.0, 0.0}), 2.0);  // (3 + 1)/2
}

TEST(ExprTangent, MaxAwayFromATieIsTheSlopeOfTheLargerArgument) {
  EXPECT_EQ(Gradient("max(x0, x1)", {1.0, 0.0, 0.0}), (Gradient3{1.0, 0.0, 0.0}));
  EXPECT_EQ(Gradient("max(x0, x1)", {0.0, 1e-300, 0.0}), (Gradient3{0.0, 1.0, 0.0}));
  EXPECT_EQ(Gradient("max(x0, 0)", {-1.0, 0.0, 0.0}), (Gradient3{0.0, 0.0, 0.0}));
}

TEST(ExprTangent, MinAtATieTakesHalfOfEachArgument) {
  EXPECT_EQ(Gradient("min(x0, x1)", {0.0, 0.0, 0.0}), (Gradient3{0.5, 0.5, 0.0}));
  EXPECT_EQ(Gradient("min(x0, 0)", {0.0, 0.0, 0.0}), (Gradient3{0.5, 0.0, 0.0}));
  EXPECT_EQ(TangentAt("min(x0, -x0)", {0.0, 0.0, 0.0}, {1.0, 0.0, 0.0}), 0.0);  // (1 - 1)/2: -|x0|
}

TEST(ExprTangent, MinAwayFromATieIsTheSlopeOfTheSmallerArgument) {
  EXPECT_EQ(Gradient("min(x0, x1)", {1.0, 0.0, 0.0}), (Gradient3{0.0, 1.0, 0.0}));
  EXPECT_EQ(Gradient("min(x0, x1)", {-1e-300, 0.0, 0.0}), (Gradient3{1.0, 0.0, 0.0}));
}

TEST(ExprTangent, ClampAtABoundTakesHalfForXAndHalfForTheBound) {
  EXPECT_EQ(Gradient("clamp(x0, x1, x2)", {-1.0, -1.0, 1.0}), (Gradient3{0.5, 0.5, 0.0}));  // at lo
  EXPECT_EQ(Gradient("clamp(x0, x1, x2)", {1.0, -1.0, 1.0}), (Gradient3{0.5, 0.0, 0.5}));   // at hi
  // lo == x == hi: lo on one side, hi on the other, x on neither.
  EXPECT_EQ(Gradient("clamp(x0, x1, x2)", {2.0, 2.0, 2.0}), (Gradient3{0.0, 0.5, 0.5}));
  EXPECT_EQ(Gradient("clamp(x0, -1, 1)", {-1.0, 0.0, 0.0}), (Gradient3{0.5, 0.0, 0.0}));
  EXPECT_EQ(Gradient("clamp(x0, -1, 1)", {1.0, 0.0, 0.0}), (Gradient3{0.5, 0.0, 0.0}));
}

TEST(ExprTangent, ClampAwayFromItsBoundsIsTheSlopeOfTheBranchTaken) {
  EXPECT_EQ(Gradient("clamp(x0, x1, x2)", {0.0, -1.0, 1.0}), (Gradient3{1.0, 0.0, 0.0}));   // between
  EXPECT_EQ(Gradient("clamp(x0, x1, x2)", {-2.0, -1.0, 1.0}), (Gradient3{0.0, 1.0, 0.0}));  // below
  EXPECT_EQ(Gradient("clamp(x0, x1, x2)", {2.0, -1.0, 1.0}), (Gradient3{0.0, 0.0, 1.0}));   // above
  // lo > hi (no interval): lo wins below lo, hi elsewhere, as the value does.
  EXPECT_EQ(Gradient("clamp(x0, x1, x2)", {0.0, 1.0, -1.0}), (Gradient3{0.0, 1.0, 0.0}));
  EXPECT_EQ(Gradient("clamp(x0, x1, x2)", {2.0, 1.0, -1.0}), (Gradient3{0.0, 0.0, 1.0}));
}

TEST(ExprTangent, AbsAtZeroIsZeroAndSignsSlopeIsZero) {
  EXPECT_EQ(Gradient("abs(x0)", {0.0, 0.0, 0.0}), (Gradient3{0.0, 0.0, 0.0}));
  EXPECT_EQ(Gradient("abs(x0)", {-0.0, 0.0, 0.0}), (Gradient3{0.0, 0.0, 0.0}));
  EXPECT_EQ(Gradient("abs(x0)", {2.0, 0.0, 0.0}), (Gradient3{1.0, 0.0, 0.0}));
  EXPECT_EQ(Gradient("abs(x0)", {-2.0, 0.0, 0.0}), (Gradient3{-1.0, 0.0, 0.0}));
  for (const double x : {-1.0, 0.0, 1.0}) EXPECT_EQ(Gradient("sign(x0)", {x, 0.0, 0.0}), (Gradient3{0.0, 0.0, 0.0})) << x;
}

TEST(ExprTangent, ABilinearDamperAtRestHasTheMeanOfItsTwoRates) {
  // c_bump max(f, 0) + c_reb min(f, 0) at f = 0: (c_bump + c_reb)/2, not their sum.
  EXPECT_EQ(TangentAt("800*max(x0, 0) + 2400*min(x0, 0)", {0.0, 0.0, 0.0}, {1.0, 0.0, 0.0}), 1600.0);
  EXPECT_EQ(TangentAt("800*max(x0, 0) + 2400*min(x0, 0)", {0.5, 0.0, 0.0}, {1.0, 0.0, 0.0}), 800.0);
  EXPECT_EQ(TangentAt("800*max(x0, 0) + 2400*min(x0, 0)", {-0.5, 0.0, 0.0}, {1.0, 0.0, 0.0}), 2400.0);
}

/// Points at and away from every kink of the formulas below (small integers and their halves).
const std::vector<std::vector<double>> kKinkPoints = {
    {0, 0, 0}, {1, 1, 1}, {-1, -1, 1}, {1, -1, 1}, {2, 2, 2}, {0, -1, 1}, {-2, -1, 1}, {2, -1, 1}, {0.5, 0, -0.5}, {-1, 0, 2},
};
const std::vector<std::string> kKinkFormulas = {
    "max(x0, x1)", "min(x0, x1)", "clamp(x0, x1, x2)", "abs(x0)", "sign(x0)", "max(x0, 0)", "min(x0, 0)",
    "clamp(2*x0, -1, 1)", "3*max(x0, x1) - 2*min(x1, x2) + abs(x2)",
};

TEST(ExprTangent, EveryKinkHasTheMeanOfItsOneSidedSlopesAlongEachArgument) {
  // Along one argument at a time the one-sided slopes are those of the branches; their mean is
  // the tangent (sign: 0 away from its jump, and 0 by definition at it).
  for (const std::string& f : kKinkFormulas)
    for (const std::vector<double>& x : kKinkPoints) {
      const std::vector<double> g = Gradient(f, x);
      for (int i = 0; i < 3; ++i) {
        if (f.find("sign") != std::string::npos) {
          EXPECT_EQ(g[static_cast<size_t>(i)], 0.0) << f;
          continue;
        }
        EXPECT_EQ(g[static_cast<size_t>(i)], MeanOneSidedSlope(f, x, i))
            << f << " along x" << i << " at (" << x[0] << ", " << x[1] << ", " << x[2] << ")";
      }
    }
}

TEST(ExprTangent, AgreesWithTheSymbolicDerivativesAtAndAwayFromKinks) {
  // The symbolic derivative (compile/symbolic.cc: Newton's slopes, laws from energies) and the
  // tangent take the same value at a kink, so that the linearisation and the laws agree. (Not
  // abs at 0, where GiNaC's derivative of abs is not defined: NaN, the tangent 0.)
  for (const std::string& f : kKinkFormulas)
    for (const std::vector<double>& x : kKinkPoints) {
      if (f.find("abs(x2)") != std::string::npos && x[2] == 0.0) continue;
      if (f == "abs(x0)" && x[0] == 0.0) continue;
      const std::vector<double> g = Gradient(f, x);
      const auto at = [&](const std::string& name) -> std::optional<double> {
        if (name.size() == 2 && name[0] == 'x') return x[static_cast<size_t>(name[1] - '0')];
        return std::nullopt;
      };
      for (int i = 0; i < 3; ++i) {
        const NodePtr d = Differentiate(*Tree(f), fmt::format("x{}", i));
        EXPECT_EQ(g[static_cast<size_t>(i)], Evaluate(*d, at))
            << f << " along x" << i << " at (" << x[0] << ", " << x[1] << ", " << x[2] << ")";
      }
    }
}

}  // namespace
}  // namespace multibond::expr
