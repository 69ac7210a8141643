#include "multibond/io/atomic_file.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <random>
#include <stdexcept>

#include <fmt/format.h>

namespace multibond {

namespace {

std::string UniqueTag() {
  static std::random_device device;
  return fmt::format("{}.{:08x}", getpid(), device());
}

}  // namespace

TargetFolder OpenTargetFolder(const std::string& path, const std::function<void(const std::string&)>& fail) {
  TargetFolder f;
  const std::filesystem::path p(path);
  f.name = p.filename().string();
  f.dir = p.has_parent_path() ? p.parent_path().string() : ".";
  if (f.name.empty() || f.name == "." || f.name == "..") fail("it names a folder, not a file");
  f.fd = open(f.dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (f.fd < 0) fail(errno == ENOENT ? fmt::format("no folder '{}'", f.dir) : std::strerror(errno));
  struct stat st {};
  if (fstatat(f.fd, f.name.c_str(), &st, AT_SYMLINK_NOFOLLOW) == 0 && S_ISDIR(st.st_mode)) {
    close(f.fd);
    fail("it is a directory");
  }
  return f;
}

AtomicFile::AtomicFile(std::string path) : path_(std::move(path)) {
  const TargetFolder folder = OpenTargetFolder(path_, [this](const std::string& why) { Fail(why); });
  dir_ = folder.dir;
  name_ = folder.name;
  dir_fd_ = folder.fd;
  // No name until complete; where the file system cannot, a unique name nobody else can take.
  fd_ = openat(dir_fd_, ".", O_TMPFILE | O_WRONLY | O_CLOEXEC, 0644);
  if (fd_ < 0) {
    for (int attempt = 0; attempt < 16 && fd_ < 0; ++attempt) {
      temp_name_ = fmt::format(".{}.{}{}", name_, UniqueTag(), kTemporarySuffix);
      fd_ = openat(dir_fd_, temp_name_.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0644);
      if (fd_ < 0 && errno != EEXIST) break;
    }
    if (fd_ < 0) {
      temp_name_.clear();
      Fail(std::strerror(errno));
    }
  }
  file_ = fdopen(fd_, "wb");
  if (!file_) Fail(std::strerror(errno));
}

AtomicFile::~AtomicFile() {
  if (!published_) Discard();
  if (dir_fd_ >= 0) close(dir_fd_);
}

void AtomicFile::Discard() {
  if (file_) std::fclose(file_);
  else if (fd_ >= 0) close(fd_);
  file_ = nullptr;
  fd_ = -1;
  if (!temp_name_.empty() && dir_fd_ >= 0) unlinkat(dir_fd_, temp_name_.c_str(), 0);
  temp_name_.clear();
}

void AtomicFile::Fail(const std::string& why) {
  Discard();
  throw std::runtime_error(fmt::format("cannot write '{}': {}", path_, why));
}

void AtomicFile::Write(std::string_view data) {
  if (!file_ || finished_) return;
  if (std::fwrite(data.data(), 1, data.size(), file_) != data.size() && write_errno_ == 0) write_errno_ = errno ? errno : EIO;
  hash_.Update(data);
  bytes_ += data.size();
}

void AtomicFile::Finish() {
  if (finished_) return;
  if (!file_) Fail("the file is not open");
  errno = 0;
  const bool flushed = std::fflush(file_) == 0;
  if (write_errno_ == 0 && !flushed) write_errno_ = errno ? errno : EIO;
  if (write_errno_ != 0 || std::ferror(file_)) Fail(std::strerror(write_errno_ ? write_errno_ : EIO));
  if (fsync(fd_) != 0) Fail(std::strerror(errno));
  finished_ = true;
}

void AtomicFile::Publish() {
  if (published_) return;
  if (!finished_) Finish();
  if (temp_name_.empty()) {
    // An O_TMPFILE file gets a unique hidden name (linkat cannot replace), then the real one.
    const std::string proc = fmt::format("/proc/self/fd/{}", fd_);
    for (int attempt = 0; attempt < 16 && temp_name_.empty(); ++attempt) {
      const std::string candidate = fmt::format(".{}.{}{}", name_, UniqueTag(), kTemporarySuffix);
      if (linkat(AT_FDCWD, proc.c_str(), dir_fd_, candidate.c_str(), AT_SYMLINK_FOLLOW) == 0) temp_name_ = candidate;
      else if (errno != EEXIST) Fail(std::strerror(errno));
    }
    if (temp_name_.empty()) Fail("no unique temporary name");
  }
  if (renameat(dir_fd_, temp_name_.c_str(), dir_fd_, name_.c_str()) != 0) {
    struct stat st {};
    const bool is_dir = fstatat(dir_fd_, name_.c_str(), &st, AT_SYMLINK_NOFOLLOW) == 0 && S_ISDIR(st.st_mode);
    Fail(is_dir ? "it is a directory" : std::strerror(errno));
  }
  temp_name_.clear();
  std::fclose(file_);
  file_ = nullptr;
  fd_ = -1;
  published_ = true;
}

void WriteFileAtomic(const std::string& path, const std::string& content) {
  AtomicFile f(path);
  f.Write(content);
  f.Commit();
}

}  // namespace multibond
