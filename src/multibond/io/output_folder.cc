#include "multibond/io/output_folder.h"

#include <dirent.h>
#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <stdexcept>

#include <fmt/format.h>

#include "multibond/io/atomic_file.h"

namespace multibond {

namespace {

bool EndsWith(const std::string& s, const std::string& tail) {
  return s.size() >= tail.size() && s.compare(s.size() - tail.size(), tail.size(), tail) == 0;
}

/// A temporary this program (or an earlier version of it) writes: removed once nobody holds the
/// lock, since nobody can be writing it.
bool IsTemporary(const std::string& name) {
  return (name.size() > 1 && name[0] == '.' && EndsWith(name, kTemporarySuffix)) || EndsWith(name, ".partial") ||
         name.rfind(".multibond-plot-", 0) == 0;
}

std::string ReadHolder(int fd) {
  char buf[1024];
  const ssize_t n = pread(fd, buf, sizeof buf - 1, 0);
  std::string s = n > 0 ? std::string(buf, static_cast<size_t>(n)) : std::string();
  while (!s.empty() && (s.back() == '\n' || s.back() == '\0')) s.pop_back();
  for (char& c : s)
    if (static_cast<unsigned char>(c) < 0x20 && c != '\n') c = '?';
  return s;
}

std::string Now() {
  const std::time_t t = std::chrono::system_clock::to_time_t(std::chrono::system_clock::now());
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

}  // namespace

OutputFolder::OutputFolder(std::string path, const std::string& command, bool create) : path_(std::move(path)) {
  auto fail = [&](const std::string& why) -> std::runtime_error {
    return std::runtime_error(fmt::format("cannot write into '{}': {}", path_, why));
  };
  std::error_code ec;
  if (create) {
    std::filesystem::create_directories(path_, ec);
    if (ec) throw fail(fmt::format("cannot create the folder ({})", ec.message()));
  }
  const int dir_fd = open(path_.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dir_fd < 0) throw fail(errno == ENOTDIR ? "it is not a folder" : std::strerror(errno));
  lock_fd_ = openat(dir_fd, kLockFileName, O_RDWR | O_CREAT | O_NOFOLLOW | O_CLOEXEC, 0644);
  if (lock_fd_ < 0) {
    const int err = errno;
    close(dir_fd);
    throw fail(fmt::format("cannot open its lock file {}: {}", kLockFileName,
                           err == ELOOP ? "it is a symbolic link (remove it)" : std::strerror(err)));
  }
  struct stat st {};
  if (fstat(lock_fd_, &st) != 0 || !S_ISREG(st.st_mode)) {
    close(dir_fd);
    close(lock_fd_);
    lock_fd_ = -1;
    throw fail(fmt::format("its lock file {} is not a regular file", kLockFileName));
  }
  if (flock(lock_fd_, LOCK_EX | LOCK_NB) != 0) {
    const std::string holder = ReadHolder(lock_fd_);
    close(dir_fd);
    close(lock_fd_);
    lock_fd_ = -1;
    throw fail(fmt::format("another multibond command is writing into it ({}); wait for it to finish, or write elsewhere",
                           holder.empty() ? "its details are not recorded" : holder));
  }
  const std::string record = fmt::format("pid {}, started {}: {}\n", getpid(), Now(), command);
  if (ftruncate(lock_fd_, 0) == 0) (void)!pwrite(lock_fd_, record.data(), record.size(), 0);
  // Nobody else holds the folder: the temporaries in it belong to commands that died.
  if (DIR* d = fdopendir(dir_fd)) {
    while (const dirent* e = readdir(d)) {
      const std::string name = e->d_name;
      struct stat s {};
      if (!IsTemporary(name) || fstatat(dir_fd, name.c_str(), &s, AT_SYMLINK_NOFOLLOW) != 0) continue;
      if ((S_ISREG(s.st_mode) || S_ISLNK(s.st_mode)) && unlinkat(dir_fd, name.c_str(), 0) == 0) removed_.push_back(name);
      if (S_ISDIR(s.st_mode) && name.rfind(".multibond-plot-", 0) == 0) {  // a work folder of plot (results_folder.h); links inside are removed, not followed
        std::error_code ec;
        if (std::filesystem::remove_all(std::filesystem::path(path_) / name, ec) > 0 && !ec) removed_.push_back(name);
      }
    }
    closedir(d);  // closes dir_fd
  } else {
    close(dir_fd);
  }
}

OutputFolder::~OutputFolder() {
  if (lock_fd_ >= 0) {
    (void)!ftruncate(lock_fd_, 0);
    close(lock_fd_);  // releases the lock
  }
}

std::string OutputFolder::File(const std::string& name) const { return (std::filesystem::path(path_) / name).string(); }

}  // namespace multibond
