// A setpoint from the wire to a verdict (protocol/setpoint_check.hpp): the
// layout first (undecodable), then the instance's size, finite values within
// 1e6, and the scene's limits on q, each refusal naming the field.

#include "protocol/setpoint_check.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <vector>

#include "protocol/wire.hpp"
#include "tests/support/lcm_messages.hpp"

namespace lagrange {
namespace {

using Kind = SetpointVerdict::Kind;

SetpointRules TwoJoints() {
  SetpointRules rules;
  rules.n = 2;
  rules.lower = VectorXd::Constant(2, -std::numeric_limits<double>::infinity());
  rules.upper = VectorXd::Constant(2, std::numeric_limits<double>::infinity());
  return rules;
}

SetpointVerdict Check(const setpoint_t& s, const SetpointRules& rules = TwoJoints()) {
  const std::vector<std::uint8_t> bytes = testing::Encode(s);
  setpoint_t out;
  return CheckSetpoint(bytes.data(), bytes.size(), rules, out);
}

TEST(SetpointCheck, AWellFormedSetpointIsAcceptedAndDecoded) {
  const std::vector<std::uint8_t> bytes = testing::Encode(testing::MakeSetpoint({0.5, -0.25}, 7, {1.0, 2.0}));
  setpoint_t out;
  const SetpointVerdict v = CheckSetpoint(bytes.data(), bytes.size(), TwoJoints(), out);
  EXPECT_EQ(v.kind, Kind::kAccepted) << v.reason;
  EXPECT_EQ(out.utime, 7);
  EXPECT_EQ(out.q, (std::vector<double>{0.5, -0.25}));
  EXPECT_EQ(out.qd, (std::vector<double>{1.0, 2.0}));
}

TEST(SetpointCheck, APacketThatFailsItsLayoutIsUndecodable) {
  std::vector<std::uint8_t> bytes = testing::Encode(testing::MakeSetpoint({0.5, -0.25}, 7));
  bytes.pop_back();
  setpoint_t out;
  const SetpointVerdict v = CheckSetpoint(bytes.data(), bytes.size(), TwoJoints(), out);
  EXPECT_EQ(v.kind, Kind::kUndecodable);
  EXPECT_EQ(v.reason, ToString(WireCheck::kSizeMismatch));
}

TEST(SetpointCheck, TheWrongNumberOfJointsIsRejectedNamingBoth) {
  const SetpointVerdict v = Check(testing::MakeSetpoint({0.1, 0.2, 0.3}, 1));
  EXPECT_EQ(v.kind, Kind::kRejected);
  EXPECT_EQ(v.reason, "num_dofs is 3, expected 2");
}

TEST(SetpointCheck, NonFiniteAndHugeValuesAreRejectedNamingTheEntry) {
  SetpointVerdict v = Check(testing::MakeSetpoint({0.1, 0.2}, 1, {0.0, std::nan("")}));
  EXPECT_EQ(v.kind, Kind::kRejected);
  EXPECT_EQ(v.reason, "non-finite value in qd[1]");
  v = Check(testing::MakeSetpoint({2e6, 0.2}, 1));
  EXPECT_EQ(v.kind, Kind::kRejected);
  EXPECT_EQ(v.reason, "q[0] = 2e+06 is out of range (|x| <= 1e6)");
  v = Check(testing::MakeSetpoint({0.1, 0.2}, 1, {}, {std::numeric_limits<double>::infinity(), 0.0}));
  EXPECT_EQ(v.reason, "non-finite value in qdd[0]");
}

TEST(SetpointCheck, AQOutsideTheScenesLimitsIsRejectedWithThem) {
  SetpointRules rules = TwoJoints();
  rules.lower << -1.0, -1.0;
  rules.upper << 1.0, 1.0;
  EXPECT_EQ(Check(testing::MakeSetpoint({1.0, -1.0}, 1), rules).kind, Kind::kAccepted);  // the limits themselves
  const SetpointVerdict v = Check(testing::MakeSetpoint({0.0, 2.0}, 1), rules);
  EXPECT_EQ(v.kind, Kind::kRejected);
  EXPECT_EQ(v.reason, "q[1] = 2 is outside the setpoint limits [-1, 1]");
}

}  // namespace
}  // namespace lagrange

