#include "multibond/core/process.h"

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <sstream>

#include <fmt/format.h>

#include "multibond/core/interrupt.h"

extern char** environ;

namespace multibond {

namespace {

void SleepMs(int ms) {
  timespec ts{ms / 1000, (ms % 1000) * 1000000L};
  nanosleep(&ts, nullptr);  // a signal cuts it short: the caller looks at the flag at once
}

/// True once `pid` has exited (still a zombie: its id, and its group's, cannot be reused yet).
bool HasExited(pid_t pid) {
  siginfo_t info{};
  return waitid(P_PID, static_cast<id_t>(pid), &info, WEXITED | WNOHANG | WNOWAIT) == 0 && info.si_pid == pid;
}

}  // namespace

pid_t StartProcess(const std::vector<std::string>& argv, const std::string& cwd, const std::string& log,
                   std::string* error, bool merge_stdout) {
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, STDIN_FILENO, "/dev/null", O_RDONLY, 0);
  posix_spawn_file_actions_addopen(&actions, STDERR_FILENO, log.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_NOFOLLOW, 0600);
  if (merge_stdout)
    posix_spawn_file_actions_adddup2(&actions, STDERR_FILENO, STDOUT_FILENO);
  else
    posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, "/dev/null", O_WRONLY, 0);
  if (!cwd.empty()) posix_spawn_file_actions_addchdir_np(&actions, cwd.c_str());
  // A process group of its own (ended as a group, see EndProcess), the stop signals at their
  // default action and none blocked, whatever the parent does with them.
  posix_spawnattr_t attr;
  posix_spawnattr_init(&attr);
  posix_spawnattr_setpgroup(&attr, 0);
  sigset_t defaults, none;
  sigemptyset(&defaults);
  for (int s : {SIGINT, SIGTERM, SIGHUP, SIGPIPE}) sigaddset(&defaults, s);
  sigemptyset(&none);
  posix_spawnattr_setsigdefault(&attr, &defaults);
  posix_spawnattr_setsigmask(&attr, &none);
  posix_spawnattr_setflags(&attr, POSIX_SPAWN_SETPGROUP | POSIX_SPAWN_SETSIGDEF | POSIX_SPAWN_SETSIGMASK);
  std::vector<std::string> copy = argv;
  std::vector<char*> args;
  for (std::string& a : copy) args.push_back(a.data());
  args.push_back(nullptr);
  pid_t pid = -1;
  const int rc = posix_spawnp(&pid, args[0], &actions, &attr, args.data(), environ);
  posix_spawnattr_destroy(&attr);
  posix_spawn_file_actions_destroy(&actions);
  if (rc != 0) {
    if (error)
      *error = rc == ENOENT ? fmt::format("cannot run '{}': it is not installed (or not on PATH)", argv[0])
                            : fmt::format("cannot run '{}': {}", argv[0], std::strerror(rc));
    return -1;
  }
  return pid;
}

void EndProcess(pid_t pid, int grace_ms) {
  if (pid <= 0) return;
  // The child leads its group (StartProcess): the group goes, the compiler's own children too.
  kill(-pid, SIGTERM);
  for (int waited = 0; waited < grace_ms && !HasExited(pid); waited += 10) SleepMs(10);
  // Whatever is left of the group (the leader is at most a zombie now or is killed here: its
  // process and group ids cannot have been reused).
  kill(-pid, SIGKILL);
  int status = 0;
  while (waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
}

std::string WaitProcess(pid_t pid, const std::string& program) {
  int status = 0;
  // Polled rather than blocked on: a stop asked for from another thread (or a signal delivered
  // to another thread) must end the wait too. The pause grows from 1 to 20 ms.
  for (int pause = 1;; pause = std::min(2 * pause, 20)) {
    const pid_t r = waitpid(pid, &status, WNOHANG);
    if (r == pid) break;
    if (r < 0 && errno != EINTR) return fmt::format("waiting for '{}' failed: {}", program, std::strerror(errno));
    if (StopRequested()) {
      EndProcess(pid);
      throw Interrupted(fmt::format("running '{}'", program));
    }
    SleepMs(pause);
  }
  if (WIFEXITED(status) && WEXITSTATUS(status) == 127)
    return fmt::format("cannot run '{}': it is not installed (or not on PATH)", program);
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0)
    return WIFEXITED(status) ? fmt::format("'{}' failed (exit status {})", program, WEXITSTATUS(status))
                             : fmt::format("'{}' failed (signal {})", program, WIFSIGNALED(status) ? WTERMSIG(status) : 0);
  return "";
}

std::string RunProcess(const std::vector<std::string>& argv, const std::string& cwd, const std::string& log,
                       bool merge_stdout, size_t max_log) {
  ThrowIfStopRequested(fmt::format("starting '{}'", argv.empty() ? std::string() : argv[0]));
  std::string error;
  const pid_t pid = StartProcess(argv, cwd, log, &error, merge_stdout);
  if (pid < 0) return error;
  error = WaitProcess(pid, argv[0]);
  if (error.empty()) return error;
  std::ifstream in(log);
  std::stringstream ss;
  ss << in.rdbuf();
  std::string text = ss.str();
  while (!text.empty() && (text.back() == '\n' || text.back() == '\r')) text.pop_back();
  if (text.size() > max_log) text = text.substr(0, max_log) + "...";
  return text.empty() ? error : error + ": " + text;
}

}  // namespace multibond
