// The sweep driver: design, journal, threads and ranks, outputs.

#include "multibond/sweep/sweep.h"

#include <chrono>
#include <filesystem>
#include <memory>
#include <mutex>
#include <thread>

#include "multibond/core/interrupt.h"
#include "multibond/core/sha256.h"
#include "multibond/io/output_folder.h"
#include "multibond/io/results_writer.h"
#include "multibond/sweep/journal.h"
#include "multibond/sweep/samples.h"
#include "multibond/sweep/scheduler.h"

namespace multibond::sweep {

namespace {

/// Throws when `p` is a symbolic link: the sweep writes into it, and would write where it points.
void RefuseLink(const std::filesystem::path& p) {
  if (std::filesystem::is_symlink(p)) throw std::runtime_error("cannot write into '" + p.string() + "': it is a symbolic link");
}

/// A run stopped by the stop flag is not a result: it is run again on --resume.
bool Recordable(const RunResult& r) { return r.ok || r.reason != "interrupted"; }

}  // namespace

std::string StudyHash(const Study& study, const std::string& model_text) {
  return Sha256Hex(CanonicalText(study) + "\nmodel text\n" + model_text);
}

SweepOutcome RunSweep(const Study& study, const Runner& runner, const std::string& model_text, const SweepOptions& o,
                      const MpiSession* mpi) {
  const auto start = std::chrono::steady_clock::now();
  const std::vector<std::vector<double>> design = Design(study);
  const long n = static_cast<long>(design.size());
  const int rank = mpi ? mpi->rank() : 0;
  const int threads = o.threads > 0 ? o.threads : mpi ? 1 : std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
  std::vector<std::unique_ptr<RunWorkspace>> workers;
  for (int t = 0; t < threads; ++t) workers.push_back(runner.NewWorkspace());
  // Each run's full results too (`results: true`): runs/run-<index>.csv, as `run` writes results.csv.
  const std::filesystem::path runs_dir = std::filesystem::path(o.dir) / "runs";
  if (study.keep_results) {
    RefuseLink(runs_dir);
    std::filesystem::create_directories(runs_dir);
  }
  auto run_one = [&](long run, int thread) {
    std::unique_ptr<CsvWriter> rows;
    if (study.keep_results) rows = std::make_unique<CsvWriter>((runs_dir / ("run-" + std::to_string(run) + ".csv")).string());
    return runner.Run(run, design[run], *workers[thread], o.stop, rows.get());
  };
  SweepOutcome out;
  if (rank != 0) {
    WorkForRankZero(*mpi, [&](long run) { return run_one(run, 0); }, o.stop);
    if (o.stop && o.stop->load()) throw Interrupted("sweeping");
    return out;
  }

  // One command at a time in the folder, as `run` and `plot` (a second sweep is refused, naming
  // the first); the folders the sweep writes into must not be links to elsewhere.
  const OutputFolder folder(o.dir, o.command);
  RefuseLink(std::filesystem::path(o.dir) / "plots");
  const std::string hash = StudyHash(study, model_text);
  Journal journal((std::filesystem::path(o.dir) / "sweep.journal").string(), hash, study.keep.size(), o.resume);
  out.results.resize(static_cast<size_t>(n));
  std::vector<bool> done(static_cast<size_t>(n), false);
  long resumed = 0;
  for (const RunResult& r : journal.finished())
    if (r.run < n && !done[r.run]) {
      out.results[r.run] = r;
      done[r.run] = true;
      ++resumed;
    }
  std::vector<long> pending;
  for (long i = 0; i < n; ++i)
    if (!done[i]) pending.push_back(i);
  WorkQueue queue(std::move(pending));
  ProgressBar progress(n, resumed, o.progress);
  std::mutex record_mutex;
  auto record = [&](const RunResult& r) {
    if (!Recordable(r)) return;
    std::lock_guard<std::mutex> lock(record_mutex);
    journal.Append(r);
    out.results[r.run] = r;
    done[r.run] = true;
    progress.Done(r.ok);
  };
  auto local = [&] { RunThreads(queue, threads, [&](long run, int t) { record(run_one(run, t)); }, o.stop); };
  if (mpi && mpi->size() > 1) {
    std::exception_ptr error;
    std::thread here([&] {
      try {
        local();
      } catch (...) {
        error = std::current_exception();
      }
    });
    ServeRanks(*mpi, queue, record, o.stop);
    here.join();
    if (error) std::rethrow_exception(error);
  } else {
    local();
  }
  progress.Finish();
  journal.Sync();
  if (o.stop && o.stop->load()) throw Interrupted("sweeping; the finished runs are in " + (std::filesystem::path(o.dir) / "sweep.journal").string() + ": --resume goes on");
  for (long i = 0; i < n; ++i)
    if (!done[i]) throw std::runtime_error("internal: a run of the sweep was never run");

  SweepFacts& f = out.facts;
  f.model_sha256 = Sha256Hex(model_text);
  f.study_hash = hash;
  f.runs = n;
  for (const RunResult& r : out.results) f.failed += r.ok ? 0 : 1;
  f.resumed = resumed;
  f.ranks = mpi ? mpi->size() : 1;
  f.threads = threads;
  for (const auto& w : workers) f.timing.Add(w->timing);
  f.wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  out.plot_problems = WriteOutputs(o.dir, study, design, out.results, f);
  return out;
}

}  // namespace multibond::sweep
