// Bad input to a running lagranged (README, "Hard cases"): every kind of bad
// setpoint and packet, a flood, and awkward commands. Each is dropped and
// counted, the loop keeps its rate, no state message is lost, and the other
// instance never notices.

#include <gtest/gtest.h>
#include <lagrange/command_t.hpp>
#include <lagrange/setpoint_t.hpp>
#include <lagrange/state_t.hpp>
#include <lagrange/status_t.hpp>
#include <pthread.h>
#include <sched.h>
#include <signal.h>
#include <time.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <limits>
#include <random>
#include <thread>

#include "daemon/instance.hpp"
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

using testing::Encode;

setpoint_t Setpoint(std::vector<double> q, std::vector<double> qd = {}, std::vector<double> qdd = {}) {
  return testing::MakeSetpoint(std::move(q), WallMicros(), std::move(qd), std::move(qdd));
}

status_t LastStatus(LcmCollector& c) { return c.Decoded<status_t>("LAGRANGE_STATUS").back(); }

// Waits for a status published after `after_us` (wall clock).
status_t StatusAfter(LcmCollector& c, std::int64_t after_us) {
  EXPECT_TRUE(c.WaitForLatest<status_t>("LAGRANGE_STATUS", [&](const status_t& s) {
    return s.utime > after_us;
  }, 20.0));
  return LastStatus(c);
}

// Every state of `channel` arrived: ticks consecutive from the first to the last.
void ExpectNoGaps(LcmCollector& c, const std::string& channel) {
  const auto states = c.Decoded<state_t>(channel);
  ASSERT_GT(states.size(), 100u) << channel;
  for (std::size_t k = 1; k < states.size(); ++k) {
    ASSERT_EQ(states[k].tick, states[k - 1].tick + 1) << channel << ": a lost state message";
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
    collector_ = std::make_unique<LcmCollector>(url_, ".*_STATE|LAGRANGE_STATUS");
    // Run as in service: the tick thread above the receive thread (lagranged warns and runs
    // on where real-time scheduling is not permitted).
    std::vector<std::string> argv = {LAGRANGED_PATH, "--lcm-url", url_, "--log-level", "error", "--rt-priority",
                                     std::to_string(kRtPriority), "--mlockall"};
    argv.insert(argv.end(), extra.begin(), extra.end());
    daemon_ = std::make_unique<BackgroundProcess>(argv);
    ASSERT_TRUE(collector_->WaitFor("LAGRANGE_STATUS", [](const auto& m) { return m.size() >= 2; }, 20.0));
    sender_ = std::make_unique<lcm::LCM>(url_);
  }
  void TearDown() override {
    if (!daemon_) return;
    daemon_->Signal(SIGTERM);
    EXPECT_EQ(daemon_->Wait(10.0), 0) << daemon_->Stderr();
  }
  void Send(const std::string& channel, const std::vector<std::uint8_t>& bytes) {
    sender_->publish(channel, bytes.data(), static_cast<unsigned>(bytes.size()));
    std::this_thread::sleep_for(std::chrono::microseconds(200));  // pace: nothing lost to LCM's receive queue
  }
  std::string url_;
  std::unique_ptr<LcmCollector> collector_;
  std::unique_ptr<BackgroundProcess> daemon_;
  std::unique_ptr<lcm::LCM> sender_;
};

