// OpenRegularFile (core/regular_file.h): a regular file opens (and its descriptor blocks again),
// a missing one is -1 with errno, and a FIFO (read or write, with no one at the other end), a
// directory or a device is refused at once with what it is.

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "multibond/core/regular_file.h"
#include "support/temp_dir.h"

namespace multibond {
namespace {

using ::testing::HasSubstr;

std::string Refusal(const std::string& path, int flags) {
  try {
    const int fd = OpenRegularFile(path, flags, 0600);
    if (fd >= 0) ::close(fd);
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "";
}

TEST(RegularFile, ARegularFileOpensBlocking) {
  testing::TempDir dir("multibond-regular");
  const std::string path = (dir.path() / "journal").string();
  std::ofstream(path) << "x\n";
  const int fd = OpenRegularFile(path, O_RDWR | O_APPEND);
  ASSERT_GE(fd, 0);
  EXPECT_EQ(::fcntl(fd, F_GETFL) & O_NONBLOCK, 0);
  EXPECT_NE(::fcntl(fd, F_GETFD) & FD_CLOEXEC, 0);
  ::close(fd);
  errno = 0;
  EXPECT_EQ(OpenRegularFile((dir.path() / "missing").string(), O_RDONLY), -1);
  EXPECT_EQ(errno, ENOENT);
}

TEST(RegularFile, AFifoADirectoryAndADeviceAreRefusedAtOnce) {
  testing::TempDir dir("multibond-regular");
  const std::string fifo = (dir.path() / "fifo").string();
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  EXPECT_THAT(Refusal(fifo, O_RDONLY), HasSubstr("is a FIFO (named pipe), not a regular file"));
  EXPECT_THAT(Refusal(fifo, O_RDWR | O_APPEND), HasSubstr("is a FIFO (named pipe), not a regular file"));
  EXPECT_THAT(Refusal(fifo, O_WRONLY | O_CREAT | O_TRUNC), HasSubstr("is a FIFO (named pipe), not a regular file"));
  EXPECT_THAT(Refusal(dir.path().string(), O_RDONLY), HasSubstr("is a directory"));
  EXPECT_THAT(Refusal("/dev/null", O_RDONLY), HasSubstr("is a device"));
}

}  // namespace
}  // namespace multibond
