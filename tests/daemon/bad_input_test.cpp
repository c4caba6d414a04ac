// Bad input to a running lagranged (README, "Hard cases"): every kind of bad
// setpoint and packet, a flood, and awkward commands. Each is dropped, the
// daemon keeps running and exits 0, memory stays flat, no state it publishes
// is non-finite, and the other instance never notices (its states match an
// undisturbed run of the same scene, tick for tick). UDP may lose packets
// under a flood, so nothing here counts messages or measures time: the exact
// counts live in bridge_test.cpp, timing in bench/.

#include <gtest/gtest.h>
#include <signal.h>
#include <lagrange/command_t.hpp>
#include <lagrange/reply_t.hpp>
#include <lagrange/setpoint_t.hpp>
#include <lagrange/state_t.hpp>
#include <lagrange/status_t.hpp>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <optional>
#include <random>
#include <thread>

#include "sim/instance.hpp"
#include "tests/support/lcm_messages.hpp"
#include "tests/support/lcm_testing.hpp"

namespace lagrange {
namespace {

namespace fs = std::filesystem;
using testing::BackgroundProcess;
using testing::LcmCollector;
using testing::WallMicros;

constexpr long kMemoryGrowthKiB = 1024;  // "memory stays flat": at most 1 MiB
constexpr int kRtPriority = 80;          // the service's tick priority (config/lagranged.service)
constexpr double kWait = 30.0;           // s: bound on waiting for an effect; a pass takes far less

using testing::Encode;

setpoint_t Setpoint(std::vector<double> q, std::vector<double> qd = {}, std::vector<double> qdd = {}) {
  return testing::MakeSetpoint(std::move(q), WallMicros(), std::move(qd), std::move(qdd));
}

status_t LastStatus(LcmCollector& c) { return c.Decoded<status_t>("LAGRANGE_STATUS").back(); }

// Waits for a status published after `after_us` (wall clock).
status_t StatusAfter(LcmCollector& c, std::int64_t after_us) {
  EXPECT_TRUE(c.WaitForLatest<status_t>(
      "LAGRANGE_STATUS", [&](const status_t& s) { return s.utime > after_us; }, kWait));
  return LastStatus(c);
}

// Every state of `channel` received: finite, tick numbers increasing (UDP may lose some).
void ExpectWellFormed(LcmCollector& c, const std::string& channel) {
  const auto states = c.Decoded<state_t>(channel);
  ASSERT_FALSE(states.empty()) << channel;
  for (std::size_t k = 0; k < states.size(); ++k) {
    const state_t& s = states[k];
    bool finite = std::isfinite(s.t) && std::isfinite(s.kinetic_energy) && std::isfinite(s.potential_energy);
    for (const auto* v : {&s.q, &s.qd, &s.qdd, &s.tau, &s.q_des, &s.qd_des}) {
      for (const double x : *v) finite = finite && std::isfinite(x);
    }
    ASSERT_TRUE(finite) << channel << " tick " << s.tick;
    if (k > 0) {
      ASSERT_GT(s.tick, states[k - 1].tick) << channel;
    }
  }
}

// The cart-pole the daemon ran matches an undisturbed run of the same scene
// instance, tick by tick.
void ExpectCartPoleUndisturbed(LcmCollector& c) {
  const Scene scene = LoadScene(std::string(LAGRANGE_SOURCE_DIR) + "/config/default.yaml");
  Instance reference(scene.instances[1]);
  const auto states = c.Decoded<state_t>("CARTPOLE_STATE");
  ASSERT_FALSE(states.empty());
  std::int64_t steps = 0;
  for (const state_t& s : states) {
    while (steps <= s.tick) {
      reference.Step(scene.period);
      ++steps;
    }
    ASSERT_NEAR(s.q[0], reference.q()[0], 1e-12) << "tick " << s.tick;
    ASSERT_NEAR(s.q[1], reference.q()[1], 1e-12) << "tick " << s.tick;
    ASSERT_EQ(s.mode, state_t::MODE_RUNNING);
  }
}

class BadInput : public ::testing::Test {
 protected:
  void Start(int port, std::vector<std::string> extra = {}) {
    ASSERT_EQ(testing::PrepareLoopbackMulticast(port), "");
    url_ = testing::TestLcmUrl(port);
    collector_ = std::make_unique<LcmCollector>(url_, ".*_STATE|.*_REPLY|LAGRANGE_STATUS");
    // Run as in service: the tick thread above the receive thread (lagranged warns and runs
    // on where real-time scheduling is not permitted).
    std::vector<std::string> argv = {
        LAGRANGED_PATH, "--lcm-url", url_, "--log-level", "error", "--rt-priority", std::to_string(kRtPriority),
        "--mlockall"};
    argv.insert(argv.end(), extra.begin(), extra.end());
    daemon_ = std::make_unique<BackgroundProcess>(argv);
    ASSERT_TRUE(collector_->WaitFor(
        "LAGRANGE_STATUS", [](const auto& m) { return m.size() >= 2; }, kWait));
    sender_ = std::make_unique<lcm::LCM>(url_);
  }
  void TearDown() override {
    if (!daemon_) return;
    daemon_->Signal(SIGTERM);
    EXPECT_EQ(daemon_->Wait(kWait), 0) << daemon_->Stderr();
  }
  void Send(const std::string& channel, const std::vector<std::uint8_t>& bytes) {
    sender_->publish(channel, bytes.data(), static_cast<unsigned>(bytes.size()));
    std::this_thread::sleep_for(std::chrono::microseconds(200));  // pace (losses are harmless, only fewer reach it)
  }
  std::string url_;
  std::unique_ptr<LcmCollector> collector_;
  std::unique_ptr<BackgroundProcess> daemon_;
  std::unique_ptr<lcm::LCM> sender_;
};

TEST_F(BadInput, BadValuesMalformedPacketsAndRandomBytesAreRefusedAndHarmless) {
  Start(7841);
  const long rss_before = daemon_->ResidentKiB();
  const double nan = std::numeric_limits<double>::quiet_NaN(), inf = std::numeric_limits<double>::infinity();
  const double snan = std::numeric_limits<double>::signaling_NaN();
  const std::vector<setpoint_t> bad_values = {
      Setpoint({nan, 0.1}),
      Setpoint({inf, 0.1}),
      Setpoint({0.1, 0.2}, {-inf, 0.0}),
      Setpoint({0.1, 0.2}, {}, {0.0, snan}),
      Setpoint({1e300, 0.1}),
      Setpoint({0.1, 0.2}, {1e300, 0.0}),
      Setpoint({0.1, 0.2, 0.3}),
      Setpoint({0.1}),
      Setpoint({}),
  };
  for (const setpoint_t& s : bad_values) Send("ARM_SETPOINT", Encode(s));

  // A packet claiming 2³¹ − 1 doubles: refused from its size, before any allocation.
  std::vector<std::uint8_t> crafted = Encode(Setpoint({0.1, 0.2}));
  crafted[16] = 0x7f, crafted[17] = crafted[18] = crafted[19] = 0xff;
  Send("ARM_SETPOINT", crafted);
  // Truncated packets of every length, of a setpoint and of a command.
  command_t command;
  command.utime = WallMicros();
  command.command = command_t::SET_GAINS;
  command.controller = "pd";
  command.num_gains = 2;
  command.kp = {1.0, 2.0};
  command.kd = {0.1, 0.2};
  for (const auto& [channel, whole] : {std::pair{std::string("ARM_SETPOINT"), Encode(Setpoint({0.1, 0.2}))},
                                       std::pair{std::string("ARM_COMMAND"), Encode(command)}}) {
    for (std::size_t len = 0; len < whole.size(); ++len) {
      Send(channel, std::vector<std::uint8_t>(whole.begin(), whole.begin() + static_cast<long>(len)));
    }
  }
  // Another type's packets on both channels: fingerprint mismatches.
  state_t state;
  state.num_dofs = 0;
  for (const char* channel : {"ARM_SETPOINT", "ARM_COMMAND"}) {
    Send(channel, Encode(state));
  }
  // Refused and counted (how many arrived is UDP's business; bridge_test counts them exactly).
  EXPECT_TRUE(collector_->WaitForLatest<status_t>(
      "LAGRANGE_STATUS", [](const status_t& s) { return s.setpoints_rejected > 0 && s.decode_errors > 0; }, kWait));
  status_t s = LastStatus(*collector_);
  EXPECT_EQ(s.setpoints_accepted, 0);
  EXPECT_EQ(s.commands_accepted, 0);

  // 5 × 10⁴ seeded random packets, some with a valid fingerprint in front, at up to ~20 000/s.
  std::mt19937 rng{42};
  std::uniform_int_distribution<int> length(0, 200), byte(0, 255), kind(0, 3);
  const std::vector<std::uint8_t> setpoint_head = Encode(Setpoint({0.1, 0.2})), command_head = Encode(command);
  for (int k = 0; k < 50000; ++k) {
    std::vector<std::uint8_t> p(static_cast<std::size_t>(length(rng)));
    for (auto& b : p) b = static_cast<std::uint8_t>(byte(rng));
    const int k_kind = kind(rng);
    const auto& head = k_kind == 0 ? setpoint_head : command_head;
    if (k_kind <= 1) std::copy_n(head.begin(), std::min<std::size_t>(8, p.size()), p.begin());
    sender_->publish(k % 2 == 0 ? "ARM_SETPOINT" : "ARM_COMMAND", p.data(), static_cast<unsigned>(p.size()));
    if (k % 20 == 0) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  s = StatusAfter(*collector_, WallMicros());
  EXPECT_EQ(s.setpoints_accepted, 0);
  EXPECT_EQ(s.commands_accepted, 0);
  EXPECT_EQ(s.instance_modes, (std::vector<int8_t>{state_t::MODE_RUNNING, state_t::MODE_RUNNING}));
  if (testing::kResidentSizeMeaningful) {
    EXPECT_LT(daemon_->ResidentKiB() - rss_before, kMemoryGrowthKiB);
  }
  ExpectWellFormed(*collector_, "ARM_STATE");
  ExpectWellFormed(*collector_, "CARTPOLE_STATE");
  ExpectCartPoleUndisturbed(*collector_);
}

TEST_F(BadInput, AFloodOf50000SetpointsPerSecondChangesNothingButTheSetpoint) {
  const double seconds = 5.0;
  Start(7842);
  const status_t before = StatusAfter(*collector_, WallMicros());
  const long rss_before = daemon_->ResidentKiB();
  // 50 valid setpoints every millisecond (as far as this machine keeps up).
  const setpoint_t target = Setpoint({0.6, 0.3});
  const auto start = std::chrono::steady_clock::now();
  for (auto next = start; next - start < std::chrono::duration<double>(seconds); next += std::chrono::milliseconds(1)) {
    for (int k = 0; k < 50; ++k) {
      setpoint_t s = target;
      s.utime = WallMicros();
      sender_->publish("ARM_SETPOINT", &s);
    }
    std::this_thread::sleep_until(next + std::chrono::milliseconds(1));
  }
  const status_t after = StatusAfter(*collector_, WallMicros());
  EXPECT_GT(after.setpoints_accepted, before.setpoints_accepted);  // it was fed
  EXPECT_GT(after.ticks, before.ticks);
  if (testing::kResidentSizeMeaningful) {
    EXPECT_LT(daemon_->ResidentKiB() - rss_before, kMemoryGrowthKiB);
  }
  // It followed the setpoint (then holds there once the stream stopped).
  EXPECT_TRUE(collector_->WaitForLatest<state_t>(
      "ARM_STATE", [](const state_t& s) { return std::abs(s.q[0] - 0.6) < 1e-3 && std::abs(s.q[1] - 0.3) < 1e-3; },
      kWait))
      << "arm at " << collector_->Decoded<state_t>("ARM_STATE").back().q[0];
  ExpectWellFormed(*collector_, "ARM_STATE");
  ExpectCartPoleUndisturbed(*collector_);
}

class BadCommands : public BadInput {
 protected:
  static command_t Command(int8_t kind, const std::string& controller = "", std::vector<double> kp = {},
                           std::vector<double> kd = {}) {
    return testing::MakeCommand(kind, 0, WallMicros(), controller, std::move(kp), std::move(kd));
  }
  std::optional<reply_t> FindReply(const std::string& instance, std::int64_t request_id) {
    for (const reply_t& r : collector_->Decoded<reply_t>(instance + "_REPLY")) {
      if (r.request_id == request_id) return r;
    }
    return std::nullopt;
  }
  // Sends `c` under a new request id (again, while no reply came) and returns the first reply.
  reply_t Request(const std::string& instance, command_t c) {
    c.request_id = ++next_request_id_;
    EXPECT_TRUE(testing::SendUntil([&] { Send(instance + "_COMMAND", Encode(c)); },
                                   [&] { return FindReply(instance, c.request_id).has_value(); }, kWait))
        << instance << ": no reply to command " << static_cast<int>(c.command);
    return FindReply(instance, c.request_id).value_or(reply_t{});
  }
  // Sends `c` (again, every 0.25 s) until the latest state of `instance` satisfies `predicate`.
  void SendUntilState(const std::string& instance, command_t c, const std::function<bool(const state_t&)>& predicate) {
    c.request_id = ++next_request_id_;
    EXPECT_TRUE(testing::SendUntil([&] { Send(instance + "_COMMAND", Encode(c)); },
                                   [&] {
                                     const auto states = collector_->Decoded<state_t>(instance + "_STATE");
                                     return !states.empty() && predicate(states.back());
                                   },
                                   kWait))
        << instance << ": command " << static_cast<int>(c.command) << " had no effect";
  }
  state_t AwaitState(const std::string& channel, const std::function<bool(const state_t&)>& predicate) {
    state_t found;
    EXPECT_TRUE(collector_->WaitForLatest<state_t>(
        channel,
        [&](const state_t& s) {
          found = s;
          return predicate(s);
        },
        kWait))
        << channel << ": last seen mode " << static_cast<int>(found.mode) << " t " << found.t;
    return found;
  }
  std::int64_t next_request_id_ = 0x7843000;
};

TEST_F(BadCommands, UnknownControllersAndBadGainsAreRefusedWithReasons) {
  Start(7843);
  struct Case {
    std::string instance;
    command_t command;
    std::string why;
  };
  const std::vector<Case> cases = {
      {"ARM", Command(command_t::SWITCH_CONTROLLER, "mpc"), "unknown controller 'mpc'"},
      {"ARM", Command(command_t::SET_GAINS, "", {1.0, 2.0, 3.0}, {1.0, 2.0, 3.0}), "gains: num_gains is 3, expected 2"},
      {"ARM", Command(command_t::SET_GAINS, "", {-5.0, 2.0}, {1.0, 1.0}),
       "gains for computed-torque: kp: expected finite gains >= 0"},
      {"ARM", Command(command_t::SET_GAINS, "lqr", {1.0, 2.0}, {1.0, 1.0}), "unknown controller 'lqr'"},
      {"CARTPOLE", Command(command_t::SET_GAINS, "", {1.0, 2.0}, {1.0, 1.0}),
       "gains for lqr: lqr has no adjustable gains"},
      {"ARM", Command(42), "unknown command 42"},
  };
  for (const Case& c : cases) {
    const reply_t reply = Request(c.instance, c.command);
    EXPECT_FALSE(reply.accepted) << c.why;
    EXPECT_EQ(reply.reason.rfind(c.why, 0), 0u) << reply.reason;
    // The status names the instance and the same reason.
    std::string instance = c.instance;
    for (char& ch : instance) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
    EXPECT_TRUE(collector_->WaitForLatest<status_t>(
        "LAGRANGE_STATUS",
        [&](const status_t& s) { return s.last_command_error.rfind(instance + ": " + c.why, 0) == 0; }, kWait))
        << LastStatus(*collector_).last_command_error;
  }
  EXPECT_EQ(LastStatus(*collector_).commands_accepted, 0);
  EXPECT_EQ(AwaitState("ARM_STATE", [](const state_t&) { return true; }).controller, "computed-torque");
}

TEST_F(BadCommands, EmergencyStopDuringSwingUpBrakesTheCartPoleAndClears) {
  Start(7844, {"--config", std::string(LAGRANGE_SOURCE_DIR) + "/config/cartpole_swingup.yaml"});
  // Mid-swing: the pole is moving fast.
  AwaitState("CARTPOLE_STATE", [](const state_t& s) { return std::abs(s.qd[1]) > 3.0; });
  SendUntilState("CARTPOLE", Command(command_t::ESTOP), [](const state_t& s) { return s.mode == state_t::MODE_ESTOP; });
  // Braked to rest (the pole hangs down again), never faulted, every state finite.
  const state_t braked = AwaitState("CARTPOLE_STATE", [](const state_t& s) {
    return s.mode == state_t::MODE_ESTOP && std::abs(s.qd[0]) < 1e-3 && std::abs(s.qd[1]) < 1e-2;
  });
  EXPECT_EQ(braked.mode, state_t::MODE_ESTOP);
  for (const state_t& s : collector_->Decoded<state_t>("CARTPOLE_STATE")) {
    ASSERT_NE(s.mode, state_t::MODE_FAULT);
    ASSERT_TRUE(std::isfinite(s.q[0] + s.q[1] + s.qd[0] + s.qd[1] + s.tau[0]));
  }
  SendUntilState("CARTPOLE", Command(command_t::CLEAR_ESTOP),
                 [](const state_t& s) { return s.mode == state_t::MODE_HOLD; });
}

TEST_F(BadCommands, ResetClearsAFaultedInstanceAndTheOtherRunsThrough) {
  const fs::path scene = fs::temp_directory_path() / ("lagrange_fault_scene_" + std::to_string(getpid()) + ".yaml");
  std::ofstream(scene) << R"(
instances:
  - name: arm
    plant: {type: arm2}
    initial: {q: [0.5, 0.3]}
    controller: {type: pd, kp: 300, kd: 1}
    setpoint: {q: [1.5, 0.0]}
    max_energy: 8.0
  - name: cartpole
    plant: {type: cartpole}
    initial: {q: [0.0, 3.0415926535897933]}
    controller: {type: lqr}
    setpoint: {q: [0.0, 3.141592653589793]}
)";
  Start(7845, {"--config", scene.string()});
  const state_t faulted = AwaitState("ARM_STATE", [](const state_t& s) { return s.mode == state_t::MODE_FAULT; });
  EXPECT_LE(std::abs(faulted.kinetic_energy + faulted.potential_energy), 8.0);  // the last good state
  EXPECT_EQ(faulted.tau[0], 0.0);
  const reply_t estop = Request("ARM", Command(command_t::ESTOP));  // refused: a faulted instance is frozen
  EXPECT_FALSE(estop.accepted);
  EXPECT_EQ(estop.reason, "estop: the instance is faulted (frozen); reset it");
  // Reset restarts the arm from its initial state, running (this scene faults it again within
  // a few ticks, so look through everything received rather than at the latest state).
  auto restarted = [](const std::vector<LcmCollector::Message>& messages) {
    bool faulted_before = false;
    for (const auto& m : messages) {
      state_t s;
      if (s.decode(m.data.data(), 0, static_cast<int>(m.data.size())) < 0) continue;
      if (s.mode == state_t::MODE_FAULT) faulted_before = true;
      if (faulted_before && s.mode == state_t::MODE_RUNNING && s.t <= 0.005 && std::abs(s.q[0] - 0.5) < 1e-2)
        return true;
    }
    return false;
  };
  EXPECT_TRUE(collector_->WaitForLatest<status_t>(
      "LAGRANGE_STATUS",
      [](const status_t& s) {
        return s.last_command_error == "arm: estop: the instance is faulted (frozen); reset it";
      },
      kWait))
      << LastStatus(*collector_).last_command_error;
  const command_t reset = Command(command_t::RESET);
  EXPECT_TRUE(testing::SendUntil([&] { Send("ARM_COMMAND", Encode(reset)); },
                                 [&] { return restarted(collector_->Messages("ARM_STATE")); }, kWait));
  for (const state_t& s : collector_->Decoded<state_t>("CARTPOLE_STATE")) ASSERT_EQ(s.mode, state_t::MODE_RUNNING);
  ExpectWellFormed(*collector_, "ARM_STATE");
  fs::remove(scene);
}

}  // namespace
}  // namespace lagrange
