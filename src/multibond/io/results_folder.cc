#include "multibond/io/results_folder.h"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <random>
#include <stdexcept>

#include <fmt/format.h>

#include "multibond/io/limits.h"

namespace multibond {

namespace {

[[noreturn]] void Fail(const std::string& message) { throw std::runtime_error(message); }

std::string Errno() { return std::strerror(errno); }

/// Writes all of `data` to `fd`; false on a write error (errno set).
bool WriteAll(int fd, const char* data, size_t size) {
  while (size > 0) {
    const ssize_t n = ::write(fd, data, size);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return false;
    data += n;
    size -= static_cast<size_t>(n);
  }
  return true;
}

/// A name for the work folder that nobody can guess.
std::string RandomSuffix() {
  static constexpr char kChars[] = "abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789";
  std::random_device rd;
  std::string out;
  for (int i = 0; i < 12; ++i) out += kChars[rd() % (sizeof(kChars) - 1)];
  return out;
}

}  // namespace

Fd::~Fd() {
  if (fd_ >= 0) ::close(fd_);
}

Fd& Fd::operator=(Fd&& o) noexcept {
  if (this != &o) {
    if (fd_ >= 0) ::close(fd_);
    fd_ = o.fd_;
    o.fd_ = -1;
  }
  return *this;
}

BoundedFileBuf::int_type BoundedFileBuf::underflow() {
  if (gptr() < egptr()) return traits_type::to_int_type(*gptr());
  if (left_ == 0) {
    // At the bound: is there more?
    char probe;
    ssize_t n;
    do n = ::read(fd_, &probe, 1);
    while (n < 0 && errno == EINTR);
    if (n > 0) exceeded_ = true;
    return traits_type::eof();
  }
  ssize_t n;
  do n = ::read(fd_, buf_, static_cast<size_t>(std::min<std::uint64_t>(sizeof(buf_), left_)));
  while (n < 0 && errno == EINTR);
  if (n <= 0) return traits_type::eof();
  left_ -= static_cast<std::uint64_t>(n);
  setg(buf_, buf_, buf_ + n);
  return traits_type::to_int_type(*gptr());
}

ResultsFolder::ResultsFolder(const std::string& dir) : path_(dir) {
  dir_ = Fd(::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC));
  if (dir_.get() < 0)
    Fail(fmt::format("cannot open the results folder '{}': {} (run 'multibond run MODEL -o DIR' first)", dir, Errno()));
}

std::string ResultsFolder::PathOf(const std::string& name) const {
  return path_.empty() || path_.back() == '/' ? path_ + name : path_ + "/" + name;
}

Fd ResultsFolder::OpenInput(const std::string& name, std::uint64_t max_bytes, const char* limit, struct stat* st) const {
  const std::string shown = PathOf(name);
  Fd fd(::openat(dir_.get(), name.c_str(), O_RDONLY | O_NOFOLLOW | O_NONBLOCK | O_NOCTTY | O_CLOEXEC));
  if (fd.get() < 0) {
    if (errno == ENOENT) return Fd();
    if (errno == ELOOP)
      Fail(fmt::format("'{}' is a symbolic link: plot reads only the results folder's own files (put the file itself there)", shown));
    Fail(fmt::format("cannot read '{}': {}", shown, Errno()));
  }
  if (::fstat(fd.get(), st) != 0) Fail(fmt::format("cannot read '{}': {}", shown, Errno()));
  if (!S_ISREG(st->st_mode))
    Fail(fmt::format("'{}' is not a regular file: plot reads only the results folder's own files", shown));
  const std::uint64_t size = static_cast<std::uint64_t>(st->st_size);
  if (size > max_bytes)
    Fail(fmt::format("'{}' is {} bytes, more than the {} bytes plot reads{}", shown, size, max_bytes,
                     limit ? "; " + RaiseLimitHint(limit, max_bytes) : std::string()));
  // Regular files do not block; reads should wait as usual.
  ::fcntl(fd.get(), F_SETFL, ::fcntl(fd.get(), F_GETFL) & ~O_NONBLOCK);
  return fd;
}

std::optional<std::string> ResultsFolder::ReadText(const std::string& name, std::uint64_t max_bytes, const char* limit) const {
  struct stat st {};
  const Fd fd = OpenInput(name, max_bytes, limit, &st);
  if (fd.get() < 0) return std::nullopt;
  std::string text;
  BoundedFileBuf buf(fd.get(), max_bytes);
  std::istream in(&buf);
  text.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  if (buf.exceeded())
    Fail(fmt::format("'{}' grew beyond {} bytes while it was read{}", PathOf(name), max_bytes,
                     limit ? "; " + RaiseLimitHint(limit, max_bytes) : std::string()));
  return text;
}

