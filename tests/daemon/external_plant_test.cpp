// The controller of an external plant (config/arm_external_controller.yaml),
// deterministic (tests/daemon/external_support.hpp): its watchdog (waiting, the
// timeout, each bad state, re-arming by clear or reset, an estop it interrupted),
// and where its trajectory starts.

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

class ExternalPlantWatchdog : public ::testing::Test {
 protected:
  ExternalPlantWatchdog() : controller_(LoadScene(Config("arm_external_controller.yaml")), "CTRL_", kControllerRunId) {}
  void TearDown() override { EXPECT_TRUE(controller_.all_finite()); }

  // A measured state of tick `tick`, sent now (`age_us` ago).
  void SendState(std::int64_t tick, std::vector<double> q = {0.8, 0.1}, std::vector<double> qd = {0.2, -0.1},
                 std::int64_t age_us = 0) {
    controller_.SendState(MakeState(std::move(q), std::move(qd), tick, controller_.WallMicros() - age_us));
  }
  std::size_t Torques() const { return controller_.torques().size(); }
  Mode ModeNow() { return controller_.runtime().mode(0); }
  // Runs on a state, then lets it time out: stopped, one zero torque published.
  void StopByTimeout() {
    SendState(1);
    controller_.Ticks(kTimeoutTicks + 2);
    ASSERT_EQ(ModeNow(), Mode::kStopped);
    ASSERT_EQ(controller_.reason(), kMeasuredTimedOut);
  }
  // `ticks` more ticks, each after a fresh state: none is answered.
  void ExpectSilenceThroughFreshStates(int ticks) {
    const std::size_t before = Torques();
    for (int k = 0; k < ticks; ++k) {
      SendState(1000 + k);
      controller_.Ticks(1);
      ASSERT_EQ(ModeNow(), Mode::kStopped) << "tick " << k;
      ASSERT_EQ(Torques(), before) << "tick " << k;
    }
  }

  Daemon controller_;
};

TEST_F(ExternalPlantWatchdog, WaitsCommandingNothingUntilTheFirstMeasuredState) {
  controller_.Ticks(100);
  EXPECT_EQ(ModeNow(), Mode::kWaiting);
  EXPECT_EQ(controller_.states().back().mode, state_t::MODE_WAITING);
  EXPECT_EQ(controller_.reason(), kWaitingForState);
  EXPECT_EQ(Torques(), 0u);
  SendState(7);
  controller_.Ticks(1);
  EXPECT_EQ(ModeNow(), Mode::kRunning);
  EXPECT_EQ(controller_.reason(), "");
  ASSERT_EQ(Torques(), 1u);
  EXPECT_EQ(controller_.torques()[0].state_tick, 7);
}

// One torque_t per tick, answering the state that tick took; C's own state_t
// carries the measured q, qd and the torque it commanded.
TEST_F(ExternalPlantWatchdog, AnswersEveryFreshStateWithOneTorqueNamingItsTick) {
  for (int k = 0; k < 200; ++k) {
    const std::vector<double> q = {0.7 + 0.001 * k, 0.1 - 0.0005 * k}, qd = {0.2, -0.1 + 0.001 * k};
    SendState(1000 + k, q, qd);
    controller_.Ticks(1);
    ASSERT_EQ(Torques(), static_cast<std::size_t>(k + 1));
    const torque_t& t = controller_.torques().back();
    EXPECT_EQ(t.state_tick, 1000 + k);
    EXPECT_EQ(t.sequence, k + 1);
    EXPECT_EQ(t.num_dofs, 2);
    const state_t& s = controller_.states().back();
    EXPECT_EQ(s.mode, state_t::MODE_RUNNING);
    EXPECT_LT((Vec(s.q) - Vec(q)).cwiseAbs().maxCoeff(), kExact);
    EXPECT_LT((Vec(s.qd) - Vec(qd)).cwiseAbs().maxCoeff(), kExact);
    EXPECT_LT((Vec(s.tau) - Vec(t.tau)).cwiseAbs().maxCoeff(), kExact);
    EXPECT_GT(Vec(t.tau).norm(), 1.0);  // computed torque against gravity, not nothing
  }
  EXPECT_EQ(controller_.stats().measured_accepted.load(), 200);
  EXPECT_EQ(controller_.stats().measured_rejected.load(), 0);
}

