#include "multibond/compile/jit.h"

#include "multibond/core/interrupt.h"
#include "multibond/core/process.h"

#include <dlfcn.h>
#include <fcntl.h>
#include <openssl/evp.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <random>
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

/// SHA-256 of what `fd` holds from its start ("" when it cannot be read).
std::string Sha256(int fd) {
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
/// there is none).
std::string OpenVerified(int dir, const std::string& stem, Fd& out, bool* missing) {
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
  const std::string actual = Sha256(fd.get());
  if (recorded.size() != 64 || actual != recorded) return fmt::format("{} does not match the SHA-256 recorded in {}", so, sum);
  out = std::move(fd);
  return "";
}

/// Compiles `source` into `stem`.so of the folder `dir` (descriptor `dfd`), published by rename
/// with its sidecar; returns why not ("" when it is there). Throws Interrupted.
std::string Build(const fs::path& dir, int dfd, const std::string& stem, const std::string& source, const Compiler& cxx,
                  const std::vector<std::string>& flags) {
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
    failure = RunProcess(argv, "", (dir / log).string(), /*merge_stdout=*/true, 400);
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
void BuildAndLoad(const fs::path& dir, int dfd, const std::string& stem, const std::string& source, const Compiler& cxx,
                  const std::vector<std::string>& flags, const std::string& symbol, JitResult& r) {
  std::string notes;
  const fs::path so = dir / (stem + ".so");
  Fd fd;
  bool missing = false;
  if (std::string why = OpenVerified(dfd, stem, fd, &missing); !why.empty()) {
    if (!missing) {
      // Cut short, overwritten or not ours: never loaded; built again.
      notes += fmt::format("; the cached library was not loaded ({}): built again", why);
      unlinkat(dfd, (stem + ".so").c_str(), 0);
      unlinkat(dfd, (stem + ".so.sha256").c_str(), 0);
    }
    if (std::string failure = Build(dir, dfd, stem, source, cxx, flags); !failure.empty()) {
      r.description = failure + notes;
      return;
    }
    missing = false;
    if (std::string again = OpenVerified(dfd, stem, fd, &missing); !again.empty()) {
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

const std::vector<std::string>& JitFlags() {
  // -march=native: the object is built per machine (the key includes the flags).
  // -ffp-contract=off: no fused multiply-add where the source has a product and a sum, as in the
  // library (src/CMakeLists.txt): generated code and interpreter give the same bits. The sums'
  // fused multiply-adds are written out (__builtin_fma, exact_sum.h); -march=native makes each one
  // instruction where the CPU has FMA.
  // -fno-tree-slp-vectorize: GCC's straight-line vectoriser packs the scalar results of the
  // generated code into vectors with more shuffles than it saves; without it the differential's
  // right-hand side takes 151 ns instead of 174 (GCC 12; clang accepts the flag too).
  static const std::vector<std::string> flags = {"-std=c++20",  "-O2",   "-march=native", "-ffp-contract=off", "-fno-tree-slp-vectorize",
                                                 "-fPIC",       "-shared", "-fno-math-errno"};
  return flags;
}

}  // namespace

JitResult CompileAndLoad(const std::string& source, const std::string& symbol) {
  JitResult r;
  const Compiler cxx = FindCompiler();
  const std::vector<std::string>& flags = JitFlags();
  std::string key_text = cxx.identity;
  for (const auto& f : flags) key_text += " " + f;
  key_text += "\n" + source;
  const std::string stem = "rhs-" + Sha256(key_text);
  const fs::path cache = JitCacheFolder();
  Fd dfd;
  std::string refused = cache.empty() ? "no cache folder ($MULTIBOND_CACHE, $XDG_CACHE_HOME and $HOME are not set)"
                                      : OpenPrivateFolder(cache, dfd);
  if (refused.empty()) {
    BuildAndLoad(cache, dfd.get(), stem, source, cxx, flags, symbol, r);
    return r;
  }
  // No shared fallback: a folder of our own that nobody else can have prepared, gone after loading.
  r.warning = fmt::format("the JIT cache is not used: {}; the generated code is compiled in a private temporary folder "
                          "(set MULTIBOND_CACHE to a folder of yours that only you can write)",
                          refused);
  PrivateTempFolder tmp;
  std::string templ = (fs::temp_directory_path() / "multibond-jit-XXXXXX").string();
  if (!mkdtemp(templ.data())) {
    r.description = fmt::format("{}; cannot create a private temporary folder: {}", refused, Errno());
    return r;
  }
  tmp.path = templ;
  Fd tfd;
  if (std::string why = OpenPrivateFolder(tmp.path, tfd); !why.empty()) {
    r.description = refused + "; " + why;
    return r;
  }
  BuildAndLoad(tmp.path, tfd.get(), stem, source, cxx, flags, symbol, r);
  if (r.symbol) r.description = "compiled in a private temporary folder, not cached: " + refused;
  else r.description = refused + "; " + r.description;
  return r;
}

}  // namespace multibond
