#include "multibond/compile/jit.h"

#include "multibond/core/interrupt.h"
#include "multibond/core/process.h"

#include <dlfcn.h>
#include <fcntl.h>
#include <openssl/evp.h>
#include <sys/file.h>
#include <sys/mman.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <random>
#include <sstream>
#include <thread>
#include <unordered_map>
#include <vector>

#include <fmt/format.h>

namespace multibond {

namespace fs = std::filesystem;

namespace {

/// A file descriptor, closed on destruction.
class Fd {
 public:
  explicit Fd(int fd = -1) : fd_(fd) {}
  ~Fd() {
    if (fd_ >= 0) close(fd_);
  }
  Fd(Fd&& o) noexcept : fd_(o.fd_) { o.fd_ = -1; }
  Fd& operator=(Fd&& o) noexcept {
    std::swap(fd_, o.fd_);
    return *this;
  }
  int get() const { return fd_; }
  int release() {
    const int fd = fd_;
    fd_ = -1;
    return fd;
  }

 private:
  int fd_;
};

std::string Errno() { return std::strerror(errno); }

std::string Hex(const unsigned char* d, unsigned n) {
  std::string hex;
  for (unsigned i = 0; i < n; ++i) hex += fmt::format("{:02x}", d[i]);
  return hex;
}

std::string Sha256(const std::string& text) {
  unsigned char digest[EVP_MAX_MD_SIZE];
  unsigned int len = 0;
  EVP_Digest(text.data(), text.size(), digest, &len, EVP_sha256(), nullptr);
  return Hex(digest, len);
}

/// SHA-256 of what `fd` holds from its start ("" when it cannot be read); with `copy` >= 0, the
/// bytes hashed are written there too.
std::string Sha256(int fd, int copy = -1) {
  EVP_MD_CTX* ctx = EVP_MD_CTX_new();
  EVP_DigestInit_ex(ctx, EVP_sha256(), nullptr);
  char buf[1 << 16];
  off_t at = 0;
  bool ok = true;
  for (;;) {
    const ssize_t n = pread(fd, buf, sizeof buf, at);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) ok = false;
    if (n <= 0) break;
    EVP_DigestUpdate(ctx, buf, static_cast<size_t>(n));
    for (ssize_t done = 0; copy >= 0 && ok && done < n;) {
      const ssize_t w = write(copy, buf + done, static_cast<size_t>(n - done));
      if (w < 0 && errno == EINTR) continue;
      if (w <= 0) ok = false;
      else done += w;
    }
    at += n;
  }
  unsigned char digest[EVP_MAX_MD_SIZE];
  unsigned int len = 0;
  EVP_DigestFinal_ex(ctx, digest, &len);
  EVP_MD_CTX_free(ctx);
  return ok ? Hex(digest, len) : "";
}

/// Why the open file `fd` may not be trusted ("" when it may): it must be a `kind` (S_IFDIR or
/// S_IFREG) owned by this user and writable by nobody else.
std::string Untrusted(int fd, mode_t kind, const std::string& what) {
  struct stat st {};
  if (fstat(fd, &st) != 0) return fmt::format("cannot examine {}: {}", what, Errno());
  if ((st.st_mode & S_IFMT) != kind) return fmt::format("{} is not a {}", what, kind == S_IFDIR ? "folder" : "regular file");
  if (st.st_uid != geteuid()) return fmt::format("{} belongs to user {}, not to you (user {})", what, st.st_uid, geteuid());
  if (st.st_mode & (S_IWGRP | S_IWOTH))
    return fmt::format("{} can be written by {} (mode {:04o})", what, st.st_mode & S_IWOTH ? "other users" : "its group",
                       st.st_mode & 07777);
  return "";
}

/// Opens the folder `dir`, creating it (mode 0700, its parents as needed) when it does not exist.
/// Refused ("" and an open descriptor otherwise): a symbolic link, anything but a folder, a
/// folder of another user or one that others can write.
std::string OpenPrivateFolder(const fs::path& dir, Fd& out) {
  std::error_code ec;
  if (dir.has_parent_path()) fs::create_directories(dir.parent_path(), ec);
  if (mkdir(dir.c_str(), 0700) != 0 && errno != EEXIST) return fmt::format("cannot create {}: {}", dir.string(), Errno());
  Fd fd(open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC));
  if (fd.get() < 0) {
    struct stat st {};
    if ((errno == ELOOP || errno == ENOTDIR) && lstat(dir.c_str(), &st) == 0 && S_ISLNK(st.st_mode))
      return fmt::format("{} is a symbolic link", dir.string());
    return fmt::format("cannot open {}: {}", dir.string(), Errno());
  }
  if (std::string why = Untrusted(fd.get(), S_IFDIR, dir.string()); !why.empty()) return why;
  out = std::move(fd);
  return "";
}