TEST_F(ExternalPlantWatchdog, NoStateForTheTimeoutStopsWithOneZeroTorqueThenSilence) {
  SendState(5);          // sent at S
  controller_.Ticks(1);  // taken at S + 1 ms
  ASSERT_EQ(Torques(), 1u);
  for (int ms = 2; ms <= kTimeoutTicks; ++ms) {  // now − S ≤ state_timeout: still commanding, on that state
    controller_.Ticks(1);
    ASSERT_EQ(ModeNow(), Mode::kRunning) << ms << " ms after the state was sent";
    ASSERT_EQ(Torques(), static_cast<std::size_t>(ms));
    ASSERT_EQ(controller_.torques().back().state_tick, 5);
  }
  controller_.Ticks(1);  // 51 ms after the send
  EXPECT_EQ(ModeNow(), Mode::kStopped);
  EXPECT_EQ(controller_.states().back().mode, state_t::MODE_STOPPED);
  EXPECT_EQ(controller_.reason(), kMeasuredTimedOut);
  ASSERT_EQ(Torques(), static_cast<std::size_t>(kTimeoutTicks + 1));
  EXPECT_TRUE(AllZero(controller_.torques().back().tau));
  EXPECT_TRUE(AllZero(controller_.states().back().tau));
  controller_.Ticks(100);
  EXPECT_EQ(Torques(), static_cast<std::size_t>(kTimeoutTicks + 1));
  ExpectSilenceThroughFreshStates(100);  // fresh states do not resume it
}

TEST_F(ExternalPlantWatchdog, ClearRearmsItIntoWaitingAndTheNextStateRunsIt) {
  StopByTimeout();
  const std::size_t stopped = Torques();
  controller_.SendCommand(command_t::CLEAR_ESTOP, 41);
  controller_.Ticks(1);
  EXPECT_EQ(ModeNow(), Mode::kWaiting);
  EXPECT_EQ(controller_.reason(), kWaitingForState);
  controller_.Ticks(100);  // waiting has no timeout
  EXPECT_EQ(ModeNow(), Mode::kWaiting);
  EXPECT_EQ(Torques(), stopped);
  SendState(77);
  controller_.Ticks(1);
  EXPECT_EQ(ModeNow(), Mode::kRunning);
  ASSERT_EQ(Torques(), stopped + 1);
  EXPECT_EQ(controller_.torques().back().state_tick, 77);
  ASSERT_EQ(controller_.replies().size(), 1u);
  EXPECT_TRUE(controller_.replies()[0].accepted);
}

TEST_F(ExternalPlantWatchdog, ResetRearmsItIntoWaitingAndTheNextStateRunsIt) {
  StopByTimeout();
  const std::size_t stopped = Torques();
  controller_.SendCommand(command_t::RESET, 42);
  controller_.Ticks(1);
  EXPECT_EQ(ModeNow(), Mode::kWaiting);
  EXPECT_EQ(controller_.reason(), kWaitingForState);
  EXPECT_NEAR(controller_.states().back().t, 0.0, kExact);  // back to the start of its trajectory
  controller_.Ticks(100);
  EXPECT_EQ(Torques(), stopped);
  SendState(78);
  controller_.Ticks(1);
  EXPECT_EQ(ModeNow(), Mode::kRunning);
  ASSERT_EQ(Torques(), stopped + 1);
  EXPECT_EQ(controller_.torques().back().state_tick, 78);
}

