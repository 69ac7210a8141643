#pragma once
/// \file
/// Compiling generated C++ into a shared object and loading it. The source is written to a cache
/// folder under the hash of its text (and of the compiler command), compiled once with the
/// system's C++ compiler and loaded with dlopen; later runs of the same model reuse the object.
///
/// Compiler: $MULTIBOND_CXX, else `c++` on the PATH. Cache: $MULTIBOND_CACHE, else
/// $XDG_CACHE_HOME/multibond, else ~/.cache/multibond.

#include <memory>
#include <string>

namespace multibond {

struct JitResult {
  std::shared_ptr<void> library;  ///< dlopen handle (dlclose on release); null on failure
  void* symbol = nullptr;         ///< the requested function
  std::string description;        ///< what was loaded, or why nothing was
};

/// Compiles `source` (C++20) into a shared object, loads it and looks up `symbol`. Never throws
/// for a missing compiler or a compile error: the result says why and has no symbol.
JitResult CompileAndLoad(const std::string& source, const std::string& symbol);

}  // namespace multibond
