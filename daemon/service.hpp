#pragma once
// lagranged as a process: options, logging, the three threads, signals.
//
// Signals: SIGINT and SIGTERM stop it after the current tick (every state
// published, the final status logged, exit 0); SIGHUP reopens --log-file by
// name (logrotate); SIGPIPE, SIGXFSZ, SIGUSR1, SIGUSR2 and SIGALRM are ignored. The
// handled ones are blocked in every thread and taken by the main thread.
//
// Threads under --rt-priority P: tick SCHED_FIFO P, publish P-1, receive P-2
// (at least 1); see daemon/realtime.hpp.

namespace lagrange {

// main() of lagranged. Exit status: 0 after SIGINT/SIGTERM or --duration;
// 2 for a bad option, LCM URL, log file or scene, or a scene whose worst-case
// tick does not fit its period (sim/work_bound.hpp), each named in one line
// before the loop starts; 3 when --require-rt is given and real-time set-up
// of the tick thread or the memory lock failed; 1 for other failures.
int RunLagranged(int argc, char** argv);

}  // namespace lagrange
