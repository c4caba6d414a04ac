#pragma once
// Running the project's programs as separate processes in tests.

#include <sys/types.h>

#include <string>
#include <vector>

namespace lagrange::testing {

struct ProcessResult {
  int exit_code = -1;  // 128 + signal if killed by a signal; -1 if it timed out
  std::string out;
  std::string err;
};

// Starts argv[0] (a path: no PATH search) with arguments, its stdout and
// stderr on `stdout_fd` and `stderr_fd` (−1: this process's), SIGPIPE at its
// default action, killed if this test process dies first (a crash leaves no
// lagranged behind); returns its pid (throws when fork fails). lagrange::Spawn
// (tools/spawn.hpp) does the fork and exec.
pid_t Spawn(const std::vector<std::string>& argv, int stdout_fd = -1, int stderr_fd = -1);

// Runs argv[0] with arguments, captures stdout and stderr, waits up to
// `timeout_s` (then kills it).
ProcessResult RunProcess(const std::vector<std::string>& argv, double timeout_s = 120.0);

// Lines of `text`, without the trailing empty one.
std::vector<std::string> Lines(const std::string& text);

// The whole of the file at `path` ("" when it cannot be read).
std::string ReadFile(const std::string& path);

}  // namespace lagrange::testing
