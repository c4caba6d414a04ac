// The daemon's bus side as a protocol, with nothing left to chance: Receiver, the
// Runtime's tick (through Loop) and Publisher over an InProcessBus with a
// FakeClock, so every count below is a fact, not a sample of UDP delivery or
// of a machine's speed. What lagranged refuses and counts, what it answers,
// and that an urgent command lands in the very next tick whatever came first.

#include <gtest/gtest.h>
#include <lagrange/command_t.hpp>
#include <lagrange/base_state_t.hpp>
#include <lagrange/forces_t.hpp>
#include <lagrange/reply_t.hpp>
#include <lagrange/setpoint_t.hpp>
#include <lagrange/state_t.hpp>
#include <lagrange/status_t.hpp>
#include <lagrange/telemetry_t.hpp>

#include <atomic>
#include <cmath>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <optional>
#include <random>
#include <sstream>
#include <string>
#include <variant>
#include <vector>

#include "daemon/loop.hpp"
#include "daemon/publisher.hpp"
#include "daemon/receiver.hpp"
#include "daemon/runtime.hpp"
#include "plant/arm2.hpp"
#include "plant/effects.hpp"
#include "plant/integrators.hpp"
#include "plant/types.hpp"
#include "protocol/bus.hpp"
#include "protocol/channels.hpp"
#include "sim/scene.hpp"
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
      : Bridge(LoadScene(std::string(LAGRANGE_SOURCE_DIR) + "/config/default.yaml"), age) {}
  // Another scene with the default one's instances (arm, cartpole).
  Bridge(Scene scene, SetpointAge age, const BuildOptions& options = {})
      : scene_(std::move(scene)),
        runtime_(scene_, options),
        receiver_(input_, &output_, output_, runtime_, clock_, stats_, age, kRunId),
        ring_(2048, runtime_.MakeRecord()),
        loop_(runtime_, clock_, {kMs, OverrunPolicy::kSkip, 0}, ring_),
        publisher_(output_, runtime_, ring_, loop_, stats_, -1, kRunId) {
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
    output_.Subscribe("ARM_TELEMETRY", [this](std::string_view, const std::uint8_t* d, std::size_t n) {
      telemetry_t m;
      if (Decode(d, n, m)) telemetry_.push_back(m);
    });
    output_.Subscribe("CARTPOLE_TELEMETRY",
                      [this](std::string_view, const std::uint8_t*, std::size_t) { ++cartpole_telemetry_; });
    output_.Subscribe("ARM_FORCES", [this](std::string_view, const std::uint8_t* d, std::size_t n) {
      forces_t f;
      if (Decode(d, n, f)) forces_.push_back(f);
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
  static command_t Switch(int8_t kind, std::int64_t request_id, testing::SwitchFields fields) {
    return testing::MakeSwitchCommand(kind, request_id, 0, std::move(fields));
  }
  // The one reply to `request_id` (a failed assertion when there is none, or more).
  reply_t OnlyReply(std::int64_t request_id) const {
    const auto by_id = RepliesById();
    const auto it = by_id.find(request_id);
    EXPECT_NE(it, by_id.end()) << "no reply to " << request_id;
    if (it == by_id.end()) return reply_t{};
    EXPECT_EQ(it->second.size(), 1u) << "request " << request_id;
    return it->second.front();
  }

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
  testing::FakeClock clock_;
  ReceiverStats stats_;
  InProcessBus input_, output_;
  Receiver receiver_;
  SpscRing<TickRecord> ring_;
  Loop loop_;
  Publisher publisher_;
  std::vector<reply_t> replies_;
  state_t last_state_;
  std::int64_t states_ = 0;
  status_t last_status_;
  std::vector<telemetry_t> telemetry_;  // the arm's
  std::int64_t cartpole_telemetry_ = 0;
  std::vector<forces_t> forces_;  // the arm's
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
    Ticks(c.command.command == command_t::ESTOP ? 500 : 2);  // an estop lasts its dwell (0.5 s) before a clear
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

// A scene's loop and publisher, without a receiver, on an in-process output
// bus: the latest status it published.
struct StatusHarness {
  explicit StatusHarness(const std::string& scene) : runtime(ParseScene(scene, "inline")) {
    output.Subscribe("LAGRANGE_STATUS", [this](std::string_view, const std::uint8_t* d, std::size_t n) {
      status_t s;
      if (Decode(d, n, s)) status = s;
    });
  }
  // Runs the loop up to tick `tick`, then publishes and delivers what it recorded.
  void RunTo(std::int64_t tick) {
    loop.Run(stop, tick);
    publisher.Drain();
    while (output.Drain() > 0) {
    }
  }
  Runtime runtime;
  testing::FakeClock clock;
  ReceiverStats stats;
  InProcessBus output;
  SpscRing<TickRecord> ring{256, runtime.MakeRecord()};
  Loop loop{runtime, clock, {kMs, OverrunPolicy::kSkip, 0}, ring};
  Publisher publisher{output, runtime, ring, loop, stats, -1, kRunId};
  std::atomic<bool> stop{false};
  std::optional<status_t> status;
};

// energy_balance with on_exceed: warn: the status's reason names the instance
// whose |ε| exceeds its bound while it runs; the other instance's stays "".
TEST(BridgeResidualBound, TheStatusSaysWhichInstanceExceedsItsEnergyBalanceBound) {
  StatusHarness h(R"(
instances:
  - {name: p, plant: {type: pendulum}, initial: {q: [1.5]}, integrator: {type: explicit-euler},
     energy_balance: {bound: 0.1, on_exceed: warn}}
  - {name: r, plant: {type: pendulum}, initial: {q: [1.5]}, integrator: {type: rk4},
     energy_balance: {bound: 0.1, on_exceed: warn}}
)");
  for (int k = 1; k <= 10; ++k) h.RunTo(1000 * k);  // 10 s, drained a second at a time
  const std::optional<status_t>& status = h.status;
  ASSERT_TRUE(status);
  EXPECT_EQ(status->instance_modes, (std::vector<std::int8_t>{state_t::MODE_RUNNING, state_t::MODE_RUNNING}));
  ASSERT_EQ(status->instance_reasons.size(), 2u);
  EXPECT_EQ(status->instance_reasons[0].rfind("|ε| = ", 0), 0u) << status->instance_reasons[0];
  EXPECT_NE(status->instance_reasons[0].find(" J exceeds energy_balance.bound = 0.1 J"), std::string::npos)
      << status->instance_reasons[0];
  EXPECT_EQ(status->instance_reasons[1], "");
}

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
  StatusHarness h(text);
  h.RunTo(100);
  ASSERT_TRUE(h.status);
  EXPECT_EQ(h.status->instance_dofs, std::vector<std::int32_t>(8, 256));
  EXPECT_EQ(h.status->num_joints, 0);
  EXPECT_TRUE(h.status->joint_names.empty());
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

// Verdicts come in the order the commands came; an estop wins its tick: a
// clear_estop in the same tick is refused whether it came before or after.
TEST_F(Bridge, UrgentCommandsWithinOneTickAreAnsweredInOrderAndTheEstopWins) {
  SendCommand(Command(command_t::ESTOP, 1));
  SendCommand(Command(command_t::CLEAR_ESTOP, 2));
  TickRecord record = TickByHand();
  ASSERT_EQ(record.instances[0].num_verdicts, 2u);
  EXPECT_EQ(record.instances[0].verdicts[0].request_id, 1);
  EXPECT_EQ(record.instances[0].verdicts[0].error, nullptr);
  EXPECT_EQ(record.instances[0].verdicts[1].request_id, 2);
  EXPECT_STREQ(record.instances[0].verdicts[1].error, kClearWithEstop);
  EXPECT_EQ(runtime_.mode(0), Mode::kEstop);
  Ticks(499);                                        // the estop's dwell (0.5 s) out
  SendCommand(Command(command_t::CLEAR_ESTOP, 3));  // a tick of its own: leaves the estop
  record = TickByHand();
  EXPECT_EQ(runtime_.mode(0), Mode::kHold);
  SendCommand(Command(command_t::CLEAR_ESTOP, 4));
  SendCommand(Command(command_t::ESTOP, 5));
  record = TickByHand();
  ASSERT_EQ(record.instances[0].num_verdicts, 2u);
  EXPECT_STREQ(record.instances[0].verdicts[0].error, kClearWithEstop);
  EXPECT_EQ(record.instances[0].verdicts[1].error, nullptr);
  EXPECT_EQ(runtime_.mode(0), Mode::kEstop);
}

// ------------------------------------------------------------------ issue 14: switches, telemetry, forces

constexpr double kForceBalance = 1e-9;  // N·m: closed-form M, G, C against the published rows (round-off only)

TEST_F(Bridge, ASwitchedIntegratorIsAcceptedAndTheTelemetryAndStatusShowIt) {
  Ticks(10);
  ASSERT_FALSE(telemetry_.empty());
  EXPECT_EQ(telemetry_.back().integrator, "rk4");  // the scene's
  EXPECT_EQ(telemetry_.back().evaluations, 4);
  SendCommand(Switch(command_t::SET_INTEGRATOR, 201, {.setting = "rk4", .substeps = 4}));
  Ticks(100);
  const reply_t r = OnlyReply(201);
  EXPECT_TRUE(r.accepted) << r.reason;
  EXPECT_EQ(r.reason, "");
  EXPECT_EQ(r.command, command_t::SET_INTEGRATOR);
  EXPECT_EQ(r.run_id, kRunId);
  // One telemetry_t per state_t, tick for tick, after it.
  EXPECT_EQ(static_cast<std::int64_t>(telemetry_.size()), states_);
  const telemetry_t& m = telemetry_.back();
  EXPECT_EQ(m.run_id, kRunId);
  EXPECT_EQ(m.tick, last_state_.tick);
  EXPECT_DOUBLE_EQ(m.t, last_state_.t);
  EXPECT_EQ(m.mode, state_t::MODE_RUNNING);
  EXPECT_EQ(m.integrator, "rk4");
  EXPECT_EQ(m.substeps, 4);
  EXPECT_EQ(m.method, "closed-form");
  EXPECT_EQ(m.evaluations, 16);  // 4 per sub-step
  EXPECT_EQ(m.steps_accepted, 4);
  EXPECT_EQ(m.steps_rejected, 0);
  EXPECT_EQ(m.newton_iterations, 0);
  EXPECT_EQ(m.failures, 0);
  EXPECT_DOUBLE_EQ(m.error_estimate, -1.0);  // a fixed-step method estimates nothing
  EXPECT_DOUBLE_EQ(m.step, scene_.period / 4);
  EXPECT_TRUE(std::isfinite(m.energy_residual)) << m.energy_residual;
  EXPECT_DOUBLE_EQ(m.energy, last_state_.kinetic_energy + last_state_.potential_energy);
  EXPECT_EQ(last_status_.instance_integrators, (std::vector<std::string>{"rk4 x4", "rk4"}));
  EXPECT_EQ(last_status_.instance_methods, (std::vector<std::string>{"closed-form", "closed-form"}));
  EXPECT_EQ(last_status_.instance_effects.at(0), "gravity,coriolis");
  EXPECT_EQ(last_status_.instance_forces, (std::vector<std::int8_t>{0, 0}));
  EXPECT_EQ(last_status_.commands_accepted, 1);
  EXPECT_EQ(last_status_.commands_rejected, 0);
  // The method and an effect, in one tick, in the order they came.
  SendCommand(Switch(command_t::SET_METHOD, 202, {.setting = "recursive"}));
  SendCommand(Switch(command_t::SET_EFFECT, 203, {.setting = "gravity", .on = false}));
  Ticks(100);
  EXPECT_TRUE(OnlyReply(202).accepted) << OnlyReply(202).reason;
  EXPECT_TRUE(OnlyReply(203).accepted) << OnlyReply(203).reason;
  EXPECT_EQ(telemetry_.back().method, "recursive");
  EXPECT_EQ(last_status_.instance_methods.at(0), "recursive");
  EXPECT_EQ(last_status_.instance_effects.at(0), "coriolis");
  EXPECT_EQ(last_status_.commands_accepted, 3);
}

// The default scene with known costs per evaluation (closed form 1 µs,
// lagrangian 5 µs, recursive 2 µs) and no other cost: the work bound is exact.
class CostedBridge : public Bridge {
 protected:
  CostedBridge()
      : Bridge(LoadScene(std::string(LAGRANGE_SOURCE_DIR) + "/config/default.yaml"), SetpointAge::kWall,
               BuildOptions::WithCosts({1e-6, 5e-6, 2e-6})) {}
};

// A switch the work bound refuses quotes its figures, as a refused scene does,
// in its reply and in the status's last_command_error.
TEST_F(CostedBridge, ARefusedSwitchQuotesTheWorstCaseAndWhatFitsInItsReplyAndTheStatus) {
  // The arm at rk4 x 300: 1201 evaluations x 1 µs with the cart-pole's 5 (rk4) = 1.206 ms of 0.8.
  SendCommand(Switch(command_t::SET_INTEGRATOR, 401, {.setting = "rk4", .substeps = 300}));
  Ticks(100);
  const reply_t r = OnlyReply(401);
  EXPECT_FALSE(r.accepted);
  EXPECT_EQ(r.reason, std::string(kSwitchDoesNotFit) + ": the worst case would be 1.206 ms per tick, 0.8 ms fit");
  EXPECT_EQ(last_status_.last_command_error, "arm: " + r.reason);
  // dopri5 with a max_steps too large names the largest that fits.
  SendCommand(Switch(command_t::SET_INTEGRATOR, 402, {.setting = "dopri5", .max_steps = 1000}));
  Ticks(100);
  const reply_t d = OnlyReply(402);
  EXPECT_FALSE(d.accepted);
  EXPECT_NE(d.reason.find("max_steps fit"), std::string::npos) << d.reason;
  EXPECT_EQ(last_status_.last_command_error, "arm: " + d.reason);
}

TEST_F(Bridge, TheVariationalIntegratorIsRefusedWhileCoriolisIsOff) {
  SendCommand(Switch(command_t::SET_EFFECT, 301, {.setting = "coriolis", .on = false}));
  Ticks(1);
  SendCommand(Switch(command_t::SET_INTEGRATOR, 302, {.setting = "variational"}));
  Ticks(100);
  EXPECT_TRUE(OnlyReply(301).accepted) << OnlyReply(301).reason;
  const reply_t refused = OnlyReply(302);
  EXPECT_FALSE(refused.accepted);
  EXPECT_EQ(refused.command, command_t::SET_INTEGRATOR);
  EXPECT_NE(refused.reason.find("needs effects.coriolis on"), std::string::npos) << refused.reason;
  EXPECT_EQ(last_status_.commands_rejected, 1);
  EXPECT_EQ(last_status_.last_command_error.rfind("arm: ", 0), 0u) << last_status_.last_command_error;
  EXPECT_NE(last_status_.last_command_error.find("needs effects.coriolis on"), std::string::npos);
  EXPECT_EQ(last_status_.instance_integrators.at(0), "rk4");  // nothing changed
  EXPECT_EQ(last_status_.instance_effects.at(0), "gravity");
  EXPECT_EQ(telemetry_.back().integrator, "rk4");
  // Coriolis back on, then the same switch is applied.
  SendCommand(Switch(command_t::SET_EFFECT, 303, {.setting = "coriolis", .on = true}));
  SendCommand(Switch(command_t::SET_INTEGRATOR, 304, {.setting = "variational"}));
  Ticks(100);
  EXPECT_TRUE(OnlyReply(303).accepted) << OnlyReply(303).reason;
  EXPECT_TRUE(OnlyReply(304).accepted) << OnlyReply(304).reason;
  EXPECT_EQ(last_status_.instance_integrators.at(0), "variational");
  EXPECT_EQ(last_status_.instance_effects.at(0), "gravity,coriolis");
  EXPECT_EQ(telemetry_.back().integrator, "variational");
  EXPECT_GT(telemetry_.back().newton_iterations, 0);
  EXPECT_DOUBLE_EQ(telemetry_.back().error_estimate, -1.0);
  EXPECT_EQ(runtime_.mode(0), Mode::kRunning);
}

// The receiver parses names and checks the integrator's numbers (0 is the
// default; anything else must be in range): each refusal is answered, says
// what was expected, is counted, and never reaches the tick.
TEST_F(Bridge, BadSwitchSettingsAreRefusedByTheReceiverNamingWhatWasExpected) {
  const double nan = std::numeric_limits<double>::quiet_NaN(), inf = std::numeric_limits<double>::infinity();
  struct Case {
    command_t command;
    std::vector<std::string> says;  // substrings of the reason
  };
  const std::string integrators = IntegratorTypeNames(), effects = EffectKindNames(), methods = MethodNames();
  const std::vector<Case> cases = {
      {Switch(command_t::SET_INTEGRATOR, 501, {.setting = "rk5"}),
       {"unknown integrator 'rk5'", "expected", integrators}},
      {Switch(command_t::SET_INTEGRATOR, 502, {.setting = ""}), {"unknown integrator ''", "expected", integrators}},
      {Switch(command_t::SET_EFFECT, 503, {.setting = "wind", .on = true}),
       {"unknown effect 'wind'", "expected", effects}},
      {Switch(command_t::SET_METHOD, 504, {.setting = "magic"}), {"unknown method 'magic'", "expected", methods}},
      {Switch(command_t::SET_METHOD, 505, {.setting = "recursive\n\x1b[31m"}),
       {"unknown method 'recursive\\n\\x1b[31m'", "expected", methods}},
      {Switch(command_t::SET_INTEGRATOR, 506, {.setting = "rk4", .substeps = 1001}), {"substeps: expected 1 to 1000"}},
      {Switch(command_t::SET_INTEGRATOR, 507, {.setting = "rk4", .substeps = -1}), {"substeps: expected 1 to 1000"}},
      {Switch(command_t::SET_INTEGRATOR, 508, {.setting = "dopri5", .rtol = nan}),
       {"rtol: expected a finite number > 0"}},
      {Switch(command_t::SET_INTEGRATOR, 509, {.setting = "dopri5", .rtol = -1.0}),
       {"rtol: expected a finite number > 0"}},
      {Switch(command_t::SET_INTEGRATOR, 510, {.setting = "dopri5", .atol = inf}),
       {"atol: expected a finite number > 0"}},
      {Switch(command_t::SET_INTEGRATOR, 511, {.setting = "dopri5", .max_steps = -5}),
       {"max_steps: expected 1 to 10000000"}},
  };
  for (const Case& c : cases) {
    SendCommand(c.command);
    Ticks(1);
    const reply_t r = OnlyReply(c.command.request_id);
    EXPECT_FALSE(r.accepted) << c.command.request_id;
    EXPECT_EQ(r.command, c.command.command);
    EXPECT_TRUE(Printable(r.reason)) << r.reason;
    for (const std::string& part : c.says) {
      EXPECT_NE(r.reason.find(part), std::string::npos)
          << c.command.request_id << ": '" << r.reason << "' does not say '" << part << "'";
    }
  }
  Ticks(100);
  const auto refused = static_cast<std::int64_t>(cases.size());
  EXPECT_EQ(stats_.commands_rejected.load(), refused);
  EXPECT_EQ(last_status_.commands_rejected, refused);
  EXPECT_EQ(last_status_.commands_accepted, 0);
  EXPECT_EQ(last_status_.last_command_error.rfind("arm: ", 0), 0u) << last_status_.last_command_error;
  EXPECT_EQ(stats_.decode_errors.load(), 0);
  EXPECT_EQ(replies_.size(), cases.size());
  // Nothing reached the tick: the arm runs what the scene says.
  EXPECT_EQ(last_status_.instance_integrators.at(0), "rk4");
  EXPECT_EQ(last_status_.instance_methods.at(0), "closed-form");
  EXPECT_EQ(last_status_.instance_effects.at(0), "gravity,coriolis");
  EXPECT_EQ(runtime_.mode(0), Mode::kRunning);
}

// forces_t rows are the terms of M(q) qdd = tau_applied + disturbance +
// damping + friction + limits + constraint − coriolis − gravity at the tick's end state:
// checked against the arm's closed form at the q, qd, qdd of the same tick's
// state_t, on a swinging arm so that every row that is on is not zero.
TEST_F(Bridge, ForcesArePublishedOnlyWhileAskedAndTheirRowsSumToTheStatesMTimesQdd) {
  std::map<std::int64_t, state_t> states;  // the arm's, by tick
  output_.Subscribe("ARM_STATE", [&](std::string_view, const std::uint8_t* d, std::size_t n) {
    state_t s;
    if (Decode(d, n, s)) states[s.tick] = s;
  });
  SendFresh({0.5, 0.4});  // a step: the arm swings towards it
  Ticks(100);
  EXPECT_TRUE(forces_.empty());
  EXPECT_EQ(last_status_.instance_forces.at(0), 0);
  SendCommand(Switch(command_t::SET_FORCES, 401, {.setting = "", .on = true}));
  SendFresh({0.5, 0.4});
  Ticks(100);
  EXPECT_TRUE(OnlyReply(401).accepted) << OnlyReply(401).reason;
  ASSERT_EQ(forces_.size(), 100u);  // one per tick, from the tick that applied it
  EXPECT_EQ(last_status_.instance_forces, (std::vector<std::int8_t>{1, 0}));
  const Arm2ClosedForm arm(std::get<Arm2Params>(scene_.instances[0].plant.params));
  const std::unique_ptr<DynamicsData> arm_data = arm.MakeData();
  MatrixXd M(2, 2);
  VectorXd G(2), c(2);
  double largest_coriolis = 0.0;
  for (const forces_t& f : forces_) {
    ASSERT_EQ(f.num_dofs, 2);
    ASSERT_EQ(states.count(f.tick), 1u) << "no state_t for tick " << f.tick;
    const state_t& s = states.at(f.tick);
    EXPECT_EQ(f.run_id, kRunId);
    EXPECT_EQ(f.utime, s.utime);
    EXPECT_DOUBLE_EQ(f.t, s.t);
    EXPECT_TRUE(f.gravity_on && f.coriolis_on);
    EXPECT_FALSE(f.damping_on || f.friction_on || f.limits_on || f.saturation_on || f.disturbance_on ||
                 f.constraint_on);
    EXPECT_EQ(f.num_contacts, 0);  // lagrange's own plant: no constraints, no contacts
    EXPECT_EQ(f.contacts_total, 0);
    const Eigen::Map<const VectorXd> q(s.q.data(), 2), qd(s.qd.data(), 2), qdd(s.qdd.data(), 2);
    arm.ComputeMassMatrix(*arm_data, q, M);
    arm.ComputeGravityForce(*arm_data, q, G);
    arm.ComputeCoriolisForce(*arm_data, q, qd, c);
    const VectorXd Mqdd = M * qdd;
    for (std::size_t j = 0; j < 2; ++j) {
      const auto k = static_cast<Eigen::Index>(j);
      const double sum = f.tau_applied[j] + f.disturbance[j] + f.damping[j] + f.friction[j] + f.limits[j] +
                         f.constraint[j] - f.coriolis[j] - f.gravity[j];
      EXPECT_NEAR(sum, Mqdd[k], kForceBalance) << "tick " << f.tick << ", row " << j;
      EXPECT_NEAR(f.gravity[j], G[k], kForceBalance) << "tick " << f.tick;
      EXPECT_NEAR(f.coriolis[j], c[k], kForceBalance) << "tick " << f.tick;
      for (const auto* off : {&f.damping, &f.friction, &f.limits, &f.constraint, &f.disturbance}) {
        EXPECT_DOUBLE_EQ((*off)[j], 0.0);
      }
      EXPECT_DOUBLE_EQ(f.tau_applied[j], s.tau[j]);      // state_t's tau is as applied
      EXPECT_DOUBLE_EQ(f.tau_cmd[j], f.tau_applied[j]);  // saturation is off
      largest_coriolis = std::max(largest_coriolis, std::abs(f.coriolis[j]));
    }
  }
  EXPECT_GT(largest_coriolis, 1e-3);  // the arm moved: the Coriolis row was exercised
  SendCommand(Switch(command_t::SET_FORCES, 402, {.setting = "", .on = false}));
  Ticks(100);
  EXPECT_TRUE(OnlyReply(402).accepted) << OnlyReply(402).reason;
  EXPECT_EQ(forces_.size(), 100u);  // none from the tick that applied it
  EXPECT_EQ(last_status_.instance_forces, (std::vector<std::int8_t>{0, 0}));
}

// telemetry_t and forces_t carry this run's id (README, "Run ids") on this
// run's output channels: another run's there is counted like one on ARM_STATE.
TEST_F(Bridge, AnotherRunsTelemetryOrForcesOnOurChannelsIsCountedAndOursAreNot) {
  SendCommand(Switch(command_t::SET_FORCES, 701, {.setting = "", .on = true}));
  Ticks(300);  // our telemetry and forces, 300 of each
  ASSERT_EQ(forces_.size(), 300u);
  EXPECT_EQ(stats_.foreign_messages.load(), 0);
  telemetry_t telemetry{};
  telemetry.run_id = 0x5eed5eed5eed;
  output_.PublishMessage("ARM_TELEMETRY", telemetry);
  Receive();
  EXPECT_EQ(stats_.foreign_messages.load(), 1);
  EXPECT_EQ(stats_.last_foreign_run_id.load(), 0x5eed5eed5eed);
  forces_t forces{};
  forces.run_id = 0x0f0f0f0f;
  forces.num_dofs = 0;
  output_.PublishMessage("CARTPOLE_FORCES", forces);
  Receive();
  EXPECT_EQ(stats_.foreign_messages.load(), 2);
  EXPECT_EQ(stats_.last_foreign_run_id.load(), 0x0f0f0f0f);
}

// The default scene with `telemetry: false` on the arm.
std::string SceneWithQuietArm() {
  std::ifstream in(std::string(LAGRANGE_SOURCE_DIR) + "/config/default.yaml");
  std::stringstream text;
  text << in.rdbuf();
  std::string yaml = text.str();
  const std::string arm = "  - name: arm\n";
  const std::size_t at = yaml.find(arm);
  if (at == std::string::npos) return "";
  return yaml.insert(at + arm.size(), "    telemetry: false\n");
}

class QuietArmBridge : public Bridge {
 protected:
  QuietArmBridge()
      : Bridge(ParseScene(SceneWithQuietArm(), "default.yaml, arm telemetry: false"), SetpointAge::kWall) {}
};

TEST_F(QuietArmBridge, AnInstanceWithTelemetryOffPublishesNoTelemetryAndTheOthersStillDo) {
  ASSERT_FALSE(scene_.instances[0].telemetry);
  Ticks(200);
  EXPECT_EQ(states_, 200);
  EXPECT_TRUE(telemetry_.empty());
  EXPECT_EQ(cartpole_telemetry_, 200);
  // Switching still works and shows in the status.
  SendCommand(Switch(command_t::SET_INTEGRATOR, 601, {.setting = "rk4", .substeps = 2}));
  Ticks(100);
  EXPECT_TRUE(OnlyReply(601).accepted) << OnlyReply(601).reason;
  EXPECT_EQ(last_status_.instance_integrators.at(0), "rk4 x2");
  EXPECT_TRUE(telemetry_.empty());
}

// A floating base (tests/fixtures/scenes/floating_fall.yaml's tree) beside a fixed one (a pendulum).
class FloatingBridge : public Bridge {
 protected:
  FloatingBridge()
      : Bridge(ParseScene(R"(
instances:
  - name: tree
    plant: {type: urdf, file: ../urdf/floating_tree.urdf, floating_base: true}
    initial: {base_q: [0, 0, 1, 0, 0, 0, 1], base_v: [0, 0, 0.5, 0, 0, 0.4]}
  - name: pendulum
    plant: {type: pendulum}
)",
                          std::string(LAGRANGE_SOURCE_DIR) + "/tests/fixtures/scenes/floating_bridge.yaml"),
               SetpointAge::kWall) {
    for (const char* channel : {"TREE_BASE", "PENDULUM_BASE"}) {
      output_.Subscribe(channel, [this](std::string_view c, const std::uint8_t* d, std::size_t n) {
        base_state_t b;
        if (Decode(d, n, b)) bases_[std::string(c)].push_back(b);
      });
    }
    output_.Subscribe("TREE_STATE", [this](std::string_view, const std::uint8_t* d, std::size_t n) {
      state_t st;
      if (Decode(d, n, st)) tree_states_.push_back(st);
    });
  }
  std::map<std::string, std::vector<base_state_t>> bases_;
  std::vector<state_t> tree_states_;
};

// One base_state_t per tick on <NAME>_BASE, with its state_t's tick, time and
// run, the state_t's q the 5 joints alone; a fixed base publishes none.
TEST_F(FloatingBridge, EveryTickPublishesOneBaseStateBesideItsStateAndAFixedBaseNone) {
  Ticks(100);
  const std::vector<base_state_t>& tree = bases_["TREE_BASE"];
  ASSERT_EQ(tree.size(), 100u);
  ASSERT_EQ(tree_states_.size(), 100u);
  EXPECT_TRUE(bases_["PENDULUM_BASE"].empty());
  for (std::size_t k = 0; k < tree.size(); ++k) {
    EXPECT_EQ(tree[k].tick, tree_states_[k].tick);
    EXPECT_EQ(tree[k].run_id, kRunId);
    EXPECT_EQ(tree[k].utime, tree_states_[k].utime);
    EXPECT_DOUBLE_EQ(tree[k].t, tree_states_[k].t);
    EXPECT_EQ(tree_states_[k].num_dofs, 5);
  }
  // The base rose at 0.5 m/s and fell back under gravity: z(0.1 s) ≈ 1 + 0.05 − 0.049.
  EXPECT_NEAR(tree.back().position[2], 1.0 + 0.05 - 0.5 * 9.81 * 0.01, 5e-3);
  EXPECT_GT(tree.back().orientation[2], 0.01);  // turning about z at 0.4 rad/s
}

}  // namespace
}  // namespace lagrange
