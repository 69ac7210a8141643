#include "multibond/io/staged_file.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <random>
#include <stdexcept>
#include <string_view>
#include <vector>

#include <fmt/format.h>

#include "multibond/core/sha256.h"
#include "multibond/io/atomic_file.h"

namespace multibond {

StagedFile::StagedFile(std::string path) : path_(std::move(path)) {
  const TargetFolder folder = OpenTargetFolder(path_, [this](const std::string& why) { Fail(why); });
  dir_ = folder.dir;
  name_ = folder.name;
  dir_fd_ = folder.fd;
  static std::random_device device;
  for (int attempt = 0; attempt < 16 && fd_ < 0; ++attempt) {
    temp_name_ = fmt::format(".{}.{}.{:08x}{}", name_, getpid(), device(), kTemporarySuffix);
    fd_ = openat(dir_fd_, temp_name_.c_str(), O_RDWR | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0644);
    if (fd_ < 0 && errno != EEXIST) break;
  }
  if (fd_ < 0) {
    const int err = errno;
    temp_name_.clear();
    Fail(std::strerror(err));
  }
}

StagedFile::~StagedFile() {
  if (!published_) Discard();
  if (dir_fd_ >= 0) close(dir_fd_);
}

std::string StagedFile::temp_path() const { return (std::filesystem::path(dir_) / temp_name_).string(); }

void StagedFile::Discard() {
  if (fd_ >= 0) close(fd_);
  fd_ = -1;
  if (!temp_name_.empty() && dir_fd_ >= 0) unlinkat(dir_fd_, temp_name_.c_str(), 0);
  temp_name_.clear();
}

void StagedFile::Fail(const std::string& why) {
  Discard();
  throw std::runtime_error(fmt::format("cannot write '{}': {}", path_, why));
}

void StagedFile::Finish() {
  if (finished_) return;
  if (fd_ < 0) Fail("the file is not open");
  // The name must still lead to the file created: a regular file, not a link put in its place.
  struct stat mine {}, named {};
  if (fstat(fd_, &mine) != 0) Fail(std::strerror(errno));
  if (fstatat(dir_fd_, temp_name_.c_str(), &named, AT_SYMLINK_NOFOLLOW) != 0) Fail(std::strerror(errno));
  if (!S_ISREG(named.st_mode) || named.st_dev != mine.st_dev || named.st_ino != mine.st_ino)
    Fail("its temporary was replaced while it was written");
  if (fsync(fd_) != 0) Fail(std::strerror(errno));
  Sha256 hash;
  std::vector<char> buffer(1 << 20);
  std::uint64_t total = 0;
  for (;;) {
    const ssize_t n = pread(fd_, buffer.data(), buffer.size(), static_cast<off_t>(total));
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) Fail(std::strerror(errno));
    if (n == 0) break;
    hash.Update(std::string_view(buffer.data(), static_cast<size_t>(n)));
    total += static_cast<std::uint64_t>(n);
  }
  if (total != static_cast<std::uint64_t>(mine.st_size)) Fail("the file changed while it was read");
  bytes_ = total;
  sha256_ = hash.HexDigest();
  finished_ = true;
}

void StagedFile::Publish() {
  if (published_) return;
  if (!finished_) Finish();
  if (renameat(dir_fd_, temp_name_.c_str(), dir_fd_, name_.c_str()) != 0) {
    struct stat st {};
    const bool is_dir = fstatat(dir_fd_, name_.c_str(), &st, AT_SYMLINK_NOFOLLOW) == 0 && S_ISDIR(st.st_mode);
    Fail(is_dir ? "it is a directory" : std::strerror(errno));
  }
  temp_name_.clear();
  close(fd_);
  fd_ = -1;
  published_ = true;
}

}  // namespace multibond
