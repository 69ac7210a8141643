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
/// through a sealed in-memory copy (memfd) of the bytes that were hashed (/proc/self/fd/N), so
/// that nothing done to the file later reaches the loaded code. Anything else is built again.
/// When the cache folder is refused there is no shared fallback: the code is compiled in a
/// private temporary folder (mkdtemp) removed after loading, and JitResult::warning says why.
///
/// Generated code may come as several units (docs/design.md, "Generated code at scale"): each is
/// its own shared object, cached under its own hash and compiled by its own compiler process, at
/// most std::thread::hardware_concurrency() at a time; all are loaded together. A library loaded
/// once stays loaded for the process: a later request for the same text (the same model with
/// other parameter values) reuses it without compiling or hashing its file again, as long as the
/// cached file is still the one that was checked (same inode, size, mode and times).

#include <atomic>
#include <functional>
#include <memory>
#include <string>
#include <vector>

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

/// How a batch of units is compiled: a time budget and a cancellation, both of which end the
/// compilers still running (their units fail, the others stay cached), and progress.
struct JitControl {
  double budget_seconds = 0;                   ///< > 0: the compilers still running after this are ended
  const std::atomic<bool>* cancel = nullptr;   ///< when it becomes true: the same, at once
  /// After each unit that needed the disk cache or a compiler: units done, units in all, seconds
  /// since the start. Called from the compiling threads, one call at a time.
  std::function<void(int done, int total, double seconds)> progress;
  bool light = false;  ///< -O1 instead of -O2: the same bits, for a large model's many units
  int nice = 0;        ///< > 0: the compilers run at this niceness (behind a run that goes on meanwhile)
};

/// Several units loaded together.
struct JitBatch {
  std::vector<void*> symbols;                     ///< per unit: its `symbol`; all null on failure
  std::vector<std::shared_ptr<void>> libraries;   ///< keep them loaded while the symbols are used
  std::string description;                        ///< where they are, or why they are not
  std::string warning;                            ///< as JitResult::warning
  int compiled = 0;   ///< units built by a compiler
  int from_disk = 0;  ///< units loaded from the cache folder
  int reused = 0;     ///< units already loaded in this process
  bool ok() const { return !symbols.empty() && symbols.front() != nullptr; }
};

/// Compiles (what is not cached) and loads every source, each its own shared object exporting
/// `symbol`. Throws Interrupted as CompileAndLoad does; a budget or a cancellation is a failure
/// (JitBatch::description says which), not an exception.
JitBatch CompileAndLoadUnits(const std::vector<std::string>& sources, const std::string& symbol, const JitControl& control = {});

/// Hands the units of a background compile that the end of a run would cancel over to a process
/// of their own, so that the generated code reaches the cache for the next run of the model
/// (`--jit auto`). Each unit not yet cached is stored in the cache folder as <stem>.cc (as a
/// build stores it), then `program jit-finish [--light] STEM...` is started in a process group of
/// its own, at niceness 10, and not waited for. Returns what was started ("" when every unit was
/// already built), or "not kept: " and why not.
std::string HandOverUnits(const std::vector<std::string>& sources, bool light, const std::string& program);

/// The other side, `multibond jit-finish`: builds the library of each named unit of the cache
/// folder that has none. A unit's text is compiled only when it is a private file of ours whose
/// hash (with this compiler and these flags) is its name. Returns the number built; `log`
/// receives a line per unit.
int FinishUnits(const std::vector<std::string>& stems, bool light, std::string* log = nullptr);

}  // namespace multibond

