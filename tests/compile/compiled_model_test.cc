// The generated right-hand side, checked variable by variable against hand-computed values, for
// the state-dependent elements the rigid-body library is built from: an MTF carrying a rotation
// matrix, a lever-arm MTF (paper eq. 1-6), an inertia R Ib R^T and an orientation state.

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <thread>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fmt/format.h>

#include "multibond/compile/compiled_model.h"
#include "multibond/compile/exact_sum.h"
#include "multibond/compile/generated_rhs.h"
#include "multibond/core/interrupt.h"
#include "multibond/io/model_loader.h"
#include "multibond/sim/simulator.h"
#include "support/example_runner.h"
#include "support/rotation_graph.h"
#include "support/temp_dir.h"

namespace multibond {
namespace {

TEST(CompiledModel, RotationAndLeverModuliFollowTheState) {
  const Eigen::Matrix3d r0 = SomeRotation();
  const Eigen::Vector3d lever(0.1, 0.0, 0.1);
  const auto model = CompiledModel::Compile(RotationGraph(r0, lever));
  Workspace ws = model->MakeWorkspace();
  Eigen::VectorXd x = model->MakeInitialState(), xdot(x.size());
  model->CalcDerivatives(0.0, x.data(), xdot.data(), ws);
  const Eigen::Vector3d w(0.4, -1.5, 2.5);
  Eigen::Vector3d got;
  model->Read(*model->FindVariable("rb.f"), x.data(), ws, got.data());
  EXPECT_TRUE(got.isApprox(r0.transpose() * w, 1e-14)) << got.transpose();
  model->Read(*model->FindVariable("rq.f"), x.data(), ws, got.data());
  EXPECT_TRUE(got.isApprox(w.cross(r0 * lever), 1e-14)) << got.transpose();  // v_Q = w x (R r)
  // Power through each MTF is conserved: the torque on wj is M^T (resistor force).
  Eigen::Vector3d fq;
  model->Read(*model->FindVariable("rq.e"), x.data(), ws, fq.data());
  Eigen::Vector3d torque;
  model->Read(*model->FindVariable("arm.e1"), x.data(), ws, torque.data());
  EXPECT_TRUE(torque.isApprox((r0 * lever).cross(fq), 1e-14));  // moment of the force about C
  // dR/dt = [w x] R, stored row-major as R.11 ... R.33.
  const auto rv = model->FindVariable("R");
  ASSERT_TRUE(rv);
  ASSERT_EQ(rv->size, 9);
  Eigen::Matrix3d skew;
  skew << 0, -w.z(), w.y(), w.z(), 0, -w.x(), -w.y(), w.x(), 0;
  const Eigen::Matrix3d rdot = skew * r0;
  for (int i = 0; i < 9; ++i) EXPECT_NEAR(xdot[rv->offset + i], rdot(i / 3, i % 3), 1e-14);
  EXPECT_EQ(model->state_names()[rv->offset + 5], "R.23");
}

TEST(CompiledModel, FreeRigidBodyWithRotatingInertiaConservesEnergyAndMomentum) {
  // A torque-free asymmetric body: 1-junction w (inertial frame), I with inertia R Ib R^T.
  BondGraph g;
  g.AddJunction("w", ElementKind::kOne, 3);
  Element body;
  body.name = "J";
  body.kind = ElementKind::kI;
  body.param = Param::Matrix(Eigen::Vector3d(1.0, 2.0, 3.0).asDiagonal());
  body.rotation = "R";
  body.initial = Eigen::Vector3d(0.1, 2.0, 0.05);  // near the intermediate axis
  g.Add(body);
  g.Connect("w", "J");
  AuxState orient;
  orient.name = "R";
  orient.kind = AuxState::Kind::kOrientation;
  orient.of = "w";
  g.AddAux(orient);
  const auto model = CompiledModel::Compile(std::move(g));
  RunOptions o;
  o.t_end = 20;
  o.dt = 0.01;
  o.integrator.rtol = 1e-11;
  o.integrator.atol = 1e-13;
  RecordingObserver rec;
  Simulate(*model, o, rec);
  ASSERT_EQ(rec.summary().status, RunStatus::kOk);
  const double e0 = rec.rows().front()[rec.Index("energy.kinetic")];
  double max_de = 0, max_orth = 0, max_w_change = 0;
  for (const auto& row : rec.rows()) {
    max_de = std::max(max_de, std::abs(row[rec.Index("energy.kinetic")] - e0) / e0);
    Eigen::Matrix3d r;
    for (int i = 0; i < 9; ++i) r(i / 3, i % 3) = row[rec.Index("R." + std::to_string(11 + 10 * (i / 3) + i % 3))];
    max_orth = std::max(max_orth, (r.transpose() * r - Eigen::Matrix3d::Identity()).norm());
    max_w_change = std::max(max_w_change, std::abs(row[rec.Index("J.p.y")] - 2.0));
  }
  EXPECT_LT(max_de, 1e-8);
  EXPECT_LT(max_orth, 1e-8);
  EXPECT_EQ(max_w_change, 0.0);  // no torque: h is constant in the inertial frame, exactly
  // The body does tumble: the flow of w (the angular velocity) is not constant.
  EXPECT_GT(std::abs(rec.rows()[500][rec.Index("R.11")] - 1.0), 0.1);
}

TEST(CompiledModel, JunctionsShareSlotsAndPlanIsSmall) {
  // Mass-spring-damper: 4 bonds, one 1-junction: the flows share one slot; the plan has one
  // instruction per computed variable: source, I flow, C effort, R effort, junction sum.
  BondGraph g;
  g.AddSe("f", {{TimeFunction::Constant(1)}});
  g.AddI("m", Param::Scalar(1));
  g.AddC("k", Param::Scalar(1));
  g.AddR("c", Param::Scalar(1));
  g.AddJunction("j", ElementKind::kOne);
  for (const char* e : {"m", "k", "c"}) g.Connect("j", e);
  g.Connect("f", "j");
  const auto model = CompiledModel::Compile(std::move(g));
  EXPECT_EQ(model->num_instructions(), 5);
  EXPECT_EQ(model->MakeWorkspace().slots.size(), 5u);  // 4 efforts + 1 shared flow
}

TEST(CompiledModel, NamesInGeneratedCodeStayInsideTheirComments) {
  // The C++ API takes any name (the loader refuses these): a line break would end the comment
  // the name is written in and run the rest as code, a final backslash would splice the next
  // line of code into the comment.
  const std::string injected = "m\nint injected_marker = 1;\n//";
  BondGraph g("model\n#error injected");
  g.AddSe("f", {{TimeFunction::Constant(1)}});
  g.AddI(injected, Param::Scalar(1));
  g.AddC("k\\", Param::Scalar(1));
  g.AddJunction("j", ElementKind::kOne);
  for (const std::string& e : {injected, std::string("k\\")}) g.Connect("j", e);
  g.Connect("f", "j");
  const std::string src = CompiledModel::Compile(std::move(g))->GenerateSource();
  EXPECT_THAT(src, ::testing::Not(::testing::HasSubstr("\nint injected_marker")));
  EXPECT_THAT(src, ::testing::Not(::testing::HasSubstr("\n#error")));
  EXPECT_THAT(src, ::testing::HasSubstr("// m?int injected_marker = 1;?//\n"));
  EXPECT_THAT(src, ::testing::HasSubstr("// k?\n"));
  EXPECT_THAT(src, ::testing::Not(::testing::HasSubstr("\\\n")));  // no line ends in a backslash
}

}  // namespace
}  // namespace multibond

