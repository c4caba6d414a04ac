#pragma once
// Real-time set-up, when the system permits it.

#include <string>
#include <vector>

namespace lagrange {

struct RealtimeOptions {
  bool lock_memory = false;  // mlockall(MCL_CURRENT | MCL_FUTURE)
  int priority = 0;          // SCHED_FIFO priority 1..99 for the tick thread; 0: leave the scheduler alone
  int cpu = -1;              // pin the tick thread to this CPU; -1: no pinning
};

// Locks the process's memory if asked. Returns what could not be done.
std::vector<std::string> LockMemory(const RealtimeOptions& options);
// Applies priority and affinity to the calling thread. Returns what could not be done.
std::vector<std::string> ApplyToThisThread(const RealtimeOptions& options);

}  // namespace lagrange
