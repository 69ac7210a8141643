#pragma once
/// \file
/// The result files of a run in the formats asked for: results.csv (CsvWriter, streamed row by
/// row), results.mat (io/mat_writer.h) and results.h5 (io/h5_writer.h), the binary ones from the
/// columns kept in memory (ColumnStore). Each is written under a temporary name in the output
/// folder and published by Publish(), all together, after the caller has written what describes
/// them (run.json): a file is never seen half-written, and until Publish() none of them is.

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "multibond/io/column_store.h"
#include "multibond/io/results_writer.h"
#include "multibond/io/staged_file.h"

namespace multibond {

enum class ResultFormat { kCsv, kMat, kH5 };

/// "csv", "mat", "h5".
const char* ResultFormatName(ResultFormat f);
/// "results.csv", "results.mat", "results.h5".
const char* ResultFileName(ResultFormat f);
/// Every format, in the order the files are listed.
const std::vector<ResultFormat>& AllResultFormats();

/// Reads a comma-separated list of formats ("csv,mat,h5"; spaces around a name allowed, a name
/// given twice counted once) in the order of AllResultFormats. Throws std::invalid_argument for
/// an empty list or an unknown name (with a did-you-mean).
std::vector<ResultFormat> ParseResultFormats(const std::string& list);

/// True when `formats` holds one that keeps the columns in memory (mat, h5).
bool NeedsColumnStore(const std::vector<ResultFormat>& formats);

class ResultsFiles : public Observer {
 public:
  /// `folder`: an existing folder; `expected_rows`: the output grid's size (NumOutputIntervals + 1),
  /// reserved for the columns kept in memory.
  /// `compress`: the binary files compressed (zlib), smaller by a few percent to a few tenths
  /// (constant columns compress, full-mantissa values hardly) and several times slower to write.
  ResultsFiles(std::string folder, std::vector<ResultFormat> formats, long expected_rows, bool compress = false);

  void OnStart(const std::vector<Column>& columns) override;
  void OnSample(const std::vector<double>& row) override;
  void OnFinish(const RunSummary& summary) override;
  /// Events (docs/events.md) are kept for events.csv, written with the other files when the run
  /// had any: the columns `time [s]`, `kind`, `element`, `description`.
  void OnEvent(const EventRecord& event) override;

  /// After the run: writes the binary files with `record` (the run record, as run.json will hold
  /// it) and finishes every file (synced, size and hash known). Throws std::runtime_error
  /// "cannot write '<file>': <why>"; then nothing is left.
  void Finish(const nlohmann::json& record);
  /// After Finish: run.json's "files" list, one {"file", "format", "bytes", "sha256"} per file, and
  /// "compressed" (true or false) for results.mat and results.h5; events.csv's with format "events".
  nlohmann::json FilesRecord() const;
  /// After Finish: run.json's "results" entry (results.csv's), or null without csv.
  nlohmann::json CsvRecord() const;
  /// Gives every file its name.
  void Publish();

  const std::vector<ResultFormat>& formats() const { return formats_; }
  /// The time spent writing so far [s]: the rows as they came, and Finish (run.json's
  /// phase_seconds.write_results; the rest of the run's wall time is the integration's).
  double write_seconds() const { return write_seconds_; }
  const ColumnStore* columns() const { return store_.get(); }

 private:
  std::string folder_;
  std::vector<ResultFormat> formats_;
  bool compress_;
  double write_seconds_ = 0.0;
  std::unique_ptr<CsvWriter> csv_;
  std::unique_ptr<ColumnStore> store_;
  std::unique_ptr<StagedFile> mat_, h5_;
  std::vector<EventRecord> events_;
  std::unique_ptr<AtomicFile> events_file_;  ///< events.csv, when the run had events
};

/// The event log's file name, "events.csv".
inline constexpr const char kEventsFileName[] = "events.csv";

}  // namespace multibond