TEST_F(BadInput, BadValuesMalformedPacketsAndRandomBytesAreDroppedCountedAndHarmless) {
  Start(7841);
  const long rss_before = daemon_->ResidentKiB();
  const double nan = std::numeric_limits<double>::quiet_NaN(), inf = std::numeric_limits<double>::infinity();
  const double snan = std::numeric_limits<double>::signaling_NaN();
  const std::vector<setpoint_t> bad_values = {
      Setpoint({nan, 0.1}), Setpoint({inf, 0.1}), Setpoint({0.1, 0.2}, {-inf, 0.0}), Setpoint({0.1, 0.2}, {}, {0.0, snan}),
      Setpoint({1e300, 0.1}), Setpoint({0.1, 0.2}, {1e300, 0.0}), Setpoint({0.1, 0.2, 0.3}), Setpoint({0.1}), Setpoint({}),
  };
  for (const setpoint_t& s : bad_values) Send("ARM_SETPOINT", Encode(s));
  std::int64_t expected_decode_errors = 0;

  // A packet claiming 2³¹ − 1 doubles: refused from its size, before any allocation.
  std::vector<std::uint8_t> crafted = Encode(Setpoint({0.1, 0.2}));
  crafted[16] = 0x7f, crafted[17] = crafted[18] = crafted[19] = 0xff;
  Send("ARM_SETPOINT", crafted);
  ++expected_decode_errors;
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
      ++expected_decode_errors;
    }
  }
  // Another type's packets on both channels: fingerprint mismatches.
  state_t state;
  state.num_dofs = 0;
  for (const char* channel : {"ARM_SETPOINT", "ARM_COMMAND"}) {
    Send(channel, Encode(state));
    ++expected_decode_errors;
  }
  status_t s = StatusAfter(*collector_, WallMicros());
  EXPECT_EQ(s.setpoints_accepted, 0);
  EXPECT_EQ(s.setpoints_rejected, static_cast<std::int64_t>(bad_values.size()));
  EXPECT_EQ(s.decode_errors, expected_decode_errors);
  EXPECT_EQ(s.commands_accepted + s.commands_rejected, 0);

  // 10⁵ seeded random packets, some with a valid fingerprint in front, at ~20 000/s.
  std::mt19937 rng{42};
  std::uniform_int_distribution<int> length(0, 200), byte(0, 255), kind(0, 3);
  const std::vector<std::uint8_t> setpoint_head = Encode(Setpoint({0.1, 0.2})), command_head = Encode(command);
  for (int k = 0; k < 100000; ++k) {
    std::vector<std::uint8_t> p(static_cast<std::size_t>(length(rng)));
    for (auto& b : p) b = static_cast<std::uint8_t>(byte(rng));
    const int k_kind = kind(rng);
    const auto& head = k_kind == 0 ? setpoint_head : command_head;
    if (k_kind <= 1) std::copy_n(head.begin(), std::min<std::size_t>(8, p.size()), p.begin());
    sender_->publish(k % 2 == 0 ? "ARM_SETPOINT" : "ARM_COMMAND", p.data(), static_cast<unsigned>(p.size()));
    if (k % 20 == 0) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  s = StatusAfter(*collector_, WallMicros());
  EXPECT_GT(s.decode_errors, expected_decode_errors + 50000);  // most arrive; LCM's own queue may drop some
  EXPECT_EQ(s.instance_modes, (std::vector<int8_t>{state_t::MODE_RUNNING, state_t::MODE_RUNNING}));
  if (testing::kResidentSizeMeaningful) {
    EXPECT_LT(daemon_->ResidentKiB() - rss_before, kMemoryGrowthKiB);
  }
  ExpectNoGaps(*collector_, "ARM_STATE");
  ExpectNoGaps(*collector_, "CARTPOLE_STATE");
  ExpectCartPoleUndisturbed(*collector_);
  // Every period is accounted for: run, or counted as an overrun.
  const auto statuses = collector_->Decoded<status_t>("LAGRANGE_STATUS");
  EXPECT_LT(statuses.back().overruns - statuses.front().overruns, (statuses.back().ticks - statuses.front().ticks) / 100);
}

// P(X >= k) for X ~ Binomial(n, 1/2): how likely `k` or more of `n` rare events
// would fall on one of two sources with equal rates.
double BinomialUpperTail(std::int64_t k, std::int64_t n) {
  double p = 0.0;
  for (std::int64_t j = k; j <= n; ++j) {
    p += std::exp(std::lgamma(n + 1.0) - std::lgamma(j + 1.0) - std::lgamma(n - j + 1.0) - n * std::log(2.0));
  }
  return p;
}

