// The journal of finished runs: appended, synced, read back on --resume.

#include "multibond/sweep/journal.h"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <charconv>
#include <cstring>
#include <stdexcept>

#include <fmt/format.h>

#include "multibond/core/regular_file.h"
#include "multibond/io/results_writer.h"

namespace multibond::sweep {

namespace {

constexpr const char* kHeader = "multibond sweep journal ";

double ReadDouble(const std::string& s, bool& ok) {
  double v = 0.0;
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  ok = ok && !s.empty() && ec == std::errc() && end == s.data() + s.size();
  return v;
}

}  // namespace

std::string JournalLine(const RunResult& r) {
  std::string o = fmt::format("{},{}", r.run, r.ok ? "ok" : "failed");
  for (const double v : r.values) (o += ',') += ExactText(v);
  (o += ',') += CsvCell(r.reason);
  return o;
}

bool ParseJournalLine(const std::string& line, size_t num_values, RunResult& r) {
  size_t pos = 0;
  std::vector<std::string> f;
  for (size_t i = 0; i < num_values + 2; ++i) {
    const size_t comma = line.find(',', pos);
    if (comma == std::string::npos) return false;
    f.push_back(line.substr(pos, comma - pos));
    pos = comma + 1;
  }
  std::string reason = line.substr(pos);
  if (reason.size() >= 2 && reason.front() == '"' && reason.back() == '"') {
    std::string u;
    for (size_t i = 1; i + 1 < reason.size(); ++i) {
      u += reason[i];
      if (reason[i] == '"') ++i;
    }
    reason = u;
  }
  long run = -1;
  const auto [end, ec] = std::from_chars(f[0].data(), f[0].data() + f[0].size(), run);
  if (ec != std::errc() || end != f[0].data() + f[0].size() || run < 0 || (f[1] != "ok" && f[1] != "failed")) return false;
  bool ok = true;
  r.run = run;
  r.ok = f[1] == "ok";
  r.values.clear();
  for (size_t i = 0; i < num_values; ++i) r.values.push_back(ReadDouble(f[2 + i], ok));
  r.reason = reason;
  return ok;
}

namespace {
/// A journal line is at most a few hundred bytes a run; runs are at most a few million.
constexpr size_t kMaxJournalBytes = size_t{1} << 30;
}  // namespace

Journal::Journal(std::string path, std::string hash, size_t num_values, bool resume)
    : path_(std::move(path)), hash_(std::move(hash)), num_values_(num_values), last_sync_(std::chrono::steady_clock::now()) {
  const std::string header = kHeader + hash_;
  if (resume) {
    // Opened without following a link: a journal that is a link elsewhere is refused (ELOOP).
    // Nor a FIFO or a device, which could block the open or the read for ever (OpenRegularFile).
    const int fd = OpenRegularFile(path_, O_RDWR | O_APPEND | O_NOFOLLOW);
    if (fd < 0 && errno == ENOENT) throw std::invalid_argument(fmt::format("--resume: there is no journal '{}' to resume from", path_));
    if (fd < 0) throw std::runtime_error(fmt::format("cannot read '{}': {}", path_, std::strerror(errno)));
    file_ = ::fdopen(fd, "a+b");
    if (!file_) {
      ::close(fd);
      throw std::runtime_error(fmt::format("cannot read '{}': {}", path_, std::strerror(errno)));
    }
    try {
      ReadBack(header);
    } catch (...) {
      std::fclose(file_);
      throw;
    }
  } else {
    const int fd = OpenRegularFile(path_, O_WRONLY | O_CREAT | O_TRUNC | O_NOFOLLOW, 0644);
    if (fd >= 0) file_ = ::fdopen(fd, "wb");
    if (file_) std::fprintf(file_, "%s\n", header.c_str());
  }
  if (!file_) throw std::runtime_error(fmt::format("cannot write '{}': {}", path_, std::strerror(errno)));
  Sync();
}

void Journal::ReadBack(const std::string& header) {
  std::string text;
  char buffer[1 << 16];
  for (size_t got; (got = std::fread(buffer, 1, sizeof buffer, file_)) > 0;) {
    text.append(buffer, got);
    if (text.size() > kMaxJournalBytes)
      throw std::invalid_argument(fmt::format("--resume: '{}' is larger than a journal can be ({} bytes)", path_, kMaxJournalBytes));
  }
  if (std::ferror(file_)) throw std::runtime_error(fmt::format("cannot read '{}': {}", path_, std::strerror(errno)));
  const size_t first = text.find('\n');
  if (first == std::string::npos || text.substr(0, first) != header)
    throw std::invalid_argument(fmt::format("--resume: '{}' is the journal of another study (or of this one changed): "
                                            "run without --resume to start anew, or into another folder", path_));
  // Whole lines only: a line torn by a crash (no newline) is cut off before appending.
  const size_t keep = text.rfind('\n') + 1;
  size_t pos = first + 1;
  while (pos < keep) {
    const size_t nl = text.find('\n', pos);
    RunResult r;
    if (ParseJournalLine(text.substr(pos, nl - pos), num_values_, r)) finished_.push_back(std::move(r));
    pos = nl + 1;
  }
  if (::ftruncate(::fileno(file_), static_cast<off_t>(keep)) != 0)
    throw std::runtime_error(fmt::format("cannot write '{}': {}", path_, std::strerror(errno)));
}

Journal::~Journal() {
  if (file_) std::fclose(file_);
}

void Journal::Append(const RunResult& r) {
  const std::string line = JournalLine(r) + "\n";
  if (std::fwrite(line.data(), 1, line.size(), file_) != line.size() || std::fflush(file_) != 0)
    throw std::runtime_error(fmt::format("cannot write '{}': {}", path_, std::strerror(errno)));
  if (std::chrono::steady_clock::now() - last_sync_ > std::chrono::milliseconds(250)) Sync();
}

void Journal::Sync() {
  if (std::fflush(file_) != 0 || ::fsync(::fileno(file_)) != 0)
    throw std::runtime_error(fmt::format("cannot write '{}': {}", path_, std::strerror(errno)));
  last_sync_ = std::chrono::steady_clock::now();
}

}  // namespace multibond::sweep
