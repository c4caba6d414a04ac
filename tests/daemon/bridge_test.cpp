// The LCM bridge as a protocol, with nothing left to chance: LcmReceiver, the
// Runtime's tick (through Loop) and LcmPublisher over an InProcessBus with a
// FakeClock, so every count below is a fact, not a sample of UDP delivery or
// of a machine's speed. What lagranged refuses and counts, what it answers,
// and that an urgent command lands in the very next tick whatever came first.

#include <gtest/gtest.h>
#include <lagrange/command_t.hpp>
#include <lagrange/reply_t.hpp>
#include <lagrange/setpoint_t.hpp>
#include <lagrange/state_t.hpp>
#include <lagrange/status_t.hpp>

#include <atomic>
#include <cmath>
#include <functional>
#include <limits>
#include <map>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "daemon/bus.hpp"
#include "daemon/channels.hpp"
#include "daemon/lcm_bridge.hpp"
#include "daemon/loop.hpp"
#include "daemon/runtime.hpp"
#include "daemon/scene.hpp"
#include "tests/support/fake_clock.hpp"
#include "tests/support/lcm_messages.hpp"

namespace lagrange {
namespace {

using Bytes = std::vector<std::uint8_t>;
using testing::Encode;

constexpr std::int64_t kRunId = 0x0123456789abcdef;
constexpr Nanoseconds kMs = 1'000'000;
constexpr double kSettled = 1e-3;  // rad: a computed-torque arm (ω = 10 rad/s) after 2 s

// True when `text` holds no control character (below 0x20, or DEL).
bool Printable(const std::string& text) {
  for (const char ch : text) {
    const auto c = static_cast<unsigned char>(ch);
    if (c < 0x20 || c == 0x7f) return false;
  }
  return true;
}

// Decodes into `out`; false (and `out` unspecified) for what is not a T.
template <class T>
bool Decode(const std::uint8_t* data, std::size_t size, T& out) {
  return out.decode(data, 0, static_cast<int>(size)) >= 0;
}

// The default scene's daemon in one process: input bus → receiver → runtime
// (ticked by Loop on a fake clock) → publisher → output bus, on which the
// receiver also listens for other runs and this test records what goes out.
class Bridge : public ::testing::Test {
 protected:
  explicit Bridge(SetpointAge age = SetpointAge::kWall)
      : scene_(LoadScene(std::string(LAGRANGE_SOURCE_DIR) + "/config/default.yaml")),
        runtime_(scene_),
        channels_(MakeChannelNames({"arm", "cartpole"}, "")),
        receiver_(input_, &output_, output_, channels_, runtime_, clock_, stats_, age, kRunId),
        ring_(2048, runtime_.MakeRecord()),
        loop_(runtime_, clock_, {kMs, OverrunPolicy::kSkip, 0}, ring_),
        publisher_(output_, channels_, runtime_, ring_, loop_, stats_, -1, kRunId) {
    // What the publisher sends (and, in one test, a spoofer; not decoded when it is junk).
    output_.Subscribe("ARM_REPLY", [this](std::string_view, const std::uint8_t* d, std::size_t n) {
      reply_t r;
      if (Decode(d, n, r)) replies_.push_back(r);
    });
    output_.Subscribe("ARM_STATE", [this](std::string_view, const std::uint8_t* d, std::size_t n) {
      state_t s;
      if (Decode(d, n, s) && s.run_id == kRunId) {
        last_state_ = s;
        ++states_;
      }
    });
    output_.Subscribe("LAGRANGE_STATUS", [this](std::string_view, const std::uint8_t* d, std::size_t n) {
      status_t s;
      if (Decode(d, n, s)) last_status_ = s;
    });
  }