/// Creates `name` in the folder `dir` (never through a link, never over an existing file,
/// mode 0600) holding `text`.
std::string WriteNew(int dir, const std::string& name, const std::string& text) {
  Fd fd(openat(dir, name.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0600));
  if (fd.get() < 0) return fmt::format("cannot create {}: {}", name, Errno());
  for (size_t done = 0; done < text.size();) {
    const ssize_t n = write(fd.get(), text.data() + done, text.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) return fmt::format("cannot write {}: {}", name, Errno());
    done += static_cast<size_t>(n);
  }
  return "";
}

/// Removes the listed names of a folder when it goes (the temporaries of a build, whatever ends it).
struct Temporaries {
  int dir;
  std::vector<std::string> names;
  ~Temporaries() {
    for (const std::string& n : names) unlinkat(dir, n.c_str(), 0);
  }
};

/// A private folder of our own under the temporary directory, removed with its content on
/// destruction (mkdtemp: a new name, mode 0700; nothing in it can come from anyone else).
struct PrivateTempFolder {
  fs::path path;
  ~PrivateTempFolder() {
    std::error_code ec;
    if (!path.empty()) fs::remove_all(path, ec);
  }
};

/// The compiler: $MULTIBOND_CXX, else c++; with its resolved path, size and time for the key (an
/// upgrade of the compiler builds again).
struct Compiler {
  std::string command, identity;
};

Compiler FindCompiler() {
  Compiler c;
  const char* env_cxx = std::getenv("MULTIBOND_CXX");
  c.command = env_cxx && *env_cxx ? env_cxx : "c++";
  fs::path found = c.command;
  if (c.command.find('/') == std::string::npos) {
    found.clear();
    const char* path = std::getenv("PATH");
    std::string dirs = path ? path : "/usr/bin:/bin";
    for (size_t pos = 0; pos <= dirs.size();) {
      const size_t end = std::min(dirs.find(':', pos), dirs.size());
      const fs::path candidate = fs::path(dirs.substr(pos, end - pos)) / c.command;
      if (access(candidate.c_str(), X_OK) == 0) {
        found = candidate;
        break;
      }
      pos = end + 1;
    }
  }
  std::error_code ec;
  const fs::path real = found.empty() ? found : fs::canonical(found, ec);
  struct stat st {};
  c.identity = c.command;
  if (!real.empty() && stat(real.c_str(), &st) == 0)
    c.identity += fmt::format(" = {} ({} bytes, modified {}.{:09})", real.string(), st.st_size, st.st_mtim.tv_sec, st.st_mtim.tv_nsec);
  return c;
}

std::string UniqueTag() {
  std::random_device rd;
  return fmt::format("{}.{:08x}{:08x}", getpid(), rd(), rd());
}

std::string Trim(std::string s) {
  while (!s.empty() && (s.back() == '\n' || s.back() == ' ')) s.pop_back();
  return s;
}

