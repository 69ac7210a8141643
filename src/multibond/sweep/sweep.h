#pragma once
/// \file
/// A sweep from start to end: the design drawn, the journal opened (or resumed), the runs handed
/// out to threads (and ranks), each result journaled as it comes, and at the end the outputs
/// (outputs.h). Rank 0 (the only process without MPI) keeps the results and writes every file.

#include <atomic>
#include <string>
#include <vector>

#include "multibond/sweep/mpi_backend.h"
#include "multibond/sweep/outputs.h"
#include "multibond/sweep/runner.h"

namespace multibond::sweep {

struct SweepOptions {
  std::string dir;      ///< the output folder (created; held by one command at a time, io/output_folder.h)
  std::string command = "multibond sweep";  ///< what the folder's lock records (the command line)
  int threads = 0;      ///< worker threads (per rank); 0: every core without MPI, 1 under MPI
  bool resume = false;  ///< skip the runs the folder's journal holds (the same study)
  bool progress = false;
  const std::atomic<bool>* stop = nullptr;
};

struct SweepOutcome {
  SweepFacts facts;
  std::vector<RunResult> results;          ///< rank 0: every run, in run order
  std::vector<std::string> plot_problems;  ///< plots that could not be made
};

/// Runs the study. `model_text` is the model file's content (for the study's hash). `mpi` null
/// without MPI. Throws Interrupted (after syncing the journal) when a stop is asked for,
/// std::invalid_argument for a journal of another study (--resume).
SweepOutcome RunSweep(const Study& study, const Runner& runner, const std::string& model_text, const SweepOptions& options,
                      const MpiSession* mpi);

/// The hash of a study with its model: the journal's first line, sweep.json's study_hash.
std::string StudyHash(const Study& study, const std::string& model_text);

}  // namespace multibond::sweep