// Pose setpoints (pose_setpoint_t): every refusal names what is wrong.
namespace lagrange {
namespace {

PoseRules TcpRules() {
  PoseRules rules;
  rules.frame = "panda_hand_tcp";
  rules.lower = Eigen::Vector3d(-1.0, -1.0, 0.0);
  rules.upper = Eigen::Vector3d(1.0, 1.0, 1.5);
  rules.max_duration = 60.0;
  return rules;
}

pose_setpoint_t Pose(double x, double y, double z, std::string frame = "") {
  pose_setpoint_t m{};
  m.utime = 5;
  m.frame = std::move(frame);
  m.position[0] = x;
  m.position[1] = y;
  m.position[2] = z;
  m.orientation[0] = 0.0;  // a half turn about x: (w, x, y, z) = (0, 1, 0, 0)
  m.orientation[1] = 1.0;
  return m;
}

SetpointVerdict CheckPose(const pose_setpoint_t& m, const PoseRules& rules = TcpRules()) {
  const std::vector<std::uint8_t> bytes = testing::Encode(m);
  pose_setpoint_t out;
  return CheckPoseSetpoint(bytes.data(), bytes.size(), rules, out);
}

TEST(PoseSetpointCheck, AUnitPoseInsideTheWorkspaceForTheControllersFrameIsAccepted) {
  EXPECT_EQ(CheckPose(Pose(0.4, 0.0, 0.5)).kind, Kind::kAccepted);
  EXPECT_EQ(CheckPose(Pose(0.4, 0.0, 0.5, "panda_hand_tcp")).kind, Kind::kAccepted);
  pose_setpoint_t timed = Pose(0.4, 0.1, 0.5);
  timed.duration = 3.0;
  EXPECT_EQ(CheckPose(timed).kind, Kind::kAccepted);
  pose_setpoint_t streamed = Pose(0.4, 0.1, 0.5);
  streamed.twist[0] = 0.2;  // a streamed target with its velocity
  EXPECT_EQ(CheckPose(streamed).kind, Kind::kAccepted);
}

TEST(PoseSetpointCheck, EveryBadPoseIsRejectedNamingTheField) {
  const auto reason = [](const pose_setpoint_t& m, const PoseRules& rules = TcpRules()) {
    const SetpointVerdict v = CheckPose(m, rules);
    EXPECT_EQ(v.kind, Kind::kRejected);
    return v.reason;
  };
  EXPECT_EQ(reason(Pose(0.4, 0.0, 0.5, "panda_link8")),
            "frame 'panda_link8': the task-space controller moves 'panda_hand_tcp'");
  EXPECT_EQ(reason(Pose(0.4, std::nan(""), 0.5)), "non-finite value in position[1]");
  EXPECT_EQ(reason(Pose(0.4, 0.0, 2e6)), "position[2] = 2e+06 is out of range (|x| <= 1e6)");
  EXPECT_EQ(reason(Pose(0.4, 0.0, 1.6)), "position[2] = 1.6 m is outside the workspace [0, 1.5]");
  EXPECT_EQ(reason(Pose(-1.2, 0.0, 0.5)), "position[0] = -1.2 m is outside the workspace [-1, 1]");
  pose_setpoint_t m = Pose(0.4, 0.0, 0.5);
  m.orientation[1] = 0.9;
  EXPECT_EQ(reason(m), "orientation: expected a unit quaternion (w, x, y, z), got norm 0.9");
  m = Pose(0.4, 0.0, 0.5);
  m.orientation[1] = 0.0;  // all zeros: no rotation at all
  EXPECT_EQ(reason(m), "orientation: expected a unit quaternion (w, x, y, z), got norm 0");
  m = Pose(0.4, 0.0, 0.5);
  m.orientation[2] = std::numeric_limits<double>::infinity();
  EXPECT_EQ(reason(m), "non-finite value in orientation[2]");
  m = Pose(0.4, 0.0, 0.5);
  m.twist[5] = std::nan("");
  EXPECT_EQ(reason(m), "non-finite value in twist[5]");
  m = Pose(0.4, 0.0, 0.5);
  m.duration = -1.0;
  EXPECT_EQ(reason(m), "duration -1 s: expected 0 (at once) to 60 s");
  m.duration = 61.0;
  EXPECT_EQ(reason(m), "duration 61 s: expected 0 (at once) to 60 s");
  m.duration = std::nan("");
  EXPECT_EQ(reason(m), "non-finite value in duration[0]");
  m = Pose(0.4, 0.0, 0.5);
  m.duration = 2.0;
  m.twist[0] = 0.1;
  EXPECT_EQ(reason(m), "twist with duration 2 s: a timed move ends at rest (send zeros)");
}

// A feed-forward twist faster than the frame can move within the joints'
// velocity limits is refused, its linear and angular parts each against its own bound.
TEST(PoseSetpointCheck, ATwistFasterThanTheJointsAllowTheFrameIsRejected) {
  PoseRules rules = TcpRules();
  rules.max_linear_speed = 4.0;    // m/s
  rules.max_angular_speed = 16.5;  // rad/s
  pose_setpoint_t m = Pose(0.4, 0.0, 0.5);
  m.twist[2] = 3.0;
  m.twist[5] = 16.0;
  EXPECT_EQ(CheckPose(m, rules).kind, Kind::kAccepted);
  m.twist[5] = 264.0;  // issue 32: the Panda's wrist spun at this
  EXPECT_EQ(CheckPose(m, rules).reason,
            "twist: angular speed 264 rad/s is more than the joints' velocity limits allow 'panda_hand_tcp' (at most "
            "16.5 rad/s anywhere)");
  m.twist[5] = 0.0;
  m.twist[0] = 3.0;  // ‖(3, 0, 3)‖ = 4.24 m/s
  EXPECT_EQ(
      CheckPose(m, rules).reason,
      "twist: linear speed 4.24264 m/s is more than the joints' velocity limits allow 'panda_hand_tcp' (at most 4 "
      "m/s anywhere)");
}

// One rule for both targets: each is refused while the active controller follows the other.
TEST(TargetRule, AJointControllerRefusesPosesAndATaskSpaceOneRefusesJointSetpoints) {
  EXPECT_EQ(RefusedByController(TargetKind::kPose, false, "pd"),
            "the instance is not running a controller that moves a frame (active: pd; pose setpoints need a "
            "task-space controller or an mpc with a frame)");
  EXPECT_EQ(RefusedByController(TargetKind::kJointSetpoint, true, "cartesian-impedance"),
            "the instance is running a controller that moves a frame (active: cartesian-impedance), which follows "
            "pose "
            "setpoints (pose_setpoint_t, lagrangectl send --pose), not joint setpoints");
  EXPECT_EQ(RefusedByController(TargetKind::kPose, true, "operational-space"), "");
  EXPECT_EQ(RefusedByController(TargetKind::kJointSetpoint, false, "computed-torque"), "");
}

TEST(PoseSetpointCheck, AFrameNameFromTheBusIsEscapedInTheReason) {
  const SetpointVerdict v = CheckPose(Pose(0.4, 0.0, 0.5, "x\n\x1b[2J"));
  EXPECT_EQ(v.kind, Kind::kRejected);
  EXPECT_EQ(v.reason.find('\n'), std::string::npos);
  EXPECT_EQ(v.reason.find('\x1b'), std::string::npos);
}

TEST(PoseSetpointCheck, ASetpointOfAnotherTypeIsUndecodable) {
  const std::vector<std::uint8_t> bytes = testing::Encode(testing::MakeSetpoint({0.5, -0.25}, 7));
  pose_setpoint_t out;
  const SetpointVerdict v = CheckPoseSetpoint(bytes.data(), bytes.size(), TcpRules(), out);
  EXPECT_EQ(v.kind, Kind::kUndecodable);
  EXPECT_EQ(v.reason, ToString(WireCheck::kFingerprint));
}

}  // namespace
}  // namespace lagrange