/// The library `stem`.so of the folder `dir`, opened when it is ours, regular, writable by no one
/// else and of the SHA-256 its sidecar `stem`.so.sha256 records; else why not (`missing` when
/// there is none). `out` is a sealed in-memory copy of the bytes hashed (memfd; the file itself
/// where there is none): what is loaded is what was checked, and stays so whatever later
/// happens to the file. `file` receives the file's status (its identity for the process cache).
std::string OpenVerified(int dir, const std::string& stem, Fd& out, bool* missing, struct stat* file) {
  const std::string so = stem + ".so", sum = so + ".sha256";
  Fd fd(openat(dir, so.c_str(), O_RDONLY | O_NOFOLLOW | O_CLOEXEC));
  if (fd.get() < 0) {
    *missing = errno == ENOENT;
    return fmt::format("cannot open {}: {}", so, Errno());
  }
  if (std::string why = Untrusted(fd.get(), S_IFREG, so); !why.empty()) return why;
  Fd sfd(openat(dir, sum.c_str(), O_RDONLY | O_NOFOLLOW | O_CLOEXEC));
  if (sfd.get() < 0) return fmt::format("cannot open {}: {}", sum, Errno());
  if (std::string why = Untrusted(sfd.get(), S_IFREG, sum); !why.empty()) return why;
  char buf[130] = {};
  const ssize_t n = pread(sfd.get(), buf, sizeof buf - 1, 0);
  const std::string recorded = Trim(n > 0 ? std::string(buf, static_cast<size_t>(n)) : std::string());
  if (fstat(fd.get(), file) != 0) return fmt::format("cannot examine {}: {}", so, Errno());
  Fd copy(memfd_create(stem.c_str(), MFD_CLOEXEC | MFD_ALLOW_SEALING));
  const std::string actual = Sha256(fd.get(), copy.get());
  if (recorded.size() != 64 || actual != recorded) return fmt::format("{} does not match the SHA-256 recorded in {}", so, sum);
  if (copy.get() >= 0 && fcntl(copy.get(), F_ADD_SEALS, F_SEAL_SHRINK | F_SEAL_GROW | F_SEAL_WRITE | F_SEAL_SEAL) == 0)
    out = std::move(copy);
  else
    out = std::move(fd);
  return "";
}

using Clock = std::chrono::steady_clock;

/// What ends a batch's compilers early: its budget's deadline and its cancellation.
struct Limits {
  Clock::time_point deadline = Clock::time_point::max();
  const std::atomic<bool>* cancel = nullptr;
  std::atomic<bool>* abandon = nullptr;  ///< set by a thread that was interrupted: the others stop too
  double budget_seconds = 0;
  int nice = 0;  ///< the compilers' niceness (JitControl::nice)
  /// Why the batch stops now ("" when it goes on).
  std::string Stop() const {
    if ((cancel && cancel->load()) || (abandon && abandon->load())) return "cancelled";
    if (Clock::now() >= deadline) return fmt::format("the compile time budget ({} s) is spent", budget_seconds);
    return "";
  }
};

/// The compiler run as RunProcess runs a program, but also ended when `limits` say so (the
/// message says why). Throws Interrupted when a stop is asked for.
std::string RunCompiler(const std::vector<std::string>& argv, const std::string& log, const Limits& limits) {
  if (std::string why = limits.Stop(); !why.empty()) return why;
  std::string error;
  const pid_t pid = StartProcess(argv, "", log, &error, /*merge_stdout=*/true);
  if (pid < 0) return error;
  // The child leads its process group: the driver and what it started so far are in it, what it
  // starts later inherits its niceness. Best effort: a compiler at full priority is only slower.
  if (limits.nice > 0) setpriority(PRIO_PGRP, static_cast<id_t>(pid), limits.nice);
  // Polled without reaping (WNOWAIT); WaitProcess then reaps it and says how it ended.
  for (int pause = 1;; pause = std::min(2 * pause, 20)) {
    siginfo_t info{};
    if (waitid(P_PID, static_cast<id_t>(pid), &info, WEXITED | WNOHANG | WNOWAIT) == 0 && info.si_pid == pid) break;
    if (std::string why = limits.Stop(); !why.empty()) {
      EndProcess(pid);
      return why;
    }
    if (StopRequested()) break;  // WaitProcess ends it and throws Interrupted
    std::this_thread::sleep_for(std::chrono::milliseconds(pause));
  }
  error = WaitProcess(pid, argv[0]);
  if (error.empty()) return error;
  std::ifstream in(log);
  std::stringstream ss;
  ss << in.rdbuf();
  std::string text = Trim(ss.str());
  if (text.size() > 400) text = text.substr(0, 400) + "...";
  return text.empty() ? error : error + ": " + text;
}

