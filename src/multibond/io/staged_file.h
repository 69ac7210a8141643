#pragma once
/// \file
/// A file that a library writes by name (matio, HDF5), published like an AtomicFile: it is written
/// under a unique hidden name in the final folder (".<name>.<pid>.<random>.multibond-tmp", created
/// O_CREAT|O_EXCL|O_NOFOLLOW, the pattern OutputFolder removes when a command died), then checked,
/// hashed and synced (Finish), and renamed to its name (Publish). Until published, the destructor
/// removes it.
///
/// Finish reads the file back through the descriptor that created it, after checking that the name
/// still leads to that same file: the size and SHA-256 recorded are those of the file published.
/// Errors are std::runtime_error "cannot write '<path>': <why>"; after one, the temporary is gone.

#include <cstdint>
#include <string>

namespace multibond {

class StagedFile {
 public:
  /// Creates the temporary in `path`'s folder (which must exist). Throws if `path` names a folder.
  explicit StagedFile(std::string path);
  ~StagedFile();
  StagedFile(const StagedFile&) = delete;
  StagedFile& operator=(const StagedFile&) = delete;

  /// The temporary's path, for the library to write (it exists, empty, until then).
  std::string temp_path() const;
  /// The final path.
  const std::string& path() const { return path_; }

  /// After the library closed the file: checks, hashes and syncs it. Throws on failure.
  void Finish();
  /// Gives the finished file its name (replacing what was there). Throws on failure.
  void Publish();
  /// Removes the temporary now (also done by the destructor).
  void Discard();

  std::uint64_t bytes() const { return bytes_; }
  const std::string& sha256() const { return sha256_; }

 private:
  [[noreturn]] void Fail(const std::string& why);

  std::string path_, dir_, name_, temp_name_;
  int dir_fd_ = -1, fd_ = -1;
  bool finished_ = false, published_ = false;
  std::uint64_t bytes_ = 0;
  std::string sha256_;
};

}  // namespace multibond
