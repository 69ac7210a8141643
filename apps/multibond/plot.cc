// multibond plot DIR: figures from a results folder, and a page that shows them.

#include <iostream>
#include <memory>

#include <fmt/format.h>

#include "cli.h"
#include "multibond/io/output_folder.h"
#include "multibond/io/plots.h"

namespace multibond::cli {

namespace {

struct PlotArgs {
  std::string dir, model;
};

int Plot(const PlotArgs& a, const std::vector<std::string>& argv) {
  const OutputFolder folder(a.dir, CommandLine(argv), /*create=*/false);  // one command at a time
  ReportRemovedTemporaries(folder);
  PlotOptions po;
  po.model_path = a.model;
  const PlotReport report = MakePaperFigures(a.dir, po);
  for (const auto& w : report.warnings) std::cerr << "warning: " << w << '\n';
  if (report.files.empty()) {
    std::cerr << fmt::format("error: no figure drawn from '{}' (see the warnings above); nothing was written\n", a.dir);
    return kExitIo;
  }
  WriteResultsPage(a.dir, report);
  std::cout << fmt::format("wrote {} figure files in {}/figures and {}/index.html\n", report.files.size(), a.dir, a.dir);
  return kExitOk;
}

}  // namespace

Command AddPlotCommand(CLI::App& app) {
  auto a = std::make_shared<PlotArgs>();
  CLI::App* cmd = app.add_subcommand("plot", "Draw the paper's figures (Figs. 2-33) from a results folder and write DIR/index.html");
  cmd->add_option("DIR", a->dir, "results folder of 'multibond run'")->required();
  cmd->add_option("--model", a->model, "model file, for the bond graph (default: the one named in DIR/run.json)");
  return {cmd, [a](const std::vector<std::string>& argv) { return Plot(*a, argv); }, [] { return true; }};
}

}  // namespace multibond::cli