namespace multibond {
namespace {

TEST(CompiledModel, SixDimensionalBondsEqualSixScalarCopies) {
  // A 6-dimensional mass-spring-damper (e.g. a spatial twist/wrench pair) with a full,
  // symmetric positive-definite stiffness coupling components 1 and 6; checked against the same
  // linear system written out by hand: M q'' + C q' + K q = F.
  Eigen::VectorXd m(6), c(6), f(6);
  m << 1, 2, 3, 4, 5, 6;
  c << 0.5, 0.4, 0.3, 0.2, 0.1, 0.6;
  f << 1, -1, 2, -2, 3, -3;
  Eigen::MatrixXd k = Eigen::VectorXd::LinSpaced(6, 10, 60).asDiagonal();
  k(0, 5) = k(5, 0) = 4.0;
  BondGraph g;
  SourceValue src;
  for (int i = 0; i < 6; ++i) src.components.push_back(TimeFunction::Constant(f[i]));
  g.AddSe("force", src, 6);
  g.AddI("mass", Param::Matrix(m.asDiagonal()), 6);
  g.AddC("spring", Param::Matrix(k), 6);
  g.AddR("damper", Param::Matrix(c.asDiagonal()), 6);
  g.AddJunction("j", ElementKind::kOne, 6);
  for (const char* e : {"mass", "spring", "damper"}) g.Connect("j", e);
  g.Connect("force", "j");
  const auto model = CompiledModel::Compile(std::move(g));
  ASSERT_EQ(model->num_states(), 12 + 2);  // p, q and the energy account
  Workspace ws = model->MakeWorkspace();
  Eigen::VectorXd x = model->MakeInitialState(), xdot(x.size());
  for (int i = 0; i < 12; ++i) x[i] = 0.1 * (i + 1) * (i % 2 ? -1 : 1);
  model->CalcDerivatives(0.0, x.data(), xdot.data(), ws);
  const Eigen::VectorXd p = x.segment(0, 6), q = x.segment(6, 6);
  const Eigen::VectorXd v = p.cwiseQuotient(m);
  const Eigen::VectorXd pdot = f - k * q - c.cwiseProduct(v);
  EXPECT_TRUE(xdot.segment(0, 6).isApprox(pdot, 1e-14)) << xdot.segment(0, 6).transpose();
  EXPECT_TRUE(xdot.segment(6, 6).isApprox(v, 1e-14));
  EXPECT_EQ(model->state_names()[5], "mass.p.6");
}

// ---------------------------------------------------------------------------------------------
// One answer (issue 21): the interpreter and the generated code give the same bits.

/// Two engines: a model on the interpreter, and a model (the same one, or another compile) on
/// its generated code.
struct Engines {
  std::shared_ptr<const CompiledModel> interpreter, generated;
  std::shared_ptr<const GeneratedRhs> code;  ///< generated's
};

/// One compiled model of the example, evaluated by both engines: the model is immutable, the
/// generated code is outside it.
Engines CompileBoth(const std::string& example) {
  const LoadedModel lm = LoadModelFile(std::string(MULTIBOND_SOURCE_DIR) + "/examples/" + example);
  Engines e;
  e.interpreter = e.generated = CompiledModel::Compile(lm.graph, lm.compile);
  e.code = GeneratedRhs::Start(e.generated);
  return e;
}

/// Bitwise equality of two arrays of doubles (EXPECT_EQ on doubles would take -0 for 0).
::testing::AssertionResult SameBits(const char* what, const double* a, const double* b, int n, const std::vector<std::string>* names = nullptr) {
  int differ = 0;
  std::string first;
  for (int i = 0; i < n; ++i) {
    if (std::memcmp(&a[i], &b[i], sizeof(double)) == 0) continue;
    if (differ++ < 8)
      first += fmt::format("\n  {}[{}]{}: {:a} vs {:a} ({:.17g} vs {:.17g})", what, i, names ? " " + (*names)[i] : "", a[i], b[i], a[i], b[i]);
  }
  if (differ == 0) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure() << differ << " of " << n << " values differ:" << first;
}

/// Both engines of one example at the initial state and at states nearby: the same bits in every
/// state derivative and every slot.
void ExpectSameBits(const std::string& example, const Engines& e) {
  Workspace wi = e.interpreter->MakeWorkspace(), wg = e.generated->MakeWorkspace(e.code.get());
  const Eigen::VectorXd x0 = e.interpreter->MakeInitialState();
  const int n = static_cast<int>(x0.size());
  std::mt19937_64 rng(21);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int trial = 0; trial < 6; ++trial) {
    Eigen::VectorXd x = x0;
    // The initial state, then states nearby at growing distances (rotations stay near SO(3)).
    if (trial > 0)
      for (int i = 0; i < n; ++i) x[i] += std::ldexp(u(rng), -2 * (6 - trial)) * (1.0 + std::abs(x[i]));
    const double t = 0.0137 * trial;
    Eigen::VectorXd di(n), dg(n), fi(n), fg(n);
    e.interpreter->CalcDerivatives(t, x.data(), di.data(), wi);
    e.generated->CalcDerivatives(t, x.data(), dg.data(), wg);
    EXPECT_TRUE(SameBits("xdot", di.data(), dg.data(), n, &e.interpreter->state_names())) << example << " trial " << trial;
    EXPECT_TRUE(SameBits("slot", wi.slots.data(), wg.slots.data(), static_cast<int>(wi.slots.size()))) << example << " trial " << trial;
    e.interpreter->CalcStateDerivatives(t, x.data(), fi.data(), wi);
    e.generated->CalcStateDerivatives(t, x.data(), fg.data(), wg);
    EXPECT_TRUE(SameBits("xdot (integrator entry)", fi.data(), fg.data(), n, &e.interpreter->state_names())) << example << " trial " << trial;
  }
}

class OneAnswer : public ::testing::TestWithParam<std::string> {};

TEST_P(OneAnswer, InterpreterAndGeneratedCodeGiveTheSameBits) {
  const Engines e = CompileBoth(GetParam());
  if (!e.code->ready()) GTEST_SKIP() << e.code->engine();
  ExpectSameBits(GetParam(), e);
}

/// Sums as on a machine without FMA (exact_sum.h), for the scope of one test.
struct UnfusedSums {
  bool before = fused_sums;
  UnfusedSums() { fused_sums = false; }
  ~UnfusedSums() { fused_sums = before; }
};

// A machine without an FMA instruction would run glibc's software fma (about 100 ns a call) in
// the generated code and the interpreter; there both engines write each term as a multiply and an
// add, and still agree to the bit.
TEST_P(OneAnswer, WithoutFusedSumsTheEnginesStillAgree) {
  UnfusedSums unfused;
  const Engines e = CompileBoth(GetParam());
  if (!e.code->ready()) GTEST_SKIP() << e.code->engine();
  EXPECT_THAT(e.generated->GenerateSource(), ::testing::Not(::testing::HasSubstr("fma")));
  ExpectSameBits(GetParam(), e);
}

INSTANTIATE_TEST_SUITE_P(Examples, OneAnswer,
                         ::testing::Values("compliant_gear_pair.yaml", "dc_motor.yaml", "differential.yaml", "differential_ideal.yaml",
                                           "mass_spring_damper.yaml", "mass_spring_damper_3d.yaml", "rlc_circuit.yaml"),
                         [](const auto& info) {
                           std::string s = info.param.substr(0, info.param.find('.'));
                           return s;
                         });

// Where the CPU has FMA, every further term of a sum is one fused multiply-add in the generated
// code (the interpreter's std::fma gives the same bits; the speed of the FMA build, issue 21).
TEST(OneAnswerRun, TheGeneratedCodeFusesItsSumsWhereTheCpuHasFma) {
  if (!__builtin_cpu_supports("fma")) GTEST_SKIP() << "no FMA on this CPU";
  ASSERT_TRUE(fused_sums);
  const LoadedModel lm = LoadModelFile(std::string(MULTIBOND_SOURCE_DIR) + "/examples/differential.yaml");
  const std::string src = CompiledModel::Compile(lm.graph, lm.compile)->GenerateSource();
  EXPECT_THAT(src, ::testing::HasSubstr("__builtin_fma("));
}

/// A short run of a model (0.05 s, samples every 5 ms, every variable) with its file's solver.
RunOptions ShortRun(const LoadedModel& lm) {
  RunOptions o;
  o.t_end = 0.05;
  o.dt = 0.005;
  o.integrator.method = ParseMethod(lm.simulation.solver.value_or("bdf"));
  o.integrator.rtol = lm.simulation.rtol.value_or(1e-8);
  o.integrator.atol = lm.simulation.atol.value_or(1e-10);
  o.all_variables = true;
  return o;
}

// Before: runs with and without the generated code wrote different numbers (fused multiply-adds
// on one side, Eigen's vectorised 3x3 products and sums from +0.0 on the other).
TEST(OneAnswerRun, TheDifferentialGivesTheSameSamplesOnBothEngines) {
  const LoadedModel lm = LoadModelFile(std::string(MULTIBOND_SOURCE_DIR) + "/examples/differential.yaml");
  std::vector<std::vector<double>> rows[2];
  for (int engine = 0; engine < 2; ++engine) {
    const auto model = CompiledModel::Compile(lm.graph, lm.compile);
    RunOptions o = ShortRun(lm);
    if (engine == 1) {
      o.code = GeneratedRhs::Start(model);
      ASSERT_TRUE(o.code->ready()) << o.code->engine();
    }
    RecordingObserver rec;
    Simulate(*model, o, rec);
    rows[engine] = rec.rows();
  }
  ASSERT_EQ(rows[0].size(), rows[1].size());
  ASSERT_GT(rows[0].size(), 10u);
  for (size_t i = 0; i < rows[0].size(); ++i) {
    ASSERT_EQ(rows[0][i].size(), rows[1][i].size());
    EXPECT_TRUE(SameBits("sample", rows[0][i].data(), rows[1][i].data(), static_cast<int>(rows[0][i].size()))) << "row " << i;
  }
}

// A stop while the generated code compiles ends the run (it used to fall back to the
// interpreter, like a compiler that fails, after the compiler had run to its end).
TEST(OneAnswerRun, AStopWhileCompilingIsNotAFallback) {
  const char* old_cxx = std::getenv("MULTIBOND_CXX");
  const std::string saved = old_cxx ? old_cxx : "";
  testing::TempDir dir("multibond-slow-cxx");
  const std::string script = (dir.path() / "slow-cxx.sh").string();
  std::ofstream(script) << "#!/bin/sh\nexec sleep 30\n";
  std::filesystem::permissions(script, std::filesystem::perms(0700));
  setenv("MULTIBOND_CXX", script.c_str(), 1);
  const LoadedModel lm = LoadModelFile(std::string(MULTIBOND_SOURCE_DIR) + "/examples/mass_spring_damper.yaml");
  const auto model = CompiledModel::Compile(lm.graph, lm.compile);
  ResetStop();
  std::thread stopper([] {
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
    StopFlag().store(true);
  });
  const auto start = std::chrono::steady_clock::now();
  EXPECT_THROW(GeneratedRhs::Start(model), Interrupted);
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(2));
  stopper.join();
  ResetStop();
  if (old_cxx) setenv("MULTIBOND_CXX", saved.c_str(), 1);
  else unsetenv("MULTIBOND_CXX");
}


