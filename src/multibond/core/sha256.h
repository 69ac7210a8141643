#pragma once
/// \file
/// SHA-256 (OpenSSL's EVP): a content hash for provenance (run.json) and for checking what was
/// written or is about to be loaded.

#include <memory>
#include <string>
#include <string_view>

namespace multibond {

/// Incremental SHA-256: Update as data passes, HexDigest at the end.
class Sha256 {
 public:
  Sha256();
  ~Sha256();
  Sha256(const Sha256&) = delete;
  Sha256& operator=(const Sha256&) = delete;
  void Update(std::string_view data);
  /// The digest of everything given so far, as 64 lowercase hex digits (the hash can go on).
  std::string HexDigest() const;

 private:
  struct Context;
  std::unique_ptr<Context> ctx_;
};

/// SHA-256 of `data`, as 64 lowercase hex digits.
std::string Sha256Hex(std::string_view data);

}  // namespace multibond
