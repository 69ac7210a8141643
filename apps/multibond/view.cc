// multibond view DIR: the results page of a folder (written when needed), opened in a browser.

#include <fcntl.h>
#include <sys/stat.h>

#include <filesystem>
#include <iostream>
#include <memory>

#include <fmt/format.h>

#include "cli.h"
#include "multibond/core/process.h"
#include "multibond/io/output_folder.h"
#include "multibond/io/plot_web.h"
#include "multibond/io/plots.h"
#include "multibond/io/results_folder.h"

namespace multibond::cli {

namespace {

struct ViewArgs {
  std::string dir, model;
  std::vector<std::string> limits;
  bool no_open = false;
};

/// True when the page must be (re)written: no index.html or no script next to it, a model
/// given (the graph and the 3D view come from it), or results.csv newer than the page.
bool NeedsPage(const ViewArgs& a) {
  const ResultsFolder folder(a.dir);
  struct stat page {}, csv {}, script {};
  if (fstatat(folder.fd(), "index.html", &page, AT_SYMLINK_NOFOLLOW) != 0 || !S_ISREG(page.st_mode)) return true;
  if (fstatat(folder.fd(), kPageScript, &script, AT_SYMLINK_NOFOLLOW) != 0 || !S_ISREG(script.st_mode)) return true;
  if (!a.model.empty()) return true;
  if (fstatat(folder.fd(), "results.csv", &csv, AT_SYMLINK_NOFOLLOW) == 0 &&
      (csv.st_mtim.tv_sec > page.st_mtim.tv_sec || (csv.st_mtim.tv_sec == page.st_mtim.tv_sec && csv.st_mtim.tv_nsec > page.st_mtim.tv_nsec)))
    return true;
  return false;
}

/// Runs `xdg-open PATH` through core/process (an argument vector, no shell, its own process
/// group, output discarded); false when it cannot be run or fails.
bool OpenInBrowser(const std::string& path) { return RunProcess({"xdg-open", path}, "", "/dev/null").empty(); }

int View(const ViewArgs& a, const std::vector<std::string>& argv) {
  const std::string page = std::filesystem::absolute(std::filesystem::path(a.dir) / "index.html").lexically_normal().string();
  if (NeedsPage(a)) {
    const OutputFolder folder(a.dir, CommandLine(argv), /*create=*/false);  // one command at a time
    ReportRemovedTemporaries(folder);
    // The page of the figures already drawn (multibond plot draws them); the interactive part from
    // every column.
    WriteResultsPage(a.dir, PlotReport{}, ParseLimits(a.limits), a.model);
    std::cout << fmt::format("wrote {}\n", page);
  }
  if (a.no_open || !OpenInBrowser(page)) std::cout << fmt::format("open file://{} in a browser\n", page);
  return kExitOk;
}

}  // namespace

Command AddViewCommand(CLI::App& app) {
  auto a = std::make_shared<ViewArgs>();
  CLI::App* cmd = app.add_subcommand("view", "Open the results page of a folder in the browser (writing DIR/index.html when needed)");
  cmd->add_option("DIR", a->dir, "results folder of 'multibond run'")->required();
  cmd->add_option("--model", a->model,
                  "model file, for the bond graph and the 3D view of a mechanism; the model named in DIR/run.json is a record, "
                  "not followed (docs/security.md)");
  cmd->add_flag("--no-open", a->no_open, "write the page when needed and print its path, without starting a browser");
  cmd->add_option("--limit", a->limits, "NAME=VALUE: change a bound on the input, e.g. results-size=8G (repeatable; docs/security.md)")
      ->type_name("NAME=VALUE")
      ->expected(1)
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
  return {cmd, [a](const std::vector<std::string>& argv) { return View(*a, argv); }, [] { return true; }};
}

}  // namespace multibond::cli