/// Compiles `source` into `stem`.so of the folder `dir` (descriptor `dfd`), published by rename
/// with its sidecar; returns why not ("" when it is there). Throws Interrupted.
std::string Build(const fs::path& dir, int dfd, const std::string& stem, const std::string& source, const Compiler& cxx,
                  const std::vector<std::string>& flags, const Limits& limits) {
  const std::string tag = UniqueTag();
  Temporaries temps{dfd, {}};
  // The source under a unique name first, then under its fixed one (the compiler records the
  // file name in the library: parallel runs that build the same model get the same bytes).
  const std::string cc_tmp = stem + "." + tag + ".cc", cc = stem + ".cc";
  temps.names.push_back(cc_tmp);
  if (std::string why = WriteNew(dfd, cc_tmp, source); !why.empty()) return why;
  if (renameat(dfd, cc_tmp.c_str(), dfd, cc.c_str()) != 0) return fmt::format("cannot store {}: {}", cc, Errno());
  const std::string so_tmp = stem + "." + tag + ".so.tmp", log = stem + "." + tag + ".log", sum_tmp = stem + "." + tag + ".sha256";
  temps.names.insert(temps.names.end(), {so_tmp, log, sum_tmp});
  std::vector<std::string> argv = {cxx.command};
  argv.insert(argv.end(), flags.begin(), flags.end());
  argv.insert(argv.end(), {(dir / cc).string(), "-o", (dir / so_tmp).string()});
  std::string failure;
  try {
    failure = RunCompiler(argv, (dir / log).string(), limits);
  } catch (const Interrupted&) {
    throw Interrupted("compiling the generated code");  // the compiler is gone; `temps` removes its files
  }
  if (!failure.empty()) return "compiling the generated code: " + failure;
  Fd fd(openat(dfd, so_tmp.c_str(), O_RDONLY | O_NOFOLLOW | O_CLOEXEC));
  if (fd.get() < 0) return fmt::format("the compiler left no {}: {}", so_tmp, Errno());
  if (fchmod(fd.get(), 0600) != 0) return fmt::format("cannot set the mode of {}: {}", so_tmp, Errno());
  if (std::string why = Untrusted(fd.get(), S_IFREG, so_tmp); !why.empty()) return why;
  if (std::string why = WriteNew(dfd, sum_tmp, Sha256(fd.get()) + "\n"); !why.empty()) return why;
  // The sidecar first: whoever finds the library finds its hash.
  const std::string so = stem + ".so";
  if (renameat(dfd, sum_tmp.c_str(), dfd, (so + ".sha256").c_str()) != 0 || renameat(dfd, so_tmp.c_str(), dfd, so.c_str()) != 0)
    return fmt::format("cannot store {}: {}", (dir / so).string(), Errno());
  return "";
}

/// dlopen of the file open as `fd`: the file checked is the file loaded. The descriptor must stay
/// open while the library is loaded: dlopen takes a name it already loaded for the same library,
/// and /proc/self/fd/N names another file once N is closed and reused.
void* LoadFd(int fd, const fs::path& path) {
  const std::string proc = fmt::format("/proc/self/fd/{}", fd);
  if (access("/proc/self/fd", X_OK) == 0) return dlopen(proc.c_str(), RTLD_NOW | RTLD_LOCAL);
  return dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);  // no /proc: the path in our private folder
}

