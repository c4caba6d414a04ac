// Poses and task-space trajectories (controllers/task_trajectory.hpp): the
// log and exp maps invert each other at every angle, the pose error is the
// position difference and the rotation vector, the minimum-jerk/slerp move
// starts and ends at its poses at rest with a unit quaternion throughout and
// a twist and acceleration that are its pose's derivatives, the circle stays
// on its circle and starts at rest, and sampling allocates nothing.

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>

#include "controllers/task_trajectory.hpp"
#include "tests/support/alloc_counter.hpp"

namespace lagrange {
namespace {

constexpr double kRoundOff = 1e-12;      // a few ulps of unit-sized quantities
constexpr double kFiniteDiff = 1e-5;     // central differences' step, s
constexpr double kDiffAgreement = 1e-6;  // O(step²) of the central difference times the 3rd derivative

Eigen::Vector3d RandomVector(std::mt19937& rng, double scale) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  return scale * Eigen::Vector3d(u(rng), u(rng), u(rng));
}

// A random rotation of angle below π (the log map's principal range).
Eigen::Quaterniond RandomRotation(std::mt19937& rng) {
  Eigen::Vector3d r = RandomVector(rng, 1.0);
  std::uniform_real_distribution<double> angle(0.0, 0.99 * std::numbers::pi);
  return ExpMap(angle(rng) * r.normalized());
}

Pose RandomPose(std::mt19937& rng) { return Pose{RandomVector(rng, 0.8), RandomRotation(rng)}; }

// The rotation between two orientations, rad: |log(a b⁻¹)|.
double AngleBetween(const Eigen::Quaterniond& a, const Eigen::Quaterniond& b) {
  return LogMap(a * b.conjugate()).norm();
}

TEST(PoseMaps, LogMapInvertsExpMapAtEveryAngleAndNearZero) {
  std::mt19937 rng(42);
  for (int k = 0; k < 200; ++k) {
    const double angle = k < 20 ? std::pow(10.0, -k / 2.0) : std::uniform_real_distribution<double>(0.0, 3.1)(rng);
    const Eigen::Vector3d r = angle * RandomVector(rng, 1.0).normalized();
    const Eigen::Quaterniond q = ExpMap(r);
    EXPECT_NEAR(q.norm(), 1.0, kRoundOff);
    EXPECT_LE((LogMap(q) - r).norm(), kRoundOff * std::max(1.0, angle)) << "angle " << angle;
    // −q is the same rotation: the same vector.
    EXPECT_LE((LogMap(Eigen::Quaterniond(-q.coeffs())) - r).norm(), kRoundOff * std::max(1.0, angle));
    // Eigen's own angle-axis agrees.
    const Eigen::AngleAxisd aa(q);
    EXPECT_NEAR(aa.angle(), angle, 1e-9);
  }
}

TEST(PoseMaps, PoseErrorIsThePositionDifferenceAndTheRotationVectorInWorldAxes) {
  std::mt19937 rng(7);
  for (int k = 0; k < 50; ++k) {
    const Pose measured = RandomPose(rng);
    const Eigen::Vector3d r = 0.9 * std::numbers::pi * RandomVector(rng, 1.0).normalized() *
                              std::uniform_real_distribution<double>(0.0, 1.0)(rng);
    const Eigen::Vector3d dp = RandomVector(rng, 0.3);
    // Desired: the measured turned by r about world axes, and moved by dp.
    const Pose desired{measured.position + dp, ExpMap(r) * measured.orientation};
    const Vector6d e = PoseError(desired, measured);
    EXPECT_LE((e.head<3>() - dp).norm(), kRoundOff);
    EXPECT_LE((e.tail<3>() - r).norm(), 1e-10);
    EXPECT_LE(PoseError(measured, measured).norm(), kRoundOff);
  }
}

TEST(PoseTrajectories, MinimumJerkStartsAndEndsAtItsPosesAtRestWithAUnitQuaternionThroughout) {
  std::mt19937 rng(3);
  for (int k = 0; k < 20; ++k) {
    const Pose from = RandomPose(rng), to = RandomPose(rng);
    const double T = 1.5;
    const PoseTrajectory traj = PoseTrajectory::MinimumJerk(from, to, T);
    PoseSetpoint s;
    traj.Sample(0.0, s);
    EXPECT_LE(PoseError(s.pose, from).norm(), kRoundOff);
    EXPECT_LE(s.twist.norm(), kRoundOff);
    EXPECT_LE(s.acceleration.norm(), kRoundOff);
    traj.Sample(T, s);
    EXPECT_LE(PoseError(s.pose, to).norm(), kRoundOff);
    EXPECT_LE(s.twist.norm(), kRoundOff);
    EXPECT_LE(s.acceleration.norm(), kRoundOff);
    traj.Sample(T * (1.0 - 1e-9), s);  // just before the end: continuous into it
    EXPECT_LE(PoseError(s.pose, to).norm(), 1e-9);
    traj.Sample(-1.0, s);  // before the start: the start
    EXPECT_LE(PoseError(s.pose, from).norm(), kRoundOff);
    // Halfway: half the rotation about one fixed axis (slerp), half the way.
    traj.Sample(0.5 * T, s);
    EXPECT_LE((s.pose.position - 0.5 * (from.position + to.position)).norm(), kRoundOff);
    const double total = AngleBetween(to.orientation, from.orientation);
    EXPECT_NEAR(AngleBetween(s.pose.orientation, from.orientation), 0.5 * total, 1e-10);
    EXPECT_NEAR(AngleBetween(to.orientation, s.pose.orientation), 0.5 * total, 1e-10);
    for (int i = 0; i <= 100; ++i) {
      traj.Sample(T * i / 100.0, s);
      EXPECT_NEAR(s.pose.orientation.norm(), 1.0, kRoundOff);
    }
  }
}

// The twist is the pose's derivative and the acceleration the twist's,
// by central differences: ṗ = (p(t+δ) − p(t−δ))/2δ, ω = log(q(t+δ) q(t−δ)⁻¹)/2δ.
void ExpectConsistentDerivatives(const PoseTrajectory& traj, double t) {
  PoseSetpoint s, plus, minus;
  traj.Sample(t, s);
  traj.Sample(t + kFiniteDiff, plus);
  traj.Sample(t - kFiniteDiff, minus);
  const double scale = std::max(1.0, s.twist.norm());
  const Eigen::Vector3d v = (plus.pose.position - minus.pose.position) / (2.0 * kFiniteDiff);
  const Eigen::Vector3d w = LogMap(plus.pose.orientation * minus.pose.orientation.conjugate()) / (2.0 * kFiniteDiff);
  EXPECT_LE((v - s.twist.head<3>()).norm(), kDiffAgreement * scale) << "t " << t;
  EXPECT_LE((w - s.twist.tail<3>()).norm(), kDiffAgreement * scale) << "t " << t;
  const Vector6d a = (plus.twist - minus.twist) / (2.0 * kFiniteDiff);
  EXPECT_LE((a - s.acceleration).norm(), kDiffAgreement * std::max(1.0, s.acceleration.norm())) << "t " << t;
}

TEST(PoseTrajectories, MinimumJerkTwistAndAccelerationAreItsPosesDerivatives) {
  std::mt19937 rng(11);
  const PoseTrajectory traj = PoseTrajectory::MinimumJerk(RandomPose(rng), RandomPose(rng), 2.0);
  for (double t : {0.1, 0.4, 0.77, 1.0, 1.3, 1.9}) ExpectConsistentDerivatives(traj, t);
}

// ρ = |center|: every sample is ρ from the centre, in the plane ⊥ n through
// the start; it starts at the start at rest and runs at ρ·2πf after the ramp,
// counter-clockwise about n; the orientation holds.
TEST(PoseTrajectories, CircleStaysOnItsCircleStartsAtRestAndRunsAtItsSpeed) {
  std::mt19937 rng(5);
  const Pose from = RandomPose(rng);
  const Eigen::Vector3d normal = Eigen::Vector3d(0.2, -0.3, 1.0).normalized();
  const Eigen::Vector3d center = normal.cross(Eigen::Vector3d::UnitX()).normalized() * 0.1;
  const double f = 0.5, ramp = 1.0, rho = 0.1;
  const PoseTrajectory traj = PoseTrajectory::Circle(from, center, normal, f, ramp);
  const Eigen::Vector3d c = from.position + center;
  PoseSetpoint s;
  traj.Sample(0.0, s);
  EXPECT_LE((s.pose.position - from.position).norm(), kRoundOff);
  EXPECT_LE(s.twist.norm(), kRoundOff);
  EXPECT_LE(s.acceleration.norm(), kRoundOff);
  for (int i = 0; i <= 400; ++i) {
    const double t = 0.01 * i;
    traj.Sample(t, s);
    EXPECT_NEAR((s.pose.position - c).norm(), rho, kRoundOff);
    EXPECT_NEAR((s.pose.position - c).dot(normal), 0.0, kRoundOff);
    EXPECT_LE(AngleBetween(s.pose.orientation, from.orientation), kRoundOff);
    if (t >= ramp) {
      EXPECT_NEAR(s.twist.head<3>().norm(), rho * 2.0 * std::numbers::pi * f, 1e-12);
      // Counter-clockwise about n: (p − c) × v along +n.
      EXPECT_GT((s.pose.position - c).cross(s.twist.head<3>()).dot(normal), 0.0);
    }
  }
  for (double t : {0.2, 0.5, 0.99, 1.0, 1.01, 2.5}) ExpectConsistentDerivatives(traj, t);
}

TEST(PoseTrajectories, AConfigStartsFromTheGivenPoseAndHoldsItByDefault) {
  std::mt19937 rng(9);
  const Pose start = RandomPose(rng);
  PoseTrajectoryConfig c;
  ASSERT_FALSE(ValidatePoseTrajectory(c));
  PoseSetpoint s;
  MakePoseTrajectory(c, start).Sample(3.0, s);
  EXPECT_LE(PoseError(s.pose, start).norm(), kRoundOff);
  EXPECT_LE(s.twist.norm(), 0.0);
  c.type = PoseTrajectory::Type::kMinimumJerk;
  EXPECT_EQ(*ValidatePoseTrajectory(c), "target: expected the pose to move to (position and orientation)");
  c.target = RandomPose(rng);
  c.duration = 0.0;
  EXPECT_EQ(*ValidatePoseTrajectory(c), "duration: expected a positive number of seconds");
  c.duration = 1.0;
  ASSERT_FALSE(ValidatePoseTrajectory(c));
  MakePoseTrajectory(c, start).Sample(0.0, s);
  EXPECT_LE(PoseError(s.pose, start).norm(), kRoundOff);
  c.target->orientation.coeffs() *= 1.01;
  EXPECT_EQ(*ValidatePoseTrajectory(c), "target.orientation: expected a unit quaternion [w, x, y, z]");
  c.target->position.x() = std::nan("");
  EXPECT_EQ(*ValidatePoseTrajectory(c), "target: expected a finite position and orientation");
  c = PoseTrajectoryConfig{};
  c.type = PoseTrajectory::Type::kCircle;
  ASSERT_FALSE(ValidatePoseTrajectory(c));
  c.center = Eigen::Vector3d(0.1, 0.0, 0.1);
  EXPECT_EQ(*ValidatePoseTrajectory(c),
            "center: expected an offset perpendicular to the normal (in the circle's plane)");
  c.center.setZero();
  EXPECT_EQ(*ValidatePoseTrajectory(c), "center: expected the circle's centre as a nonzero offset from the start, m");
  c.center = Eigen::Vector3d(0.1, 0.0, 0.0);
  c.normal = Eigen::Vector3d(0.0, 0.0, 2.0);
  EXPECT_EQ(*ValidatePoseTrajectory(c), "normal: expected a unit vector [nx, ny, nz]");
  c.normal = Eigen::Vector3d::UnitZ();
  c.frequency = -1.0;
  EXPECT_EQ(*ValidatePoseTrajectory(c), "frequency: expected a positive Hz");
}

TEST(PoseTrajectories, MakingSamplingAndAssigningAllocateNothing) {
  std::mt19937 rng(1);
  const Pose a = RandomPose(rng), b = RandomPose(rng);
  PoseTrajectoryConfig circle;
  circle.type = PoseTrajectory::Type::kCircle;
  PoseTrajectoryConfig move;
  move.type = PoseTrajectory::Type::kMinimumJerk;
  move.target = b;
  PoseSetpoint s;
  PoseTrajectory traj;
  double sum = 0.0;
  std::int64_t allocations = 0;
  {
    testing::AllocationCounter counter;
    for (int k = 0; k < 100; ++k) {
      traj = MakePoseTrajectory(k % 2 ? circle : move, a);
      traj.Sample(0.01 * k, s);
      sum += s.pose.position.sum() + LogMap(s.pose.orientation).sum() + PoseError(s.pose, b).sum();
    }
    allocations = counter.count();
  }
  EXPECT_EQ(allocations, 0);
  EXPECT_TRUE(std::isfinite(sum));
}

// A frame's target (PoseTarget, what the task-space and mpc controllers keep):
// the scene's trajectory and a move start from the pose measured at Begin, at
// Begin's time; a setpoint holds at once; Hold keeps where the target is, at
// rest; none of it allocates.
TEST(PoseTargets, AStartWaitsForTheMeasuredPoseAndASetpointHoldsAtOnce) {
  std::mt19937 rng(4);
  const Pose measured = RandomPose(rng), goal = RandomPose(rng), streamed = RandomPose(rng);
  std::int64_t allocations = 0;
  PoseSetpoint s;
  testing::AllocationCounter counter;
  PoseTarget target;  // hold the pose it starts at
  EXPECT_TRUE(target.start_pending());
  target.Begin(2.0, measured);
  EXPECT_FALSE(target.start_pending());
  target.Begin(3.0, goal);  // nothing pending: no effect
  target.Sample(5.0, s);
  EXPECT_LE(PoseError(s.pose, measured).norm(), kRoundOff);
  target.MoveTo(goal, 1.0);
  EXPECT_TRUE(target.start_pending());
  target.Begin(10.0, measured);
  target.Sample(10.0, s);
  EXPECT_LE(PoseError(s.pose, measured).norm(), kRoundOff) << "the move starts at Begin's time and pose";
  target.Sample(10.5, s);
  EXPECT_GT(s.twist.head<3>().norm(), 0.0) << "moving half-way";
  target.Hold(10.5);
  PoseSetpoint held;
  target.Sample(20.0, held);
  EXPECT_LE(PoseError(held.pose, s.pose).norm(), kRoundOff);
  EXPECT_LE(held.twist.norm(), 0.0) << "at rest";
  target.Set(PoseSetpoint{streamed, Vector6d::Ones(), Vector6d::Zero()});
  EXPECT_FALSE(target.start_pending());
  target.Sample(30.0, s);
  EXPECT_LE(PoseError(s.pose, streamed).norm(), kRoundOff);
  EXPECT_EQ(s.twist, Vector6d::Ones()) << "the sender's feed-forward";
  allocations = counter.count();
  EXPECT_EQ(allocations, 0);
}

}  // namespace
}  // namespace lagrange
