#include "daemon/loop_timer.hpp"

#include <algorithm>

namespace lagrange {

LoopTimer::LoopTimer(Clock& clock, LoopTimerOptions options) : clock_(clock), options_(options) {}

void LoopTimer::Start() { next_ = clock_.Now() + options_.period; }

Wake LoopTimer::WaitForNextTick() {
  clock_.SleepUntil(next_);
  Wake w;
  w.deadline = next_;
  w.woke = clock_.Now();
  w.latency = w.woke - w.deadline;
  w.missed = std::max<Nanoseconds>(0, w.latency) / options_.period;
  overruns_ += w.missed;
  if (options_.policy == OverrunPolicy::kCatchUp) {
    w.ticks = 1 + static_cast<int>(std::min<std::int64_t>(w.missed, options_.max_catch_up));
  }
  next_ += (w.missed + 1) * options_.period;
  return w;
}

}  // namespace lagrange