// ---------------------------------------------------------------------------------------------
// Generated code at scale (docs/design.md): the text depends on the structure only, large models
// in units compiled in parallel, a library loaded once per process, the switch from the
// interpreter to the code compiled in the background.

/// Points the JIT cache at a fresh folder for the scope of one test.
struct FreshJitCache {
  testing::TempDir dir{"multibond-jit-scale"};
  std::string before;
  bool had = false;
  FreshJitCache() {
    if (const char* old = std::getenv("MULTIBOND_CACHE")) {
      had = true;
      before = old;
    }
    setenv("MULTIBOND_CACHE", dir.path().c_str(), 1);
  }
  ~FreshJitCache() {
    if (had) setenv("MULTIBOND_CACHE", before.c_str(), 1);
    else unsetenv("MULTIBOND_CACHE");
  }
  int Libraries() const {
    int n = 0;
    for (const auto& e : std::filesystem::directory_iterator(dir.path())) n += e.path().extension() == ".so";
    return n;
  }
};

/// The mass-spring-damper example with its mass, stiffness, resistance and force replaced.
LoadedModel MassSpringDamper(const std::string& mass, const std::string& stiffness, const std::string& resistance,
                             const std::string& force) {
  std::ifstream in(std::string(MULTIBOND_SOURCE_DIR) + "/examples/mass_spring_damper.yaml");
  std::stringstream ss;
  ss << in.rdbuf();
  std::string text = ss.str();
  auto replace = [&text](const std::string& from, const std::string& to) {
    const size_t at = text.find(from);
    ASSERT_NE(at, std::string::npos) << from;
    text.replace(at, from.size(), to);
  };
  replace("inertia: 1.0", "inertia: " + mass);
  replace("stiffness: 100.0", "stiffness: " + stiffness);
  replace("resistance: 2.0", "resistance: " + resistance);
  replace("{step: {value: 1.0", "{step: {value: " + force);
  return LoadModelString(text, "mass_spring_damper.yaml");
}