// A bare absolute-deadline 1 kHz timer loop on this process, as the baseline
// in the same run, scheduled like the daemon's tick thread: how many of its
// wakes came a period or more late.
std::int64_t BareTimerLateWakes(double seconds, int rt_priority) {
  if (rt_priority > 0) {
    sched_param param{};
    param.sched_priority = rt_priority;
    pthread_setschedparam(pthread_self(), SCHED_FIFO, &param);  // as permitted; the daemon does the same
  }
  timespec next;
  clock_gettime(CLOCK_MONOTONIC, &next);
  std::int64_t late_wakes = 0;
  const long periods = std::lround(seconds * 1000);
  for (long k = 0; k < periods; ++k) {
    next.tv_nsec += 1'000'000;
    if (next.tv_nsec >= 1'000'000'000) {
      next.tv_nsec -= 1'000'000'000;
      ++next.tv_sec;
    }
    clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &next, nullptr);
    timespec now;
    clock_gettime(CLOCK_MONOTONIC, &now);
    const long late = (now.tv_sec - next.tv_sec) * 1'000'000'000L + (now.tv_nsec - next.tv_nsec);
    if (late >= 1'000'000) {
      ++late_wakes;
      next = now;  // skip, like lagranged's default policy
    }
  }
  return late_wakes;
}

// The daemon's wakes a period or more late between two wall-clock times, from its --timing-csv.
std::int64_t DaemonLateWakes(const fs::path& timing_csv, std::int64_t from_us, std::int64_t to_us) {
  std::ifstream in(timing_csv);
  std::string line;
  std::getline(in, line);  // tick,utime_us,wake_latency_ns,compute_ns,overruns
  std::int64_t late_wakes = 0;
  while (std::getline(in, line)) {
    std::int64_t tick = 0, utime = 0, latency = 0;
    if (std::sscanf(line.c_str(), "%ld,%ld,%ld", &tick, &utime, &latency) != 3) continue;
    if (utime >= from_us && utime <= to_us && latency >= 1'000'000) ++late_wakes;
  }
  return late_wakes;
}

TEST_F(BadInput, AFloodOf50000SetpointsPerSecondForTenSecondsChangesNothing) {
  const double seconds = 10.0;
  const fs::path timing = fs::temp_directory_path() / ("lagrange_flood_timing_" + std::to_string(getpid()) + ".csv");
  Start(7842, {"--timing-csv", timing.string()});
  const fs::path log = fs::temp_directory_path() / ("lagrange_flood_" + std::to_string(getpid()) + ".lcm");
  testing::LcmLoggerProcess logger(url_, log.string(), ".*_STATE");
  const status_t before = StatusAfter(*collector_, WallMicros());
  const long rss_before = daemon_->ResidentKiB();
  std::int64_t baseline = 0;
  const std::int64_t flood_start_us = WallMicros();
  std::thread timer([&] { baseline = BareTimerLateWakes(seconds, kRtPriority); });
  // 50 valid setpoints every millisecond.
  const setpoint_t target = Setpoint({0.6, 0.3});
  std::int64_t sent = 0;
  const auto start = std::chrono::steady_clock::now();
  for (auto next = start; next - start < std::chrono::duration<double>(seconds); next += std::chrono::milliseconds(1)) {
    for (int k = 0; k < 50; ++k) {
      setpoint_t s = target;
      s.utime = WallMicros();
      sender_->publish("ARM_SETPOINT", &s);
      ++sent;
    }
    std::this_thread::sleep_until(next + std::chrono::milliseconds(1));
  }
  timer.join();
  const std::int64_t flood_end_us = WallMicros();
  const status_t after = StatusAfter(*collector_, WallMicros());
  logger.Stop();
  EXPECT_GT(sent, 490000);
  EXPECT_GT(after.setpoints_accepted - before.setpoints_accepted, 10000);  // it was really fed
  // The loop held 1 kHz: wakes a period or more late (overruns) under 1 % of the 10⁴ periods,
  // and no more frequent than a bare timer loop's, scheduled alike, over the same 10 s. Such
  // late wakes are rare events the machine causes (on a virtual machine under a UDP flood,
  // even real-time threads sometimes wake several ms late, for both loops alike), so they
  // are counted once per stall and compared as rare events: a one-sided binomial test.
  const std::int64_t late_wakes = DaemonLateWakes(timing, flood_start_us, flood_end_us);
  EXPECT_LT(late_wakes, 100) << "bare timer loop: " << baseline;
  EXPECT_GT(BinomialUpperTail(late_wakes, late_wakes + baseline), 1e-3)
      << late_wakes << " late wakes against the bare timer loop's " << baseline << " (overruns "
      << after.overruns - before.overruns << ")";
  fs::remove(timing);
  if (testing::kResidentSizeMeaningful) {
    EXPECT_LT(daemon_->ResidentKiB() - rss_before, kMemoryGrowthKiB);
  }
  EXPECT_EQ(after.state_messages_dropped, 0);
  // lcm-logger received every state message of the flood.
  lcm::LogFile file(log.string(), "r");
  ASSERT_TRUE(file.good());
  std::map<std::string, std::int64_t> last;
  std::map<std::string, std::int64_t> count;
  while (const lcm::LogEvent* e = file.readNextEvent()) {
    if (e->channel != "ARM_STATE" && e->channel != "CARTPOLE_STATE") continue;
    state_t s;
    ASSERT_GE(s.decode(e->data, 0, e->datalen), 0);
    if (count[e->channel]++ > 0) {
      ASSERT_EQ(s.tick, last[e->channel] + 1) << e->channel << ": the logger missed one";
    }
    last[e->channel] = s.tick;
  }
  EXPECT_GT(count["ARM_STATE"], 9500);
  EXPECT_LE(std::abs(count["ARM_STATE"] - count["CARTPOLE_STATE"]), 1);  // the logger may stop between the two of a tick
  fs::remove(log);
  const auto arm = collector_->Decoded<state_t>("ARM_STATE").back();
  EXPECT_NEAR(arm.q[0], 0.6, 1e-3);  // and it followed the setpoint all along
}

