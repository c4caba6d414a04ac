#include "protocol/clock.hpp"

#include <time.h>

#include <cerrno>

namespace lagrange {
namespace {

Nanoseconds Read(clockid_t id) {
  timespec ts;
  clock_gettime(id, &ts);
  return static_cast<Nanoseconds>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

}  // namespace

Nanoseconds MonotonicClock::Now() { return Read(CLOCK_MONOTONIC); }

void MonotonicClock::SleepUntil(Nanoseconds deadline) {
  const Nanoseconds wake = deadline - spin_;
  timespec ts{static_cast<time_t>(wake / 1'000'000'000), static_cast<long>(wake % 1'000'000'000)};
  while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr) == EINTR) {
  }
  while (spin_ > 0 && Now() < deadline) {
  }
}

std::int64_t MonotonicClock::WallMicros() { return Read(CLOCK_REALTIME) / 1000; }

}  // namespace lagrange
