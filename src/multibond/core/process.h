#pragma once
/// \file
/// Running an external program (Graphviz, gnuplot, the C++ compiler for generated code): no
/// shell, so arguments pass as they are; stdin from /dev/null; stdout to /dev/null; stderr to a
/// log file, quoted when the program fails.

#include <sys/types.h>

#include <string>
#include <vector>

namespace multibond {

/// Starts argv[0] (looked up on PATH) with `argv`, in `cwd` when not empty, its stderr (and, if
/// `merge_stdout`, its stdout) written to `log`. Returns the process id, or -1 with `error` set.
pid_t StartProcess(const std::vector<std::string>& argv, const std::string& cwd, const std::string& log,
                   std::string* error, bool merge_stdout = false);

/// Waits for `pid`; returns "" when it exited with status 0, else what went wrong, in words.
std::string WaitProcess(pid_t pid, const std::string& program);

/// StartProcess + WaitProcess; on failure the message ends with the log's text (at most
/// `max_log` characters). Returns "" on success.
std::string RunProcess(const std::vector<std::string>& argv, const std::string& cwd, const std::string& log,
                       bool merge_stdout = false, size_t max_log = 600);

}  // namespace multibond
