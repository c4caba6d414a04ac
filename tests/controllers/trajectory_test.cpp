// Trajectory generators: boundary conditions and derivatives that agree with
// their positions.

#include <gtest/gtest.h>

#include <cmath>

#include "controllers/trajectory.hpp"

namespace lagrange {
namespace {

VectorXd V(std::initializer_list<double> xs) {
  VectorXd v(static_cast<int>(xs.size()));
  int i = 0;
  for (double x : xs) v[i++] = x;
  return v;
}

// Central differences of q and qd match qd and qdd.
void ExpectConsistentDerivatives(const Trajectory& traj, double t0, double t1) {
  constexpr double h = 1e-5;
  Setpoint a(2), b(2), mid(2);
  for (double t = t0; t < t1; t += (t1 - t0) / 37.0) {
    traj.Sample(t - h, a);
    traj.Sample(t + h, b);
    traj.Sample(t, mid);
    EXPECT_LT(((b.q - a.q) / (2 * h) - mid.qd).norm(), 1e-6 * (1.0 + mid.qd.norm())) << traj.name() << " t=" << t;
    EXPECT_LT(((b.qd - a.qd) / (2 * h) - mid.qdd).norm(), 1e-5 * (1.0 + mid.qdd.norm())) << traj.name() << " t=" << t;
  }
}

TEST(MinimumJerk, StartsAtTheStateEndsAtRestOnTheTarget) {
  const VectorXd q0 = V({0.1, -0.2}), qd0 = V({0.5, 0.0}), target = V({1.0, 0.4});
  auto traj = MakeMinimumJerk(q0, qd0, VectorXd::Zero(2), target, 2.0);
  Setpoint s(2);
  traj->Sample(0.0, s);
  EXPECT_LT((s.q - q0).norm(), 1e-15);
  EXPECT_LT((s.qd - qd0).norm(), 1e-14);
  EXPECT_LT(s.qdd.norm(), 1e-14);
  traj->Sample(2.0 - 1e-12, s);  // the polynomial itself lands on the target
  EXPECT_LT((s.q - target).norm(), 1e-11);
  traj->Sample(2.0, s);
  EXPECT_LT((s.q - target).norm(), 1e-14);
  EXPECT_LT(s.qd.norm(), 1e-14);
  EXPECT_LT(s.qdd.norm(), 1e-13);
  traj->Sample(5.0, s);  // holds after the move
  EXPECT_LT((s.q - target).norm(), 1e-15);
  ExpectConsistentDerivatives(*traj, 0.01, 1.99);
}

TEST(MinimumJerk, FromRestIsTheClassicQuinticWithPeakSpeedAtHalfTime) {
  auto traj = MakeMinimumJerk(V({0.0, 0.0}), VectorXd::Zero(2), VectorXd::Zero(2), V({1.0, -2.0}), 4.0);
  Setpoint s(2);
  traj->Sample(2.0, s);
  EXPECT_NEAR(s.q[0], 0.5, 1e-15);
  EXPECT_NEAR(s.qd[0], 1.875 * 1.0 / 4.0, 1e-14);  // peak 15/8 · distance / duration
  EXPECT_NEAR(s.qdd[0], 0.0, 1e-14);
  traj->Sample(1.0, s);
  const double x = 0.25;
  EXPECT_NEAR(s.q[1], -2.0 * (10 * x * x * x - 15 * x * x * x * x + 6 * x * x * x * x * x), 1e-14);
}

TEST(Sine, DerivativesMatchAndAmplitudeIsAroundTheCenter) {
  auto traj = MakeSine(V({0.3, -0.1}), V({0.5, 0.2}), V({1.0, 0.25}));
  Setpoint s(2);
  traj->Sample(0.25, s);  // a quarter period of joint 0
  EXPECT_NEAR(s.q[0], 0.8, 1e-15);
  EXPECT_NEAR(s.qd[0], 0.0, 1e-14);
  ExpectConsistentDerivatives(*traj, 0.0, 3.0);
}

TEST(Step, JumpsAtItsTimeAndStaysAtRest) {
  auto traj = MakeStep(V({0.0, 0.0}), V({1.0, 2.0}), 0.5);
  Setpoint s(2);
  traj->Sample(0.49, s);
  EXPECT_EQ(s.q, V({0.0, 0.0}));
  traj->Sample(0.5, s);
  EXPECT_EQ(s.q, V({1.0, 2.0}));
  EXPECT_EQ(s.qd.norm() + s.qdd.norm(), 0.0);
}

// StartFrom starts the motion over from a measured state; what the scene
// fixed (a target, an explicit hold or centre) stays.
TEST(StartFrom, EveryGeneratorStartsFromTheGivenStateAndKeepsWhatTheSceneFixed) {
  const VectorXd q = V({1.2, -0.5}), qd = V({0.3, 0.0});
  Setpoint s(2);
  auto jerk = MakeMinimumJerk(V({0.0, 0.0}), V({0.0, 0.0}), V({0.0, 0.0}), V({1.0, 1.0}), 2.0);
  jerk->StartFrom(q, qd);
  jerk->Sample(0.0, s);
  EXPECT_EQ(s.q, q);
  EXPECT_NEAR((s.qd - qd).norm(), 0.0, 1e-15);
  jerk->Sample(2.0, s);
  EXPECT_EQ(s.q, V({1.0, 1.0}));  // the target stays
  auto step = MakeStep(V({0.0, 0.0}), V({1.0, 2.0}), 0.5);
  step->StartFrom(q, qd);
  step->Sample(0.0, s);
  EXPECT_EQ(s.q, q);
  auto defaulted = MakeHold(V({0.0, 0.0}), /*follows_start=*/true), fixed = MakeHold(V({0.0, 0.0}));
  defaulted->StartFrom(q, qd);
  fixed->StartFrom(q, qd);
  defaulted->Sample(1.0, s);
  EXPECT_EQ(s.q, q);
  fixed->Sample(1.0, s);
  EXPECT_EQ(s.q, V({0.0, 0.0}));
  auto sine = MakeSine(V({0.0, 0.0}), V({0.5, 0.2}), V({1.0, 0.25}), /*follows_start=*/true);
  sine->StartFrom(q, qd);
  sine->Sample(0.0, s);
  EXPECT_NEAR((s.q - q).norm(), 0.0, 1e-15);
}

}  // namespace
}  // namespace lagrange