/// Builds (if needed), checks and loads `stem`.so in the private folder `dir`; fills `r`.
/// `built` is set when a compiler ran; `file`: the status of the library's file when checked.
void BuildAndLoad(const fs::path& dir, int dfd, const std::string& stem, const std::string& source, const Compiler& cxx,
                  const std::vector<std::string>& flags, const std::string& symbol, JitResult& r, const Limits& limits,
                  bool* built, struct stat* file) {
  std::string notes;
  const fs::path so = dir / (stem + ".so");
  Fd fd;
  bool missing = false;
  if (std::string why = OpenVerified(dfd, stem, fd, &missing, file); !why.empty()) {
    if (!missing) {
      // Cut short, overwritten or not ours: never loaded; built again.
      notes += fmt::format("; the cached library was not loaded ({}): built again", why);
      unlinkat(dfd, (stem + ".so").c_str(), 0);
      unlinkat(dfd, (stem + ".so.sha256").c_str(), 0);
    }
    if (built) *built = true;
    if (std::string failure = Build(dir, dfd, stem, source, cxx, flags, limits); !failure.empty()) {
      r.description = failure + notes;
      return;
    }
    missing = false;
    if (std::string again = OpenVerified(dfd, stem, fd, &missing, file); !again.empty()) {
      r.description = "the library just built cannot be loaded: " + again + notes;
      return;
    }
  }
  void* handle = LoadFd(fd.get(), so);
  if (!handle) {
    r.description = fmt::format("cannot load {}: {}", so.string(), dlerror()) + notes;
    return;
  }
  const int kept = fd.release();
  r.library = std::shared_ptr<void>(handle, [kept](void* h) {
    dlclose(h);
    close(kept);
  });
  r.symbol = dlsym(handle, symbol.c_str());
  if (!r.symbol) {
    r.description = fmt::format("{} has no symbol {}", so.string(), symbol) + notes;
    r.library.reset();
    return;
  }
  r.description = so.string() + notes;
}

}  // namespace

namespace {

fs::path JitCacheFolder() {
  if (const char* c = std::getenv("MULTIBOND_CACHE"); c && *c) return c;
  if (const char* x = std::getenv("XDG_CACHE_HOME"); x && *x) return fs::path(x) / "multibond";
  if (const char* h = std::getenv("HOME"); h && *h) return fs::path(h) / ".cache" / "multibond";
  return {};
}

std::vector<std::string> JitFlags(bool light) {
  // -march=native: the object is built per machine (the key includes the flags).
  // -ffp-contract=off: no fused multiply-add where the source has a product and a sum, as in the
  // library (src/CMakeLists.txt): generated code and interpreter give the same bits. The sums'
  // fused multiply-adds are written out (__builtin_fma, exact_sum.h); -march=native makes each one
  // instruction where the CPU has FMA.
  // -fno-tree-slp-vectorize: GCC's straight-line vectoriser packs the scalar results of the
  // generated code into vectors with more shuffles than it saves; without it the differential's
  // right-hand side takes 151 ns instead of 174 (GCC 12; clang accepts the flag too).
  // -O1 (light): what the units of a large model take, half the compile time of -O2 for the same
  // bits (neither reorders floating-point operations; docs/design.md, "Generated code at scale").
  return {"-std=c++20", light ? "-O1" : "-O2", "-march=native", "-ffp-contract=off", "-fno-tree-slp-vectorize",
          "-fPIC",      "-shared",               "-fno-math-errno"};
}

/// A unit's name in the cache: the hash of the compiler, the flags and the text.
std::string Stem(const Compiler& cxx, const std::vector<std::string>& flags, const std::string& source) {
  std::string key = cxx.identity;
  for (const auto& f : flags) key += " " + f;
  return "rhs-" + Sha256(key + "\n" + source);
}

bool IsStem(const std::string& s) {
  return s.size() == 68 && s.rfind("rhs-", 0) == 0 &&
         std::all_of(s.begin() + 4, s.end(), [](char c) { return (c >= '0' && c <= '9') || (c >= 'a' && c <= 'f'); });
}

/// The largest unit source `jit-finish` reads back (a unit is a few megabytes at most).
constexpr off_t kMaxUnitBytes = off_t{256} << 20;

/// Reads `name` of the folder `dir`: a regular file of ours that nobody else can write, at most
/// kMaxUnitBytes; "" and `text` filled, else why not.
std::string ReadPrivate(int dir, const std::string& name, std::string& text) {
  Fd fd(openat(dir, name.c_str(), O_RDONLY | O_NOFOLLOW | O_CLOEXEC));
  if (fd.get() < 0) return fmt::format("cannot open {}: {}", name, Errno());
  if (std::string why = Untrusted(fd.get(), S_IFREG, name); !why.empty()) return why;
  struct stat st {};
  if (fstat(fd.get(), &st) != 0) return fmt::format("cannot examine {}: {}", name, Errno());
  if (st.st_size > kMaxUnitBytes) return fmt::format("{} is larger than {} bytes", name, kMaxUnitBytes);
  text.assign(static_cast<size_t>(st.st_size), '\0');
  for (size_t done = 0; done < text.size();) {
    const ssize_t n = pread(fd.get(), text.data() + done, text.size() - done, static_cast<off_t>(done));
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return fmt::format("cannot read {}: {}", name, n < 0 ? Errno() : "it became shorter");
    done += static_cast<size_t>(n);
  }
  return "";
}

}  // namespace

