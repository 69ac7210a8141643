#include "multibond/core/interrupt.h"

#include <csignal>

#include <fmt/format.h>

namespace multibond {

namespace {

std::atomic<bool> g_stop{false};
std::atomic<int> g_signal{0};

extern "C" void OnStopSignal(int signo) {
  int none = 0;
  g_signal.compare_exchange_strong(none, signo);
  g_stop.store(true);
}

const char* SignalName(int s) {
  switch (s) {
    case SIGINT: return "SIGINT";
    case SIGTERM: return "SIGTERM";
    case SIGHUP: return "SIGHUP";
    default: return "a signal";
  }
}

}  // namespace

std::atomic<bool>& StopFlag() { return g_stop; }

int StopSignal() { return g_signal.load(); }

void InstallStopHandlers() {
  struct sigaction sa {};
  sa.sa_handler = OnStopSignal;
  sigemptyset(&sa.sa_mask);
  sa.sa_flags = 0;  // no SA_RESTART: a blocking wait returns EINTR and looks at the flag
  for (int s : {SIGINT, SIGTERM, SIGHUP}) sigaction(s, &sa, nullptr);
}

void ResetStop() {
  g_signal.store(0);
  g_stop.store(false);
}

Interrupted::Interrupted(const std::string& phase)
    : std::runtime_error(fmt::format("interrupted by {} while {}", SignalName(StopSignal() ? StopSignal() : SIGINT), phase)),
      signal_(StopSignal() ? StopSignal() : SIGINT) {}

int Interrupted::ExitCode() const { return 128 + signal_; }

void ThrowIfStopRequested(const std::string& phase) {
  if (StopRequested()) throw Interrupted(phase);
}

}  // namespace multibond
