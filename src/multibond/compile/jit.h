#pragma once
/// \file
/// Compiling generated C++ into a shared object and loading it. The source is written to a cache
/// folder under the SHA-256 of its text, the compiler (command, resolved path, size and time) and
/// the flags, compiled once with the system's C++ compiler and loaded with dlopen; later runs of
/// the same model reuse the object.
///
/// Compiler: $MULTIBOND_CXX, else `c++` on the PATH. Cache: $MULTIBOND_CACHE, else
/// $XDG_CACHE_HOME/multibond, else ~/.cache/multibond.
///
/// The cache is private: its folder is created with mode 0700 and used only when it is a folder
/// (not a symbolic link) owned by this user that nobody else can write. Its files are created
/// under unique names (O_EXCL|O_NOFOLLOW, mode 0600) and published by rename; each library has a
/// sidecar `<name>.so.sha256` written when it was built. A library is loaded only when it is a
/// regular file of ours, writable by no one else, whose content has that hash, and it is loaded
/// through the descriptor that was checked (/proc/self/fd/N). Anything else is built again.
/// When the cache folder is refused there is no shared fallback: the code is compiled in a
/// private temporary folder (mkdtemp) removed after loading, and JitResult::warning says why.

#include <memory>
#include <string>

namespace multibond {

struct JitResult {
  std::shared_ptr<void> library;  ///< dlopen handle (dlclose on release); null on failure
  void* symbol = nullptr;         ///< the requested function
  std::string description;        ///< what was loaded, or why nothing was
  std::string warning;            ///< set when the cache was not used (and why): for the user
};

/// Compiles `source` (C++20) into a shared object, loads it and looks up `symbol`. Never throws
/// for a missing compiler or a compile error: the result says why and has no symbol. Throws
/// Interrupted("compiling the generated code") when a stop is asked for while the compiler runs
/// (the compiler is ended and the build's temporaries removed first).
JitResult CompileAndLoad(const std::string& source, const std::string& symbol);

}  // namespace multibond