namespace {

/// The libraries this process loaded from the cache folder, by name: reused while the file in
/// the folder is still the one checked (same inode, size, mode, owner, modification and change
/// times: a chmod or a write changes the last), without hashing it again. Never unloaded (a process loads few models).
struct LoadedLibrary {
  std::shared_ptr<void> library;
  struct stat file;  ///< its file in the cache folder when it was checked
};

std::mutex& LoadedMutex() {
  static std::mutex* m = new std::mutex;
  return *m;
}

std::unordered_map<std::string, LoadedLibrary>& Loaded() {
  static auto* loaded = new std::unordered_map<std::string, LoadedLibrary>;  // never destroyed: in use until exit
  return *loaded;
}

bool SameFile(int dfd, const std::string& name, const struct stat& b) {
  struct stat a {};
  return fstatat(dfd, name.c_str(), &a, AT_SYMLINK_NOFOLLOW) == 0 && a.st_dev == b.st_dev &&
         a.st_ino == b.st_ino && a.st_size == b.st_size && a.st_mtim.tv_sec == b.st_mtim.tv_sec &&
         a.st_mtim.tv_nsec == b.st_mtim.tv_nsec && a.st_ctim.tv_sec == b.st_ctim.tv_sec && a.st_ctim.tv_nsec == b.st_ctim.tv_nsec &&
         a.st_mode == b.st_mode && a.st_uid == b.st_uid;
}

/// The library `stem`.so already loaded by this process, when the folder still holds that file.
std::shared_ptr<void> FindLoaded(int dfd, const std::string& stem) {
  std::lock_guard<std::mutex> lock(LoadedMutex());
  auto it = Loaded().find(stem);
  if (it == Loaded().end()) return nullptr;
  if (!SameFile(dfd, stem + ".so", it->second.file)) {
    Loaded().erase(it);  // replaced or damaged since: the disk cache's checks decide again
    return nullptr;
  }
  return it->second.library;
}

void RememberLoaded(const std::string& stem, const std::shared_ptr<void>& library, const struct stat& file) {
  std::lock_guard<std::mutex> lock(LoadedMutex());
  Loaded()[stem] = LoadedLibrary{library, file};
}

}  // namespace

JitResult CompileAndLoad(const std::string& source, const std::string& symbol) {
  JitBatch b = CompileAndLoadUnits({source}, symbol);
  JitResult r;
  r.description = b.description;
  r.warning = b.warning;
  if (b.ok()) {
    r.library = b.libraries.front();
    r.symbol = b.symbols.front();
  }
  return r;
}