TEST(GeneratedCodeAtScale, TheTextDependsOnTheStructureNotOnTheParameterValues) {
  const LoadedModel a = MassSpringDamper("2.5", "100.0", "2.0", "1.0"), b = MassSpringDamper("4.0", "250.0", "3.5", "7.5");
  // Without the value table (one model's default) the numbers are literals: the texts differ.
  {
    const auto la = CompiledModel::Compile(a.graph, a.compile), lb = CompiledModel::Compile(b.graph, b.compile);
    const CompiledModel::GeneratedUnits ta = la->GenerateUnits(GenerateOptions::kDefaultUnitChars);
    EXPECT_NE(ta.units, lb->GenerateUnits(GenerateOptions::kDefaultUnitChars).units);
    EXPECT_TRUE(ta.values.empty());
    EXPECT_THAT(ta.units.front(), ::testing::HasSubstr(fmt::format("{:a}", 100.0)));
  }
  const auto ma = CompiledModel::Compile(a.graph, a.compile), mb = CompiledModel::Compile(b.graph, b.compile);
  const CompiledModel::GeneratedUnits ga = ma->GenerateUnits(GenerateOptions::kDefaultUnitChars, /*value_table=*/true);
  const CompiledModel::GeneratedUnits gb = mb->GenerateUnits(GenerateOptions::kDefaultUnitChars, /*value_table=*/true);
  ASSERT_EQ(ga.units.size(), 1u);
  EXPECT_EQ(ga.units, gb.units);
  EXPECT_NE(ga.values, gb.values);
  // The numbers are in the table, not in the text: 1/m, k, R and the force.
  for (double v : {0.25, 250.0, 3.5, 7.5}) {
    EXPECT_THAT(gb.values, ::testing::Contains(v));
    EXPECT_THAT(gb.units.front(), ::testing::Not(::testing::HasSubstr(fmt::format("{:a}", v))));
  }
  // The same cache entry: the second model reuses the library the first one loaded, and each
  // gives its interpreter's bits.
  FreshJitCache cache;
  GenerateOptions table;
  table.value_table = true;
  const auto ja = GeneratedRhs::Start(ma, table), jb = GeneratedRhs::Start(mb, table);
  ASSERT_TRUE(ja->ready()) << ja->engine();
  EXPECT_THAT(ja->engine(), ::testing::Not(::testing::HasSubstr("already loaded")));
  EXPECT_THAT(jb->engine(), ::testing::HasSubstr("already loaded by this process"));
  EXPECT_EQ(cache.Libraries(), 1);
  ExpectSameBits("mass_spring_damper (a)", Engines{ma, ma, ja});
  ExpectSameBits("mass_spring_damper (b)", Engines{mb, mb, jb});
}

