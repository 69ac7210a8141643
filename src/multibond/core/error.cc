#include "multibond/core/error.h"

#include <fmt/format.h>

namespace multibond {

std::string SourceLocation::ToString() const {
  if (file.empty() && !known()) return {};
  if (!known()) return file;
  return fmt::format("{}:{}:{}", file.empty() ? "<model>" : file, line, column);
}

std::string Diagnostic::ToString() const {
  std::string out;
  const std::string loc = where.ToString();
  if (!loc.empty()) out += loc + ": ";
  out += severity == Severity::kError ? "error: " : "warning: ";
  if (!element.empty()) out += element + ": ";
  out += message;
  for (const auto& d : details) out += "\n  " + d;
  if (!hint.empty()) out += "\n  hint: " + hint;
  return out;
}

static std::string JoinDiagnostics(const std::vector<Diagnostic>& ds) {
  std::string out;
  for (const auto& d : ds) {
    if (!out.empty()) out += '\n';
    out += d.ToString();
  }
  return out;
}

ModelError::ModelError(std::vector<Diagnostic> diagnostics)
    : std::runtime_error(JoinDiagnostics(diagnostics)), diagnostics_(std::move(diagnostics)) {}

ModelError::ModelError(Diagnostic diagnostic) : ModelError(std::vector<Diagnostic>{std::move(diagnostic)}) {}

void DiagnosticSink::Error(std::string code, SourceLocation where, std::string element, std::string message,
                           std::string hint) {
  Diagnostic d;
  d.where = std::move(where);
  d.element = std::move(element);
  d.message = std::move(message);
  d.hint = std::move(hint);
  d.code = std::move(code);
  diagnostics_.push_back(std::move(d));
}

bool DiagnosticSink::has_errors() const {
  for (const auto& d : diagnostics_)
    if (d.severity == Diagnostic::Severity::kError) return true;
  return false;
}

void DiagnosticSink::ThrowIfErrors() const {
  if (has_errors()) throw ModelError(diagnostics_);
}

SolverError::SolverError(double t, std::string flag, std::string text)
    : std::runtime_error(fmt::format("at t = {:.9g} s: {} ({})", t, text, flag)),
      t_(t),
      flag_(std::move(flag)),
      text_(std::move(text)) {}

void AssertionFailed(const char* condition, const char* function, const char* file, int line,
                     const std::string& message) {
  throw std::logic_error(fmt::format("internal error: assertion '{}' failed in {} ({}:{}): {}",
                                     condition, function, file, line, message));
}

}  // namespace multibond
