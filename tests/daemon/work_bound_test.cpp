// How lagranged times a cost before the loop (daemon/work_bound.hpp,
// FastestOfSamples), with an injected sample source and clock: nothing here is
// timed. Issue 32: the default scene was refused on a busy host because one
// controller's tick overhead was timed by a single sample the scheduler had
// preempted (12.6 ms, the whole per-controller budget at once).

#include <gtest/gtest.h>

#include <cstddef>
#include <vector>

#include "daemon/work_bound.hpp"

namespace lagrange {
namespace {

// Replays `samples` (s) in order, the last one over and over; the clock
// advances by each sample as it is taken, as the real one would.
struct Replay {
  std::vector<double> samples;
  std::size_t taken = 0;
  double clock = 0.0;
  double Sample() {
    const double s = samples[std::min(taken, samples.size() - 1)];
    ++taken;
    clock += s;
    return s;
  }
};

double Fastest(Replay& r, double budget) {
  return FastestOfSamples([&] { return r.Sample(); }, budget, [&] { return r.clock; });
}

constexpr double kPreempted = 12.6e-3;  // s: the sample issue 32 saw
constexpr double kTrue = 3e-6;          // s: what the same work costs unpreempted
constexpr double kBudget =
    50e-3 / 4;  // s: 50 ms shared by the default cart-pole's 4 controllers (LQR, PD, swing-up, none)

TEST(WorkBound, APreemptedFirstSampleThatSpendsTheBudgetIsNotTheCost) {
  Replay r{{kPreempted, kTrue}};
  EXPECT_EQ(Fastest(r, kBudget), kTrue);
  EXPECT_EQ(r.taken, static_cast<std::size_t>(kMinCostSamples)) << "the budget was spent: the minimum, no more";
}

TEST(WorkBound, SeveralPreemptedSamplesInARowAreNotTheCostEither) {
  Replay r{{kPreempted, kPreempted, kPreempted, kPreempted, kTrue}};
  EXPECT_EQ(Fastest(r, kBudget), kTrue);
}

TEST(WorkBound, SamplesContinueWhileTheBudgetLastsUpToTheMost) {
  Replay within{{kTrue}};
  EXPECT_EQ(Fastest(within, kBudget), kTrue);
  EXPECT_EQ(within.taken, static_cast<std::size_t>(kMaxCostSamples));
  Replay slow{{1e-3}};  // 1 ms each: the budget (12.5 ms) ends the sampling after 13
  EXPECT_EQ(Fastest(slow, kBudget), 1e-3);
  EXPECT_EQ(slow.taken, 13u);
}

TEST(WorkBound, NoBudgetStillTakesTheMinimumNumberOfSamples) {
  Replay r{{kPreempted, 2.0 * kTrue, kTrue}};
  EXPECT_EQ(Fastest(r, 0.0), kTrue);
  EXPECT_EQ(r.taken, static_cast<std::size_t>(kMinCostSamples));
}

}  // namespace
}  // namespace lagrange
