#pragma once
/// \file
/// The sweep's journal, DIR/sweep.journal: its first line the hash of the study (CanonicalText and
/// the model's text), then one line per finished run (run, status, kept values with round-trip
/// precision, reason), appended as runs finish, flushed at once and synced (fsync) at most a few
/// times a second and at the end. An interrupted sweep resumes from it (`--resume`): the runs it
/// holds are not run again. A last line torn by a crash is cut off.

#include <chrono>
#include <cstdio>
#include <string>
#include <vector>

#include "multibond/sweep/runner.h"

namespace multibond::sweep {

class Journal {
 public:
  /// Opens `path`. Without `resume` a journal there is replaced by an empty one; with it, the
  /// journal must be of the same study (`hash`), else std::invalid_argument says so.
  Journal(std::string path, std::string hash, size_t num_values, bool resume);
  ~Journal();
  Journal(const Journal&) = delete;
  Journal& operator=(const Journal&) = delete;
  /// The runs read back (resume), in the order written.
  const std::vector<RunResult>& finished() const { return finished_; }
  /// Appends a run (not thread-safe: the caller serialises). Throws std::runtime_error when the
  /// line cannot be written.
  void Append(const RunResult& r);
  /// Syncs what was appended to the disk.
  void Sync();
  const std::string& path() const { return path_; }

 private:
  /// Reads the runs back from the open journal (resume) and cuts off a torn last line.
  void ReadBack(const std::string& header);
  std::string path_, hash_;
  size_t num_values_;
  std::FILE* file_ = nullptr;
  std::vector<RunResult> finished_;
  std::chrono::steady_clock::time_point last_sync_;
};

/// A run as a journal line (without the newline): run,status,values...,reason (CSV, the reason
/// quoted). `ParseJournalLine` reads it back; false for a line that does not read.
std::string JournalLine(const RunResult& r);
bool ParseJournalLine(const std::string& line, size_t num_values, RunResult& r);

}  // namespace multibond::sweep
