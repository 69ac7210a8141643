// A study's runs: the nominal model checked once, then load, compile and simulate per run.

#include "multibond/sweep/runner.h"

#include <algorithm>
#include <chrono>
#include <tuple>
#include <cmath>
#include <limits>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "multibond/compile/generated_rhs.h"
#include "multibond/core/diagnostic_codes.h"
#include "multibond/io/did_you_mean.h"

namespace multibond::sweep {

namespace {

using Clock = std::chrono::steady_clock;
double Since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

/// Throws the diagnostics of `sink` in the order of their places (file, line, column).
void ThrowSorted(const DiagnosticSink& sink) {
  if (!sink.has_errors()) return;
  std::vector<Diagnostic> ds = sink.diagnostics();
  std::stable_sort(ds.begin(), ds.end(), [](const Diagnostic& a, const Diagnostic& b) {
    return std::tie(a.where.file, a.where.line, a.where.column) < std::tie(b.where.file, b.where.line, b.where.column);
  });
  DiagnosticSink sorted;
  for (Diagnostic& d : ds) sorted.Add(std::move(d));
  sorted.ThrowIfErrors();
}

/// The nominal model: the file's parameters, then checks the names of `study` against them.
LoadedModel LoadNominal(const Study& s, const std::string& text, const InputLimits& limits, DiagnosticSink& sink) {
  LoadedModel plain = LoadModelString(text, s.model, limits);
  std::vector<std::string> names;
  for (const ModelParameter& p : plain.parameters) names.push_back(p.name);
  auto check = [&](const std::string& name, const SourceLocation& where) {
    if (std::find(names.begin(), names.end(), name) != names.end()) return;
    const std::string guess = DidYouMean(name, names);
    sink.Error(codes::kSweepUnknownParameter, where, name, fmt::format("the model '{}' has no parameter '{}'", s.model, name),
               !guess.empty() ? fmt::format("did you mean '{}'?", guess)
               : names.empty() ? "declare it in the model's 'parameters:' section and use it there (docs/model-format.md)"
                               : fmt::format("its parameters: {}", fmt::join(names, ", ")));
  };
  for (const Axis& a : s.axes) check(a.name, a.where);
  for (size_t i = 0; i < s.set.size(); ++i) check(s.set[i].first, i < s.set_where.size() ? s.set_where[i] : SourceLocation{kCommandLine, 1, 1});
  if (sink.has_errors()) return plain;
  std::vector<ParameterOverride> set;
  for (const auto& [n, v] : s.set) set.push_back({n, v});
  return set.empty() ? std::move(plain) : LoadModelString(text, s.model, limits, set);
}

KeptQuantities CompileKept(const Study& s, const LoadedModel& lm, DiagnosticSink& sink) {
  const auto compiled = CompiledModel::Compile(lm.graph, lm.compile);  // the columns only: no generated code
  std::vector<std::string> columns, all;
  for (const Column& c : MakeColumns(*compiled, false)) columns.push_back(c.name);
  for (const Column& c : MakeColumns(*compiled, true)) all.push_back(c.name);
  KeptQuantities q(s.keep, columns, all, sink);
  ThrowSorted(sink);
  return q;
}

std::string FirstLine(std::string s) {
  for (char& c : s)
    if (c == '\n' || c == '\r') c = ' ';
  return s;
}

}  // namespace

std::string ExactText(double v) { return fmt::format("{}", v); }

Runner::Runner(const Study& study, std::string model_text, const InputLimits& limits, std::string jit, const DiagnosticSink& earlier)
    : study_(study),
      text_(std::move(model_text)),
      limits_(limits),
      jit_(std::move(jit)),
      sink_(earlier),
      nominal_(LoadNominal(study_, text_, limits_, sink_)),
      kept_(CompileKept(study_, nominal_, sink_)) {}

void Runner::set_run_options(RunOptions o) {
  options_ = std::move(o);
  options_.all_variables = options_.all_variables || kept_.needs_all_variables();
  options_.progress = nullptr;
}

std::unique_ptr<RunWorkspace> Runner::NewWorkspace() const {
  return std::make_unique<RunWorkspace>(text_, study_.model, limits_, kept_);
}

RunResult Runner::Run(long run, const std::vector<double>& values, RunWorkspace& ws, const std::atomic<bool>* stop, Observer* also) const {
  KeptObserver& kept = ws.kept;
  RunTiming& timing = ws.timing;
  RunResult r;
  r.run = run;
  r.values.assign(study_.keep.size(), std::numeric_limits<double>::quiet_NaN());
  std::vector<ParameterOverride> set;
  for (const auto& [n, v] : study_.set) set.push_back({n, v});
  for (size_t j = 0; j < values.size(); ++j) set.push_back({study_.axes[j].name, ExactText(values[j])});
  ++timing.runs;
  try {
    auto t0 = Clock::now();
    LoadedModel lm = ws.parsed.Load(set);
    timing.load += Since(t0);
    t0 = Clock::now();
    const std::shared_ptr<const CompiledModel> compiled = CompiledModel::Compile(std::move(lm.graph), lm.compile);
    RunOptions o = options_;
    if (jit_ != "off") {
      GenerateOptions go;
      go.value_table = true;  // the runs' numbers from a table: one library for every run
      o.code = GeneratedRhs::Start(compiled, go);
    }
    timing.compile += Since(t0);
    o.stop = stop;
    kept.Reset();
    struct Both : Observer {
      KeptObserver& k;
      Observer* also;
      Both(KeptObserver& k_, Observer* a) : k(k_), also(a) {}
      void OnStart(const std::vector<Column>& c) override {
        k.OnStart(c);
        if (also) also->OnStart(c);
      }
      void OnSample(const std::vector<double>& row) override {
        k.OnSample(row);
        if (also) also->OnSample(row);
      }
      void OnEvent(const EventRecord& e) override {
        k.OnEvent(e);
        if (also) also->OnEvent(e);
      }
      void OnFinish(const RunSummary& s) override {
        k.OnFinish(s);
        if (also) also->OnFinish(s);
      }
    } both(kept, also);
    t0 = Clock::now();
    const RunSummary s = Simulate(*compiled, o, both);
    timing.simulate += Since(t0);
    if (s.status == RunStatus::kInterrupted) {
      r.reason = "interrupted";
      return r;
    }
    if (!kept.column_problem().empty()) {
      r.reason = kept.column_problem();
      return r;
    }
    if (s.status == RunStatus::kFailed) {
      r.reason = FirstLine(fmt::format("solver failure at t = {}: {}", s.t_reached, s.message));
      return r;
    }
    r.values = kept.Values();
    r.ok = true;
  } catch (const ModelError& e) {
    const auto& ds = e.diagnostics();
    r.reason = FirstLine(ds.empty() ? e.what() : fmt::format("{}{}", ds.front().code.empty() ? "" : ds.front().code + ": ", ds.front().message));
  } catch (const std::exception& e) {
    r.reason = FirstLine(e.what());
  }
  return r;
}

}  // namespace multibond::sweep
