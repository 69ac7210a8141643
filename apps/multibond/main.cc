// multibond: the command-line front end. Each command lives in its own file (check.cc,
// equations.cc, graph.cc, run.cc, compare.cc, plot.cc) and registers itself here; this file maps
// the library's error channels to the exit codes of the README: 0 ok, 1 model error, 2 solver
// error, 64 usage, 74 a file cannot be read or written, 128 + the signal when interrupted.

#include <filesystem>
#include <iostream>
#include <vector>

#include <CLI/CLI.hpp>

#include "cli.h"
#include "multibond/core/interrupt.h"
#include "multibond/version.h"

namespace mb = multibond;
using namespace multibond::cli;

int main(int argc, char** argv) {
  // One way to stop in every phase: loading, compiling (the compiler is ended), integrating (the
  // rows so far are kept), writing (temporaries removed); exit 128 + the signal.
  mb::InstallStopHandlers();
  CLI::App app{"multibond: model and simulate mechanisms as multibond graphs", "multibond"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "multibond " + std::string(mb::kVersion));  // as `multibond version` prints it
  const std::vector<Command> commands = {AddCheckCommand(app), AddEquationsCommand(app), AddGraphCommand(app),
                                         AddRunCommand(app),   AddCompareCommand(app),   AddPlotCommand(app),
                                         AddLinearizeCommand(app), AddModesCommand(app), AddBodeCommand(app),
                                         AddSweepCommand(app),     AddViewCommand(app),    AddJitFinishCommand(app)};
  app.add_subcommand("version", "Print the version");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);
    return code == 0 ? kExitOk : kExitUsage;
  }
  if (app.got_subcommand("version")) {
    std::cout << "multibond " << mb::kVersion << '\n';
    return kExitOk;
  }
  const std::vector<std::string> args(argv, argv + argc);
  for (const Command& c : commands) {
    if (!*c.app) continue;
    try {
      return c.run(args);
    } catch (const CliExit& e) {
      std::cerr << "error: " << e.message << '\n';
      return e.code;
    } catch (const mb::Interrupted& e) {
      std::cerr << "error: " << e.what() << "; nothing was written\n";
      return e.ExitCode();
    } catch (const mb::ModelError& e) {
      return ModelFailure(e, c.writes());
    } catch (const mb::SolverError& e) {
      std::cerr << "error: solver failure " << e.what() << '\n';
      return kExitSolver;
    } catch (const std::exception& e) {  // files that cannot be read or written (filesystem_error, runtime_error)
      std::cerr << "error: " << e.what() << '\n';
      return kExitIo;
    }
  }
  return kExitUsage;
}
