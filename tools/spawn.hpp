#pragma once
// lagrange::Spawn: the project's one fork and exec.
//
// Starts a program as a child process with its stdout and stderr where the
// caller says, optionally looked up in PATH, with its timer slack set and
// SIGPIPE back at its default action; returns the child's pid and does not wait.
//
// Every program the project starts goes through here: lagrangectl plot
// (python3), the process benchmarks (lagranged, cyclictest, lcm-logger,
// bench/harness) and the tests (RunProcess, BackgroundProcess,
// tests/support/process). It is a library of its own in tools/ (lagrange_spawn),
// which lagrangectl, the tests and the benchmarks link; not the daemon's:
// lagranged starts no process. It is the one place because the callers have
// threads, and after fork in a threaded process the child may only make
// async-signal-safe calls until exec: another thread may hold malloc's lock
// (or any other) at the moment of the fork, and in the child that lock is
// never released. So everything is prepared before fork (the argv array, the
// PATH candidates, the signal action, the parent's pid) and the child only
// dup2s, fcntls, prctls, sigactions, getppids, execs and _exits. Getting that right once here beats
// getting it right (or not) in each caller.
//
// If no exec succeeds the child exits 127 (the shell's "command not found").

#include <sys/types.h>

#include <string>
#include <vector>

namespace lagrange {

struct SpawnOptions {
  // The program to execute; empty: argv[0]. Otherwise argv[0] is only what
  // the program sees as its name.
  std::string file;
  // The child's stdout and stderr (both may be the same fd); -1: this
  // process's. The fd may be close-on-exec: the child's copy is not.
  int stdout_fd = -1;
  int stderr_fd = -1;
  // A program name without '/' is looked up in PATH (as execvp does, but the
  // search list is built before fork; no /bin/sh fallback for scripts without
  // a #! line). Otherwise it is executed as given, relative to the cwd.
  bool search_path = false;
  // > 0: the child sets its timer slack (prctl PR_SET_TIMERSLACK, ns) before
  // exec; its threads inherit it and exec keeps it.
  unsigned long timer_slack_ns = 0;
  // The child's SIGPIPE at its default action (as a service manager leaves
  // it) rather than whatever this process has.
  bool default_sigpipe = false;
  // The child is killed (SIGKILL) when its parent dies, as when a test
  // process crashes with lagranged children running: prctl PR_SET_PDEATHSIG
  // before exec, which keeps it. If the parent died before that, the child
  // exits (127) instead of running on. Linux sends the signal when the
  // thread that called Spawn exits: spawn from a thread that outlives the child.
  bool die_with_parent = false;
};

// Forks and execs `argv` (not empty) as `options` say. Returns the child's
// pid, or -1 with errno set when fork fails. Throws std::invalid_argument for
// an empty argv (before forking).
pid_t Spawn(const std::vector<std::string>& argv, const SpawnOptions& options = {});

}  // namespace lagrange
