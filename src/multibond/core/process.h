#pragma once
/// \file
/// Running an external program (Graphviz, gnuplot, the C++ compiler for generated code): no
/// shell, so arguments pass as they are; stdin from /dev/null; stdout to /dev/null; stderr to a
/// log file, quoted when the program fails.
///
/// Each child runs in a process group of its own: a Ctrl-C from the terminal reaches multibond
/// only, which then ends the whole group (a compiler's cc1plus and as included). Waiting looks at
/// the stop flag (core/interrupt.h): when a stop is asked for, the child's group gets SIGTERM,
/// then SIGKILL after a grace period, is reaped, and the wait throws Interrupted.

#include <sys/types.h>

#include <string>
#include <vector>

namespace multibond {

/// Starts argv[0] (looked up on PATH) with `argv`, in `cwd` when not empty, its stderr (and, if
/// `merge_stdout`, its stdout) written to `log` (created mode 0600, not through a symbolic link).
/// The child leads a new process group. Returns the process id, or -1 with `error` set.
pid_t StartProcess(const std::vector<std::string>& argv, const std::string& cwd, const std::string& log,
                   std::string* error, bool merge_stdout = false);

/// Waits for `pid`; returns "" when it exited with status 0, else what went wrong, in words.
/// Throws Interrupted("running '<program>'") once a stop is asked for, after ending the child's
/// process group (EndProcess).
std::string WaitProcess(pid_t pid, const std::string& program);

/// Ends a child started by StartProcess and its process group: SIGTERM, SIGKILL after
/// `grace_ms`, then reaps it. For a caller that leaves other children behind (e.g. on Interrupted).
void EndProcess(pid_t pid, int grace_ms = 1000);

/// StartProcess + WaitProcess; on failure the message ends with the log's text (at most
/// `max_log` characters). Returns "" on success; throws Interrupted as WaitProcess does.
std::string RunProcess(const std::vector<std::string>& argv, const std::string& cwd, const std::string& log,
                       bool merge_stdout = false, size_t max_log = 600);

}  // namespace multibond
