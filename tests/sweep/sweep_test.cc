// A sweep from end to end on the mass-spring-damper (examples/sweeps/mass_spring_damper.yaml):
// x_final = 1/k, x_max = (1/k)(1 + exp(-pi zeta / sqrt(1 - zeta^2))), zeta = c / (2 sqrt(k m));
// the same table on 1 and 2 threads; a failing run recorded with its reason; a resume.

#include "multibond/sweep/sweep.h"

#include <cmath>
#include <fstream>

#include <gtest/gtest.h>

#include "multibond/core/diagnostic_codes.h"
#include "multibond/io/output_folder.h"
#include "multibond/io/yaml_document.h"
#include "multibond/sweep/samples.h"
#include "support/temp_dir.h"

namespace multibond::sweep {
namespace {

const std::string kStudy = std::string(MULTIBOND_SOURCE_DIR) + "/examples/sweeps/mass_spring_damper.yaml";

RunOptions Options(const Study& s) {
  RunOptions o;
  o.t_end = s.t_end.value_or(5.0);
  o.dt = s.dt.value_or(1e-3);
  o.integrator.method = ParseMethod("bdf");
  o.integrator.rtol = 1e-10;  // the model file's
  o.integrator.atol = 1e-12;
  return o;
}

struct Fixture {
  explicit Fixture(Study study) : s(std::move(study)), text(ReadModelText(s.model, {})), runner(s, text, {}, "off") {
    runner.set_run_options(Options(s));
  }
  Study s;
  std::string text;
  Runner runner;
};

std::string Read(const std::filesystem::path& p) { return testing::ReadFile(p); }

/// A sweep into `dir` on `threads` threads.
SweepOptions Into(const testing::TempDir& dir, int threads) {
  SweepOptions o;
  o.dir = dir.path().string();
  o.threads = threads;
  return o;
}

TEST(Sweep, MassSpringDamperMatchesTheClosedForms) {
  Fixture f(ReadStudyFile(kStudy));
  testing::TempDir one, two;
  SweepOptions o = Into(one, 1);
  const SweepOutcome a = RunSweep(f.s, f.runner, f.text, o, nullptr);
  ASSERT_EQ(a.results.size(), 20u);
  const auto design = Design(f.s);
  for (const RunResult& r : a.results) {
    ASSERT_TRUE(r.ok) << r.reason;
    const double k = design[r.run][0], m = 1.0, c = 2.0;
    const double zeta = c / (2 * std::sqrt(k * m));
    EXPECT_NEAR(r.values[0], 1 / k, 1e-8) << "k = " << k;
    const double peak = (1 / k) * (1 + std::exp(-M_PI * zeta / std::sqrt(1 - zeta * zeta)));
    EXPECT_NEAR(r.values[1], peak, 1e-3 * peak) << "k = " << k;
  }
  o.dir = two.path().string();
  o.threads = 2;
  const SweepOutcome b = RunSweep(f.s, f.runner, f.text, o, nullptr);
  EXPECT_EQ(b.facts.threads, 2);
  // The same table to the last bit, whichever thread ran which run.
  EXPECT_EQ(Read(one.path() / "sweep.csv"), Read(two.path() / "sweep.csv"));
  const std::string csv = Read(one.path() / "sweep.csv");
  EXPECT_EQ(csv.substr(0, csv.find('\n')), "run,k,status,x_final,x_max,t_settle,reason");
  EXPECT_NE(Read(one.path() / "sweep.json").find("\"study_hash\""), std::string::npos);
}

Study ListStudy(const std::string& values) {
  DiagnosticSink sink;
  Study s;
  s.model = std::string(MULTIBOND_SOURCE_DIR) + "/examples/sweeps/mass_spring_damper_model.yaml";
  AddAxisSpec(s, "--list", "k=" + values, sink);
  AddKeepSpec(s, "x_final=final:spring.q", sink);
  s.t_end = 1.0;
  EXPECT_FALSE(sink.has_errors());
  return s;
}

TEST(Sweep, AFailedRunIsRecordedAndTheOthersGoOn) {
  Study s = ListStudy("100,-5,400");
  s.keep_results = true;
  Fixture f(std::move(s));
  testing::TempDir dir;
  SweepOptions o = Into(dir, 2);
  const SweepOutcome out = RunSweep(f.s, f.runner, f.text, o, nullptr);
  ASSERT_EQ(out.results.size(), 3u);
  EXPECT_TRUE(out.results[0].ok);
  EXPECT_FALSE(out.results[1].ok);
  EXPECT_NE(out.results[1].reason.find("param.range"), std::string::npos) << out.results[1].reason;
  EXPECT_TRUE(out.results[2].ok);
  EXPECT_EQ(out.facts.failed, 1);
  const std::string csv = Read(dir.path() / "sweep.csv");
  EXPECT_NE(csv.find("\n1,-5,failed,nan,param.range: "), std::string::npos) << csv;
  // Each run's rows too: the last row's spring.q is the kept final value.
  const std::string rows = Read(dir.path() / "runs" / "run-2.csv");
  const std::string last = rows.substr(rows.rfind('\n', rows.size() - 2) + 1);
  EXPECT_NE(rows.find("spring.q"), std::string::npos);
  EXPECT_NE(last.find("," + ExactText(out.results[2].values[0])), std::string::npos) << last;
}

// A kept quantity over a window (#43): the mass driven from rest by a force step overshoots first,
// so its maximum after 0.5 s is below its maximum over the run; a window past the end keeps NaN in
// every run, and its plot is left out with one sentence (gnuplot said "all points y value
// undefined" for each parameter).
TEST(Sweep, AWindowedQuantityAndOneThatNoRunHas) {
  Study s = ListStudy("100,400");
  DiagnosticSink sink;
  AddKeepSpec(s, "x_max=max:spring.q", sink);
  AddKeepSpec(s, "x_late=max[0.5,]:spring.q", sink);
  AddKeepSpec(s, "x_never=max[20,]:spring.q", sink);
  ASSERT_FALSE(sink.has_errors());
  Fixture f(std::move(s));
  testing::TempDir dir;
  SweepOptions o = Into(dir, 1);
  const SweepOutcome out = RunSweep(f.s, f.runner, f.text, o, nullptr);
  ASSERT_EQ(out.results.size(), 2u);
  for (const RunResult& r : out.results) {
    ASSERT_TRUE(r.ok) << r.reason;
    EXPECT_LT(r.values[2], r.values[1]);  // the overshoot is over by t = 0.5 s: a lower maximum after it
    EXPECT_TRUE(std::isnan(r.values[3]));
  }
  ASSERT_EQ(out.plot_problems.size(), 1u);
  EXPECT_NE(out.plot_problems[0].find("x_never: not drawn"), std::string::npos) << out.plot_problems[0];
  EXPECT_FALSE(std::filesystem::exists(dir.path() / "plots" / "x_never_vs_k.gp"));
  EXPECT_TRUE(std::filesystem::exists(dir.path() / "plots" / "x_late_vs_k.svg"));
}

TEST(Sweep, ResumeRunsOnlyWhatTheJournalLacks) {
  Fixture f(ListStudy("100,200,400"));
  testing::TempDir dir;
  SweepOptions o = Into(dir, 1);
  RunSweep(f.s, f.runner, f.text, o, nullptr);
  const std::string full = Read(dir.path() / "sweep.csv");
  // As if interrupted after run 1: the journal's header and its first two runs.
  const std::filesystem::path journal = dir.path() / "sweep.journal";
  std::string j = Read(journal);
  size_t cut = 0;
  for (int lines = 0; lines < 3; ++lines) cut = j.find('\n', cut) + 1;
  {
    std::ofstream out(journal, std::ios::trunc | std::ios::binary);
    out << j.substr(0, cut);
  }
  std::filesystem::remove(dir.path() / "sweep.csv");
  o.resume = true;
  const SweepOutcome again = RunSweep(f.s, f.runner, f.text, o, nullptr);
  EXPECT_EQ(again.facts.resumed, 2);
  EXPECT_EQ(Read(dir.path() / "sweep.csv"), full);
  // Another study in the same folder is refused.
  Fixture other(ListStudy("100,200,401"));
  EXPECT_THROW(RunSweep(other.s, other.runner, other.text, o, nullptr), std::invalid_argument);
}

// A results folder may come from anyone: a journal or a plots folder that is a link elsewhere is
// not followed, and a second sweep into a folder that one is writing is refused.
TEST(Sweep, LinksInTheFolderAreNotFollowedAndABusyFolderIsRefused) {
  Fixture f(ListStudy("100,200"));
  testing::TempDir dir, elsewhere;
  SweepOptions o = Into(dir, 1);
  RunSweep(f.s, f.runner, f.text, o, nullptr);
  const std::string journal = Read(dir.path() / "sweep.journal");
  std::filesystem::rename(dir.path() / "sweep.journal", elsewhere.path() / "journal");
  std::filesystem::create_symlink(elsewhere.path() / "journal", dir.path() / "sweep.journal");
  o.resume = true;
  EXPECT_THROW(RunSweep(f.s, f.runner, f.text, o, nullptr), std::runtime_error);
  EXPECT_EQ(Read(elsewhere.path() / "journal"), journal);  // not truncated through the link
  o.resume = false;
  std::filesystem::remove(dir.path() / "sweep.journal");
  std::filesystem::remove_all(dir.path() / "plots");
  std::filesystem::create_directory_symlink(elsewhere.path(), dir.path() / "plots");
  try {
    RunSweep(f.s, f.runner, f.text, o, nullptr);
    ADD_FAILURE() << "a plots folder that is a link was written through";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("it is a symbolic link"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(std::filesystem::exists(elsewhere.path() / "x_final_vs_k.gp"));
  std::filesystem::remove(dir.path() / "plots");
  const OutputFolder busy(dir.path().string(), "multibond sweep (the first)");
  try {
    RunSweep(f.s, f.runner, f.text, o, nullptr);
    ADD_FAILURE() << "a second sweep wrote into a busy folder";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("the first"), std::string::npos) << e.what();
  }
}

TEST(Sweep, AnUnknownParameterIsLocatedWithADidYouMean) {
  DiagnosticSink sink;
  Study s;
  s.model = std::string(MULTIBOND_SOURCE_DIR) + "/examples/sweeps/mass_spring_damper_model.yaml";
  AddAxisSpec(s, "--grid", "kk=1:2:3", sink);
  AddKeepSpec(s, "x=final:spring.q", sink);
  try {
    Runner r(s, ReadModelText(s.model, {}), {}, "off");
    FAIL() << "no error";
  } catch (const ModelError& e) {
    ASSERT_EQ(e.diagnostics().size(), 1u);
    EXPECT_EQ(e.diagnostics()[0].code, codes::kSweepUnknownParameter);
    EXPECT_EQ(e.diagnostics()[0].hint, "did you mean 'k'?");
    EXPECT_EQ(e.diagnostics()[0].where.column, 8);
  }
}

}  // namespace
}  // namespace multibond::sweep