  // The receiver handles everything sent so far.
  void Receive() {
    for (;;) {
      const std::int64_t before = input_.stats().received + output_.stats().received;
      receiver_.Poll(0);
      if (input_.stats().received + output_.stats().received == before) return;
    }
  }
  // Receive, then `n` ticks of 1 ms, then everything they published is out and recorded.
  void Ticks(int n = 1) {
    Receive();
    while (n > 0) {
      const int chunk = std::min(n, 1000);
      std::atomic<bool> stop{false};
      loop_.Run(stop, loop_.ticks() + chunk);
      publisher_.Drain();
      while (output_.Drain() > 0) {
      }
      n -= chunk;
    }
  }
  // One tick by hand, to read its verdicts.
  TickRecord TickByHand() {
    Receive();
    TickRecord record = runtime_.MakeRecord();
    clock_.Advance(kMs);
    runtime_.Tick(clock_.Now(), record);
    return record;
  }

  void Send(const std::string& channel, const Bytes& bytes) { input_.Publish(channel, bytes.data(), bytes.size()); }
  void SendSetpoint(std::vector<double> q, std::int64_t utime) {
    input_.PublishMessage("ARM_SETPOINT", testing::MakeSetpoint(std::move(q), utime));
  }
  void SendFresh(std::vector<double> q) { SendSetpoint(std::move(q), clock_.WallMicros()); }
  static command_t Command(int8_t kind, std::int64_t request_id, const std::string& controller = "",
                           std::vector<double> kp = {}, std::vector<double> kd = {}) {
    return testing::MakeCommand(kind, request_id, 0, controller, std::move(kp), std::move(kd));
  }
  void SendCommand(const command_t& c) { input_.PublishMessage("ARM_COMMAND", c); }

  // Replies by request id.
  std::map<std::int64_t, std::vector<reply_t>> RepliesById() const {
    std::map<std::int64_t, std::vector<reply_t>> by_id;
    for (const reply_t& r : replies_) by_id[r.request_id].push_back(r);
    return by_id;
  }

  // Fresh setpoints every 10 ms for 2 s with stale and future-dated packets
  // between them: never hold, every bad one refused, and the arm gets there.
  void StreamWithBadPacketsInterleaved() {
    std::mt19937 rng{42};
    std::uniform_real_distribution<double> age_s(0.6, 1e5);
    const std::vector<double> target = {0.5, 0.4};
    std::int64_t bad = 0;
    for (int k = 0; k < 200; ++k) {
      SendFresh(target);
      if (k % 3 == 0) {
        SendSetpoint({-1.0, -1.0}, clock_.WallMicros() - std::llround(age_s(rng) * 1e6));
        ++bad;
      }
      if (k % 7 == 0) {  // ahead by more than the timeout
        SendSetpoint({-1.0, -1.0}, clock_.WallMicros() + 2'000'000);
        ++bad;
      }
      for (int t = 0; t < 10; ++t) {
        Ticks(1);
        ASSERT_EQ(runtime_.mode(0), Mode::kRunning) << "packet " << k;
      }
    }
    EXPECT_EQ(stats_.setpoints_rejected.load(), bad);
    EXPECT_EQ(stats_.setpoints_accepted.load(), 200);
    for (int j = 0; j < 2; ++j)
      EXPECT_NEAR(last_state_.q[static_cast<std::size_t>(j)], target[static_cast<std::size_t>(j)], kSettled);
  }

  // 10 000 commands ahead of whatever comes next (the queue holds 32; the rest are refused).
  void Flood(const std::function<command_t(int)>& make) {
    for (int k = 0; k < 10000; ++k) SendCommand(make(k));
  }

