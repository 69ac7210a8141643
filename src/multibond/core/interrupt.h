#pragma once
/// \file
/// Stopping on a signal, the same way in every phase (loading, compiling, integrating, writing).
///
/// InstallStopHandlers() makes SIGINT, SIGTERM and SIGHUP set one process-wide flag instead of
/// killing the program. Long phases look at it (StopRequested) and end by throwing Interrupted:
/// a child process being waited for is ended first (core/process.h), temporaries are removed by
/// their owners, and the command exits with 128 + the signal's number (130 for SIGINT, 143 for
/// SIGTERM, 129 for SIGHUP). A run that is integrating keeps the rows it computed (run.json marks
/// it interrupted); any other phase leaves nothing behind.

#include <atomic>
#include <stdexcept>
#include <string>

namespace multibond {

/// The flag the handlers set: read it from any thread (RunOptions::stop points here).
std::atomic<bool>& StopFlag();

/// The signal that asked to stop (SIGINT, SIGTERM, SIGHUP), or 0 while none did.
int StopSignal();

/// True once a stop was asked for.
inline bool StopRequested() { return StopFlag().load(std::memory_order_relaxed); }

/// Installs the handlers (idempotent). Only programs call it; the library never does.
void InstallStopHandlers();

/// Clears the flag (tests that stop twice in one process).
void ResetStop();

/// Thrown by a phase that stopped because a stop was asked for.
class Interrupted : public std::runtime_error {
 public:
  explicit Interrupted(const std::string& phase);
  int signal() const { return signal_; }
  /// 128 + the signal's number (130 when no signal was recorded).
  int ExitCode() const;

 private:
  int signal_;
};

/// Throws Interrupted("<phase>") when a stop was asked for.
void ThrowIfStopRequested(const std::string& phase);

}  // namespace multibond
