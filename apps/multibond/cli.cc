#include "cli.h"

#include <cmath>
#include <csignal>
#include <iostream>
#include <stdexcept>

#include <fmt/format.h>

#include "multibond/core/interrupt.h"

namespace multibond::cli {

namespace fs = std::filesystem;

// CLI11's own range checks name the range ("Value 0 not in range 0.000000 to 1797...") and say
// the same for a word that is not a number; these say what is expected and what was given.
CLI::Validator NumberAbove(double low, bool inclusive) {
  return CLI::Validator(
      [low, inclusive](std::string& text) -> std::string {
        double v = 0.0;
        try {
          size_t used = 0;
          v = std::stod(text, &used);
          if (used != text.size()) throw std::invalid_argument(text);
        } catch (const std::out_of_range&) {
          return fmt::format("'{}' is beyond the range of normal double-precision numbers (2.2e-308 to 1.8e308 in magnitude)", text);
        } catch (const std::exception&) {
          return fmt::format("'{}' is not a number", text);
        }
        if (!std::isfinite(v)) return fmt::format("must be a finite number (got {})", text);
        if (inclusive ? !(v >= low) : !(v > low)) return fmt::format("must be {} {:g} (got {})", inclusive ? ">=" : ">", low, text);
        return "";
      },
      inclusive ? "NUMBER >= 0" : "NUMBER > 0");
}

const CLI::Validator kPositive = NumberAbove(0.0, false), kNonNegative = NumberAbove(0.0, true);

const CLI::Validator kPathName(
    [](std::string& text) -> std::string { return text.empty() ? "must name a file or folder (got an empty string)" : ""; },
    "PATH");

void AddLoadOptions(CLI::App* cmd, LoadArgs& a) {
  cmd->add_option("--constraints", a.constraints,
                  "ideal: accept derivative causality and solve the dependent storage exactly (constraint efforts); "
                  "compliant: require integral causality (default: the model file's 'constraints:', else compliant)")
      ->check(CLI::IsMember({"ideal", "compliant"}));
  cmd->add_option("--algebraic-loops", a.loops,
                  "solve: tear each algebraic loop at one variable and solve its linear system at every evaluation; "
                  "error: report it and refuse the model (default: the model file's 'algebraic_loops:', else error)")
      ->check(CLI::IsMember({"solve", "error"}));
  std::string names;
  for (const std::string& n : LimitNames()) names += (names.empty() ? "" : ", ") + n;
  cmd->add_option("--limit", a.limits,
                  "NAME=VALUE: change a bound on the input (repeatable; VALUE a whole number, k/M/G suffixes allowed); names: " +
                      names + " (docs/security.md)")
      ->type_name("NAME=VALUE")
      ->expected(1)
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
  cmd->add_option("--set", a.sets,
                  "NAME=VALUE: give the model's parameter NAME the value VALUE, a number or a formula of the other "
                  "parameters (repeatable; the file's value is replaced; docs/model-format.md, 'Parameters')")
      ->type_name("NAME=VALUE")
      ->expected(1)
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
}

InputLimits ParseLimits(const std::vector<std::string>& assignments) {
  InputLimits limits;
  for (const std::string& a : assignments) {
    try {
      SetLimit(limits, a);
    } catch (const std::invalid_argument& e) {
      throw CliExit{kExitUsage, e.what()};
    }
  }
  return limits;
}

std::vector<ParameterOverride> ParseSets(const std::vector<std::string>& assignments, const char* option) {
  std::vector<ParameterOverride> out;
  for (const std::string& a : assignments) {
    try {
      out.push_back(ParseParameterAssignment(a));
    } catch (const std::invalid_argument& e) {
      throw CliExit{kExitUsage, fmt::format("{} {}", option, e.what())};
    }
  }
  return out;
}

LoadedModel Load(const std::string& path, const LoadArgs& a, const std::vector<std::string>& extra_sets, const char* extra_option) {
  std::vector<ParameterOverride> sets = ParseSets(a.sets);
  for (ParameterOverride& o : ParseSets(extra_sets, extra_option ? extra_option : "--set")) sets.push_back(std::move(o));
  LoadedModel lm;
  try {
    lm = LoadModelFile(path, ParseLimits(a.limits), sets);
  } catch (const std::invalid_argument& e) {
    // A parameter set on the command line that the model does not have, or a value that does not read.
    const std::string option = extra_sets.empty() ? "--set" : a.sets.empty() ? extra_option : fmt::format("--set or {}", extra_option);
    throw CliExit{kExitUsage, fmt::format("{}: {} (model {})", option, e.what(), path)};
  }
  PrintDiagnostics(lm.warnings);
  if (a.constraints) lm.compile.ideal_constraints = *a.constraints == "ideal";
  if (a.loops) lm.compile.solve_algebraic_loops = *a.loops == "solve";
  ThrowIfStopRequested("loading the model");
  return lm;
}

void PrintDiagnostics(const std::vector<Diagnostic>& ds) {
  for (const auto& d : ds) std::cerr << d.ToString() << '\n';
}

int ModelFailure(const ModelError& e, bool wrote_nothing) {
  PrintDiagnostics(e.diagnostics());
  int errors = 0;
  bool unreadable = false;  // a model file that cannot be read is an I/O failure (74), not a model error
  for (const auto& d : e.diagnostics()) {
    errors += d.severity == Diagnostic::Severity::kError;
    unreadable = unreadable || d.code.rfind("io.", 0) == 0;
  }
  if (unreadable) {
    if (wrote_nothing) std::cerr << "nothing was written\n";
    return kExitIo;
  }
  std::cerr << fmt::format("{} error{} in the model{}\n", errors, errors == 1 ? "" : "s", wrote_nothing ? "; nothing was written" : "");
  return kExitModel;
}

int InterruptedExitCode() { return 128 + (StopSignal() ? StopSignal() : SIGINT); }

std::string CommandLine(const std::vector<std::string>& argv) {
  std::string s;
  for (const std::string& a : argv) s += (s.empty() ? "" : " ") + a;
  return s;
}

void RefuseWritingOnto(const std::vector<fs::path>& outputs, const std::vector<std::string>& inputs) {
  for (const fs::path& out : outputs)
    for (const std::string& in : inputs) {
      std::error_code ec;
      if (fs::equivalent(out, in, ec))
        throw CliExit{kExitUsage, fmt::format("'{}' is '{}', an input of this command: writing there would replace it; choose "
                                              "another output name", out.string(), in)};
    }
}

void ReportRemovedTemporaries(const OutputFolder& folder) {
  for (const std::string& stale : folder.removed_stale())
    std::cerr << fmt::format("note: removed '{}', a temporary file of an earlier command that did not finish\n", folder.File(stale));
}

}  // namespace multibond::cli
