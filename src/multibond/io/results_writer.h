#pragma once
/// \file
/// Writing results: results.csv (header "name [unit]", one row per output time) and run.json
/// (provenance: model file and hash, options, solver statistics, wall time, version, status).
/// Files are written under a temporary name and renamed when complete, so a file called
/// results.csv or run.json is never half-written; when the write or the rename fails, the
/// temporary file is removed and std::runtime_error says "cannot write '<file>': <why>".

#include <cstdio>
#include <memory>
#include <string>

#include <nlohmann/json.hpp>

#include "multibond/sim/simulator.h"

namespace multibond {

/// Writes `content` to `path` through a temporary file in the same folder and a rename.
void WriteFileAtomic(const std::string& path, const std::string& content);

/// `text` as one CSV cell (RFC 4180): in double quotes, each quote doubled, when it holds a comma,
/// a quote or a line break; as it is otherwise, so plain names read the same as ever.
std::string CsvCell(const std::string& text);

/// SHA-256 of `data`, as 64 lowercase hex digits.
std::string Sha256Hex(const std::string& data);

/// Streams samples to `path`.partial and renames it to `path` when the run finishes (also when
/// it failed or was interrupted: the rows computed are kept; run.json says how the run ended).
/// If the run never finishes (an exception passed through Simulate), `path`.partial is left as it
/// is. Header cells are CSV-quoted when needed (CsvCell).
class CsvWriter : public Observer {
 public:
  explicit CsvWriter(std::string path);
  ~CsvWriter() override;
  void OnStart(const std::vector<Column>& columns) override;
  void OnSample(const std::vector<double>& row) override;
  void OnFinish(const RunSummary& summary) override;

 private:
  std::string path_, partial_;
  std::FILE* file_ = nullptr;
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

/// The run record written as run.json.
nlohmann::json MakeRunRecord(const std::string& model_file, const std::string& model_text, const std::string& model_name,
                             const RunOptions& options, const RunSummary& summary, const std::vector<std::string>& command_line);

}  // namespace multibond
