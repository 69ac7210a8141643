#pragma once
// Test helper: whether a process still runs (a zombie, ended but not yet reaped by its parent or
// by init, counts as ended).

#include <signal.h>
#include <sys/types.h>

#include <cerrno>
#include <fstream>
#include <iterator>
#include <string>

namespace multibond::testing {

inline bool Alive(pid_t pid) {
  if (kill(pid, 0) != 0) return errno != ESRCH;
  std::ifstream stat("/proc/" + std::to_string(pid) + "/stat");
  const std::string text((std::istreambuf_iterator<char>(stat)), std::istreambuf_iterator<char>());
  const auto close = text.rfind(')');
  if (close == std::string::npos) return false;  // gone between the two looks
  return close + 2 >= text.size() || text[close + 2] != 'Z';
}

}  // namespace multibond::testing
