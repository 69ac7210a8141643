#include "multibond/core/process.h"

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <sstream>

#include <fmt/format.h>

extern char** environ;

namespace multibond {

pid_t StartProcess(const std::vector<std::string>& argv, const std::string& cwd, const std::string& log,
                   std::string* error, bool merge_stdout) {
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, STDIN_FILENO, "/dev/null", O_RDONLY, 0);
  posix_spawn_file_actions_addopen(&actions, STDERR_FILENO, log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  if (merge_stdout)
    posix_spawn_file_actions_adddup2(&actions, STDERR_FILENO, STDOUT_FILENO);
  else
    posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, "/dev/null", O_WRONLY, 0);
  if (!cwd.empty()) posix_spawn_file_actions_addchdir_np(&actions, cwd.c_str());
  std::vector<std::string> copy = argv;
  std::vector<char*> args;
  for (std::string& a : copy) args.push_back(a.data());
  args.push_back(nullptr);
  pid_t pid = -1;
  const int rc = posix_spawnp(&pid, args[0], &actions, nullptr, args.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (rc != 0) {
    if (error)
      *error = rc == ENOENT ? fmt::format("cannot run '{}': it is not installed (or not on PATH)", argv[0])
                            : fmt::format("cannot run '{}': {}", argv[0], std::strerror(rc));
    return -1;
  }
  return pid;
}

std::string WaitProcess(pid_t pid, const std::string& program) {
  int status = 0;
  while (waitpid(pid, &status, 0) < 0)
    if (errno != EINTR) return fmt::format("waiting for '{}' failed: {}", program, std::strerror(errno));
  if (WIFEXITED(status) && WEXITSTATUS(status) == 127)
    return fmt::format("cannot run '{}': it is not installed (or not on PATH)", program);
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0)
    return WIFEXITED(status) ? fmt::format("'{}' failed (exit status {})", program, WEXITSTATUS(status))
                             : fmt::format("'{}' failed (signal {})", program, WIFSIGNALED(status) ? WTERMSIG(status) : 0);
  return "";
}

std::string RunProcess(const std::vector<std::string>& argv, const std::string& cwd, const std::string& log,
                       bool merge_stdout, size_t max_log) {
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
