#pragma once
/// \file
/// A results folder as `plot` uses it, which anyone may have made: it reads only the folder's own
/// regular files (opened with O_NOFOLLOW, never through a link, never more than a bound), and it
/// writes only inside it: its output subfolders are refused when they are links, and what it
/// writes (gnuplot's and Graphviz's pictures too) is made in a private work folder inside the
/// results folder (mode 0700, unique name) and renamed into place, which replaces a planted link
/// instead of writing through it.
///
/// Errors are std::runtime_error naming the file and what is wrong (the CLI exits 74).

#include <sys/stat.h>

#include <cstdint>
#include <istream>
#include <memory>
#include <optional>
#include <streambuf>
#include <string>

namespace multibond {

/// An open file descriptor, closed on destruction.
class Fd {
 public:
  Fd() = default;
  explicit Fd(int fd) : fd_(fd) {}
  ~Fd();
  Fd(Fd&& o) noexcept : fd_(o.fd_) { o.fd_ = -1; }
  Fd& operator=(Fd&& o) noexcept;
  Fd(const Fd&) = delete;
  Fd& operator=(const Fd&) = delete;
  int get() const { return fd_; }

 private:
  int fd_ = -1;
};

/// Reads an open file as a stream, at most `limit` bytes: past them the stream ends and
/// exceeded() is true (so that a header line or a file cannot take more memory than the bound).
class BoundedFileBuf : public std::streambuf {
 public:
  BoundedFileBuf(int fd, std::uint64_t limit) : fd_(fd), left_(limit) {}
  /// Sets how many more bytes may be read from here on.
  void set_limit(std::uint64_t limit) { left_ = limit + static_cast<std::uint64_t>(egptr() - gptr()); }
  bool exceeded() const { return exceeded_; }

 protected:
  int_type underflow() override;

 private:
  int fd_;
  std::uint64_t left_;
  bool exceeded_ = false;
  char buf_[1 << 16];
};

class ResultsFolder {
 public:
  /// Opens the folder `dir` (the path the user gave). Throws when it is not a folder.
  explicit ResultsFolder(const std::string& dir);

  const std::string& path() const { return path_; }
  int fd() const { return dir_.get(); }
  /// "DIR/name", for messages and reports.
  std::string PathOf(const std::string& name) const;

  /// Opens the folder's file `name` (one path component) for reading: a regular file, not a link,
  /// of at most `max_bytes` (`limit` names the --limit that raises it, or is null for a fixed
  /// bound). Returns an empty Fd when the file does not exist; throws otherwise. `st` gets its
  /// status.
  Fd OpenInput(const std::string& name, std::uint64_t max_bytes, const char* limit, struct stat* st) const;

  /// The text of OpenInput's file, or nullopt when it does not exist.
  std::optional<std::string> ReadText(const std::string& name, std::uint64_t max_bytes, const char* limit) const;

  /// The output subfolder `name` ("figures", "plots"), created when absent (mode 0755). Throws
  /// when it is a link (even one to a folder) or not a folder.
  Fd OutputDir(const std::string& name) const;

  /// The subfolder `name` opened for looking (not a link); an empty Fd when it is absent or not a folder.
  Fd ExistingDir(const std::string& name) const;

 private:
  std::string path_;
  Fd dir_;
};

/// True when `dir`/`name` is a regular file (not a link) of at least one byte.
bool IsNonEmptyRegularFile(int dir, const std::string& name);

/// A private folder inside a results folder (".multibond-plot-XXXXXX", mode 0700, removed with
/// what is left in it on destruction) with subfolders figures/ and plots/: programs write there
/// (nobody else can plant a link in it), and Publish renames each finished file into place.
class WorkFolder {
 public:
  explicit WorkFolder(const ResultsFolder& folder);
  ~WorkFolder();
  WorkFolder(const WorkFolder&) = delete;
  WorkFolder& operator=(const WorkFolder&) = delete;

  /// Its path (the cwd of the programs run there).
  const std::string& path() const { return path_; }
  int fd() const { return fd_.get(); }

  /// Writes a new file `rel` ("plots/x.gp"), created with O_EXCL|O_NOFOLLOW. Throws on failure.
  void Write(const std::string& rel, const std::string& content) const;

  /// Makes the folder's input `name` readable here under the same name, as the very file that was
  /// read (`st`, open as `fd`): a hard link when the file system allows it, else a copy.
  void AddInput(const ResultsFolder& folder, const std::string& name, int fd, const struct stat& st) const;

  /// Renames `rel` (a regular file made here, not a link) to `to_name` in the folder `to_dir`,
  /// replacing whatever is there (a planted link is replaced, never followed). Returns false when
  /// `rel` is missing or not a regular file (left for the destructor); throws when the rename fails.
  bool Publish(const std::string& rel, int to_dir, const std::string& to_name) const;

 private:
  std::string path_;
  Fd fd_;
};

}  // namespace multibond
