#include "daemon/realtime.hpp"

#include <pthread.h>
#include <sched.h>
#include <sys/mman.h>
#include <sys/resource.h>

#include <algorithm>
#include <cerrno>
#include <cstring>

namespace lagrange {

ThreadPriorities PrioritiesBelow(int tick_priority) {
  if (tick_priority <= 0) return {};
  return {tick_priority, std::max(1, tick_priority - 1), std::max(1, tick_priority - 2)};
}

std::vector<std::string> LockMemory(const RealtimeOptions& options) {
  std::vector<std::string> problems;
  if (options.lock_memory && mlockall(MCL_CURRENT | MCL_FUTURE) != 0) {
    const int error = errno;
    std::string why = std::string("mlockall: ") + std::strerror(error);
    rlimit limit{};
    if ((error == ENOMEM || error == EPERM) && getrlimit(RLIMIT_MEMLOCK, &limit) == 0) {
      why += limit.rlim_cur == RLIM_INFINITY
                 ? " (RLIMIT_MEMLOCK is unlimited)"
                 : " (RLIMIT_MEMLOCK is " + std::to_string(limit.rlim_cur / 1024) +
                       " KiB: raise it, e.g. LimitMEMLOCK=infinity in the service unit or ulimit -l, or run as root)";
    }
    problems.push_back(why);
  }
  return problems;
}

std::vector<std::string> SetThisThreadPriority(int priority) {
  std::vector<std::string> problems;
  if (priority > 0) {
    sched_param param{};
    param.sched_priority = priority;
    if (const int err = pthread_setschedparam(pthread_self(), SCHED_FIFO, &param); err != 0) {
      problems.push_back("SCHED_FIFO priority " + std::to_string(priority) + ": " + std::strerror(err));
    }
  }
  return problems;
}

std::vector<std::string> ApplyToThisThread(const RealtimeOptions& options) {
  std::vector<std::string> problems = SetThisThreadPriority(options.priority);
  if (options.cpu >= 0) {
    cpu_set_t set;
    CPU_ZERO(&set);
    CPU_SET(options.cpu, &set);
    if (const int err = pthread_setaffinity_np(pthread_self(), sizeof set, &set); err != 0) {
      problems.push_back("CPU affinity " + std::to_string(options.cpu) + ": " + std::strerror(err));
    }
  }
  return problems;
}

std::string DescribeThisThreadScheduling() {
  int policy = 0;
  sched_param param{};
  if (pthread_getschedparam(pthread_self(), &policy, &param) != 0) return "unknown";
  switch (policy) {
    case SCHED_FIFO: return "SCHED_FIFO " + std::to_string(param.sched_priority);
    case SCHED_RR: return "SCHED_RR " + std::to_string(param.sched_priority);
    case SCHED_OTHER: return "SCHED_OTHER";
    case SCHED_BATCH: return "SCHED_BATCH";
    case SCHED_IDLE: return "SCHED_IDLE";
    default: return "policy " + std::to_string(policy);
  }
}

}  // namespace lagrange
