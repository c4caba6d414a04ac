// A simulated arm under an external controller (config/arm_external_plant.yaml),
// deterministic (tests/daemon/external_support.hpp): hold until a torque, torques
// applied within the limits, the timeout, the fallback, switching to and from the
// external controller, and the line logged when it holds on for a new reason.

#include <gtest/gtest.h>
#include <lagrange/command_t.hpp>

#include <spdlog/sinks/ostream_sink.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cstdio>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "tests/daemon/external_support.hpp"
#include "tests/support/lcm_messages.hpp"
#include "tests/support/process.hpp"

namespace lagrange {
namespace {

using namespace external_test;

constexpr double kHoldDrift = 1e-9;    // rad: an exact gravity compensation holds a pose at rest to round-off
constexpr double kHoldTorque = 1e-6;   // N·m: pushing G(q) and nothing more
constexpr double kMoved = 1e-3;        // rad: a pose told apart from another
constexpr double kSettledHold = 1e-4;  // rad: the fallback's PD 1 s after catching a moving arm (measured 2.4e-5)

TEST_F(ExternalControllerLoop, BeforeTheFirstTorqueTheFallbackHoldsThePoseAgainstGravity) {
  const VectorXd q0 = arm_.runtime().instance(0).config().q0;
  double drift = 0.0;
  for (int k = 0; k < 1000; ++k) {
    arm_.Ticks(1);
    ASSERT_EQ(arm_.runtime().mode(0), Mode::kHold) << "tick " << k;
    ASSERT_EQ(arm_.states().back().mode, state_t::MODE_HOLD);
    ASSERT_EQ(arm_.reason(), kNoTorqueYet);
    drift = std::max(drift, (Q() - q0).cwiseAbs().maxCoeff());
  }
  EXPECT_LE(drift, kHoldDrift);
  // Held against gravity, not resting: the fallback pushes G(q0).
  EXPECT_LT((Tau() - Gravity(q0)).cwiseAbs().maxCoeff(), kHoldTorque);
  EXPECT_GT(Gravity(q0).norm(), 1.0);
  EXPECT_EQ(arm_.states().back().controller, "external");
}

TEST_F(ExternalControllerLoop, TheFirstTorqueRunsTheArmAndEachIsAppliedWithinTheTorqueLimits) {
  arm_.Ticks(10);
  struct Case {
    std::vector<double> sent, applied;  // limits [40, 15] N·m
  };
  const std::vector<Case> cases = {{{1.5, -0.5}, {1.5, -0.5}},
                                   {{100.0, -3.0}, {40.0, -3.0}},
                                   {{-50.0, 20.0}, {-40.0, 15.0}},
                                   {{0.0, -1e6}, {0.0, -15.0}}};
  for (const Case& c : cases) {
    SendTorque(c.sent);
    arm_.Ticks(1);
    EXPECT_EQ(arm_.runtime().mode(0), Mode::kRunning);
    EXPECT_EQ(arm_.states().back().mode, state_t::MODE_RUNNING);
    EXPECT_EQ(arm_.reason(), "");
    EXPECT_LT((Tau() - Vec(c.applied)).cwiseAbs().maxCoeff(), kExact) << Tau().transpose();
  }
  EXPECT_EQ(arm_.stats().torques_accepted.load(), static_cast<std::int64_t>(cases.size()));
  EXPECT_EQ(arm_.status().torques_accepted, static_cast<std::int64_t>(cases.size()));
}

class GravityCompensatedClient : public ExternalControllerLoop {
 protected:
  GravityCompensatedClient() : ExternalControllerLoop(LoadScene(Config("arm_impedance_client.yaml"))) {}
};

// compensate_gravity: τ = clip(τ_sent + G(q)), G at the state the tick starts from.
TEST_F(GravityCompensatedClient, TheAppliedTorqueIsTheSentOnePlusGravityWithinTheLimits) {
  arm_.Ticks(10);
  const VectorXd limits = arm_.runtime().instance(0).config().torque_limits;
  for (const std::vector<double>& sent : {std::vector<double>{0.5, -0.2}, {2.0, 1.0}, {39.0, -14.9}, {-45.0, 0.0}}) {
    const VectorXd q_start = Q();
    SendTorque(sent);
    arm_.Ticks(1);
    ASSERT_EQ(arm_.runtime().mode(0), Mode::kRunning);
    const VectorXd expected = (Vec(sent) + Gravity(q_start)).cwiseMax(-limits).cwiseMin(limits);
    EXPECT_LT((Tau() - expected).cwiseAbs().maxCoeff(), 1e-9) << Tau().transpose() << " vs " << expected.transpose();
  }
}

TEST_F(ExternalControllerLoop, TorquesStoppingEnterHoldAtTheFirstTickPastTheTimeoutNeverEarlier) {
  // One torque, slightly more than gravity at q0: the arm rises until the hold.
  const VectorXd lift = Gravity(arm_.runtime().instance(0).config().q0) + Vec({0.5, 0.2});
  SendTorque({lift[0], lift[1]});  // sent at S (age 0 on arrival)
  arm_.Ticks(1);                   // taken at S + 1 ms
  ASSERT_EQ(arm_.runtime().mode(0), Mode::kRunning);
  // The timeout counts from the send, not from the take: a torque is never
  // applied once older than torque_timeout, however long it waited.
  for (int ms = 2; ms <= kTimeoutTicks; ++ms) {  // now − S = ms ≤ torque_timeout
    arm_.Ticks(1);
    ASSERT_EQ(arm_.runtime().mode(0), Mode::kRunning) << ms << " ms after the torque was sent";
    ASSERT_LT((Tau() - lift).cwiseAbs().maxCoeff(), kExact);  // the torque is held until then
  }
  arm_.Ticks(1);  // now − S = 51 ms > 50 ms
  EXPECT_EQ(arm_.runtime().mode(0), Mode::kHold);
  EXPECT_EQ(arm_.reason(), kTorquesTimedOut);
  const VectorXd held = Vec(arm_.states().back().q_des);
  EXPECT_GT((held - arm_.runtime().instance(0).config().q0).cwiseAbs().maxCoeff(), kMoved);
  arm_.Ticks(1000);
  EXPECT_EQ(arm_.runtime().mode(0), Mode::kHold);
  EXPECT_LT((Q() - held).cwiseAbs().maxCoeff(), kSettledHold);  // the fallback holds where the stream stopped
  SendTorque({2.0, -1.0});
  arm_.Ticks(1);
  EXPECT_EQ(arm_.runtime().mode(0), Mode::kRunning);
  EXPECT_EQ(arm_.reason(), "");
  EXPECT_LT((Tau() - Vec({2.0, -1.0})).cwiseAbs().maxCoeff(), kExact);
}

class ZeroTorqueOnTimeout : public ExternalControllerLoop {
 protected:
  ZeroTorqueOnTimeout()
      : ExternalControllerLoop(ArmScene("{type: external, torque_timeout: 0.05}", "    on_timeout: zero-torque\n")) {}
};

TEST_F(ZeroTorqueOnTimeout, HoldAppliesNoTorqueBeforeTheFirstTorqueAndAfterTheStreamStops) {
  for (int k = 0; k < 100; ++k) {
    arm_.Ticks(1);
    ASSERT_EQ(arm_.runtime().mode(0), Mode::kHold);
    ASSERT_LT(Tau().cwiseAbs().maxCoeff(), kExact);
  }
  SendTorque({1.0, 0.5});
  arm_.Ticks(1);
  EXPECT_EQ(arm_.runtime().mode(0), Mode::kRunning);
  EXPECT_LT((Tau() - Vec({1.0, 0.5})).cwiseAbs().maxCoeff(), kExact);
  arm_.Ticks(kTimeoutTicks + 1);
  EXPECT_EQ(arm_.runtime().mode(0), Mode::kHold);
  EXPECT_EQ(arm_.reason(), kTorquesTimedOut);
  for (int k = 0; k < 100; ++k) {
    arm_.Ticks(1);
    ASSERT_LT(Tau().cwiseAbs().maxCoeff(), kExact);
  }
}

// The brake B = [3, 1] N·m·s/rad within tight limits [2, 0.5] N·m: the arm
// sinks under gravity and the brake saturates.
class BrakeFallback : public ExternalControllerLoop {
 protected:
  BrakeFallback()
      : ExternalControllerLoop(ArmScene("{type: external, torque_timeout: 0.05, fallback: brake}",
                                        "    estop_damping: [3, 1]\n", "[2, 0.5]")) {}
};

TEST_F(BrakeFallback, HoldAppliesMinusBTimesTheVelocityWithinTheLimits) {
  const VectorXd B = Vec({3.0, 1.0}), limits = Vec({2.0, 0.5});
  VectorXd qd_start = VectorXd::Zero(2);  // the state each tick starts from
  int clipped = 0;
  for (int k = 0; k < 300; ++k) {
    arm_.Ticks(1);
    ASSERT_EQ(arm_.runtime().mode(0), Mode::kHold);
    const VectorXd brake = -B.cwiseProduct(qd_start);
    const VectorXd expected = brake.cwiseMax(-limits).cwiseMin(limits);
    ASSERT_LT((Tau() - expected).cwiseAbs().maxCoeff(), kExact) << "tick " << k;
    clipped += (brake.cwiseAbs().array() > limits.array()).any();
    qd_start = Vec(arm_.states().back().qd);
  }
  EXPECT_GT(clipped, 0);                           // the limits were reached
  EXPECT_GT(qd_start.cwiseAbs().maxCoeff(), 0.1);  // and the arm moved: the brake had work to do
}

// A pause does not make an old torque young: after a resume the instance
// holds at once rather than apply a torque older than torque_timeout.
TEST_F(ExternalControllerLoop, ResumeNeverAppliesATorqueOlderThanTheTimeout) {
  SendTorque({5.0, 2.0});
  arm_.Ticks(1);
  ASSERT_EQ(arm_.runtime().mode(0), Mode::kRunning);
  arm_.SendCommand(command_t::PAUSE, 1);
  arm_.Ticks(1);
  ASSERT_EQ(arm_.runtime().mode(0), Mode::kPaused);
  arm_.Ticks(2000);  // the client is long gone
  arm_.SendCommand(command_t::RESUME, 2);
  arm_.Ticks(1);
  EXPECT_EQ(arm_.runtime().mode(0), Mode::kHold);
  EXPECT_EQ(arm_.reason(), kTorquesTimedOut);
  EXPECT_GT((Tau() - Vec({5.0, 2.0})).cwiseAbs().maxCoeff(), 0.1);
}

// Switching from a torque hold to a setpoint controller whose streamed
// setpoints timed out long ago holds; it does not run to the old setpoint.
TEST_F(ExternalControllerLoop, SwitchingAwayFromATorqueHoldHoldsWhenTheSetpointsHadTimedOut) {
  arm_.SendCommand(command_t::SWITCH_CONTROLLER, 1, "gravity-compensation");
  arm_.Ticks(1);
  arm_.input().PublishMessage(arm_.channels().setpoint, testing::MakeSetpoint({0.0, 1.5}, arm_.WallMicros()));
  arm_.Ticks(3000);  // setpoint_timeout (0.5 s) long past: hold
  ASSERT_EQ(arm_.runtime().mode(0), Mode::kHold);
  const VectorXd held = Vec(arm_.states().back().q_des);
  arm_.SendCommand(command_t::SWITCH_CONTROLLER, 2, "external");
  arm_.Ticks(1);
  ASSERT_EQ(arm_.reason(), kNoTorqueYet);
  arm_.SendCommand(command_t::SWITCH_CONTROLLER, 3, "gravity-compensation");
  arm_.Ticks(1);
  EXPECT_EQ(arm_.runtime().mode(0), Mode::kHold);
  EXPECT_EQ(arm_.reason(), kSetpointsTimedOut);
  EXPECT_LT((Vec(arm_.states().back().q_des) - held).cwiseAbs().maxCoeff(), 1e-3);  // still where it held
  arm_.Ticks(1000);
  EXPECT_EQ(arm_.runtime().mode(0), Mode::kHold);  // an old setpoint is never taken up again
}

// What the daemon logs while it lives (the publisher logs through spdlog's
// default logger), each line as lagranged writes it after its timestamp:
// "LEVEL MESSAGE", at lagranged's default level (info).
class CapturedLog {
 public:
  CapturedLog() : previous_(spdlog::default_logger()) {
    auto logger = std::make_shared<spdlog::logger>("captured", std::make_shared<spdlog::sinks::ostream_sink_mt>(out_));
    logger->set_pattern("%l %v");
    logger->set_level(spdlog::level::info);
    spdlog::set_default_logger(std::move(logger));
  }
  ~CapturedLog() { spdlog::set_default_logger(previous_); }
  CapturedLog(const CapturedLog&) = delete;
  CapturedLog& operator=(const CapturedLog&) = delete;

