#pragma once
/// \file
/// A results folder that one command at a time writes into. Opening it takes an advisory lock
/// (flock on DIR/.multibond.lock, which records the holder: pid, command line, start time): a
/// second command into the same folder is refused, naming the running one, instead of mixing its
/// rows into the first one's files. The lock goes with the process, however it ends.
///
/// Holding the lock, it removes the temporaries that commands which died left behind (hidden
/// AtomicFile names, and the `*.partial` files of earlier versions) and lists them.

#include <string>
#include <vector>

namespace multibond {

class OutputFolder {
 public:
  /// `create`: make the folder (and its parents) when missing; else it must exist. `command`: what
  /// the lock file records for a second command's message. Throws std::runtime_error "cannot
  /// write into '<path>': <why>" (a busy folder says who holds it).
  OutputFolder(std::string path, const std::string& command, bool create = true);
  ~OutputFolder();
  OutputFolder(const OutputFolder&) = delete;
  OutputFolder& operator=(const OutputFolder&) = delete;

  const std::string& path() const { return path_; }
  /// The path of `name` in the folder.
  std::string File(const std::string& name) const;
  /// Temporaries of dead commands that were removed (their names).
  const std::vector<std::string>& removed_stale() const { return removed_; }

 private:
  std::string path_;
  int lock_fd_ = -1;
  std::vector<std::string> removed_;
};

/// The name of the lock file in a results folder.
inline constexpr const char* kLockFileName = ".multibond.lock";

}  // namespace multibond