// runtime.hpp: "reset keeps an estop". An emergency stop must not be lost
// because the plant's state went quiet while it held: a reset after the
// watchdog stopped an estopped instance must not let it command again.
TEST_F(ExternalPlantWatchdog, AResetKeepsAnEstopThatTheWatchdogThenStopped) {
  for (int k = 0; k < 10; ++k) {
    SendState(k);
    controller_.Ticks(1);
  }
  controller_.SendCommand(command_t::ESTOP, 51);
  SendState(10);
  controller_.Ticks(1);
  ASSERT_EQ(ModeNow(), Mode::kEstop);
  controller_.Ticks(kTimeoutTicks + 1);  // the plant goes quiet
  ASSERT_EQ(ModeNow(), Mode::kStopped);
  controller_.SendCommand(command_t::RESET, 52);
  controller_.Ticks(1);
  SendState(100);
  controller_.Ticks(1);
  EXPECT_NE(ModeNow(), Mode::kRunning) << "commanding again after an estop that nobody cleared";
  EXPECT_NE(ModeNow(), Mode::kWaiting) << "re-armed after an estop that nobody cleared";
}

// Each bad state trips the watchdog in the tick after it: stopped with its
// reason, one zero torque, then nothing whatever comes.
TEST(ExternalPlantTrips, EachBadStateStopsItWithItsReasonAndOneZeroTorque) {
  struct Case {
    std::vector<double> q, qd;
    std::int64_t run_id;
    const char* reason;
    std::string rejection;  // the status's last_rejection begins with it
  };
  const std::vector<Case> cases = {
      {{kNaN, 0.1},
       {0.0, 0.0},
       kPlantRunId,
       kMeasuredNotFinite,
       "arm_controller: measured state: non-finite value in q[0]"},
      {{0.8, 0.1},
       {0.0, kInf},
       kPlantRunId,
       kMeasuredNotFinite,
       "arm_controller: measured state: non-finite value in qd[1]"},
      {{2e6, 0.1},
       {0.0, 0.0},
       kPlantRunId,
       kMeasuredNotFinite,
       "arm_controller: measured state: q[0] = 2e+06 is out of range"},
      {{0.8, 0.1, 0.0},
       {0.0, 0.0, 0.0},
       kPlantRunId,
       kMeasuredWrongSize,
       "arm_controller: measured state: num_dofs is 3, expected 2"},
      {{0.8}, {0.0}, kPlantRunId, kMeasuredWrongSize, "arm_controller: measured state: num_dofs is 1, expected 2"},
      {{0.8, 0.1},
       {0.0, 0.0},
       kPlantRunId + 1,
       kMeasuredSecondSource,
       "arm_controller: measured state: from run_id 0123456789abcdf0 after 0123456789abcdef: a second source"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.rejection);
    Daemon controller(LoadScene(Config("arm_external_controller.yaml")), "CTRL_", kControllerRunId);
    for (int k = 0; k < 10; ++k) {
      controller.SendState(MakeState({0.8, 0.1}, {0.2, -0.1}, k, controller.WallMicros()));
      controller.Ticks(1);
    }
    ASSERT_EQ(controller.runtime().mode(0), Mode::kRunning);
    controller.SendState(MakeState(c.q, c.qd, 10, controller.WallMicros(), c.run_id));
    controller.Ticks(1);
    EXPECT_EQ(controller.runtime().mode(0), Mode::kStopped);
    EXPECT_EQ(controller.reason(), c.reason);
    EXPECT_EQ(controller.status().last_rejection.rfind(c.rejection, 0), 0u) << controller.status().last_rejection;
    EXPECT_EQ(controller.stats().measured_rejected.load(), 1);
    ASSERT_EQ(controller.torques().size(), 11u);
    EXPECT_TRUE(AllZero(controller.torques().back().tau));
    EXPECT_EQ(controller.states().back().mode, state_t::MODE_STOPPED);
    for (int k = 0; k < 100; ++k) {
      controller.SendState(MakeState({0.8, 0.1}, {0.2, -0.1}, 11 + k, controller.WallMicros(), c.run_id));
      controller.Ticks(1);
    }
    EXPECT_EQ(controller.torques().size(), 11u);
    EXPECT_EQ(controller.runtime().mode(0), Mode::kStopped);
    EXPECT_TRUE(controller.all_finite());  // a NaN measured is never published
  }
}