/// An example compiled, with its generated code split into units of about `unit_chars`.
testing::Built CompileSplit(const std::string& example, std::size_t unit_chars, bool background = false) {
  const LoadedModel lm = LoadModelFile(std::string(MULTIBOND_SOURCE_DIR) + "/examples/" + example);
  testing::Built b{CompiledModel::Compile(lm.graph, lm.compile), nullptr};
  GenerateOptions go;
  go.unit_chars = unit_chars;
  go.background = background;
  b.code = GeneratedRhs::Start(b.model, go);
  return b;
}

TEST(GeneratedCodeAtScale, SplitUnitsGiveTheBitsOfOneUnitAndOfTheInterpreter) {
  const std::pair<std::string, std::size_t> examples[] = {
      {"differential.yaml", 3000}, {"mass_spring_damper_3d.yaml", 300}, {"compliant_gear_pair.yaml", 300}};
  for (const auto& [example, unit_chars] : examples) {
    const Engines e = CompileBoth(example);
    ASSERT_TRUE(e.code->ready()) << e.code->engine();
    const testing::Built split = CompileSplit(example, unit_chars);
    ASSERT_TRUE(split.code->ready()) << split.engine();
    EXPECT_GT(split.model->GenerateUnits(unit_chars).units.size(), 1u) << example;
    EXPECT_THAT(split.engine(), ::testing::HasSubstr(" units in ")) << example;
    ExpectSameBits(example + " (split, against the interpreter)", Engines{e.interpreter, split.model, split.code});
    // One unit against the split units: each as the "interpreter" side's workspace has no code,
    // so compare the two codes' workspaces directly.
    Workspace w1 = e.generated->MakeWorkspace(e.code.get()), w2 = split.MakeWorkspace();
    const Eigen::VectorXd x = e.generated->MakeInitialState();
    Eigen::VectorXd d1(x.size()), d2(x.size());
    e.generated->CalcDerivatives(0.01, x.data(), d1.data(), w1);
    split.model->CalcDerivatives(0.01, x.data(), d2.data(), w2);
    EXPECT_TRUE(SameBits("xdot (split, against one unit)", d1.data(), d2.data(), static_cast<int>(x.size()))) << example;
    EXPECT_TRUE(SameBits("slot (split, against one unit)", w1.slots.data(), w2.slots.data(), static_cast<int>(w1.slots.size())))
        << example;
  }
}