class BadCommands : public BadInput {
 protected:
  void SendCommand(const std::string& instance, int8_t kind, const std::string& controller = "",
                   std::vector<double> kp = {}, std::vector<double> kd = {}) {
    command_t c;
    c.utime = WallMicros();
    c.command = kind;
    c.controller = controller;
    c.num_gains = static_cast<int32_t>(kp.size());
    c.kp = std::move(kp);
    c.kd = std::move(kd);
    Send(instance + "_COMMAND", Encode(c));
  }
  state_t AwaitState(const std::string& channel, const std::function<bool(const state_t&)>& predicate) {
    state_t found;
    EXPECT_TRUE(collector_->WaitForLatest<state_t>(channel, [&](const state_t& s) {
      found = s;
      return predicate(s);
    }, 20.0)) << channel << ": last seen mode " << static_cast<int>(found.mode) << " t " << found.t;
    return found;
  }
};

TEST_F(BadCommands, UnknownControllersAndBadGainsAreRefusedWithReasons) {
  Start(7843);
  const std::vector<std::pair<std::function<void()>, std::string>> cases = {
      {[&] { SendCommand("ARM", command_t::SWITCH_CONTROLLER, "mpc"); }, "arm: unknown controller 'mpc'"},
      {[&] { SendCommand("ARM", command_t::SET_GAINS, "", {1.0, 2.0, 3.0}, {1.0, 2.0, 3.0}); },
       "arm: gains: num_gains is 3, expected 2"},
      {[&] { SendCommand("ARM", command_t::SET_GAINS, "", {-5.0, 2.0}, {1.0, 1.0}); },
       "arm: gains for computed-torque: kp: expected finite gains >= 0"},
      {[&] { SendCommand("ARM", command_t::SET_GAINS, "lqr", {1.0, 2.0}, {1.0, 1.0}); }, "arm: unknown controller 'lqr'"},
      {[&] { SendCommand("CARTPOLE", command_t::SET_GAINS, "", {1.0, 2.0}, {1.0, 1.0}); },
       "cartpole: gains for lqr: lqr has no adjustable gains"},
      {[&] { SendCommand("ARM", 42); }, "arm: unknown command 42"},
  };
  for (const auto& [send, why] : cases) {
    const std::int64_t rejected = LastStatus(*collector_).commands_rejected;
    send();
    ASSERT_TRUE(collector_->WaitForLatest<status_t>("LAGRANGE_STATUS", [&](const status_t& s) {
      return s.commands_rejected > rejected;
    }, 10.0)) << why;
    EXPECT_EQ(LastStatus(*collector_).last_command_error.rfind(why, 0), 0u) << LastStatus(*collector_).last_command_error;
  }
  EXPECT_EQ(LastStatus(*collector_).commands_accepted, 0);
  EXPECT_EQ(AwaitState("ARM_STATE", [](const state_t&) { return true; }).controller, "computed-torque");
}

