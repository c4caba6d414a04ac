// What the receiver of a simulated arm under an external controller refuses
// (config/arm_external_plant.yaml), deterministic (tests/daemon/external_support.hpp):
// every bad torque counted with its reason and never applied, a second sender, a
// sequence that does not grow, torques while another controller is active, and
// malformed or truncated packets.

#include <gtest/gtest.h>
#include <lagrange/command_t.hpp>

#include <cstdint>
#include <string>
#include <vector>

#include "tests/daemon/external_support.hpp"
#include "tests/support/lcm_messages.hpp"

namespace lagrange {
namespace {

using namespace external_test;

using testing::Encode;

TEST_F(ExternalControllerLoop, EveryBadTorqueIsRefusedCountedWithItsReasonAndNeverApplied) {
  SendTorque({1.0, 0.5});
  arm_.Ticks(1);
  struct Bad {
    std::vector<double> tau;
    std::int64_t age_us;  // sent this long ago (< 0: ahead)
    std::int64_t run_id;
    std::string reason;  // the status's last_rejection begins with it
  };
  const std::vector<Bad> bad = {
      {{1.0, 2.0, 3.0}, 0, kClientRunId, "arm: torque: num_dofs is 3, expected 2"},
      {{5.0}, 0, kClientRunId, "arm: torque: num_dofs is 1, expected 2"},
      {{}, 0, kClientRunId, "arm: torque: num_dofs is 0, expected 2"},
      {{kNaN, 0.0}, 0, kClientRunId, "arm: torque: non-finite value in tau[0]"},
      {{0.0, -kInf}, 0, kClientRunId, "arm: torque: non-finite value in tau[1]"},
      {{2e6, 0.0}, 0, kClientRunId, "arm: torque: tau[0] = 2e+06 is out of range (|x| <= 1e+06)"},
      {{0.0, -1.5e6}, 0, kClientRunId, "arm: torque: tau[1] = -1.5e+06 is out of range"},
      {{3.0, 3.0}, 1'000'000, kClientRunId, "arm: torque: stale: sent 1 s ago (torque_timeout 0.05 s)"},
      {{3.0, 3.0}, 51'000, kClientRunId, "arm: torque: stale: sent 0.051 s ago"},
      {{3.0, 3.0}, -1'000'000, kClientRunId, "arm: torque: timestamp 1 s in the future"},
      {{3.0, 3.0}, 0, 0, "arm: torque: run_id 0: expected the sender's non-zero id"},
  };
  for (std::size_t k = 0; k < bad.size(); ++k) {
    arm_.SendTorque(Next(bad[k].tau, bad[k].age_us, bad[k].run_id));
    arm_.Ticks(1);
    EXPECT_EQ(arm_.stats().torques_rejected.load(), static_cast<std::int64_t>(k + 1));
    EXPECT_EQ(arm_.status().last_rejection.rfind(bad[k].reason, 0), 0u) << arm_.status().last_rejection;
    ASSERT_EQ(arm_.runtime().mode(0), Mode::kRunning);
    EXPECT_LT((Tau() - Vec({1.0, 0.5})).cwiseAbs().maxCoeff(), kExact) << "case " << k;  // the last good one
  }
  EXPECT_EQ(arm_.stats().torques_accepted.load(), 1);
  EXPECT_EQ(arm_.stats().decode_errors.load(), 0);
  EXPECT_EQ(arm_.status().torques_rejected, static_cast<std::int64_t>(bad.size()));
}

TEST_F(ExternalControllerLoop, ASecondSenderIsRefusedWhileTheFirstStreamsAndAcceptedOnceItLapses) {
  SendTorque({1.0, 0.5});  // received at W
  arm_.Ticks(1);
  const std::int64_t second = kClientRunId + 1;
  std::int64_t second_sequence = 0;
  for (int ms = 1; ms <= kTimeoutTicks; ++ms) {  // received at W + ms: the first still streams
    arm_.SendTorque(MakeTorque({-2.0, 1.0}, ++second_sequence, arm_.WallMicros(), second));
    arm_.Ticks(1);
    ASSERT_EQ(arm_.stats().torques_rejected.load(), ms);
    // Applied until it is torque_timeout old (counted from its send at W), then the fallback holds.
    if (ms < kTimeoutTicks) {
      ASSERT_LT((Tau() - Vec({1.0, 0.5})).cwiseAbs().maxCoeff(), kExact);
    }
  }
  EXPECT_EQ(arm_.runtime().mode(0), Mode::kHold);
  EXPECT_EQ(arm_.status().last_rejection.rfind("arm: torque: from a second sender (run_id 0000000000c11e48) while "
                                               "0000000000c11e47 streams",
                                               0),
            0u)
      << arm_.status().last_rejection;
  arm_.SendTorque(MakeTorque({-2.0, 1.0}, ++second_sequence, arm_.WallMicros(), second));  // W + 51 ms: lapsed
  arm_.Ticks(1);
  EXPECT_EQ(arm_.stats().torques_rejected.load(), kTimeoutTicks);
  EXPECT_EQ(arm_.stats().torques_accepted.load(), 2);
  EXPECT_EQ(arm_.runtime().mode(0), Mode::kRunning);
  EXPECT_LT((Tau() - Vec({-2.0, 1.0})).cwiseAbs().maxCoeff(), kExact);
  // Now the first is the second sender.
  SendTorque({1.0, 0.5});
  arm_.Ticks(1);
  EXPECT_EQ(arm_.stats().torques_rejected.load(), kTimeoutTicks + 1);
  EXPECT_LT((Tau() - Vec({-2.0, 1.0})).cwiseAbs().maxCoeff(), kExact);
}

TEST_F(ExternalControllerLoop, ATorqueWhoseSequenceDoesNotGrowIsRefused) {
  arm_.SendTorque(MakeTorque({1.0, 0.5}, 5, arm_.WallMicros()));
  arm_.Ticks(1);
  arm_.SendTorque(MakeTorque({3.0, 3.0}, 5, arm_.WallMicros()));  // a duplicate
  arm_.Ticks(1);
  EXPECT_EQ(arm_.status().last_rejection,
            "arm: torque: sequence 5 does not grow (last 5): a duplicate or reordered packet");
  arm_.SendTorque(MakeTorque({3.0, 3.0}, 4, arm_.WallMicros()));  // reordered
  arm_.Ticks(1);
  EXPECT_EQ(arm_.status().last_rejection.rfind("arm: torque: sequence 4 does not grow (last 5)", 0), 0u);
  EXPECT_EQ(arm_.stats().torques_rejected.load(), 2);
  EXPECT_LT((Tau() - Vec({1.0, 0.5})).cwiseAbs().maxCoeff(), kExact);
  arm_.SendTorque(MakeTorque({2.0, 1.0}, 9, arm_.WallMicros()));  // a gap is a loss, not a refusal
  arm_.Ticks(1);
  EXPECT_EQ(arm_.stats().torques_accepted.load(), 2);
  EXPECT_LT((Tau() - Vec({2.0, 1.0})).cwiseAbs().maxCoeff(), kExact);
}

TEST_F(ExternalControllerLoop, TorquesAreRefusedWhileAnotherControllerIsActive) {
  SendTorque({1.0, 0.5});
  arm_.Ticks(1);
  arm_.SendCommand(command_t::SWITCH_CONTROLLER, 1, "gravity-compensation");
  arm_.Ticks(1);
  ASSERT_EQ(arm_.states().back().controller, "gravity-compensation");
  SendTorque({3.0, 3.0});
  arm_.Ticks(1);
  EXPECT_EQ(arm_.stats().torques_rejected.load(), 1);
  EXPECT_EQ(arm_.status().last_rejection,
            "arm: torque: the instance is not running its external controller (active: gravity-compensation)");
  EXPECT_EQ(arm_.runtime().mode(0), Mode::kRunning);
  ExternalController* external = arm_.runtime().instance(0).external_controller(0);
  ASSERT_NE(external, nullptr);
  EXPECT_LT((external->torque() - Vec({1.0, 0.5})).cwiseAbs().maxCoeff(), kExact);  // never reached it
}

TEST_F(ExternalControllerLoop, EveryMalformedOrTruncatedTorqueIsExactlyOneDecodeError) {
  const Bytes whole = Encode(Next({1.0, 0.5}));
  std::int64_t expected = 0;
  for (std::size_t len = 0; len < whole.size(); ++len) {
    arm_.SendBytes("ARM_TORQUE", Bytes(whole.begin(), whole.begin() + static_cast<long>(len)));
    ++expected;
  }
  Bytes longer = whole;
  longer.push_back(0);
  arm_.SendBytes("ARM_TORQUE", longer);
  Bytes crafted = whole;  // num_dofs (after fingerprint, utime, run_id, sequence, state_tick) = 2³¹ − 1
  crafted[40] = 0x7f, crafted[41] = crafted[42] = crafted[43] = 0xff;
  arm_.SendBytes("ARM_TORQUE", crafted);
  arm_.SendBytes("ARM_TORQUE", Encode(MakeState({0.1, 0.2}, {0.0, 0.0}, 1, arm_.WallMicros())));  // another type
  expected += 3;
  arm_.Ticks(1);
  EXPECT_EQ(arm_.stats().decode_errors.load(), expected);
  EXPECT_EQ(arm_.status().decode_errors, expected);
  EXPECT_EQ(arm_.stats().torques_accepted.load(), 0);
  EXPECT_EQ(arm_.stats().torques_rejected.load(), 0);
  EXPECT_EQ(arm_.runtime().mode(0), Mode::kHold);
  arm_.SendBytes("ARM_TORQUE", whole);  // the whole packet passes
  arm_.Ticks(1);
  EXPECT_EQ(arm_.stats().torques_accepted.load(), 1);
  EXPECT_EQ(arm_.runtime().mode(0), Mode::kRunning);
}

}  // namespace
}  // namespace lagrange
