#pragma once
// A clock for driving the loop in tests: sleeping jumps time to the deadline
// (plus a scripted lateness), and work takes a scripted time.

#include <deque>

#include "protocol/clock.hpp"

namespace lagrange::testing {

class FakeClock final : public Clock {
 public:
  Nanoseconds Now() override { return now_; }
  void SleepUntil(Nanoseconds deadline) override {
    if (deadline > now_) now_ = deadline;
    if (!late_.empty()) {
      now_ += late_.front();
      late_.pop_front();
    }
  }
  std::int64_t WallMicros() override { return 1'700'000'000'000'000 + now_ / 1000; }

  void Advance(Nanoseconds dt) { now_ += dt; }
  // The next wake-ups return this much after their deadlines, in order.
  void ScriptLateness(std::initializer_list<Nanoseconds> late) { late_.insert(late_.end(), late); }

 private:
  Nanoseconds now_ = 1'000'000'000;
  std::deque<Nanoseconds> late_;
};

}  // namespace lagrange::testing
