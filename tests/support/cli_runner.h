#pragma once
// Test helper: runs the multibond CLI (or any program) with an argument vector, no shell, its
// stdout and stderr captured together, ended with SIGKILL after a deadline.

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <string>
#include <vector>

extern char** environ;

namespace multibond::testing {

struct CliResult {
  int code = -1;          ///< exit status; -1 when killed by a signal
  int signal = 0;         ///< the signal that ended it (0: it exited)
  bool timed_out = false; ///< killed at the deadline
  std::string out;        ///< stdout and stderr together (stdout alone when stderr went to a file)
  std::string err;        ///< stderr, when RunProgram was given a file for it
};

/// Runs `argv` (argv[0] a path) with stdin from /dev/null and at most `seconds` of wall time.
/// `stderr_file`: stderr goes there (made anew, O_EXCL | O_NOFOLLOW) and into CliResult::err.
inline CliResult RunProgram(const std::vector<std::string>& argv, double seconds = 60, const std::string& cwd = "",
                            const std::string& stderr_file = "") {
  CliResult r;
  if (!stderr_file.empty()) unlink(stderr_file.c_str());
  int fds[2];
  if (pipe2(fds, O_CLOEXEC) != 0) return r;
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, STDIN_FILENO, "/dev/null", O_RDONLY, 0);
  posix_spawn_file_actions_adddup2(&actions, fds[1], STDOUT_FILENO);
  if (stderr_file.empty()) {
    posix_spawn_file_actions_adddup2(&actions, fds[1], STDERR_FILENO);
  } else {
    posix_spawn_file_actions_addopen(&actions, STDERR_FILENO, stderr_file.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW, 0600);
  }
  if (!cwd.empty()) posix_spawn_file_actions_addchdir_np(&actions, cwd.c_str());
  std::vector<std::string> copy = argv;
  std::vector<char*> args;
  for (std::string& a : copy) args.push_back(a.data());
  args.push_back(nullptr);
  pid_t pid = -1;
  const int rc = posix_spawn(&pid, args[0], &actions, nullptr, args.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  close(fds[1]);
  if (rc != 0) {
    close(fds[0]);
    r.out = "cannot start " + argv[0];
    return r;
  }
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  char buf[4096];
  for (;;) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now()).count();
    if (left <= 0) {
      r.timed_out = true;
      kill(pid, SIGKILL);
      break;
    }
    pollfd p{fds[0], POLLIN, 0};
    if (poll(&p, 1, static_cast<int>(left)) <= 0) continue;
    const ssize_t n = read(fds[0], buf, sizeof buf);
    if (n <= 0) break;
    if (r.out.size() < (8u << 20)) r.out.append(buf, static_cast<size_t>(n));
  }
  close(fds[0]);
  int status = 0;
  while (waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  if (WIFEXITED(status)) r.code = WEXITSTATUS(status);
  if (WIFSIGNALED(status)) r.signal = WTERMSIG(status);
  if (!stderr_file.empty()) {
    const int fd = open(stderr_file.c_str(), O_RDONLY | O_NOFOLLOW | O_CLOEXEC);
    for (ssize_t n; fd >= 0 && (n = read(fd, buf, sizeof buf)) > 0;) r.err.append(buf, static_cast<size_t>(n));
    if (fd >= 0) close(fd);
  }
  return r;
}

/// `text` split at spaces: the argument vector of a test's own command line (no shell, no quoting).
inline std::vector<std::string> SplitArgs(const std::string& text) {
  std::vector<std::string> out;
  std::string word;
  for (const char c : text) {
    if (c != ' ') {
      word += c;
    } else if (!word.empty()) {
      out.push_back(word);
      word.clear();
    }
  }
  if (!word.empty()) out.push_back(word);
  return out;
}

/// The multibond CLI with `args`.
inline CliResult RunCli(std::vector<std::string> args, double seconds = 60, const std::string& cwd = "") {
  args.insert(args.begin(), MULTIBOND_CLI);
  return RunProgram(args, seconds, cwd);
}

}  // namespace multibond::testing
