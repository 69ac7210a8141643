// The generated right-hand side outside the compiled model (compile/generated_rhs.h): one
// immutable model evaluated by either engine at once, from several threads; the code keeps its
// model; a run refuses another model's code; a model generated code does not cover says why.

#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "multibond/compile/compiled_model.h"
#include "multibond/compile/generated_rhs.h"
#include "multibond/io/model_loader.h"
#include "multibond/sim/simulator.h"
#include "support/example_runner.h"

namespace multibond {
namespace {

using ::testing::HasSubstr;

std::shared_ptr<const CompiledModel> CompileExample(const std::string& name, bool solve_loops = false) {
  const LoadedModel lm = LoadModelFile(testing::ExamplePath(name));
  CompileOptions co = lm.compile;
  co.solve_algebraic_loops = solve_loops;
  return CompiledModel::Compile(lm.graph, co);
}

bool SameBits(const std::vector<std::vector<double>>& a, const std::vector<std::vector<double>>& b) {
  if (a.size() != b.size()) return false;
  for (size_t i = 0; i < a.size(); ++i)
    if (a[i].size() != b[i].size() || std::memcmp(a[i].data(), b[i].data(), a[i].size() * sizeof(double)) != 0) return false;
  return true;
}

// The model holds no engine: two runs of one model at the same time, one on its generated code
// and one on the interpreter, each on its own thread, give the bits of a run alone.
TEST(GeneratedRhs, OneModelRunsOnBothEnginesAtOnceFromTwoThreads) {
  const auto model = CompileExample("differential.yaml");
  const auto code = GeneratedRhs::Start(model);
  ASSERT_TRUE(code->ready()) << code->engine();
  const RecordingObserver alone = testing::RunCompiled(*model, 0.05, 0.005, Method::kBdf, 1e-8, 1e-10);
  ASSERT_GT(alone.rows().size(), 10u);
  RecordingObserver generated, interpreted;
  std::thread a([&] { generated = testing::RunCompiled(*model, 0.05, 0.005, Method::kBdf, 1e-8, 1e-10, true, code); });
  std::thread b([&] { interpreted = testing::RunCompiled(*model, 0.05, 0.005, Method::kBdf, 1e-8, 1e-10); });
  a.join();
  b.join();
  EXPECT_TRUE(SameBits(generated.rows(), alone.rows()));
  EXPECT_TRUE(SameBits(interpreted.rows(), alone.rows()));
  EXPECT_EQ(generated.summary().stats.rhs_evals, alone.summary().stats.rhs_evals);
}

// A workspace without code evaluates on the interpreter even while the model's code is loaded:
// the engine is the workspace's, not the model's.
TEST(GeneratedRhs, TheEngineIsTheWorkspacesNotTheModels) {
  const auto model = CompileExample("mass_spring_damper_3d.yaml");
  const auto code = GeneratedRhs::Start(model);
  ASSERT_TRUE(code->ready()) << code->engine();
  Workspace plain = model->MakeWorkspace(), fast = model->MakeWorkspace(code.get());
  EXPECT_EQ(plain.code, nullptr);
  EXPECT_EQ(fast.code, code.get());
  const Eigen::VectorXd x = model->MakeInitialState();
  Eigen::VectorXd a(x.size()), b(x.size());
  model->CalcStateDerivatives(0.1, x.data(), a.data(), plain);
  model->CalcStateDerivatives(0.1, x.data(), b.data(), fast);
  EXPECT_EQ(std::memcmp(a.data(), b.data(), sizeof(double) * a.size()), 0);
}

// The code keeps its model alive: the caller may let go of the model first.
TEST(GeneratedRhs, TheCodeKeepsItsModel) {
  std::shared_ptr<const GeneratedRhs> code;
  std::weak_ptr<const CompiledModel> weak;
  {
    const auto model = CompileExample("rlc_circuit.yaml");
    weak = model;
    code = GeneratedRhs::Start(model);
  }
  ASSERT_FALSE(weak.expired());
  ASSERT_TRUE(code->ready()) << code->engine();
  const CompiledModel& model = code->model();
  Workspace ws = model.MakeWorkspace(code.get());
  const Eigen::VectorXd x = model.MakeInitialState();
  Eigen::VectorXd xdot(x.size());
  model.CalcStateDerivatives(0.0, x.data(), xdot.data(), ws);
  EXPECT_TRUE(xdot.allFinite());
  code.reset();
  EXPECT_TRUE(weak.expired());
}

// A run given the code of another model (even one of the same file) refuses it before it starts:
// its offsets and numbers belong to that model.
TEST(GeneratedRhs, ARunRefusesTheCodeOfAnotherModel) {
  const auto one = CompileExample("mass_spring_damper.yaml"), other = CompileExample("mass_spring_damper.yaml");
  RunOptions o;
  o.t_end = 0.1;
  o.dt = 0.01;
  o.code = GeneratedRhs::Start(other);
  RecordingObserver rec;
  try {
    Simulate(*one, o, rec);
    FAIL() << "the run took another model's code";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("another model's"));
  }
  EXPECT_TRUE(rec.rows().empty());
}

// A model that generated code does not cover gets code that says why and runs on the interpreter.
TEST(GeneratedRhs, AModelGeneratedCodeDoesNotCoverSaysWhy) {
  const auto model = CompileExample("algebraic_loop.yaml", /*solve_loops=*/true);
  const auto code = GeneratedRhs::Start(model);
  EXPECT_FALSE(code->uses_generated_code());
  EXPECT_FALSE(code->Wait());
  EXPECT_EQ(code->code(), nullptr);
  EXPECT_THAT(code->engine(), HasSubstr("interpreter (algebraic loops are solved around the plan"));
  EXPECT_EQ(model->GeneratedCodeRefusal(), "algebraic loops are solved around the plan, which the generated code does not do");
  EXPECT_EQ(CompileExample("differential.yaml")->GeneratedCodeRefusal(), "");
  EXPECT_EQ(RhsEngine(nullptr), "interpreter");
}

// The compiled model is plain data: no thread, mutex, condition variable or atomic among its
// members (the background compile's are GeneratedRhs's).
TEST(GeneratedRhs, TheCompiledModelHoldsNoThreadMutexOrAtomic) {
  std::ifstream in(std::string(MULTIBOND_SOURCE_DIR) + "/src/multibond/compile/compiled_model.h");
  std::stringstream ss;
  ss << in.rdbuf();
  const std::string header = ss.str();
  ASSERT_THAT(header, HasSubstr("class CompiledModel"));
  for (const char* word : {"std::thread", "std::mutex", "std::condition_variable", "std::atomic"})
    EXPECT_EQ(header.find(word), std::string::npos) << word;
}

}  // namespace
}  // namespace multibond