JitBatch CompileAndLoadUnits(const std::vector<std::string>& sources, const std::string& symbol, const JitControl& control) {
  JitBatch batch;
  const auto start = Clock::now();
  const size_t n = sources.size();
  const Compiler cxx = FindCompiler();
  const std::vector<std::string> flags = JitFlags(control.light);
  std::vector<std::string> stems(n);
  for (size_t i = 0; i < n; ++i) stems[i] = Stem(cxx, flags, sources[i]);

  const fs::path cache = JitCacheFolder();
  Fd dfd;
  const std::string refused = cache.empty() ? "no cache folder ($MULTIBOND_CACHE, $XDG_CACHE_HOME and $HOME are not set)"
                                            : OpenPrivateFolder(cache, dfd);
  // No shared fallback: a folder of our own that nobody else can have prepared, gone after loading.
  PrivateTempFolder tmp;
  fs::path dir = cache;
  if (!refused.empty()) {
    batch.warning = fmt::format("the JIT cache is not used: {}; the generated code is compiled in a private temporary folder "
                                "(set MULTIBOND_CACHE to a folder of yours that only you can write)",
                                refused);
    std::string templ = (fs::temp_directory_path() / "multibond-jit-XXXXXX").string();
    if (!mkdtemp(templ.data())) {
      batch.description = fmt::format("{}; cannot create a private temporary folder: {}", refused, Errno());
      return batch;
    }
    tmp.path = dir = templ;
    if (std::string why = OpenPrivateFolder(tmp.path, dfd); !why.empty()) {
      batch.description = refused + "; " + why;
      return batch;
    }
  }

  std::vector<JitResult> results(n);
  std::vector<size_t> todo;
  for (size_t i = 0; i < n; ++i) {
    std::shared_ptr<void> lib = refused.empty() ? FindLoaded(dfd.get(), stems[i]) : nullptr;
    if (lib) {
      results[i].library = lib;
      results[i].symbol = dlsym(lib.get(), symbol.c_str());
      results[i].description = (dir / (stems[i] + ".so")).string();
      ++batch.reused;
    } else {
      todo.push_back(i);
    }
  }

  std::atomic<bool> abandon{false};
  Limits limits;
  limits.cancel = control.cancel;
  limits.abandon = &abandon;
  limits.budget_seconds = control.budget_seconds;
  limits.nice = control.nice;
  if (control.budget_seconds > 0)
    limits.deadline = start + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(control.budget_seconds));
  std::atomic<size_t> next{0};
  std::atomic<int> compiled{0};
  std::mutex progress_mutex;
  int done = 0;
  std::exception_ptr interrupted;
  auto work = [&] {
    for (size_t k; (k = next++) < todo.size();) {
      const size_t i = todo[k];
      bool built = false;
      struct stat file {};
      try {
        BuildAndLoad(dir, dfd.get(), stems[i], sources[i], cxx, flags, symbol, results[i], limits, &built, &file);
      } catch (const Interrupted&) {
        std::lock_guard<std::mutex> lock(progress_mutex);
        if (!interrupted) interrupted = std::current_exception();
        abandon = true;
        return;
      }
      if (built) ++compiled;
      if (results[i].symbol && refused.empty()) RememberLoaded(stems[i], results[i].library, file);
      std::lock_guard<std::mutex> lock(progress_mutex);
      ++done;
      if (control.progress) control.progress(done, static_cast<int>(todo.size()), std::chrono::duration<double>(Clock::now() - start).count());
    }
  };
  const size_t threads = std::min<size_t>(todo.size(), std::max(1u, std::thread::hardware_concurrency()));
  if (threads <= 1) {
    work();
  } else {
    std::vector<std::thread> pool;
    for (size_t k = 0; k < threads; ++k) pool.emplace_back(work);
    for (std::thread& t : pool) t.join();
  }
  if (interrupted) std::rethrow_exception(interrupted);

  batch.compiled = compiled;
  batch.from_disk = static_cast<int>(todo.size()) - batch.compiled;
  for (size_t i = 0; i < n; ++i) {
    if (results[i].symbol) continue;
    batch.description = n == 1 ? results[i].description : fmt::format("unit {} of {}: {}", i + 1, n, results[i].description);
    if (!refused.empty()) batch.description = refused + "; " + batch.description;
    return batch;
  }
  for (JitResult& r : results) {
    batch.symbols.push_back(r.symbol);
    batch.libraries.push_back(std::move(r.library));
  }
  if (!refused.empty()) batch.description = "compiled in a private temporary folder, not cached: " + refused;
  else if (n == 1) batch.description = results.front().description + (batch.reused ? " (already loaded by this process)" : "");
  else
    batch.description = fmt::format("{} units in {}: {} compiled, {} from the cache, {} already loaded by this process", n,
                                    dir.string(), batch.compiled, batch.from_disk, batch.reused);
  return batch;
}

