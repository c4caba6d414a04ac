#include "daemon/realtime.hpp"

#include <pthread.h>
#include <sched.h>
#include <sys/mman.h>

#include <cerrno>
#include <cstring>

namespace lagrange {

std::vector<std::string> LockMemory(const RealtimeOptions& options) {
  std::vector<std::string> problems;
  if (options.lock_memory && mlockall(MCL_CURRENT | MCL_FUTURE) != 0) {
    problems.push_back(std::string("mlockall: ") + std::strerror(errno));
  }
  return problems;
}

std::vector<std::string> ApplyToThisThread(const RealtimeOptions& options) {
  std::vector<std::string> problems;
  if (options.priority > 0) {
    sched_param param{};
    param.sched_priority = options.priority;
    if (const int err = pthread_setschedparam(pthread_self(), SCHED_FIFO, &param); err != 0) {
      problems.push_back("SCHED_FIFO priority " + std::to_string(options.priority) + ": " + std::strerror(err));
    }
  }
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

}  // namespace lagrange