TEST_F(BadCommands, EmergencyStopDuringSwingUpBrakesTheCartPoleAndClears) {
  Start(7844, {"--config", std::string(LAGRANGE_SOURCE_DIR) + "/config/cartpole_swingup.yaml"});
  // Mid-swing: the pole is moving fast.
  AwaitState("CARTPOLE_STATE", [](const state_t& s) { return std::abs(s.qd[1]) > 3.0; });
  SendCommand("CARTPOLE", command_t::ESTOP);
  AwaitState("CARTPOLE_STATE", [](const state_t& s) { return s.mode == state_t::MODE_ESTOP; });
  // Braked to rest (the pole hangs down again), never faulted, every state finite.
  const state_t braked = AwaitState("CARTPOLE_STATE", [](const state_t& s) {
    return s.mode == state_t::MODE_ESTOP && std::abs(s.qd[0]) < 1e-3 && std::abs(s.qd[1]) < 1e-2;
  });
  EXPECT_EQ(braked.mode, state_t::MODE_ESTOP);
  for (const state_t& s : collector_->Decoded<state_t>("CARTPOLE_STATE")) {
    ASSERT_NE(s.mode, state_t::MODE_FAULT);
    ASSERT_TRUE(std::isfinite(s.q[0] + s.q[1] + s.qd[0] + s.qd[1] + s.tau[0]));
  }
  SendCommand("CARTPOLE", command_t::CLEAR_ESTOP);
  AwaitState("CARTPOLE_STATE", [](const state_t& s) { return s.mode == state_t::MODE_HOLD; });
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
  SendCommand("ARM", command_t::ESTOP);  // refused: a faulted instance is frozen
  SendCommand("ARM", command_t::RESET);
  // Reset restarts the arm from its initial state, running (this scene faults it again within
  // a few ticks, so look through everything received rather than at the latest state).
  auto restarted = [](const std::vector<LcmCollector::Message>& messages) {
    bool faulted_before = false;
    for (const auto& m : messages) {
      state_t s;
      if (s.decode(m.data.data(), 0, static_cast<int>(m.data.size())) < 0) continue;
      if (s.mode == state_t::MODE_FAULT) faulted_before = true;
      if (faulted_before && s.mode == state_t::MODE_RUNNING && s.t <= 0.0015 && std::abs(s.q[0] - 0.5) < 1e-2) return true;
    }
    return false;
  };
  EXPECT_TRUE(collector_->WaitFor("ARM_STATE", restarted, 20.0));
  ASSERT_TRUE(collector_->WaitForLatest<status_t>("LAGRANGE_STATUS", [](const status_t& s) { return s.commands_rejected >= 1; },
                                                  10.0));
  EXPECT_EQ(LastStatus(*collector_).last_command_error, "arm: estop: the instance is faulted (frozen); reset it");
  for (const state_t& s : collector_->Decoded<state_t>("CARTPOLE_STATE")) ASSERT_EQ(s.mode, state_t::MODE_RUNNING);
  ExpectNoGaps(*collector_, "ARM_STATE");
  fs::remove(scene);
}

}  // namespace
}  // namespace lagrange
