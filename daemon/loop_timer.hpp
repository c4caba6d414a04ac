#pragma once
// Absolute-deadline pacing for the loop, with overrun accounting.
//
// Deadlines are start + k·period on the monotonic clock: sleeping never
// drifts. A tick that wakes late by more than a whole period has missed
// deadlines (overruns). The policy decides what happens to them:
//   skip      run one tick now and resume at the next deadline in the future;
//             the missed periods are counted, never run (simulated time falls
//             behind wall time by that much);
//   catch-up  run up to max_catch_up extra ticks back to back to make them up;
//             any beyond that are skipped as above.
// Either way tick numbers stay consecutive: a missed period is an overrun,
// not a gap in the published ticks.

#include <cstdint>
#include <string_view>

#include "protocol/clock.hpp"

namespace lagrange {

enum class OverrunPolicy : std::uint8_t { kSkip, kCatchUp };

struct LoopTimerOptions {
  Nanoseconds period = 1'000'000;
  OverrunPolicy policy = OverrunPolicy::kSkip;
  int max_catch_up = 5;
};

struct Wake {
  Nanoseconds deadline = 0;  // the deadline this wake was for
  Nanoseconds woke = 0;      // when the sleep returned
  Nanoseconds latency = 0;   // woke − deadline
  std::int64_t missed = 0;   // whole periods missed before this wake
  int ticks = 1;             // ticks to run now (1, or more when catching up)
};

class LoopTimer {
 public:
  LoopTimer(Clock& clock, LoopTimerOptions options);

  // The first deadline is one period from now.
  void Start();
  // Sleeps until the next deadline and accounts for lateness.
  Wake WaitForNextTick();

  // Moves the next deadline (and every one after it) by `delta`: a phase
  // adjustment, bounded by the caller (Runtime::PhaseShift).
  void Shift(Nanoseconds delta) { next_ += delta; }

  std::int64_t overruns() const { return overruns_; }
  const LoopTimerOptions& options() const { return options_; }

 private:
  Clock& clock_;
  LoopTimerOptions options_;
  Nanoseconds next_ = 0;
  std::int64_t overruns_ = 0;
};

}  // namespace lagrange
