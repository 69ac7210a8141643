// multibond plot DIR: figures from a results folder, and a page that shows them.

#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstddef>
#include <cstring>
#include <iostream>
#include <memory>

#include <fmt/format.h>

#include "cli.h"
#include "multibond/io/output_folder.h"
#include "multibond/io/plots.h"

namespace multibond::cli {

namespace {

struct PlotArgs {
  std::string dir, model, figures;
  std::vector<std::string> limits;
  std::size_t max_figures = PlotOptions{}.max_figures;
};

int Plot(const PlotArgs& a, const std::vector<std::string>& argv) {
  // DIR is read first (its results), then written into (figures, the page): a folder that is not
  // there is said as a read.
  struct stat st {};
  if (stat(a.dir.c_str(), &st) != 0)
    throw CliExit{kExitIo, fmt::format("cannot read the results folder '{}': {}; nothing was written\n  hint: 'multibond run MODEL -o "
                                       "{}' writes one", a.dir, std::strerror(errno), a.dir)};
  if (!S_ISDIR(st.st_mode))
    throw CliExit{kExitIo, fmt::format("cannot read the results folder '{}': it is not a folder; nothing was written", a.dir)};
  const OutputFolder folder(a.dir, CommandLine(argv), /*create=*/false);  // one command at a time
  ReportRemovedTemporaries(folder);
  PlotOptions po;
  po.model_path = a.model;
  po.figures_path = a.figures;
  po.max_figures = a.max_figures;
  po.limits = ParseLimits(a.limits);
  const bool tty = ::isatty(STDERR_FILENO) != 0;
  if (tty) po.progress = [](std::size_t done, std::size_t total) { std::fprintf(stderr, "\r  figure %zu of %zu", done, total); };
  const PlotInputs inputs(a.dir, po);  // read once, for the figures and the page
  const PlotReport report = MakeFigures(inputs, po);
  if (tty) std::fprintf(stderr, "\r%*s\r", 40, "");  // the progress line goes
  for (const auto& w : report.warnings) std::cerr << "warning: " << w << '\n';
  if (report.files.empty()) {
    std::cerr << fmt::format("error: no figure drawn from '{}' (see the warnings above); nothing was written\n", a.dir);
    return kExitIo;
  }
  WriteResultsPage(inputs, report);
  std::cout << fmt::format("wrote {} figure files in {}/figures and {}/index.html\n", report.files.size(), a.dir, a.dir);
  return kExitOk;
}

}  // namespace

Command AddPlotCommand(CLI::App& app) {
  auto a = std::make_shared<PlotArgs>();
  CLI::App* cmd = app.add_subcommand("plot", "Draw every output of a results folder against time (or the figures of a figure list) and write DIR/index.html");
  cmd->add_option("DIR", a->dir, "results folder of 'multibond run'")->required();
  cmd->add_option("--figures", a->figures,
                  "figure list (YAML, docs/plots.md) to draw instead of the general figures, e.g. "
                  "examples/differential/figures.yaml for the paper's figures");
  cmd->add_option("--model", a->model,
                  "model file, for the bond graph (figure and interactive) and the 3D view of a mechanism; without them the bond graph and 3D view are left out: the model named in DIR/run.json "
                  "is a record, not followed (docs/security.md)");
  cmd->add_option("--max-figures", a->max_figures, "draw at most N figures (gnuplot runs); the rest are left out with a warning")
      ->type_name("N")
      ->check(CLI::Range(std::size_t{1}, std::size_t{100000}));
  cmd->add_option("--limit", a->limits, "NAME=VALUE: change a bound on the input, e.g. results-size=8G (repeatable; docs/security.md)")
      ->type_name("NAME=VALUE")
      ->expected(1)
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
  return {cmd, [a](const std::vector<std::string>& argv) { return Plot(*a, argv); }, [] { return true; }};
}

}  // namespace multibond::cli