TEST(GeneratedCodeAtScale, ASecondModelOfTheSameTextLoadsNothingAgain) {
  FreshJitCache cache;
  const testing::Built first = CompileSplit("differential.yaml", 3000);
  const int units = static_cast<int>(first.model->GenerateUnits(3000).units.size());
  ASSERT_GT(units, 2);
  EXPECT_THAT(first.engine(), ::testing::HasSubstr(fmt::format("{} units in {}: {} compiled, 0 from the cache, 0 already loaded",
                                                                    units, cache.dir.path().string(), units)));
  EXPECT_EQ(cache.Libraries(), units);  // each unit cached under its own hash
  const testing::Built second = CompileSplit("differential.yaml", 3000);
  EXPECT_THAT(second.engine(), ::testing::HasSubstr(fmt::format("0 compiled, 0 from the cache, {} already loaded", units)));
}

/// Records the samples; at the first it notes whether the generated code is there yet, at
/// `wait_at` it waits for it: the run switches engines between those two samples.
class SwitchObserver : public RecordingObserver {
 public:
  SwitchObserver(const GeneratedRhs& code, size_t wait_at) : code_(code), wait_at_(wait_at) {}
  void OnSample(const std::vector<double>& row) override {
    RecordingObserver::OnSample(row);
    if (rows().size() == 1) ready_at_start = code_.ready();
    if (rows().size() == wait_at_) ready_after_wait = code_.Wait() && code_.ready();
  }
  bool ready_at_start = true, ready_after_wait = false;

