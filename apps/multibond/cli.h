#pragma once
// What every command of the multibond CLI shares: exit codes, option validators, the options
// that load a model (--constraints, --algebraic-loops, --limit) and how a model is loaded, and
// the one way a command is registered. The CLI holds no physics: it parses, calls the library and
// maps its error channels to exit codes (README, "Exit codes").

#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "multibond/io/limits.h"
#include "multibond/io/model_loader.h"
#include "multibond/io/output_folder.h"

namespace multibond::cli {

inline constexpr int kExitOk = 0, kExitModel = 1, kExitSolver = 2, kExitUsage = 64, kExitIo = 74;

/// Leaves a command with an exit code and a message (printed as "error: <message>").
struct CliExit {
  int code;
  std::string message;
};

/// A number > 0 (or >= 0) that says what was expected and what was given.
CLI::Validator NumberAbove(double low, bool inclusive);
extern const CLI::Validator kPositive, kNonNegative;
/// An output path: "" names nothing (a usage error, 64, not a failed write, 74).
extern const CLI::Validator kPathName;

/// The options every command that reads a model file takes.
struct LoadArgs {
  std::optional<std::string> constraints;  ///< --constraints ideal|compliant over the file's
  std::optional<std::string> loops;        ///< --algebraic-loops solve|error over the file's
  std::vector<std::string> limits;         ///< --limit NAME=VALUE
  std::vector<std::string> sets;           ///< --set NAME=VALUE: the model's parameters
};
void AddLoadOptions(CLI::App* cmd, LoadArgs& a);
/// The limits given with --limit over the defaults; a bad one is a usage error.
InputLimits ParseLimits(const std::vector<std::string>& assignments);
/// The parameter values given with --set (`option` names the option in messages); a malformed
/// one is a usage error.
std::vector<ParameterOverride> ParseSets(const std::vector<std::string>& assignments, const char* option = "--set");
/// Loads a model with the command's options, printing its warnings. A --set that names no
/// parameter of the model, or whose value does not read, is a usage error (64). `extra_sets`
/// (compare's --set-a, --set-b) apply after the command's --set.
LoadedModel Load(const std::string& path, const LoadArgs& a, const std::vector<std::string>& extra_sets = {},
                 const char* extra_option = nullptr);

void PrintDiagnostics(const std::vector<Diagnostic>& ds);
/// Prints a model's errors; 74 when the file could not be read, else 1.
int ModelFailure(const ModelError& e, bool wrote_nothing);
/// 128 + the signal that stopped the command (130 for SIGINT, 143 for SIGTERM, 129 for SIGHUP).
int InterruptedExitCode();
/// The command line as one line of text (the lock file names the command that holds a folder).
std::string CommandLine(const std::vector<std::string>& argv);
/// Refuses (exit 64) an output that is one of the command's input files, e.g. compare -o B.yaml,
/// which would replace the model by the report.
void RefuseWritingOnto(const std::vector<std::filesystem::path>& outputs, const std::vector<std::string>& inputs);
/// Prints the notes of an output folder's clean-up (temporaries of commands that died).
void ReportRemovedTemporaries(const OutputFolder& folder);

/// A registered subcommand: its parser and what runs it (returns the exit code). `writes` says
/// whether it would have written files, for "nothing was written" after a model error.
struct Command {
  CLI::App* app = nullptr;
  std::function<int(const std::vector<std::string>& argv)> run;
  std::function<bool()> writes = [] { return false; };
};

Command AddCheckCommand(CLI::App& app);
Command AddEquationsCommand(CLI::App& app);
Command AddGraphCommand(CLI::App& app);
Command AddRunCommand(CLI::App& app);
Command AddCompareCommand(CLI::App& app);
Command AddPlotCommand(CLI::App& app);
Command AddViewCommand(CLI::App& app);
Command AddLinearizeCommand(CLI::App& app);
Command AddModesCommand(CLI::App& app);
Command AddBodeCommand(CLI::App& app);
Command AddSweepCommand(CLI::App& app);
Command AddJitFinishCommand(CLI::App& app);
/// The program a run hands an unfinished background compile over to (this executable, for
/// `jit-finish`), or "" when none may be: MULTIBOND_JIT_KEEP=0, or a program file that someone
/// other than its owner (this user or root) could have changed.
std::string JitFinisher();

}  // namespace multibond::cli
