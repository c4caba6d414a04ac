#pragma once
// The tick thread's body: sleep to the next absolute deadline, run the tick
// (or a bounded catch-up), hand the record to the publisher through a
// bounded ring, and wake the publisher. No allocation, lock or log.

#include <atomic>
#include <cstdint>

#include "daemon/loop_timer.hpp"
#include "daemon/mailbox.hpp"
#include "daemon/runtime.hpp"

namespace lagrange {

class Loop {
 public:
  // `notify_fd`: an eventfd written (non-blocking) after every record; -1 for none.
  Loop(Runtime& runtime, Clock& clock, LoopTimerOptions options, SpscRing<TickRecord>& out, int notify_fd = -1);

  // Runs until `stop` is set or `max_ticks` ticks have run (< 0: no limit).
  void Run(const std::atomic<bool>& stop, std::int64_t max_ticks = -1);

  std::int64_t ticks() const { return ticks_.load(std::memory_order_relaxed); }
  std::int64_t records_dropped() const { return dropped_.load(std::memory_order_relaxed); }
  std::int64_t overruns() const { return timer_.overruns(); }

 private:
  void RunOneTick(const Wake& wake, Nanoseconds start);

  Runtime& runtime_;
  Clock& clock_;
  LoopTimer timer_;
  SpscRing<TickRecord>& out_;
  int notify_fd_;
  TickRecord spare_;  // filled when the ring is full, so the tick still runs
  std::atomic<std::int64_t> ticks_{0};
  std::atomic<std::int64_t> dropped_{0};
};

}  // namespace lagrange
