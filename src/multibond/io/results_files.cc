#include "multibond/io/results_files.h"

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <stdexcept>

#include <fmt/format.h>

#include "multibond/io/did_you_mean.h"
#include "multibond/io/h5_writer.h"
#include "multibond/io/mat_writer.h"

namespace multibond {

const char* ResultFormatName(ResultFormat f) {
  switch (f) {
    case ResultFormat::kCsv: return "csv";
    case ResultFormat::kMat: return "mat";
    case ResultFormat::kH5: return "h5";
  }
  return "?";
}

const char* ResultFileName(ResultFormat f) {
  switch (f) {
    case ResultFormat::kCsv: return "results.csv";
    case ResultFormat::kMat: return "results.mat";
    case ResultFormat::kH5: return "results.h5";
  }
  return "?";
}

const std::vector<ResultFormat>& AllResultFormats() {
  static const std::vector<ResultFormat> all = {ResultFormat::kCsv, ResultFormat::kMat, ResultFormat::kH5};
  return all;
}

std::vector<ResultFormat> ParseResultFormats(const std::string& list) {
  std::vector<std::string> names;
  for (ResultFormat f : AllResultFormats()) names.push_back(ResultFormatName(f));
  std::vector<bool> chosen(names.size(), false);
  size_t start = 0;
  for (;;) {
    const size_t comma = std::min(list.find(',', start), list.size());
    std::string word = list.substr(start, comma - start);
    word.erase(0, word.find_first_not_of(' '));
    word.erase(word.find_last_not_of(' ') + 1);
    const auto it = std::find(names.begin(), names.end(), word);
    if (it == names.end()) {
      const std::string known = fmt::format("the formats are {}", fmt::join(names, ", "));
      if (word.empty()) throw std::invalid_argument(fmt::format("--format '{}' has an empty name in its list; {}", list, known));
      const std::string suggestion = DidYouMean(word, names);
      throw std::invalid_argument(fmt::format("unknown result format '{}' in --format '{}'{}; {}", word, list,
                                              suggestion.empty() ? "" : fmt::format(" (did you mean '{}'?)", suggestion), known));
    }
    chosen[static_cast<size_t>(it - names.begin())] = true;
    if (comma == list.size()) break;
    start = comma + 1;
  }
  std::vector<ResultFormat> formats;
  for (size_t i = 0; i < names.size(); ++i)
    if (chosen[i]) formats.push_back(AllResultFormats()[i]);
  return formats;
}

bool NeedsColumnStore(const std::vector<ResultFormat>& formats) {
  return std::any_of(formats.begin(), formats.end(), [](ResultFormat f) { return f != ResultFormat::kCsv; });
}

namespace {

bool Has(const std::vector<ResultFormat>& formats, ResultFormat f) { return std::find(formats.begin(), formats.end(), f) != formats.end(); }

/// Adds the time from its making to its end to `total` [s] (ResultsFiles::write_seconds).
class WriteTimer {
 public:
  explicit WriteTimer(double& total) : total_(total), start_(std::chrono::steady_clock::now()) {}
  ~WriteTimer() { total_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count(); }
  WriteTimer(const WriteTimer&) = delete;
  WriteTimer& operator=(const WriteTimer&) = delete;

 private:
  double& total_;
  std::chrono::steady_clock::time_point start_;
};

}  // namespace

ResultsFiles::ResultsFiles(std::string folder, std::vector<ResultFormat> formats, long expected_rows, bool compress)
    : folder_(std::move(folder)), formats_(std::move(formats)), compress_(compress) {
  const auto file = [&](ResultFormat f) { return (std::filesystem::path(folder_) / ResultFileName(f)).string(); };
  if (Has(formats_, ResultFormat::kCsv)) csv_ = std::make_unique<CsvWriter>(file(ResultFormat::kCsv), /*publish=*/false);
  if (NeedsColumnStore(formats_)) store_ = std::make_unique<ColumnStore>(expected_rows);
  // The binary files' temporaries are made now: a name they cannot take is said before the run.
  if (Has(formats_, ResultFormat::kMat)) mat_ = std::make_unique<StagedFile>(file(ResultFormat::kMat));
  if (Has(formats_, ResultFormat::kH5)) h5_ = std::make_unique<StagedFile>(file(ResultFormat::kH5));
}

void ResultsFiles::OnStart(const std::vector<Column>& columns) {
  const WriteTimer timer(write_seconds_);
  if (csv_) csv_->OnStart(columns);
  if (store_) store_->OnStart(columns);
}

void ResultsFiles::OnSample(const std::vector<double>& row) {
  const WriteTimer timer(write_seconds_);
  if (csv_) csv_->OnSample(row);
  if (store_) store_->OnSample(row);
}

void ResultsFiles::OnFinish(const RunSummary& summary) {
  const WriteTimer timer(write_seconds_);
  if (csv_) csv_->OnFinish(summary);
  if (store_) store_->OnFinish(summary);
}

void ResultsFiles::OnEvent(const EventRecord& event) { events_.push_back(event); }

void ResultsFiles::Finish(const nlohmann::json& record) {
  const WriteTimer timer(write_seconds_);
  if (!events_.empty()) {
    events_file_ = std::make_unique<AtomicFile>((std::filesystem::path(folder_) / kEventsFileName).string());
    std::string text = "time [s],kind,element,description\n";
    for (const EventRecord& e : events_)
      text += fmt::format("{:.17g},{},{},{}\n", e.time, CsvCell(e.kind), CsvCell(e.element), CsvCell(e.description));
    events_file_->Write(text);
    events_file_->Finish();
  }
  if (mat_) {
    WriteMatResults(mat_->temp_path(), *store_, record, compress_);
    mat_->Finish();
  }
  if (h5_) {
    WriteH5Results(h5_->temp_path(), *store_, record, compress_);
    h5_->Finish();
  }
}

nlohmann::json ResultsFiles::FilesRecord() const {
  nlohmann::json files = nlohmann::json::array();
  const auto add = [&](ResultFormat f, std::uint64_t bytes, const std::string& sha256) {
    nlohmann::json entry = DataFileRecord(ResultFileName(f), bytes, sha256);
    entry["format"] = ResultFormatName(f);
    if (f != ResultFormat::kCsv) entry["compressed"] = compress_;
    files.push_back(std::move(entry));
  };
  if (csv_) add(ResultFormat::kCsv, csv_->bytes(), csv_->sha256());
  if (mat_) add(ResultFormat::kMat, mat_->bytes(), mat_->sha256());
  if (h5_) add(ResultFormat::kH5, h5_->bytes(), h5_->sha256());
  if (events_file_) {
    nlohmann::json entry = DataFileRecord(kEventsFileName, events_file_->bytes(), events_file_->sha256());
    entry["format"] = "events";
    files.push_back(std::move(entry));
  }
  return files;
}

nlohmann::json ResultsFiles::CsvRecord() const {
  return csv_ ? DataFileRecord(ResultFileName(ResultFormat::kCsv), csv_->bytes(), csv_->sha256()) : nlohmann::json();
}

void ResultsFiles::Publish() {
  if (csv_) csv_->Publish();
  if (mat_) mat_->Publish();
  if (h5_) h5_->Publish();
  if (events_file_) events_file_->Publish();
}

}  // namespace multibond
