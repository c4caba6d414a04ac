// LoopTimer: absolute deadlines that never drift, and overrun accounting for
// both policies, driven by a fake clock.

#include <gtest/gtest.h>

#include "daemon/loop_timer.hpp"
#include "tests/support/fake_clock.hpp"

namespace lagrange {
namespace {

constexpr Nanoseconds kPeriod = 1'000'000;

TEST(LoopTimer, DeadlinesStayOnTheGridWhateverTheWakeLatency) {
  testing::FakeClock clock;
  LoopTimer timer(clock, {kPeriod, OverrunPolicy::kSkip, 0});
  const Nanoseconds start = clock.Now();
  timer.Start();
  clock.ScriptLateness({50'000, 900'000, 0, 999'999, 10});
  for (int k = 1; k <= 8; ++k) {
    const Wake w = timer.WaitForNextTick();
    EXPECT_EQ(w.deadline, start + k * kPeriod);  // absolute: lateness never shifts later deadlines
    EXPECT_EQ(w.latency, w.woke - w.deadline);
    EXPECT_EQ(w.missed, 0);
    EXPECT_EQ(w.ticks, 1);
  }
  EXPECT_EQ(timer.overruns(), 0);
}

// A phase shift moves the next deadline and every one after it, on the same grid.
TEST(LoopTimer, AShiftMovesEveryLaterDeadlineByIt) {
  testing::FakeClock clock;
  LoopTimer timer(clock, {1'000'000, OverrunPolicy::kSkip, 5});
  timer.Start();
  const Nanoseconds first = timer.WaitForNextTick().deadline;
  timer.Shift(-50'000);
  EXPECT_EQ(timer.WaitForNextTick().deadline, first + 1'000'000 - 50'000);
  EXPECT_EQ(timer.WaitForNextTick().deadline, first + 2'000'000 - 50'000);
  EXPECT_EQ(timer.overruns(), 0);
}

TEST(LoopTimer, SkipPolicyCountsMissedPeriodsAndRunsOneTick) {
  testing::FakeClock clock;
  LoopTimer timer(clock, {kPeriod, OverrunPolicy::kSkip, 5});
  const Nanoseconds start = clock.Now();
  timer.Start();
  clock.ScriptLateness({3'500'000});  // woke 3.5 periods late
  const Wake late = timer.WaitForNextTick();
  EXPECT_EQ(late.missed, 3);
  EXPECT_EQ(late.ticks, 1);
  EXPECT_EQ(timer.overruns(), 3);
  const Wake next = timer.WaitForNextTick();
  EXPECT_EQ(next.deadline, start + 5 * kPeriod);  // the next deadline still in the future, on the grid
  EXPECT_EQ(next.missed, 0);
}

TEST(LoopTimer, CatchUpRunsABoundedNumberOfExtraTicks) {
  testing::FakeClock clock;
  LoopTimer timer(clock, {kPeriod, OverrunPolicy::kCatchUp, 2});
  timer.Start();
  clock.ScriptLateness({3'200'000, 1'100'000});
  const Wake w = timer.WaitForNextTick();
  EXPECT_EQ(w.missed, 3);
  EXPECT_EQ(w.ticks, 3);  // this one and two made up; the third missed period is skipped
  EXPECT_EQ(timer.overruns(), 3);
  const Wake v = timer.WaitForNextTick();
  EXPECT_EQ(v.missed, 1);
  EXPECT_EQ(v.ticks, 2);
  EXPECT_EQ(timer.overruns(), 4);
}

TEST(LoopTimer, ComputeLongerThanAPeriodShowsAsAnOverrunAtTheNextWake) {
  testing::FakeClock clock;
  LoopTimer timer(clock, {kPeriod, OverrunPolicy::kSkip, 0});
  timer.Start();
  timer.WaitForNextTick();
  clock.Advance(2'500'000);  // the tick's work took 2.5 periods
  const Wake w = timer.WaitForNextTick();
  EXPECT_EQ(w.missed, 1);
  EXPECT_EQ(timer.overruns(), 1);
}

}  // namespace
}  // namespace lagrange