Fd ResultsFolder::OutputDir(const std::string& name) const {
  const std::string shown = PathOf(name);
  if (::mkdirat(dir_.get(), name.c_str(), 0755) != 0 && errno != EEXIST)
    Fail(fmt::format("cannot create the folder '{}': {}", shown, Errno()));
  Fd fd(::openat(dir_.get(), name.c_str(), O_RDONLY | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC));
  if (fd.get() >= 0) return fd;
  struct stat st {};
  if (errno == ELOOP || (::fstatat(dir_.get(), name.c_str(), &st, AT_SYMLINK_NOFOLLOW) == 0 && S_ISLNK(st.st_mode)))
    Fail(fmt::format("'{}' is a symbolic link: plot writes only inside the results folder (remove the link)", shown));
  if (errno == ENOTDIR) Fail(fmt::format("'{}' is not a folder: plot writes its files there (remove or rename it)", shown));
  Fail(fmt::format("cannot open the folder '{}': {}", shown, Errno()));
}

Fd ResultsFolder::ExistingDir(const std::string& name) const {
  return Fd(::openat(dir_.get(), name.c_str(), O_RDONLY | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC));
}

bool IsNonEmptyRegularFile(int dir, const std::string& name) {
  struct stat st {};
  return dir >= 0 && ::fstatat(dir, name.c_str(), &st, AT_SYMLINK_NOFOLLOW) == 0 && S_ISREG(st.st_mode) && st.st_size > 0;
}

WorkFolder::WorkFolder(const ResultsFolder& folder) {
  std::string name;
  for (int attempt = 0;; ++attempt) {
    name = ".multibond-plot-" + RandomSuffix();
    if (::mkdirat(folder.fd(), name.c_str(), 0700) == 0) break;
    if (errno != EEXIST || attempt > 100)
      Fail(fmt::format("cannot create a work folder in '{}': {}", folder.path(), Errno()));
  }
  path_ = folder.PathOf(name);
  fd_ = Fd(::openat(folder.fd(), name.c_str(), O_RDONLY | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC));
  std::string error = fd_.get() < 0 ? fmt::format("cannot open the work folder '{}': {}", path_, Errno()) : "";
  for (const char* sub : {"figures", "plots"})
    if (error.empty() && ::mkdirat(fd_.get(), sub, 0700) != 0) error = fmt::format("cannot create '{}/{}': {}", path_, sub, Errno());
  if (error.empty()) return;
  std::error_code ignored;
  std::filesystem::remove_all(path_, ignored);
  Fail(error);
}

WorkFolder::~WorkFolder() {
  std::error_code ignored;
  std::filesystem::remove_all(path_, ignored);  // removes links, never follows them
}

void WorkFolder::Write(const std::string& rel, const std::string& content) const {
  const Fd fd(::openat(fd_.get(), rel.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0644));
  if (fd.get() < 0 || !WriteAll(fd.get(), content.data(), content.size()))
    Fail(fmt::format("cannot write '{}/{}': {}", path_, rel, Errno()));
}

void WorkFolder::AddInput(const ResultsFolder& folder, const std::string& name, int fd, const struct stat& st) const {
  if (::linkat(folder.fd(), name.c_str(), fd_.get(), name.c_str(), 0) == 0) {
    struct stat linked {};
    if (::fstatat(fd_.get(), name.c_str(), &linked, AT_SYMLINK_NOFOLLOW) == 0 && linked.st_dev == st.st_dev &&
        linked.st_ino == st.st_ino)
      return;
    ::unlinkat(fd_.get(), name.c_str(), 0);  // replaced since it was read: copy what was read
  }
  const Fd out(::openat(fd_.get(), name.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0600));
  if (out.get() < 0) Fail(fmt::format("cannot write '{}/{}': {}", path_, name, Errno()));
  std::string buf(1 << 20, '\0');
  for (off_t at = 0; at < st.st_size;) {
    const ssize_t n = ::pread(fd, buf.data(), std::min<off_t>(static_cast<off_t>(buf.size()), st.st_size - at), at);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;  // shorter than it was: gnuplot reads what is there
    if (!WriteAll(out.get(), buf.data(), static_cast<size_t>(n))) Fail(fmt::format("cannot write '{}/{}': {}", path_, name, Errno()));
    at += n;
  }
}

bool WorkFolder::Publish(const std::string& rel, int to_dir, const std::string& to_name) const {
  struct stat st {};
  if (::fstatat(fd_.get(), rel.c_str(), &st, AT_SYMLINK_NOFOLLOW) != 0 || !S_ISREG(st.st_mode)) return false;
  if (::renameat(fd_.get(), rel.c_str(), to_dir, to_name.c_str()) != 0)
    Fail(fmt::format("cannot put '{}' in place: {}", to_name, errno == EISDIR ? "a folder has its name" : Errno()));
  return true;
}

}  // namespace multibond
