// multibond jit-finish [--light] STEM...: not for users (hidden). A run under --jit auto that ends
// before its background compile hands the units over to this command (compile/jit.h,
// HandOverUnits), which builds them into the JIT cache for the model's next run (FinishUnits).

#include <sys/stat.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include "cli.h"
#include "multibond/compile/jit.h"

namespace multibond::cli {

namespace fs = std::filesystem;

std::string JitFinisher() {
  if (const char* keep = std::getenv("MULTIBOND_JIT_KEEP"); keep && std::string(keep) == "0") return "";
  std::error_code ec;
  const fs::path self = fs::read_symlink("/proc/self/exe", ec);
  if (ec || self.empty()) return "";
  // Run again only when nobody but its owner (this user or root) can have changed it.
  struct stat st {};
  if (stat(self.c_str(), &st) != 0 || !S_ISREG(st.st_mode) || (st.st_uid != geteuid() && st.st_uid != 0) ||
      (st.st_mode & (S_IWGRP | S_IWOTH)))
    return "";
  return self.string();
}

Command AddJitFinishCommand(CLI::App& app) {
  struct Args {
    bool light = false;
    std::vector<std::string> stems;
  };
  auto a = std::make_shared<Args>();
  CLI::App* sub = app.add_subcommand("jit-finish", "Build handed-over units of generated code into the JIT cache (internal)");
  sub->group("");  // hidden from --help
  sub->add_flag("--light", a->light, "the units of a split right-hand side (-O1)");
  sub->add_option("stems", a->stems, "units of the cache folder")->required();
  return {sub, [a](const std::vector<std::string>&) {
            FinishUnits(a->stems, a->light);
            return kExitOk;
          }};
}

}  // namespace multibond::cli