std::string HandOverUnits(const std::vector<std::string>& sources, bool light, const std::string& program) {
  const fs::path cache = JitCacheFolder();
  if (cache.empty()) return "not kept: no cache folder ($MULTIBOND_CACHE, $XDG_CACHE_HOME and $HOME are not set)";
  Fd dfd;
  if (std::string why = OpenPrivateFolder(cache, dfd); !why.empty()) return "not kept: " + why;
  const Compiler cxx = FindCompiler();
  const std::vector<std::string> flags = JitFlags(light);
  std::vector<std::string> argv = {program, "jit-finish"};
  if (light) argv.emplace_back("--light");
  const size_t first = argv.size();
  for (const std::string& source : sources) {
    const std::string stem = Stem(cxx, flags, source);
    Fd fd;
    bool missing = false;
    struct stat file {};
    if (OpenVerified(dfd.get(), stem, fd, &missing, &file).empty()) continue;  // already built
    // The text under its fixed name, as Build stores it (published by rename).
    const std::string tmp = stem + "." + UniqueTag() + ".cc";
    if (std::string why = WriteNew(dfd.get(), tmp, source); !why.empty()) return "not kept: " + why;
    if (renameat(dfd.get(), tmp.c_str(), dfd.get(), (stem + ".cc").c_str()) != 0) {
      unlinkat(dfd.get(), tmp.c_str(), 0);
      return fmt::format("not kept: cannot store {}.cc: {}", stem, Errno());
    }
    argv.push_back(stem);
  }
  if (argv.size() == first) return "";
  std::string error;
  const pid_t pid = StartProcess(argv, "", "/dev/null", &error);
  if (pid < 0) return "not kept: " + error;
  // Never waited for: it outlives this process (its own process group, so a Ctrl-C at the
  // terminal does not reach it), and takes what CPU the machine leaves.
  setpriority(PRIO_PGRP, static_cast<id_t>(pid), 10);
  return fmt::format("{} unit{} compiling on for the next run in process {} ({})", argv.size() - first,
                     argv.size() - first == 1 ? "" : "s", pid, cache.string());
}

int FinishUnits(const std::vector<std::string>& stems, bool light, std::string* log) {
  const auto say = [log](const std::string& line) {
    if (log) *log += line + "\n";
  };
  const fs::path cache = JitCacheFolder();
  Fd dfd;
  if (cache.empty()) {
    say("no cache folder");
    return 0;
  }
  if (std::string why = OpenPrivateFolder(cache, dfd); !why.empty()) {
    say(why);
    return 0;
  }
  // One finisher at a time per cache folder, the others waiting their turn: a loop of short runs
  // queues its compiles instead of starting them all at once.
  Fd lock(openat(dfd.get(), "jit-finish.lock", O_RDWR | O_CREAT | O_NOFOLLOW | O_CLOEXEC, 0600));
  if (lock.get() < 0 || !Untrusted(lock.get(), S_IFREG, "jit-finish.lock").empty() || flock(lock.get(), LOCK_EX) != 0) {
    say("cannot lock jit-finish.lock of the cache folder");
    return 0;
  }
  const Compiler cxx = FindCompiler();
  const std::vector<std::string> flags = JitFlags(light);
  Limits limits;
  limits.nice = 10;
  int built = 0;
  for (const std::string& stem : stems) {
    if (!IsStem(stem)) {
      say(fmt::format("{}: not the name of a unit (rhs- and 64 hexadecimal digits)", stem));
      continue;
    }
    Fd fd;
    bool missing = false;
    struct stat file {};
    if (OpenVerified(dfd.get(), stem, fd, &missing, &file).empty()) {
      say(stem + ": already built");
      continue;
    }
    std::string source;
    if (std::string why = ReadPrivate(dfd.get(), stem + ".cc", source); !why.empty()) {
      say(stem + ": " + why);
      continue;
    }
    // Only a text whose hash is its name is compiled: what the run asked for, nothing else.
    if (Stem(cxx, flags, source) != stem) {
      say(stem + ": the text does not have this name's hash (for this compiler and these flags)");
      continue;
    }
    if (std::string why = Build(cache, dfd.get(), stem, source, cxx, flags, limits); !why.empty()) {
      say(stem + ": " + why);
      continue;
    }
    ++built;
    say(stem + ": built");
  }
  return built;
}

}  // namespace multibond
