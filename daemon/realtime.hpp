#pragma once
// Real-time set-up, when the system permits it.
//
// Thread priorities under --rt-priority P (SCHED_FIFO, higher runs first):
//   tick     P        the loop; nothing may delay it
//   publish  P - 1    drains the tick's records; a late publisher drops records
//   receive  P - 2    setpoints and commands; a late receiver only ages them
// each clamped at 1. Every other thread (the log flusher, the timing CSV
// writer) stays SCHED_OTHER.

#include <string>
#include <vector>

namespace lagrange {

struct RealtimeOptions {
  bool lock_memory = false;  // mlockall(MCL_CURRENT | MCL_FUTURE)
  int priority = 0;          // SCHED_FIFO priority 1..99 for the tick thread; 0: leave the scheduler alone
  int cpu = -1;              // pin the tick thread to this CPU; -1: no pinning
};

// SCHED_FIFO priorities of lagranged's threads for a tick priority (see above); all 0 when it is 0.
struct ThreadPriorities {
  int tick = 0;
  int publish = 0;
  int receive = 0;
};
ThreadPriorities PrioritiesBelow(int tick_priority);

// Locks the process's memory if asked. Returns what could not be done.
std::vector<std::string> LockMemory(const RealtimeOptions& options);
// Applies priority and affinity to the calling thread. Returns what could not be done.
std::vector<std::string> ApplyToThisThread(const RealtimeOptions& options);
// Gives the calling thread SCHED_FIFO `priority` (1..99); 0 leaves it alone.
// Returns what could not be done (empty on success).
std::vector<std::string> SetThisThreadPriority(int priority);
// The calling thread's policy and priority, e.g. "SCHED_FIFO 79" or "SCHED_OTHER".
std::string DescribeThisThreadScheduling();

}  // namespace lagrange
