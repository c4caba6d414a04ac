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
