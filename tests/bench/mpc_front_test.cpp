// bench/mpc_front.hpp: which runs of bench/mpc_sweep are on the work-precision
// front (mean solve time against tracking cost, both minimised), and from when
// a run's success condition held to its end.

#include "bench/mpc_front.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <vector>

namespace lagrange::bench {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kTolerance = 1e-12;  // s

TEST(MpcFront, KeepsOnlyTheRunsNoOtherBeatsOnBothTimeAndCost) {
  //                                time  cost
  const std::vector<FrontPoint> p{{1.0, 10.0, true},  // fastest: on
                                  {2.0, 5.0, true},   // on
                                  {3.0, 6.0, true},   // slower and dearer than the one before: off
                                  {4.0, 1.0, true},   // cheapest: on
                                  {2.0, 7.0, true}};  // as fast as the second, dearer: off
  EXPECT_EQ(ParetoFront(p), (std::vector<bool>{true, true, false, true, false}));
}

TEST(MpcFront, AFailedRunIsNeverOnItNorPushesAnotherOff) {
  const std::vector<FrontPoint> p{{1.0, 1.0, false},  // would dominate everything, but failed
                                  {2.0, 5.0, true},
                                  {3.0, 4.0, true}};
  EXPECT_EQ(ParetoFront(p), (std::vector<bool>{false, true, true}));
}

TEST(MpcFront, EqualRunsAreBothOnItAndNonFiniteOnesAreNot) {
  const std::vector<FrontPoint> p{{2.0, 3.0, true}, {2.0, 3.0, true}, {std::nan(""), 1.0, true}, {1.0, kInf, true}};
  EXPECT_EQ(ParetoFront(p), (std::vector<bool>{true, true, false, false}));
}

TEST(MpcFront, HeldSinceRestartsAtEveryLapseAndIsUnsetWhenTheRunEndsOutside) {
  HeldSince held;
  EXPECT_TRUE(std::isnan(held.Since()));
  held.Add(0.1, true);
  held.Add(0.2, false);
  held.Add(0.3, true);
  held.Add(0.4, true);
  EXPECT_NEAR(held.Since(), 0.3, kTolerance) << "the stretch that reaches the latest sample";
  EXPECT_TRUE(held.HeldFor(0.2, 0.5));
  EXPECT_FALSE(held.HeldFor(0.3, 0.5));
  held.Add(0.5, false);
  EXPECT_TRUE(std::isnan(held.Since()));
  EXPECT_FALSE(held.HeldFor(0.0, 0.5)) << "a run that ends outside never held";
}

}  // namespace
}  // namespace lagrange::bench