TEST_F(ExternalPlantWatchdog, AStaleStateIsRefusedAndCountedButOnlyTheTimeoutStopsIt) {
  SendState(1);  // sent at S, taken at S + 1 ms
  controller_.Ticks(1);
  for (int ms = 2; ms <= kTimeoutTicks; ++ms) {  // now − S ≤ state_timeout
    SendState(ms, {0.8, 0.1}, {0.2, -0.1}, 1'000'000);
    controller_.Ticks(1);
    ASSERT_EQ(ModeNow(), Mode::kRunning) << ms;
    ASSERT_EQ(controller_.stats().measured_rejected.load(), ms - 1);
    ASSERT_EQ(controller_.torques().back().state_tick, 1);  // answered with the fresh one still
  }
  EXPECT_EQ(controller_.status().last_rejection,
            "arm_controller: measured state: stale: sent 1 s ago (state_timeout 0.05 s)");
  SendState(100, {0.8, 0.1}, {0.2, -0.1}, 1'000'000);
  controller_.Ticks(1);
  EXPECT_EQ(ModeNow(), Mode::kStopped);
  EXPECT_EQ(controller_.reason(), kMeasuredTimedOut);
  EXPECT_EQ(controller_.stats().measured_accepted.load(), 1);
}

// An estop taken while running survives the watchdog: clear re-arms the plant
// with the estop still latched, so its first state brakes; a second clear
// then holds, as clear_estop does everywhere. Never straight to running.
TEST_F(ExternalPlantWatchdog, AnEstopTheWatchdogInterruptedBrakesAfterClearAndASecondClearHolds) {
  SendState(1);
  controller_.Ticks(1);
  controller_.SendCommand(command_t::ESTOP, 1);
  controller_.Ticks(1);
  ASSERT_EQ(ModeNow(), Mode::kEstop);
  controller_.Ticks(kTimeoutTicks + 2);
  ASSERT_EQ(ModeNow(), Mode::kStopped);
  controller_.SendCommand(command_t::CLEAR_ESTOP, 2);
  controller_.Ticks(1);
  EXPECT_EQ(ModeNow(), Mode::kWaiting);
  EXPECT_EQ(controller_.reason(), kWaitingEstopLatched);
  SendState(500);
  controller_.Ticks(1);
  EXPECT_EQ(ModeNow(), Mode::kEstop);
  for (int k = 1; k < 500; ++k) {  // the estop's dwell (0.5 s) out, braking from fresh states
    SendState(500 + k);
    controller_.Ticks(1);
  }
  ASSERT_EQ(ModeNow(), Mode::kEstop);
  controller_.SendCommand(command_t::CLEAR_ESTOP, 3);
  SendState(1000);
  controller_.Ticks(1);
  EXPECT_EQ(ModeNow(), Mode::kHold);
  EXPECT_EQ(controller_.reason(), kLeftEstop);
}

// Re-armed after the watchdog, an instance whose streamed setpoints timed out
// holds where the plant is; it does not run to the old setpoint.
TEST_F(ExternalPlantWatchdog, ClearAfterTheWatchdogHoldsWhenTheSetpointsHadTimedOut) {
  std::int64_t tick = 1;
  SendState(tick++);
  controller_.Ticks(1);
  controller_.input().PublishMessage(controller_.channels().setpoint,
                                     testing::MakeSetpoint({0.0, 1.5}, controller_.WallMicros()));
  for (int k = 0; k < 700; ++k) {  // past setpoint_timeout (0.5 s): hold
    SendState(tick++);
    controller_.Ticks(1);
  }
  ASSERT_EQ(ModeNow(), Mode::kHold);
  controller_.Ticks(kTimeoutTicks + 2);
  ASSERT_EQ(ModeNow(), Mode::kStopped);
  controller_.SendCommand(command_t::CLEAR_ESTOP, 1);
  controller_.Ticks(1);
  SendState(tick++);
  controller_.Ticks(1);
  EXPECT_EQ(ModeNow(), Mode::kHold);
  EXPECT_EQ(controller_.reason(), kSetpointsTimedOut);
  EXPECT_LT((Vec(controller_.states().back().q_des) - Vec(controller_.states().back().q)).cwiseAbs().maxCoeff(),
            kExact);  // held where the plant is
}