  std::vector<std::string> Lines() const { return testing::Lines(out_.str()); }
  // The lines logged after the first `n`.
  std::vector<std::string> LinesAfter(std::size_t n) const {
    const std::vector<std::string> all = Lines();
    return {all.begin() + static_cast<std::ptrdiff_t>(std::min(n, all.size())), all.end()};
  }

 private:
  std::ostringstream out_;
  std::shared_ptr<spdlog::logger> previous_;
};

// t as the daemon's log lines print it: "3.002".
std::string LoggedT(double t) {
  char text[32];
  std::snprintf(text, sizeof text, "%.3f", t);
  return text;
}

// An instance whose first tick is in hold (the external controller has sent
// no torque yet) logs that it starts there, never "running -> hold": it was
// never running.
TEST_F(ExternalControllerLoop, AnInstanceThatStartsInHoldSaysSoRatherThanThatItLeftRunning) {
  const CapturedLog log;
  arm_.Ticks(5);
  ASSERT_EQ(arm_.runtime().mode(0), Mode::kHold);
  ASSERT_FALSE(log.Lines().empty());
  EXPECT_EQ(log.Lines().front(), "info arm: starts in hold at t = " + LoggedT(arm_.states().front().t) +
                                     " s (no torque yet on the external controller's channel)");
  for (const std::string& line : log.Lines()) EXPECT_EQ(line.find("running -> hold"), std::string::npos) << line;
}

// An instance that stays in hold for a new reason logs one line saying so,
// "NAME: still hold at t = .. s, now (REASON)", never "hold -> hold": held
// after its setpoints timed out, switched to the external controller (hold
// until its first torque), then back (hold: the setpoints had timed out).
TEST_F(ExternalControllerLoop, HoldingOnForANewReasonIsLoggedAsStillHoldNowTheNewReason) {
  const CapturedLog log;
  arm_.SendCommand(command_t::SWITCH_CONTROLLER, 1, "gravity-compensation");
  arm_.Ticks(1);
  arm_.input().PublishMessage(arm_.channels().setpoint, testing::MakeSetpoint({0.0, 1.5}, arm_.WallMicros()));
  arm_.Ticks(3000);  // setpoint_timeout (0.5 s) long past: hold
  ASSERT_EQ(arm_.runtime().mode(0), Mode::kHold);
  ASSERT_EQ(arm_.reason(), kSetpointsTimedOut);

  std::size_t logged = log.Lines().size();
  arm_.SendCommand(command_t::SWITCH_CONTROLLER, 2, "external");
  arm_.Ticks(1);
  ASSERT_EQ(arm_.runtime().mode(0), Mode::kHold);
  EXPECT_EQ(log.LinesAfter(logged),
            std::vector<std::string>{"info arm: still hold at t = " + LoggedT(arm_.states().back().t) +
                                     " s, now (no torque yet on the external controller's channel)"});

  logged = log.Lines().size();
  arm_.SendCommand(command_t::SWITCH_CONTROLLER, 3, "gravity-compensation");
  arm_.Ticks(1);
  ASSERT_EQ(arm_.runtime().mode(0), Mode::kHold);
  EXPECT_EQ(log.LinesAfter(logged),
            std::vector<std::string>{"info arm: still hold at t = " + LoggedT(arm_.states().back().t) +
                                     " s, now (streamed setpoints timed out (setpoint_timeout))"});

  logged = log.Lines().size();
  arm_.Ticks(100);  // the same mode for the same reason: nothing more
  EXPECT_EQ(log.LinesAfter(logged), std::vector<std::string>{});
  for (const std::string& line : log.Lines()) EXPECT_EQ(line.find("hold -> hold"), std::string::npos) << line;
}

// ------------------------------------------------------------------ switching controllers

TEST_F(ExternalControllerLoop, SwitchingToTheExternalControllerHoldsUntilItsFirstTorqueAndAwayFromATorqueHoldRuns) {
  arm_.Ticks(10);
  ASSERT_EQ(arm_.reason(), kNoTorqueYet);
  arm_.SendCommand(command_t::SWITCH_CONTROLLER, 1, "gravity-compensation");  // away from the torque hold
  arm_.Ticks(1);
  EXPECT_EQ(arm_.runtime().mode(0), Mode::kRunning);
  EXPECT_EQ(arm_.reason(), "");
  arm_.Ticks(100);
  EXPECT_EQ(arm_.runtime().mode(0), Mode::kRunning);
  arm_.SendCommand(command_t::SWITCH_CONTROLLER, 2, "external");  // to it
  arm_.Ticks(1);
  EXPECT_EQ(arm_.runtime().mode(0), Mode::kHold);
  EXPECT_EQ(arm_.reason(), kNoTorqueYet);
  EXPECT_EQ(arm_.states().back().controller, "external");
  arm_.Ticks(200);  // no torque for four timeouts: still waiting for the first, not "timed out"
  EXPECT_EQ(arm_.reason(), kNoTorqueYet);
  SendTorque({1.0, 0.5});
  arm_.Ticks(1);
  EXPECT_EQ(arm_.runtime().mode(0), Mode::kRunning);
  EXPECT_LT((Tau() - Vec({1.0, 0.5})).cwiseAbs().maxCoeff(), kExact);
  arm_.Ticks(kTimeoutTicks + 1);
  ASSERT_EQ(arm_.reason(), kTorquesTimedOut);
  arm_.SendCommand(command_t::SWITCH_CONTROLLER, 3, "gravity-compensation");  // away from a timed-out one
  arm_.Ticks(1);
  EXPECT_EQ(arm_.runtime().mode(0), Mode::kRunning);
  EXPECT_EQ(arm_.reason(), "");
  ASSERT_EQ(arm_.replies().size(), 3u);
  for (const reply_t& r : arm_.replies()) EXPECT_TRUE(r.accepted) << r.request_id << ": " << r.reason;
}

}  // namespace
}  // namespace lagrange