  Scene scene_;
  Runtime runtime_;
  ChannelNames channels_;
  testing::FakeClock clock_;
  ReceiverStats stats_;
  InProcessBus input_, output_;
  LcmReceiver receiver_;
  SpscRing<TickRecord> ring_;
  Loop loop_;
  LcmPublisher publisher_;
  std::vector<reply_t> replies_;
  state_t last_state_;
  std::int64_t states_ = 0;
  status_t last_status_;
};

class StreamBridge : public Bridge {
 protected:
  StreamBridge() : Bridge(SetpointAge::kStream) {}
};

// ------------------------------------------------------------------ packets

TEST_F(Bridge, EveryTruncationOfASetpointOrCommandIsExactlyOneDecodeError) {
  std::int64_t expected = 0;
  const Bytes setpoint = Encode(testing::MakeSetpoint({0.1, 0.2}, clock_.WallMicros()));
  const Bytes command = Encode(testing::MakeSetGainsCommand());
  for (const auto& [channel, whole] :
       {std::pair{std::string("ARM_SETPOINT"), setpoint}, std::pair{std::string("ARM_COMMAND"), command}}) {
    for (std::size_t len = 0; len < whole.size(); ++len) {
      Send(channel, Bytes(whole.begin(), whole.begin() + static_cast<long>(len)));
      ++expected;
    }
    Bytes longer = whole;  // one byte too many is as wrong as one too few
    longer.push_back(0);
    Send(channel, longer);
    ++expected;
  }
  // A setpoint claiming 2³¹ − 1 doubles, and another type's packet on each channel.
  Bytes crafted = setpoint;
  crafted[16] = 0x7f, crafted[17] = crafted[18] = crafted[19] = 0xff;
  Send("ARM_SETPOINT", crafted);
  ++expected;
  state_t state;
  state.num_dofs = 0;
  Send("ARM_SETPOINT", Encode(state));
  Send("ARM_COMMAND", Encode(state));
  expected += 2;
  Ticks(1);
  EXPECT_EQ(stats_.decode_errors.load(), expected);
  EXPECT_EQ(stats_.setpoints_accepted.load(), 0);
  EXPECT_EQ(stats_.setpoints_rejected.load(), 0);
  EXPECT_EQ(stats_.commands_rejected.load(), 0);
  EXPECT_TRUE(replies_.empty());  // an undecodable command has no request id to answer
  EXPECT_EQ(last_status_.decode_errors, expected);
  EXPECT_EQ(runtime_.mode(0), Mode::kRunning);
  // The whole packets pass.
  Send("ARM_SETPOINT", setpoint);
  Send("ARM_COMMAND", command);
  Ticks(1);
  EXPECT_EQ(stats_.decode_errors.load(), expected);
  EXPECT_EQ(stats_.setpoints_accepted.load(), 1);
  ASSERT_EQ(replies_.size(), 1u);
  EXPECT_TRUE(replies_[0].accepted);
}

TEST_F(Bridge, BadValuesAreRejectedAndCountedExactlyAndNeverReachTheTick) {
  const double nan = std::numeric_limits<double>::quiet_NaN(), inf = std::numeric_limits<double>::infinity();
  const double snan = std::numeric_limits<double>::signaling_NaN();
  const std::int64_t now = clock_.WallMicros();
  const std::vector<std::pair<setpoint_t, std::string>> bad = {
      {testing::MakeSetpoint({nan, 0.1}, now), "arm: non-finite value in q[0]"},
      {testing::MakeSetpoint({inf, 0.1}, now), "arm: non-finite value in q[0]"},
      {testing::MakeSetpoint({0.1, -inf}, now), "arm: non-finite value in q[1]"},
      {testing::MakeSetpoint({0.1, 0.2}, now, {-inf, 0.0}), "arm: non-finite value in qd[0]"},
      {testing::MakeSetpoint({0.1, 0.2}, now, {}, {0.0, snan}), "arm: non-finite value in qdd[1]"},
      {testing::MakeSetpoint({1e300, 0.1}, now), "arm: q[0] = 1e+300 is out of range"},
      {testing::MakeSetpoint({0.1, 0.2}, now, {1e300, 0.0}), "arm: qd[0] = 1e+300 is out of range"},
      {testing::MakeSetpoint({0.1, 0.2, 0.3}, now), "arm: num_dofs is 3, expected 2"},
      {testing::MakeSetpoint({0.1}, now), "arm: num_dofs is 1, expected 2"},
      {testing::MakeSetpoint({}, now), "arm: num_dofs is 0, expected 2"},
      {testing::MakeSetpoint({10.0, 0.2}, now), "arm: q[0] = 10 is outside the setpoint limits [-3.1416, 3.1416]"},
  };
  Ticks(1);
  const std::vector<double> q_des_before = last_state_.q_des;
  for (std::size_t k = 0; k < bad.size(); ++k) {
    input_.PublishMessage("ARM_SETPOINT", bad[k].first);
    Ticks(1);
    EXPECT_EQ(stats_.setpoints_rejected.load(), static_cast<std::int64_t>(k + 1));
    EXPECT_EQ(last_status_.last_rejection.rfind(bad[k].second, 0), 0u) << last_status_.last_rejection;
  }
  EXPECT_EQ(stats_.setpoints_accepted.load(), 0);
  EXPECT_EQ(stats_.decode_errors.load(), 0);
  EXPECT_EQ(last_status_.setpoints_rejected, static_cast<std::int64_t>(bad.size()));
  EXPECT_EQ(runtime_.mode(0), Mode::kRunning);
  EXPECT_EQ(last_state_.q_des, q_des_before);
  SendFresh({0.5, 0.4});
  Ticks(1);
  EXPECT_EQ(stats_.setpoints_accepted.load(), 1);
  EXPECT_EQ(last_state_.q_des, (std::vector<double>{0.5, 0.4}));
}

// ------------------------------------------------------------------ setpoint age

TEST_F(Bridge, AStaleSetpointIsRefusedAndDoesNotSendTheInstanceToHold) {
  SendSetpoint({0.5, 0.4}, clock_.WallMicros() - 10'000'000);  // before any stream
  Ticks(1);
  EXPECT_EQ(stats_.setpoints_rejected.load(), 1);
  EXPECT_EQ(last_status_.last_rejection, "arm: stale: sent 10 s ago (setpoint_timeout 0.5 s)");
  EXPECT_EQ(runtime_.mode(0), Mode::kRunning);
  for (int k = 0; k < 10; ++k) {
    SendFresh({0.5, 0.4});
    Ticks(10);
  }
  SendSetpoint({3.0, 3.0}, clock_.WallMicros() - 10'000'000);  // within a stream
  Ticks(1);
  EXPECT_EQ(stats_.setpoints_rejected.load(), 2);
  EXPECT_EQ(runtime_.mode(0), Mode::kRunning);
  EXPECT_EQ(last_state_.q_des, (std::vector<double>{0.5, 0.4}));  // not applied
  // Only the timeout sends it to hold: 0.5 s after the last fresh setpoint.
  Ticks(480);
  EXPECT_EQ(runtime_.mode(0), Mode::kRunning);
  Ticks(40);
  EXPECT_EQ(runtime_.mode(0), Mode::kHold);
}

TEST_F(Bridge, StalePacketsInterleavedWithAFreshStreamNeverCauseHold) { StreamWithBadPacketsInterleaved(); }

TEST_F(StreamBridge, StalePacketsInterleavedWithAFreshStreamNeverCauseHold) { StreamWithBadPacketsInterleaved(); }

TEST_F(StreamBridge, AFutureDatedSetpointMidStreamDoesNotLockOutTheStreamThatFollows) {
  for (int k = 0; k < 20; ++k) {
    SendFresh({0.5, 0.4});
    Ticks(10);
  }
  SendSetpoint({-1.0, -1.0}, clock_.WallMicros() + 1'000'000'000'000);  // 10¹² µs ahead
  Ticks(1);
  EXPECT_EQ(stats_.setpoints_rejected.load(), 1);
  EXPECT_EQ(last_status_.last_rejection.rfind("arm: timestamp out of line with its stream", 0), 0u)
      << last_status_.last_rejection;
  EXPECT_EQ(last_state_.q_des, (std::vector<double>{0.5, 0.4}));
  const std::int64_t accepted = stats_.setpoints_accepted.load();
  for (int k = 0; k < 100; ++k) {
    SendFresh({0.5, 0.4});
    Ticks(1);
    EXPECT_EQ(stats_.setpoints_accepted.load(), accepted + k + 1) << "packet " << k << " after the future-dated one";
    Ticks(9);
    ASSERT_EQ(runtime_.mode(0), Mode::kRunning);
  }
  EXPECT_EQ(stats_.setpoints_rejected.load(), 1);
}

TEST_F(StreamBridge, ASenderWhoseClockJumpedIsFollowedFromItsThirdAgreeingPacket) {
  for (int k = 0; k < 20; ++k) {
    SendFresh({0.5, 0.4});
    Ticks(10);
  }
  const std::int64_t jump = 3'600'000'000;  // the sender's clock moved an hour ahead
  for (int k = 1; k <= kStreamConfirmations; ++k) {
    SendSetpoint({0.3, 0.2}, clock_.WallMicros() + jump);
    Ticks(10);
    EXPECT_EQ(stats_.setpoints_rejected.load(), k < kStreamConfirmations ? k : kStreamConfirmations - 1);
  }
  EXPECT_EQ(last_state_.q_des, (std::vector<double>{0.3, 0.2}));
  EXPECT_EQ(runtime_.mode(0), Mode::kRunning);
}

// A new stream's first packet sets its timeline, so a future-dated first
// packet is accepted and the genuine packets behind it look stale; the
// genuine stream takes the timeline back from its kStreamConfirmations-th
// packet, since those agree with one another and nothing in line comes between.
TEST_F(StreamBridge, AFutureDatedFirstPacketHoldsTheStreamOffForOnlyAFewPackets) {
  SendSetpoint({0.5, 0.4}, clock_.WallMicros() + 1'000'000'000'000);
  Ticks(1);
  EXPECT_EQ(stats_.setpoints_accepted.load(), 1);
  int sent = 0;
  while (stats_.setpoints_accepted.load() == 1 && sent < 100) {
    SendFresh({0.3, 0.2});
    ++sent;
    Ticks(1);
  }
  EXPECT_EQ(sent, kStreamConfirmations);
  Ticks(1);
  EXPECT_EQ(runtime_.mode(0), Mode::kRunning);
  EXPECT_EQ(last_state_.q_des, (std::vector<double>{0.3, 0.2}));
}

// A forger who repeats a future-dated setpoint every 0.4 s (inside the
// timeout, so the stream never ends) cannot hold a genuine 1 kHz stream off:
// after the first few genuine packets every forged one is refused.
TEST_F(StreamBridge, AForgerRepeatingAFutureDatedSetpointCannotLockOutTheGenuineStream) {
  const std::int64_t ahead = 1'000'000'000'000;
  SendSetpoint({0.5, 0.4}, clock_.WallMicros() + ahead);
  Ticks(1);
  constexpr int kGenuine = 2000;
  int forged = 0;
  for (int ms = 1; ms <= kGenuine; ++ms) {
    if (ms % 400 == 0) {
      SendSetpoint({0.5, 0.4}, clock_.WallMicros() + ahead);
      ++forged;
    }
    SendFresh({0.3, 0.2});
    Ticks(1);
  }
  // Refused: the first kStreamConfirmations − 1 genuine packets and every forged repeat.
  EXPECT_EQ(stats_.setpoints_rejected.load(), kStreamConfirmations - 1 + forged);
  EXPECT_EQ(stats_.setpoints_accepted.load(), 1 + kGenuine - (kStreamConfirmations - 1));
  EXPECT_EQ(runtime_.mode(0), Mode::kRunning);
  EXPECT_EQ(last_state_.q_des, (std::vector<double>{0.3, 0.2}));
}

// ------------------------------------------------------------------ commands and replies

TEST_F(Bridge, EveryCommandGetsExactlyOneReplyWithItsRequestId) {
  struct Case {
    command_t command;
    bool accepted;
    std::string reason;  // prefix
  };
  const std::vector<Case> cases = {
      {Command(command_t::SWITCH_CONTROLLER, 101, "pd"), true, ""},
      {Command(command_t::SWITCH_CONTROLLER, 102, "mpc"), false, "unknown controller 'mpc' for arm"},
      {Command(command_t::SET_GAINS, 103, "", {1, 2, 3}, {1, 2, 3}), false, "gains: num_gains is 3, expected 2"},
      {Command(command_t::SET_GAINS, 104, "", {60, 20}, {8, 3}), true, ""},
      {Command(command_t::PAUSE, 105), true, ""},
      {Command(command_t::PAUSE, 106), false, "pause: the instance is not running or holding"},
      {Command(command_t::RESUME, 107), true, ""},
      {Command(command_t::RESUME, 108), false, "resume: the instance is not paused"},
      {Command(command_t::ESTOP, 109), true, ""},
      {Command(command_t::CLEAR_ESTOP, 110), true, ""},
      {Command(command_t::CLEAR_ESTOP, 111), false, "clear_estop: the instance is not in an emergency stop"},
      {Command(command_t::RESET, 112), true, ""},
      {Command(42, 113), false, "unknown command 42"},
      {Command(command_t::SET_GAINS, 114, "", {-5, 2}, {1, 1}), false, "gains for computed-torque: kp"},
  };
  for (const Case& c : cases) {
    SendCommand(c.command);
    Ticks(2);
  }
  const auto by_id = RepliesById();
  EXPECT_EQ(replies_.size(), cases.size());
  for (const Case& c : cases) {
    const auto it = by_id.find(c.command.request_id);
    ASSERT_NE(it, by_id.end()) << "no reply to " << c.command.request_id;
    ASSERT_EQ(it->second.size(), 1u) << "request " << c.command.request_id;
    const reply_t& r = it->second.front();
    EXPECT_EQ(r.run_id, kRunId);
    EXPECT_EQ(r.command, c.command.command);
    EXPECT_EQ(r.accepted, c.accepted) << c.command.request_id << ": " << r.reason;
    EXPECT_EQ(r.reason.rfind(c.reason, 0), 0u) << c.command.request_id << ": " << r.reason;
    if (c.accepted) {
      EXPECT_EQ(r.reason, "");
    }
  }
  EXPECT_EQ(last_state_.controller, "computed-torque");  // the reset
  EXPECT_EQ(stats_.foreign_messages.load(), 0);          // our own replies, states and statuses are not foreign
}

TEST_F(Bridge, ControlCharactersInAControllerNameAreEscapedInTheReplyAndTheStatus) {
  const std::vector<std::pair<std::string, std::string>> names = {
      {"x\n2026-01-01T00:00:00.000 info forged\x1b[31m", "x\\n2026-01-01T00:00:00.000 info forged\\x1b[31m"},
      {"\x1b]0;pwned\x07", "\\x1b]0;pwned\\x07"},
  };
  std::int64_t id = 1;
  for (const auto& [name, escaped] : names) {
    SendCommand(Command(command_t::SWITCH_CONTROLLER, id, name));
    Ticks(1);
    ASSERT_EQ(replies_.size(), static_cast<std::size_t>(id));
    const reply_t& r = replies_.back();
    EXPECT_EQ(r.request_id, id);
    EXPECT_FALSE(r.accepted);
    EXPECT_TRUE(Printable(r.reason)) << r.reason;
    EXPECT_NE(r.reason.find("'" + escaped + "'"), std::string::npos) << r.reason;
    EXPECT_TRUE(Printable(last_status_.last_command_error)) << last_status_.last_command_error;
    EXPECT_NE(last_status_.last_command_error.find(escaped), std::string::npos) << last_status_.last_command_error;
    ++id;
  }
}

// ------------------------------------------------------------------ joint names

// Every status names each instance's joints, instance after instance, after
// its joint count: the default scene's are generated.
TEST_F(Bridge, TheStatusNamesEveryInstancesJointsAfterItsJointCount) {
  Ticks(100);
  EXPECT_EQ(last_status_.instance_names, (std::vector<std::string>{"arm", "cartpole"}));
  EXPECT_EQ(last_status_.instance_dofs, (std::vector<std::int32_t>{2, 2}));
  EXPECT_EQ(last_status_.num_joints, 4);
  EXPECT_EQ(last_status_.joint_names, (std::vector<std::string>{"q1", "q2", "x", "theta"}));
}

// Names that would not fit in one datagram are left out (num_joints = 0), and
// the status still goes out: eight 256-link chains name 2048 joints.
TEST(BridgeJointNames, NamesTooLongForOneStatusDatagramAreLeftOutAndTheStatusStillGoesOut) {
  std::string text = "instances:\n";
  for (int i = 0; i < 8; ++i) {
    text += "  - {name: chain" + std::to_string(i) + ", plant: {type: chain, params: {links: 256}}}\n";
  }
  Runtime runtime(ParseScene(text, "inline"));
  const ChannelNames channels =
      MakeChannelNames({"chain0", "chain1", "chain2", "chain3", "chain4", "chain5", "chain6", "chain7"}, "");
  testing::FakeClock clock;
  ReceiverStats stats;
  InProcessBus output;
  SpscRing<TickRecord> ring(256, runtime.MakeRecord());
  Loop loop(runtime, clock, {kMs, OverrunPolicy::kSkip, 0}, ring);
  LcmPublisher publisher(output, channels, runtime, ring, loop, stats, -1, kRunId);
  std::optional<status_t> status;
  output.Subscribe("LAGRANGE_STATUS", [&](std::string_view, const std::uint8_t* d, std::size_t n) {
    status_t s;
    if (Decode(d, n, s)) status = s;
  });
  std::atomic<bool> stop{false};
  loop.Run(stop, 100);
  publisher.Drain();
  while (output.Drain() > 0) {
  }
  ASSERT_TRUE(status);
  EXPECT_EQ(status->instance_dofs, std::vector<std::int32_t>(8, 256));
  EXPECT_EQ(status->num_joints, 0);
  EXPECT_TRUE(status->joint_names.empty());
}

// ------------------------------------------------------------------ other publishers

TEST_F(Bridge, AnotherRunsMessageOnOurOutputChannelsIsCountedAndOursAreNot) {
  SendCommand(Command(command_t::SWITCH_CONTROLLER, 7, "mpc"));  // a reply from the receiver too
  Ticks(300);                                                    // 600 states, 3 statuses, a reply: all ours
  Receive();
  EXPECT_GT(states_, 0);
  EXPECT_EQ(stats_.foreign_messages.load(), 0);
  EXPECT_EQ(stats_.last_foreign_run_id.load(), 0);

  state_t spoof;
  spoof.run_id = 0x5eed5eed5eed;
  spoof.num_dofs = 0;
  output_.PublishMessage("ARM_STATE", spoof);
  Receive();
  EXPECT_EQ(stats_.foreign_messages.load(), 1);
  EXPECT_EQ(stats_.last_foreign_run_id.load(), 0x5eed5eed5eed);
  // Not a lagrange message at all: counted, with no run id to name.
  const Bytes junk = {1, 2, 3};
  output_.Publish("LAGRANGE_STATUS", junk.data(), junk.size());
  Receive();
  EXPECT_EQ(stats_.foreign_messages.load(), 2);
  EXPECT_EQ(stats_.last_foreign_run_id.load(), 0);
  // Our own run id in a state_t is ours, whoever sent it.
  spoof.run_id = kRunId;
  output_.PublishMessage("ARM_STATE", spoof);
  Ticks(1);
  EXPECT_EQ(stats_.foreign_messages.load(), 2);
  EXPECT_EQ(last_status_.foreign_messages, 2);
}

// ------------------------------------------------------------------ urgent commands

TEST_F(Bridge, AnEstopLandsInTheTickAfterItArrivesWhateverFloodCameFirst) {
  Ticks(10);
  Flood([](int k) {
    return Command(k % 2 == 0 ? command_t::SWITCH_CONTROLLER : command_t::PAUSE, 1000 + k,
                   k % 4 == 0 ? "pd" : "computed-torque");
  });
  SendCommand(Command(command_t::ESTOP, 777777));
  Receive();
  const std::int64_t refused = 10000 - static_cast<std::int64_t>(kCommandQueueCapacity);
  EXPECT_EQ(stats_.commands_rejected.load(), refused);
  const std::int64_t ticks = loop_.ticks();
  Ticks(1);
  EXPECT_EQ(loop_.ticks(), ticks + 1);
  EXPECT_EQ(runtime_.mode(0), Mode::kEstop);
  EXPECT_EQ(last_state_.mode, state_t::MODE_ESTOP);
  const auto by_id = RepliesById();
  ASSERT_EQ(by_id.count(777777), 1u);
  ASSERT_EQ(by_id.at(777777).size(), 1u);
  EXPECT_TRUE(by_id.at(777777).front().accepted);
  // The receiver answered the refusals its reply budget allows, and counted the rest.
  std::int64_t full = 0;
  for (const reply_t& r : replies_) full += r.reason == "the command queue is full";
  EXPECT_EQ(full, static_cast<std::int64_t>(kMaxRepliesPerSecond));
  EXPECT_EQ(stats_.replies_suppressed.load(), refused - full);
  EXPECT_EQ(last_status_.replies_suppressed, refused - full);
  EXPECT_EQ(last_status_.last_command_error.rfind("arm: ", 0), 0u);
  // In the tick, the estop went first, before the 32 queued commands.
  SendCommand(Command(command_t::CLEAR_ESTOP, 888888));
  Flood([](int k) { return Command(command_t::PAUSE, 20000 + k); });
  SendCommand(Command(command_t::ESTOP, 999999));
  const TickRecord record = TickByHand();
  const InstanceRecord& arm = record.instances[0];
  ASSERT_EQ(arm.num_verdicts, kCommandQueueCapacity + 2);
  EXPECT_EQ(arm.verdicts[0].request_id, 888888);
  EXPECT_EQ(arm.verdicts[1].request_id, 999999);
  EXPECT_EQ(arm.verdicts[1].kind, CommandKind::kEstop);
  EXPECT_EQ(arm.verdicts[1].error, nullptr);
  EXPECT_EQ(arm.mode, Mode::kEstop);
}

TEST_F(Bridge, AResetLandsInTheTickAfterItArrivesWhateverFloodCameFirst) {
  Ticks(100);
  Flood([](int k) {
    return Command(command_t::SWITCH_CONTROLLER, 1000 + k, k % 2 == 0 ? "pd" : "gravity-compensation");
  });
  SendCommand(Command(command_t::RESET, 424242));
  const TickRecord record = TickByHand();
  const InstanceRecord& arm = record.instances[0];
  ASSERT_GE(arm.num_verdicts, 1u);
  EXPECT_EQ(arm.verdicts[0].request_id, 424242);
  EXPECT_EQ(arm.verdicts[0].kind, CommandKind::kReset);
  EXPECT_EQ(arm.verdicts[0].error, nullptr);
  EXPECT_NEAR(arm.t, scene_.period, 1e-12);  // back to t = 0, then this tick's step
}

TEST_F(Bridge, TwoEstopsInOneTickAreAppliedOnce) {
  SendCommand(Command(command_t::ESTOP, 1));
  SendCommand(Command(command_t::ESTOP, 2));
  TickRecord record = TickByHand();
  ASSERT_EQ(record.instances[0].num_verdicts, 1u);
  EXPECT_EQ(record.instances[0].verdicts[0].request_id, 2);  // latest wins
  EXPECT_EQ(record.instances[0].verdicts[0].error, nullptr);
  EXPECT_EQ(runtime_.mode(0), Mode::kEstop);
  record = TickByHand();
  EXPECT_EQ(record.instances[0].num_verdicts, 0u);  // and not again
}

TEST_F(Bridge, UrgentCommandsWithinOneTickApplyInTheOrderTheyCame) {
  SendCommand(Command(command_t::ESTOP, 1));
  SendCommand(Command(command_t::CLEAR_ESTOP, 2));
  TickRecord record = TickByHand();
  ASSERT_EQ(record.instances[0].num_verdicts, 2u);
  EXPECT_EQ(record.instances[0].verdicts[0].request_id, 1);
  EXPECT_EQ(record.instances[0].verdicts[1].request_id, 2);
  EXPECT_EQ(runtime_.mode(0), Mode::kHold);
  SendCommand(Command(command_t::CLEAR_ESTOP, 3));
  SendCommand(Command(command_t::ESTOP, 4));
  record = TickByHand();
  ASSERT_EQ(record.instances[0].num_verdicts, 2u);
  EXPECT_STREQ(record.instances[0].verdicts[0].error, "clear_estop: the instance is not in an emergency stop");
  EXPECT_EQ(record.instances[0].verdicts[1].error, nullptr);
  EXPECT_EQ(runtime_.mode(0), Mode::kEstop);
}

}  // namespace
}  // namespace lagrange
