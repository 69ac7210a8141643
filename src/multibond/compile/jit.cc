#include "multibond/compile/jit.h"

#include "multibond/core/process.h"

#include <dlfcn.h>
#include <unistd.h>

#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <vector>

#include <fmt/format.h>

namespace multibond {

namespace fs = std::filesystem;

namespace {

/// FNV-1a: a cache key, not a security measure (a collision only costs a wrong cache hit between
/// two different 64-bit-identical sources, and the file name also carries the source size).
std::uint64_t Fnv1a(const std::string& s) {
  std::uint64_t h = 1469598103934665603ULL;
  for (unsigned char c : s) {
    h ^= c;
    h *= 1099511628211ULL;
  }
  return h;
}

fs::path CacheDir() {
  if (const char* c = std::getenv("MULTIBOND_CACHE"); c && *c) return c;
  if (const char* x = std::getenv("XDG_CACHE_HOME"); x && *x) return fs::path(x) / "multibond";
  if (const char* h = std::getenv("HOME"); h && *h) return fs::path(h) / ".cache" / "multibond";
  return fs::temp_directory_path() / fmt::format("multibond-cache-{}", getuid());
}

/// An ELF file at least as long as its header: what a compiled library always is, and what a
/// file cut short or overwritten is not.
bool LooksLikeASharedObject(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  char head[64] = {};
  in.read(head, sizeof head);
  return in.gcount() == static_cast<std::streamsize>(sizeof head) && head[0] == 0x7f && head[1] == 'E' && head[2] == 'L' &&
         head[3] == 'F';
}

}  // namespace

JitResult CompileAndLoad(const std::string& source, const std::string& symbol) {
  JitResult r;
  const char* env_cxx = std::getenv("MULTIBOND_CXX");
  const std::string cxx = env_cxx && *env_cxx ? env_cxx : "c++";
  // -march=native: the object is cached per machine (the cache key includes the flags).
  // -fno-tree-slp-vectorize: GCC's straight-line vectoriser packs the scalar results of the
  // generated code into vectors with more shuffles than it saves; without it the differential's
  // right-hand side takes 151 ns instead of 174 (GCC 12; clang accepts the flag too).
  const std::vector<std::string> flags = {"-std=c++20", "-O2", "-march=native", "-fno-tree-slp-vectorize",
                                          "-fPIC", "-shared", "-fno-math-errno"};
  std::string key_text = cxx;
  for (const auto& f : flags) key_text += " " + f;
  key_text += "\n" + source;
  const std::string stem = fmt::format("rhs-{:016x}-{}", Fnv1a(key_text), source.size());
  std::error_code ec;
  const fs::path dir = CacheDir();
  fs::create_directories(dir, ec);
  if (ec) {
    r.description = fmt::format("cannot create the cache folder {}: {}", dir.string(), ec.message());
    return r;
  }
  const fs::path so = dir / (stem + ".so");
  // Compiles the source into `so`; returns why not ("" once it is there).
  auto build = [&]() -> std::string {
    // Unique temporary names: parallel runs of the same model may compile at the same time.
    const std::string tag = fmt::format("{}.{}", getpid(), reinterpret_cast<std::uintptr_t>(&r));
    const fs::path cc = dir / (stem + ".cc"), tmp = dir / (stem + "." + tag + ".so.tmp"), log = dir / (stem + "." + tag + ".log");
    {
      std::ofstream out(dir / (stem + "." + tag + ".cc"));
      out << source;
    }
    fs::rename(dir / (stem + "." + tag + ".cc"), cc, ec);
    std::vector<std::string> argv = {cxx};
    argv.insert(argv.end(), flags.begin(), flags.end());
    argv.insert(argv.end(), {cc.string(), "-o", tmp.string()});
    const std::string failure = RunProcess(argv, "", log.string(), /*merge_stdout=*/true, 400);
    if (!failure.empty()) {
      fs::remove(tmp, ec);
      fs::remove(log, ec);
      return "compiling the generated code: " + failure;
    }
    fs::remove(log, ec);
    fs::rename(tmp, so, ec);
    if (ec) return fmt::format("cannot store {}: {}", so.string(), ec.message());
    return "";
  };
  const bool cached = fs::exists(so);
  if (!cached) {
    if (std::string failure = build(); !failure.empty()) {
      r.description = std::move(failure);
      return r;
    }
  }
  void* handle = dlopen(so.c_str(), RTLD_NOW | RTLD_LOCAL);
  if (!handle && cached && !LooksLikeASharedObject(so)) {
    // A cached library cut short (a full disk, an interrupted copy) would otherwise send every
    // later run to the interpreter: it is built again, once. (One that is whole but does not
    // load, e.g. from a noexec folder, is left alone: building it again would not help.)
    const std::string problem = fmt::format("cannot load {}: {}", so.string(), dlerror());
    fs::remove(so, ec);
    if (std::string failure = build(); !failure.empty()) {
      r.description = problem + "; building it again: " + failure;
      return r;
    }
    handle = dlopen(so.c_str(), RTLD_NOW | RTLD_LOCAL);
  }
  if (!handle) {
    r.description = fmt::format("cannot load {}: {}", so.string(), dlerror());
    return r;
  }
  r.library = std::shared_ptr<void>(handle, [](void* h) { dlclose(h); });
  r.symbol = dlsym(handle, symbol.c_str());
  if (!r.symbol) {
    r.description = fmt::format("{} has no symbol {}", so.string(), symbol);
    r.library.reset();
    return r;
  }
  r.description = so.string();
  return r;
}

}  // namespace multibond
