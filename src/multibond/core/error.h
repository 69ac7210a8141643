#pragma once
/// \file
/// The three error channels of multibond (see docs/design.md):
///  1. ModelError: bad user input, carrying every diagnostic found (file:line:col, element, hint).
///  2. MB_ASSERT: programmer errors; always on, names condition, function, file and line.
///  3. SolverError: an integration failure, carrying the time and the solver's flag.

#include <stdexcept>
#include <string>
#include <vector>

namespace multibond {

/// Where something was written in a model file. line and column are 1-based; 0 = unknown.
struct SourceLocation {
  std::string file;
  int line = 0;
  int column = 0;
  bool known() const { return line > 0; }
  std::string ToString() const;  ///< "file:line:col" (or "file" / "" when unknown)
};

/// One problem found in a model.
struct Diagnostic {
  enum class Severity { kError, kWarning };
  Severity severity = Severity::kError;
  SourceLocation where;
  std::string element;  ///< the element, bond or key concerned ("" if none)
  std::string message;  ///< what is wrong
  std::string hint;     ///< how to fix it ("" if none)
  std::vector<std::string> details;  ///< extra lines (causal paths, loop members)
  /// A stable identifier of the kind of problem (e.g. "param.range", "causality.derivative");
  /// tests and tools match on it rather than on the wording.
  std::string code;
  std::string ToString() const;
};

/// Bad user input: a model file, a parameter, a connection. Carries every diagnostic found.
class ModelError : public std::runtime_error {
 public:
  explicit ModelError(std::vector<Diagnostic> diagnostics);
  explicit ModelError(Diagnostic diagnostic);
  const std::vector<Diagnostic>& diagnostics() const { return diagnostics_; }

 private:
  std::vector<Diagnostic> diagnostics_;
};

/// Collects diagnostics and throws them together as one ModelError.
class DiagnosticSink {
 public:
  /// An error of `code` (core/diagnostic_codes.h: every error has one, which Python's ModelError
  /// and the command line's exit code read).
  void Error(std::string code, SourceLocation where, std::string element, std::string message, std::string hint = {});
  void Add(Diagnostic d) { diagnostics_.push_back(std::move(d)); }
  bool has_errors() const;
  const std::vector<Diagnostic>& diagnostics() const { return diagnostics_; }
  /// Throws ModelError if any error was collected.
  void ThrowIfErrors() const;

 private:
  std::vector<Diagnostic> diagnostics_;
};

/// An integration failure: the time reached, the solver's flag name and its text.
class SolverError : public std::runtime_error {
 public:
  SolverError(double t, std::string flag, std::string text);
  double t() const { return t_; }
  const std::string& flag() const { return flag_; }
  const std::string& text() const { return text_; }
  /// Indices of the states that caused the failure, worst first (largest weighted local error
  /// estimate, or the entries that became non-finite); empty if the solver could not tell.
  const std::vector<int>& states() const { return states_; }
  void set_states(std::vector<int> s) { states_ = std::move(s); }

 private:
  double t_;
  std::string flag_;
  std::string text_;
  std::vector<int> states_;
};

[[noreturn]] void AssertionFailed(const char* condition, const char* function, const char* file,
                                  int line, const std::string& message);

}  // namespace multibond

/// Programmer-error check, always on. Never use it for user input.
#define MB_ASSERT(cond, msg)                                                           \
  do {                                                                                 \
    if (!(cond)) ::multibond::AssertionFailed(#cond, __func__, __FILE__, __LINE__, (msg)); \
  } while (0)
