// The fastest a frame can move within joint speed limits (plant/frame_speed.hpp),
// checked against the frame Jacobian (plant/kinematics.hpp): no joint velocity
// within the limits, at any configuration, moves the frame faster than the
// bound; and where one can reach it (a single joint, aligned axes), it is exact.

#include "plant/frame_speed.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <random>
#include <string>

#include "plant/chain.hpp"
#include "plant/kinematics.hpp"
#include "plant/urdf.hpp"

namespace lagrange {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kTol = 1e-12;

UrdfRobot Robot(const std::string& relative) { return LoadUrdf(std::string(LAGRANGE_SOURCE_DIR) + "/" + relative); }

// The robot's <limit velocity lower upper>, as lagranged reads them for poses.
struct Limits {
  VectorXd speed, lower, upper;
};
Limits LimitsOf(const UrdfRobot& robot) {
  const int n = robot.tree.num_dofs();
  Limits l{VectorXd(n), VectorXd(n), VectorXd(n)};
  for (int d = 0; d < n; ++d) {
    const UrdfJointProperties& p = robot.properties[static_cast<std::size_t>(d)];
    l.speed[d] = p.velocity.value_or(kInf);
    l.lower[d] = p.lower.value_or(-kInf);
    l.upper[d] = p.upper.value_or(kInf);
  }
  return l;
}

// The Panda's flange: every joint revolute, so its angular bound is Σ v_d, and
// no configuration and joint velocity within the limits (every vertex of the
// box of speeds, the extremes of a linear map) goes beyond either bound.
TEST(FrameSpeed, NoJointVelocityWithinThePandasLimitsMovesItsFlangeFasterThanTheBound) {
  const UrdfRobot panda = Robot("config/robots/panda.urdf");
  const Limits l = LimitsOf(panda);
  const Kinematics kinematics(panda.tree);
  const int flange = *kinematics.FrameIndex("panda_link8");
  const FrameSpeedBound bound = MaxFrameSpeed(panda.tree, flange, l.speed, l.lower, l.upper);
  EXPECT_NEAR(bound.angular, 4 * 2.175 + 3 * 2.61, kTol);  // rad/s: the URDF's limits, summed
  EXPECT_GT(bound.linear, 0.0);
  EXPECT_LT(bound.linear, 20.0);  // m/s: finite, from the arm's ~1 m of links

  const std::unique_ptr<KinematicsData> data = kinematics.MakeData();
  std::mt19937 rng{42};
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const int n = panda.tree.num_dofs();
  double fastest_linear = 0.0, fastest_angular = 0.0;
  for (int sample = 0; sample < 200; ++sample) {
    VectorXd q(n);
    for (int d = 0; d < n; ++d) q[d] = l.lower[d] + unit(rng) * (l.upper[d] - l.lower[d]);
    kinematics.ComputeFrameJacobian(*data, q, flange, FrameAxes::kWorldAligned);
    const Matrix6Xd& J = data->jacobian(flange, FrameAxes::kWorldAligned);
    for (int vertex = 0; vertex < (1 << n); ++vertex) {
      VectorXd qd(n);
      for (int d = 0; d < n; ++d) qd[d] = (vertex >> d & 1) ? l.speed[d] : -l.speed[d];
      const Vector6d twist = J * qd;
      fastest_linear = std::max(fastest_linear, twist.head<3>().norm());
      fastest_angular = std::max(fastest_angular, twist.tail<3>().norm());
    }
  }
  EXPECT_LE(fastest_linear, bound.linear);
  EXPECT_LE(fastest_angular, bound.angular);
  EXPECT_GT(fastest_angular, 0.5 * bound.angular) << "a bound, not a wild one";
}

// One revolute joint carrying a frame at distance L: ‖ω‖ = v, ‖ṗ‖ = v·L exactly.
TEST(FrameSpeed, ASingleJointsBoundIsItsExactSpeed) {
  ChainParams p;
  ChainLink link;
  link.m = 1.0;
  link.L = 0.7;
  p.links = {link};
  const RigidTree tree = ToRigidTree(p);
  const Kinematics kinematics(tree);
  const int tip = *kinematics.FrameIndex("tip");
  const VectorXd v = VectorXd::Constant(1, 3.0), none = VectorXd::Constant(1, kInf);
  const FrameSpeedBound bound = MaxFrameSpeed(tree, tip, v, -none, none);
  EXPECT_NEAR(bound.angular, 3.0, kTol);
  EXPECT_NEAR(bound.linear, 3.0 * 0.7, kTol);
}

// The built-in plants have no velocity limits: nothing bounds the frame.
TEST(FrameSpeed, WithoutVelocityLimitsTheFrameIsUnbounded) {
  ChainParams p;
  p.links.assign(6, ChainLink{});
  const RigidTree tree = ToRigidTree(p);
  const Kinematics kinematics(tree);
  const VectorXd none = VectorXd::Constant(6, kInf);
  const FrameSpeedBound bound = MaxFrameSpeed(tree, *kinematics.FrameIndex("tip"), none, -none, none);
  EXPECT_EQ(bound.linear, kInf);
  EXPECT_EQ(bound.angular, kInf);
}

}  // namespace
}  // namespace lagrange
