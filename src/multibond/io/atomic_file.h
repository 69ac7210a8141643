#pragma once
/// \file
/// Files that appear complete or not at all. An AtomicFile is written under no name (Linux's
/// O_TMPFILE) or, where the file system cannot do that, under a unique hidden name created with
/// O_CREAT|O_EXCL|O_NOFOLLOW; it gets its name by rename(2) only when complete and on disk
/// (fsync). A planted link at the final name is replaced, never followed; a process killed
/// mid-write leaves nothing (O_TMPFILE) or a hidden temporary that OutputFolder removes.
///
/// Errors are std::runtime_error "cannot write '<path>': <why>"; after one, the temporary is gone.

#include <sys/types.h>

#include <cstdint>
#include <cstdio>
#include <functional>
#include <string>
#include <string_view>

#include "multibond/core/sha256.h"

namespace multibond {

/// The suffix of the hidden temporaries: ".<name>.<unique>" + kTemporarySuffix.
inline constexpr const char* kTemporarySuffix = ".multibond-tmp";

/// The folder a file `path` is to be created in, opened (O_DIRECTORY, O_CLOEXEC): its path, the
/// file's name, the folder's descriptor. Calls `fail` (which must not return) when the path names
/// a folder, the folder does not exist or cannot be opened, or a directory has the file's name.
struct TargetFolder {
  std::string dir, name;
  int fd = -1;
};
TargetFolder OpenTargetFolder(const std::string& path, const std::function<void(const std::string&)>& fail);

class AtomicFile {
 public:
  /// Opens the temporary in `path`'s folder (which must exist). Throws if `path` names a folder.
  explicit AtomicFile(std::string path);
  /// Removes the temporary unless Publish() ran.
  ~AtomicFile();
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;

  /// Appends (buffered). A write error is remembered and thrown by Finish().
  void Write(std::string_view data);
  /// Flushes and syncs the content: after it, bytes() and sha256() describe the file, and
  /// Publish() cannot fail for lack of space. Throws on a write error (a full disk).
  void Finish();
  /// Gives the finished file its name (replacing what was there). Throws on failure.
  void Publish();
  /// Finish() then Publish().
  void Commit() {
    Finish();
    Publish();
  }

  const std::string& path() const { return path_; }
  std::uint64_t bytes() const { return bytes_; }
  /// SHA-256 of the content, 64 hex digits.
  std::string sha256() const { return hash_.HexDigest(); }

 private:
  void Discard();
  [[noreturn]] void Fail(const std::string& why);

  std::string path_, dir_, name_;
  std::string temp_name_;  ///< the hidden temporary's name, "" with O_TMPFILE
  int dir_fd_ = -1;
  std::FILE* file_ = nullptr;
  int fd_ = -1;
  bool finished_ = false, published_ = false;
  int write_errno_ = 0;  ///< the first failed write's error (a full disk), said by Finish
  std::uint64_t bytes_ = 0;
  Sha256 hash_;
};

/// Writes `content` to `path` through an AtomicFile.
void WriteFileAtomic(const std::string& path, const std::string& content);

}  // namespace multibond