// The watchdog locks onto a source by its run_id: a state with run_id 0 is
// refused and counted, so a second sender can never hide behind 0.
TEST_F(ExternalPlantWatchdog, AMeasuredStateWithRunIdZeroIsRefusedAndNeverApplied) {
  SendState(1);
  controller_.Ticks(1);
  ASSERT_EQ(ModeNow(), Mode::kRunning);
  const std::int64_t rejected = controller_.stats().measured_rejected.load();
  controller_.SendState(MakeState({2.0, 2.0}, {0.0, 0.0}, 2, controller_.WallMicros(), 0));
  controller_.Ticks(1);
  EXPECT_EQ(controller_.stats().measured_rejected.load(), rejected + 1);
  EXPECT_EQ(controller_.status().last_rejection,
            "arm_controller: measured state: run_id 0: expected the sender's non-zero id");
  EXPECT_GT((Vec(controller_.states().back().q) - Vec({2.0, 2.0})).cwiseAbs().maxCoeff(), 0.5);
}

TEST_F(ExternalPlantWatchdog, PauseIsRefusedForAnExternalPlant) {
  SendState(1);
  controller_.Ticks(1);
  controller_.SendCommand(command_t::PAUSE, 9);
  SendState(2);
  controller_.Ticks(1);
  ASSERT_EQ(controller_.replies().size(), 1u);
  EXPECT_EQ(controller_.replies()[0].request_id, 9);
  EXPECT_FALSE(controller_.replies()[0].accepted);
  EXPECT_EQ(controller_.replies()[0].reason,
            "pause: an external plant keeps moving and cannot be frozen (estop brakes it)");
  EXPECT_EQ(ModeNow(), Mode::kRunning);
  EXPECT_EQ(Torques(), 2u);
}

// ------------------------------------------------------------------ where its trajectory starts

// An external plant's controller that starts (or restarts) on a robot that
// is not where its scene assumed starts its trajectory from the measured
// state, as libfranka's motion generators do: the shipped controller scene's
// sine is centred on the initial q (0.785, 0), the robot is at (1.2, -0.5).
TEST(ExternalPlantStart, TheTrajectoryStartsFromTheFirstMeasuredStateNotTheScenesInitialQ) {
  Runtime runtime(LoadScene(std::string(LAGRANGE_SOURCE_DIR) + "/config/arm_external_controller.yaml"));
  TickRecord record = runtime.MakeRecord();
  const VectorXd measured = Vec({1.2, -0.5});
  PostMeasured(runtime, measured, Vec({0.0, 0.0}), 1);
  runtime.Tick(kMs, record);
  ASSERT_EQ(runtime.mode(0), Mode::kRunning);
  // The sine's value at its start is its centre: the measured q, so nothing jumps.
  EXPECT_LT((record.instances[0].q_des - measured).norm(), 1e-12) << record.instances[0].q_des.transpose();
  // And a reset starts it from the scene's initial q again (then the next first state anchors it anew).
  runtime.instance(0).Reset();
  Setpoint sp(2);
  runtime.instance(0).SampleTrajectory(sp);
  EXPECT_LT((sp.q - runtime.instance(0).config().q0).norm(), 1e-12);
}

}  // namespace
}  // namespace lagrange
