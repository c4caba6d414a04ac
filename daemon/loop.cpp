#include "daemon/loop.hpp"

#include <unistd.h>

namespace lagrange {

Loop::Loop(Runtime& runtime, Clock& clock, LoopTimerOptions options, SpscRing<TickRecord>& out, int notify_fd)
    : runtime_(runtime),
      clock_(clock),
      timer_(clock, options),
      out_(out),
      notify_fd_(notify_fd),
      spare_(runtime.MakeRecord()) {
  runtime_.SetClock(&clock_);  // each instance's compute time (telemetry_t)
}

void Loop::Run(const std::atomic<bool>& stop, std::int64_t max_ticks) {
  timer_.Start();
  while (!stop.load(std::memory_order_relaxed) && (max_ticks < 0 || ticks() < max_ticks)) {
    const Wake wake = timer_.WaitForNextTick();
    for (int k = 0; k < wake.ticks; ++k) RunOneTick(wake, k == 0 ? wake.woke : clock_.Now());
    timer_.Shift(runtime_.PhaseShift());  // 0 unless an external plant locks the phase
  }
}

void Loop::RunOneTick(const Wake& wake, Nanoseconds start) {
  TickRecord* record = out_.BeginPush();
  const bool to_publisher = record != nullptr;
  if (!to_publisher) record = &spare_;
  record->tick = ticks_.load(std::memory_order_relaxed);
  record->utime = clock_.WallMicros();
  record->wake_latency = start - wake.deadline;
  record->overruns = timer_.overruns();
  runtime_.Tick(start, *record);
  record->compute = clock_.Now() - start;
  ticks_.fetch_add(1, std::memory_order_relaxed);
  if (!to_publisher) {
    dropped_.fetch_add(1, std::memory_order_relaxed);
    return;
  }
  out_.Push();
  if (notify_fd_ >= 0) {
    const std::uint64_t one = 1;
    [[maybe_unused]] const ssize_t n = write(notify_fd_, &one, sizeof one);  // non-blocking eventfd
  }
}

}  // namespace lagrange
