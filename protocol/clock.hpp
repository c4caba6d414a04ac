#pragma once
// Time for the loop, injectable so tests can drive it, and the wall clock a
// message's utime is read from (daemon and clients alike).

#include <cmath>
#include <cstdint>

namespace lagrange {

using Nanoseconds = std::int64_t;

// s → ns and s → µs, rounded to the nearest (a truncation makes 0.00026 s
// 259999 ns, and a two-tick timeout one tick short).
inline Nanoseconds ToNanoseconds(double seconds) { return std::llround(seconds * 1e9); }
inline std::int64_t ToMicroseconds(double seconds) { return std::llround(seconds * 1e6); }

class Clock {
 public:
  virtual ~Clock() = default;
  // Monotonic time, ns.
  virtual Nanoseconds Now() = 0;
  // Returns at or after `deadline` (monotonic, ns).
  virtual void SleepUntil(Nanoseconds deadline) = 0;
  // Wall-clock time, µs since the Unix epoch.
  virtual std::int64_t WallMicros() = 0;
};

// CLOCK_MONOTONIC with absolute-deadline clock_nanosleep; optionally sleeps
// until `spin` before the deadline and busy-waits the rest (lower latency, more CPU).
class MonotonicClock final : public Clock {
 public:
  explicit MonotonicClock(Nanoseconds spin = 0) : spin_(spin) {}
  Nanoseconds Now() override;
  void SleepUntil(Nanoseconds deadline) override;
  std::int64_t WallMicros() override;

 private:
  Nanoseconds spin_;
};

}  // namespace lagrange