 private:
  const GeneratedRhs& code_;
  size_t wait_at_;
};

TEST(GeneratedCodeAtScale, ARunThatSwitchesToTheGeneratedCodeMidwayGivesTheSameBits) {
  FreshJitCache cache;  // nothing cached: the compiler takes far longer than the first sample
  const LoadedModel lm = LoadModelFile(std::string(MULTIBOND_SOURCE_DIR) + "/examples/differential.yaml");
  RunOptions o = ShortRun(lm);
  RecordingObserver interpreted;
  Simulate(*CompiledModel::Compile(lm.graph, lm.compile), o, interpreted);
  for (const std::size_t unit_chars : {std::size_t{0}, std::size_t{3000}}) {  // one unit; several
    const testing::Built model = CompileSplit("differential.yaml", unit_chars, /*background=*/true);
    EXPECT_THAT(model.engine(), ::testing::HasSubstr("compiles in the background"));
    SwitchObserver switched(*model.code, 5);
    o.code = model.code;
    Simulate(*model.model, o, switched);
    EXPECT_FALSE(switched.ready_at_start) << "the generated code was there before the run: no switch to test";
    EXPECT_TRUE(switched.ready_after_wait) << model.engine();
    EXPECT_THAT(model.engine(), ::testing::StartsWith("generated code"));
    ASSERT_EQ(switched.rows().size(), interpreted.rows().size());
    for (size_t i = 0; i < interpreted.rows().size(); ++i)
      EXPECT_TRUE(SameBits("sample", interpreted.rows()[i].data(), switched.rows()[i].data(),
                           static_cast<int>(interpreted.rows()[i].size())))
          << "row " << i << ", units of " << unit_chars;
  }
}

// A compile that exceeds its budget leaves the interpreter in charge, with the reason.
TEST(GeneratedCodeAtScale, ACompileOverItsBudgetLeavesTheInterpreter) {
  FreshJitCache cache;
  const LoadedModel lm = LoadModelFile(std::string(MULTIBOND_SOURCE_DIR) + "/examples/differential.yaml");
  GenerateOptions go;
  go.background = true;
  go.budget_seconds = 1e-6;
  const auto code = GeneratedRhs::Start(CompiledModel::Compile(lm.graph, lm.compile), go);
  EXPECT_FALSE(code->Wait());
  EXPECT_THAT(code->engine(), ::testing::HasSubstr("the compile time budget (1e-06 s) is spent"));
  ExpectSameBits("differential (over budget)", CompileBoth("differential.yaml"));
}

}  // namespace
}  // namespace multibond
