#pragma once
/// \file
/// Writing results: results.csv (header "name [unit]", one row per output time) and run.json
/// (provenance: model file and hash, options, solver statistics, wall time, version, status, and
/// the size and hash of results.csv). Both are AtomicFiles (io/atomic_file.h): a file called
/// results.csv or run.json is never half-written; when a write or the rename fails, the
/// temporary is removed and std::runtime_error says "cannot write '<file>': <why>".

#include <cstdint>
#include <memory>
#include <string>

#include <nlohmann/json.hpp>

#include "multibond/io/atomic_file.h"
#include "multibond/sim/simulator.h"

namespace multibond {

/// `text` as one CSV cell (RFC 4180): in double quotes, each quote doubled, when it holds a comma,
/// a quote or a line break; as it is otherwise, so plain names read the same as ever.
std::string CsvCell(const std::string& text);

/// Streams samples into an AtomicFile for `path`. When the run finishes (also when it failed or
/// was interrupted: the rows computed are kept; run.json says how the run ended) the file is
/// finished and, with `publish` (the default), given its name; without, the caller publishes it
/// with Publish(), after writing what describes it (run.json records its size and hash). If the run
/// never finishes (an exception passed through Simulate), nothing is left. Header cells are
/// CSV-quoted when needed (CsvCell).
class CsvWriter : public Observer {
 public:
  explicit CsvWriter(std::string path, bool publish = true);
  void OnStart(const std::vector<Column>& columns) override;
  void OnSample(const std::vector<double>& row) override;
  void OnFinish(const RunSummary& summary) override;

  /// After OnFinish: the finished file's size and SHA-256, and giving it its name.
  std::uint64_t bytes() const;
  std::string sha256() const;
  void Publish();

 private:
  std::string path_;
  bool publish_;
  std::unique_ptr<AtomicFile> file_;
  std::string line_;
};

/// Sends each sample to several observers.
class TeeObserver : public Observer {
 public:
  TeeObserver(Observer& a, Observer& b) : a_(a), b_(b) {}
  void OnStart(const std::vector<Column>& c) override { a_.OnStart(c), b_.OnStart(c); }
  void OnSample(const std::vector<double>& r) override { a_.OnSample(r), b_.OnSample(r); }
  void OnFinish(const RunSummary& s) override { a_.OnFinish(s), b_.OnFinish(s); }

 private:
  Observer& a_;
  Observer& b_;
};

/// The run record written as run.json (see DumpRecord).
nlohmann::json MakeRunRecord(const std::string& model_file, const std::string& model_text, const std::string& model_name,
                             const RunOptions& options, const RunSummary& summary, const std::vector<std::string>& command_line);

/// run.json's "results" entry: the data file's name, size in bytes and SHA-256.
nlohmann::json DataFileRecord(const std::string& name, std::uint64_t bytes, const std::string& sha256);

/// Dumps `record` as run.json text (indented; invalid UTF-8 replaced, never thrown).
std::string DumpRecord(const nlohmann::json& record);

}  // namespace multibond
