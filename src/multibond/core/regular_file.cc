#include "multibond/core/regular_file.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <stdexcept>

#include <fmt/format.h>

namespace multibond {

const char* FileKindName(mode_t st_mode) {
  if (S_ISDIR(st_mode)) return "a directory";
  if (S_ISFIFO(st_mode)) return "a FIFO (named pipe)";
  if (S_ISCHR(st_mode) || S_ISBLK(st_mode)) return "a device";
  if (S_ISSOCK(st_mode)) return "a socket";
  return S_ISREG(st_mode) ? "a regular file" : "not a regular file";
}

int OpenRegularFile(const std::string& path, int flags, mode_t mode) {
  const int fd = ::open(path.c_str(), flags | O_NONBLOCK | O_CLOEXEC, mode);
  if (fd < 0) {
    // A FIFO opened for writing with no reader: ENXIO. Said as what it is.
    struct stat st {};
    if (errno == ENXIO && ::lstat(path.c_str(), &st) == 0 && !S_ISREG(st.st_mode))
      throw std::runtime_error(fmt::format("'{}' is {}, not a regular file", path, FileKindName(st.st_mode)));
    return -1;
  }
  struct stat st {};
  if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
    const int saved = errno;
    ::close(fd);
    if (st.st_mode == 0) {
      errno = saved;
      return -1;
    }
    throw std::runtime_error(fmt::format("'{}' is {}, not a regular file", path, FileKindName(st.st_mode)));
  }
  const int status = ::fcntl(fd, F_GETFL);
  if (status >= 0) (void)::fcntl(fd, F_SETFL, status & ~O_NONBLOCK);
  return fd;
}

}  // namespace multibond
