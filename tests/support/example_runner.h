#pragma once
// Test helpers: load a shipped example, compile it and run it into memory.

#include <memory>
#include <stdexcept>
#include <string>

#include "multibond/compile/generated_rhs.h"
#include "multibond/io/model_loader.h"
#include "multibond/sim/simulator.h"
#include "support/temp_dir.h"

namespace multibond::testing {

inline std::string ExamplePath(const std::string& name) { return std::string(MULTIBOND_SOURCE_DIR) + "/examples/" + name; }

/// The text of examples/<name>.
inline std::string ExampleText(const std::string& name) { return ReadFile(ExamplePath(name)); }

/// A compiled model and, when asked for, its generated code (compile/generated_rhs.h), loaded.
struct Built {
  std::shared_ptr<const CompiledModel> model;
  std::shared_ptr<const GeneratedRhs> code;
  /// A workspace that the generated code evaluates into (the interpreter without code).
  Workspace MakeWorkspace() const { return model->MakeWorkspace(code.get()); }
  std::string engine() const { return RhsEngine(code.get()); }
};

/// Generated code for `model`, loaded before it returns; throws if it is not (a test that asks
/// for generated code must not pass on the interpreter's fallback).
inline std::shared_ptr<const GeneratedRhs> GenerateLoaded(std::shared_ptr<const CompiledModel> model, const GenerateOptions& go = {}) {
  auto code = GeneratedRhs::Start(std::move(model), go);
  if (!code->Wait()) throw std::runtime_error("generated code was asked for and not built: " + code->engine());
  return code;
}

/// Compiles a graph with `co`, with generated code when `generate_code` (GenerateLoaded).
inline Built CompileGraph(BondGraph g, const CompileOptions& co, bool generate_code) {
  Built b{CompiledModel::Compile(std::move(g), co), nullptr};
  if (generate_code) b.code = GenerateLoaded(b.model);
  return b;
}

/// Compiles a loaded model with its own options, with generated code when `generate_code`.
inline Built CompileWith(const LoadedModel& lm, bool generate_code) { return CompileGraph(lm.graph, lm.compile, generate_code); }

/// Simulates a compiled model into memory over [0, t_end], samples every dt; on `code` when given.
inline RecordingObserver RunCompiled(const CompiledModel& model, double t_end, double dt,
                                     Method method = IntegratorOptions{}.method, double rtol = 1e-10, double atol = 1e-12,
                                     bool project = true, std::shared_ptr<const GeneratedRhs> code = nullptr) {
  RunOptions o;
  o.code = std::move(code);
  o.t_end = t_end;
  o.dt = dt;
  o.integrator.method = method;
  o.integrator.rtol = rtol;
  o.integrator.atol = atol;
  o.integrator.project = project;
  RecordingObserver rec;
  Simulate(model, o, rec);
  return rec;
}

/// The same on a model's generated code, when it has one.
inline RecordingObserver RunCompiled(const Built& b, double t_end, double dt, Method method = IntegratorOptions{}.method,
                                     double rtol = 1e-10, double atol = 1e-12, bool project = true) {
  return RunCompiled(*b.model, t_end, dt, method, rtol, atol, project, b.code);
}

/// Loads examples/<name>, compiles it and simulates it with the file's simulation settings,
/// overridden by `t_end` and `dt` when they are > 0, and by `coordinates` ("joint" or
/// "inertial") when given.
inline RecordingObserver RunExample(const std::string& name, double t_end = 0.0, double dt = 0.0,
                                    Method method = Method::kBdf, bool generate_code = false,
                                    const std::string& coordinates = "") {
  const LoadedModel lm = LoadModelFile(ExamplePath(name));
  const Built b = CompileWith(lm, generate_code);
  RunOptions o;
  o.code = b.code;
  o.t_end = t_end > 0 ? t_end : lm.simulation.t_end.value_or(1.0);
  o.dt = dt > 0 ? dt : lm.simulation.dt.value_or(1e-3);
  o.integrator.method = method;
  o.integrator.rtol = lm.simulation.rtol.value_or(1e-10);
  o.integrator.atol = lm.simulation.atol.value_or(1e-12);
  if ((coordinates.empty() ? lm.simulation.coordinates.value_or("inertial") : coordinates) == "joint")
    o.joint_coordinates = lm.mechanism->MakeJointTree();
  RecordingObserver rec;
  Simulate(*b.model, o, rec);
  return rec;
}

/// Loads examples/<name> and simulates it as its file says (times, output interval, tolerances)
/// but for the solver, the coordinates (joint or inertial) and, when > 0, rtol and atol; rk4 takes
/// a fixed step of 1 ms.
inline RecordingObserver RunExampleWith(const std::string& name, Method method, bool joint, double rtol = 0.0, double atol = 0.0) {
  const LoadedModel lm = LoadModelFile(ExamplePath(name));
  const auto model = CompiledModel::Compile(lm.graph, lm.compile);
  RunOptions o;
  o.t_end = *lm.simulation.t_end;
  o.dt = *lm.simulation.dt;
  o.integrator.method = method;
  o.integrator.rtol = rtol > 0 ? rtol : *lm.simulation.rtol;
  o.integrator.atol = atol > 0 ? atol : *lm.simulation.atol;
  if (method == Method::kRk4) o.integrator.fixed_step = 1e-3;
  if (joint) o.joint_coordinates = lm.mechanism->MakeJointTree();
  RecordingObserver rec;
  Simulate(*model, o, rec);
  return rec;
}

/// Compiles a graph and simulates it into memory over [0, t_end], samples every dt.
inline RecordingObserver RunGraph(BondGraph g, const CompileOptions& co, double t_end, double dt,
                                  Method method = IntegratorOptions{}.method, double rtol = 1e-10, double atol = 1e-12,
                                  bool project = true) {
  return RunCompiled(*CompiledModel::Compile(std::move(g), co), t_end, dt, method, rtol, atol, project);
}

/// The same for a loaded model.
inline RecordingObserver RunModel(const LoadedModel& lm, double t_end, double dt, Method method = IntegratorOptions{}.method,
                                  double rtol = 1e-10, double atol = 1e-12) {
  return RunGraph(lm.graph, lm.compile, t_end, dt, method, rtol, atol);
}

/// The same for a model given as YAML text.
inline RecordingObserver RunModelText(const std::string& yaml, double t_end, double dt,
                                      Method method = IntegratorOptions{}.method, double rtol = 1e-10, double atol = 1e-12) {
  return RunModel(LoadModelString(yaml, "<test>"), t_end, dt, method, rtol, atol);
}

/// The energy balance of a run, measured two ways (see docs/design.md, "energy account"):
///  - the largest |energy.residual| = |W - dE - D| / |W| over the samples after `from_fraction`
///    of the run (at the very start W is ~0 and the ratio is 0/0);
///  - the largest absolute imbalance |W - dE - D| over the whole run, relative to max |W|.
/// Returns the larger of the two.
inline double MaxEnergyResidual(const RecordingObserver& rec, double from_fraction = 0.1) {
  const int res = rec.Index("energy.residual"), w = rec.Index("energy.work");
  const int k = rec.Index("energy.kinetic"), p = rec.Index("energy.potential"), d = rec.Index("energy.dissipated");
  const double t0 = rec.rows().front()[0], t1 = rec.rows().back()[0];
  const double e0 = rec.rows().front()[k] + rec.rows().front()[p];
  double max_rel = 0.0, max_abs = 0.0, max_work = 0.0;
  for (const auto& row : rec.rows()) {
    if (row[0] >= t0 + from_fraction * (t1 - t0)) max_rel = std::max(max_rel, std::abs(row[res]));
    max_abs = std::max(max_abs, std::abs(row[w] - (row[k] + row[p] - e0) - row[d]));
    max_work = std::max({max_work, std::abs(row[w]), e0});
  }
  return std::max(max_rel, max_work > 0 ? max_abs / max_work : max_abs);
}

}  // namespace multibond::testing
