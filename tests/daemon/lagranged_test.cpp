// lagranged as a separate process on a private LCM port: tracking a setpoint
// sent by another process, lcm-logger recording every tick, bad setpoints
// counted, clean and prompt shutdown, bad configs refused.

#include <gtest/gtest.h>
#include <lagrange/command_t.hpp>
#include <lagrange/setpoint_t.hpp>
#include <lagrange/state_t.hpp>
#include <lagrange/status_t.hpp>
#include <signal.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <regex>
#include <sstream>
#include <thread>

#include "tests/support/lcm_messages.hpp"
#include "tests/support/lcm_testing.hpp"

namespace lagrange {
namespace {

namespace fs = std::filesystem;
using testing::BackgroundProcess;
using testing::LcmCollector;
using testing::WallMicros;

class Lagranged : public ::testing::Test {
 protected:
  void Prepare(int port) {
    port_ = port;
    const std::string problem = testing::PrepareLoopbackMulticast(port);
    ASSERT_EQ(problem, "");
    url_ = testing::TestLcmUrl(port);
  }
  std::unique_ptr<BackgroundProcess> Start(std::vector<std::string> extra = {}) {
    std::vector<std::string> argv = {LAGRANGED_PATH, "--lcm-url", url_};
    argv.insert(argv.end(), extra.begin(), extra.end());
    return std::make_unique<BackgroundProcess>(argv);
  }
  // Waits until the daemon publishes on `channel`.
  static void AwaitMessages(LcmCollector& c, const std::string& channel, std::size_t n = 10) {
    ASSERT_TRUE(c.WaitFor(channel, [&](const auto& m) { return m.size() >= n; }, 20.0)) << "no " << channel;
  }
  static setpoint_t Setpoint(std::vector<double> q, std::int64_t utime = WallMicros()) {
    return testing::MakeSetpoint(std::move(q), utime);
  }
  int port_ = 0;
  std::string url_;
};

TEST_F(Lagranged, TheArmSettlesOnASetpointSentByAnotherProcessWithinTwoSeconds) {
  Prepare(7811);
  LcmCollector states(url_, "ARM_STATE");
  auto daemon = Start();
  AwaitMessages(states, "ARM_STATE");
  lcm::LCM sender(url_);
  const std::vector<double> target = {0.5, 0.4};
  const auto start = std::chrono::steady_clock::now();
  while (std::chrono::steady_clock::now() - start < std::chrono::milliseconds(3500)) {
    const setpoint_t sp = Setpoint(target);
    sender.publish("ARM_SETPOINT", &sp);
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  daemon->Signal(SIGTERM);
  ASSERT_EQ(daemon->Wait(10.0), 0) << daemon->Stderr();
  const auto all = states.Decoded<state_t>("ARM_STATE");
  // The first tick that used the setpoint, then every state from 2 s of simulated time later.
  const auto first = std::find_if(all.begin(), all.end(), [&](const state_t& s) { return s.q_des[0] == target[0]; });
  ASSERT_NE(first, all.end());
  std::size_t checked = 0;
  for (auto it = first; it != all.end(); ++it) {
    EXPECT_EQ(it->mode, state_t::MODE_RUNNING);
    if (it->t < first->t + 2.0) continue;
    ++checked;
    for (int j = 0; j < 2; ++j) ASSERT_LT(std::abs(it->q[j] - target[j]), 1e-3) << "t = " << it->t;
  }
  EXPECT_GT(checked, 1000u);  // more than a second of settled states
}

TEST_F(Lagranged, LcmLoggerRecordsEveryTickOfBothInstancesForFiveSeconds) {
  Prepare(7812);
  const fs::path log = fs::temp_directory_path() / "lagrange_logger_test.lcm";
  testing::LcmLoggerProcess logger(url_, log.string());
  auto daemon = Start({"--duration", "5"});
  ASSERT_EQ(daemon->Wait(60.0), 0) << daemon->Stderr();
  logger.Stop();  // once everything the daemon sent is in the file

  // Read it back with LCM's log reader.
  lcm::LogFile file(log.string(), "r");
  ASSERT_TRUE(file.good());
  std::map<std::string, std::vector<state_t>> states;
  while (const lcm::LogEvent* e = file.readNextEvent()) {
    if (e->channel != "ARM_STATE" && e->channel != "CARTPOLE_STATE") continue;
    state_t s;
    ASSERT_GE(s.decode(e->data, 0, e->datalen), 0);
    states[e->channel].push_back(s);
  }
  for (const char* channel : {"ARM_STATE", "CARTPOLE_STATE"}) {
    const auto& v = states[channel];
    ASSERT_EQ(v.size(), 5000u) << channel;  // 5 s at 1 kHz: 1000 messages per simulated second
    for (std::size_t k = 0; k < v.size(); ++k) {
      ASSERT_EQ(v[k].tick, static_cast<std::int64_t>(k)) << channel << ": a gap";
      ASSERT_NEAR(v[k].t, static_cast<double>(k + 1) * 1e-3, 1e-9) << channel;
    }
  }
  fs::remove(log);
}

TEST_F(Lagranged, BadSetpointsAreRejectedAndCountedWhileTheLoopKeepsRunning) {
  Prepare(7813);
  LcmCollector collector(url_);
  auto daemon = Start();
  AwaitMessages(collector, "LAGRANGE_STATUS", 2);
  lcm::LCM sender(url_);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const std::vector<std::pair<setpoint_t, std::string>> bad = {
      {Setpoint({0.1, nan}), "arm: non-finite value in q[1]"},
      {Setpoint({0.1, 0.2, 0.3}), "arm: num_dofs is 3, expected 2"},
      {Setpoint({0.1, 0.2}, WallMicros() - 10'000'000), "arm: stale: sent 10"},
      {Setpoint({10.0, 0.2}), "arm: q[0] = 10 is outside the setpoint limits [-3.1416, 3.1416]"},
  };
  for (const auto& [sp, why] : bad) {
    const std::int64_t rejected_before = collector.Decoded<status_t>("LAGRANGE_STATUS").back().setpoints_rejected;
    sender.publish("ARM_SETPOINT", &sp);
    ASSERT_TRUE(collector.WaitForLatest<status_t>("LAGRANGE_STATUS", [&](const status_t& s) {
      return s.setpoints_rejected > rejected_before;
    }, 10.0)) << why;
    const status_t s = collector.Decoded<status_t>("LAGRANGE_STATUS").back();
    EXPECT_EQ(s.last_rejection.rfind(why, 0), 0u) << s.last_rejection;
  }
  // Packets that are not setpoints at all: decode errors, also counted.
  const std::uint8_t garbage[] = {1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11};
  sender.publish("ARM_SETPOINT", garbage, sizeof garbage);
  ASSERT_TRUE(collector.WaitForLatest<status_t>("LAGRANGE_STATUS", [&](const status_t& s) {
    return s.decode_errors >= 1;
  }, 10.0));
  const auto statuses = collector.Decoded<status_t>("LAGRANGE_STATUS");
  const status_t& last = statuses.back();
  EXPECT_EQ(last.setpoints_accepted, 0);
  EXPECT_EQ(last.setpoints_rejected, 4);
  EXPECT_GT(last.ticks, statuses.front().ticks);  // the loop kept running
  EXPECT_EQ(last.instance_modes, (std::vector<int8_t>{state_t::MODE_RUNNING, state_t::MODE_RUNNING}));
  const auto arm = collector.Decoded<state_t>("ARM_STATE");
  for (std::size_t k = 1; k < arm.size(); ++k) ASSERT_EQ(arm[k].tick, arm[k - 1].tick + 1);
  daemon->Signal(SIGTERM);
  EXPECT_EQ(daemon->Wait(10.0), 0);
}

TEST_F(Lagranged, SigtermStopsItWithinTwoHundredMillisecondsAfterSendingEveryState) {
  Prepare(7814);
  LcmCollector collector(url_);
  auto daemon = Start();
  AwaitMessages(collector, "ARM_STATE", 500);
  const auto signalled = std::chrono::steady_clock::now();
  daemon->Signal(SIGTERM);
  const int status = daemon->Wait(5.0);
  const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - signalled).count();
  EXPECT_EQ(status, 0);
  EXPECT_LT(elapsed, 0.2);
  // The log was flushed, and every tick's state went out before the exit.
  std::smatch m;
  const std::string err = daemon->Stderr();
  ASSERT_TRUE(std::regex_search(err, m, std::regex("stopped by signal 15 after ([0-9]+) ticks"))) << err;
  const std::size_t ticks = std::stoul(m[1]);
  ASSERT_TRUE(collector.WaitFor("CARTPOLE_STATE", [&](const auto& v) { return v.size() >= ticks; }, 5.0));
  EXPECT_EQ(collector.Count("ARM_STATE"), ticks);
  EXPECT_EQ(collector.Count("CARTPOLE_STATE"), ticks);
}

TEST_F(Lagranged, ABadSceneIsRefusedBeforeTheLoopNamingFileKeyAndReason) {
  Prepare(7815);
  const fs::path scene = fs::temp_directory_path() / "lagrange_bad_scene.yaml";
  std::ofstream(scene) << "instances:\n  - name: arm\n    plant: {type: arm2, params: {m1: -1}}\n";
  LcmCollector collector(url_);
  auto daemon = Start({"--config", scene.string()});
  EXPECT_EQ(daemon->Wait(10.0), 2);
  EXPECT_NE(daemon->Stderr().find(scene.string() +
                                  ":3:38: instances[0].plant.params.m1: expected a positive number (kg), got -1"),
            std::string::npos)
      << daemon->Stderr();
  EXPECT_EQ(collector.Count("ARM_STATE"), 0u);
  fs::remove(scene);
  auto bad_option = Start({"--overrun", "sometimes"});
  EXPECT_EQ(bad_option->Wait(10.0), 2);
}

TEST_F(Lagranged, ChannelPrefixPutsEveryChannelUnderIt) {
  Prepare(7816);
  LcmCollector collector(url_);
  auto daemon = Start({"--channel-prefix", "ROBOT7_"});
  AwaitMessages(collector, "ROBOT7_ARM_STATE");
  AwaitMessages(collector, "ROBOT7_LAGRANGE_STATUS", 1);
  lcm::LCM sender(url_);
  const setpoint_t sp = Setpoint({0.2, 0.1});
  sender.publish("ROBOT7_ARM_SETPOINT", &sp);
  ASSERT_TRUE(collector.WaitForLatest<state_t>("ROBOT7_ARM_STATE", [&](const state_t& s) {
    return s.q_des[0] == 0.2;
  }, 10.0));
  EXPECT_EQ(collector.Count("ARM_STATE"), 0u);
  daemon->Signal(SIGINT);
  EXPECT_EQ(daemon->Wait(10.0), 0);
}

TEST_F(Lagranged, CommandsSwitchControllersStopAndAreRefusedWhenTheyDoNotFit) {
  Prepare(7817);
  LcmCollector collector(url_);
  auto daemon = Start();
  AwaitMessages(collector, "LAGRANGE_STATUS", 1);
  lcm::LCM sender(url_);
  auto send = [&](int8_t kind, const std::string& controller = "", std::vector<double> kp = {}, std::vector<double> kd = {}) {
    command_t c;
    c.utime = WallMicros();
    c.command = kind;
    c.controller = controller;
    c.num_gains = static_cast<int32_t>(kp.size());
    c.kp = kp;
    c.kd = kd;
    sender.publish("ARM_COMMAND", &c);
  };
  auto last_state = [&](const char* channel) { return collector.Decoded<state_t>(channel).back(); };
  auto await_state = [&](const std::function<bool(const state_t&)>& p) {
    return collector.WaitForLatest<state_t>("ARM_STATE", p, 10.0);
  };
  send(command_t::SWITCH_CONTROLLER, "pd");
  ASSERT_TRUE(await_state([](const state_t& s) { return s.controller == "pd"; }));
  send(command_t::ESTOP);
  ASSERT_TRUE(await_state([](const state_t& s) { return s.mode == state_t::MODE_ESTOP; }));
  EXPECT_EQ(last_state("CARTPOLE_STATE").mode, state_t::MODE_RUNNING);  // the other instance runs on
  send(command_t::CLEAR_ESTOP);
  ASSERT_TRUE(await_state([](const state_t& s) { return s.mode == state_t::MODE_HOLD; }));
  send(command_t::SWITCH_CONTROLLER, "mpc");
  send(command_t::SET_GAINS, "", {1.0, 2.0, 3.0}, {1.0, 2.0, 3.0});
  ASSERT_TRUE(collector.WaitForLatest<status_t>("LAGRANGE_STATUS", [&](const status_t& s) {
    return s.commands_rejected >= 2;
  }, 10.0));
  const status_t status = collector.Decoded<status_t>("LAGRANGE_STATUS").back();
  EXPECT_EQ(status.commands_accepted, 3);
  EXPECT_EQ(status.last_command_error, "arm: gains: num_gains is 3, expected 2");
  send(command_t::RESET);
  ASSERT_TRUE(await_state([](const state_t& s) { return s.mode == state_t::MODE_RUNNING && s.controller == "computed-torque"; }));
  daemon->Signal(SIGTERM);
  EXPECT_EQ(daemon->Wait(10.0), 0);
}

TEST_F(Lagranged, TheSystemdUnitsCommandLineRunsAndLogsToItsFile) {
  Prepare(7818);
  std::ifstream unit(std::string(LAGRANGE_SOURCE_DIR) + "/config/lagranged.service");
  std::string line, exec;
  while (std::getline(unit, line)) {
    if (line.rfind("ExecStart=", 0) == 0) exec = line.substr(10);
  }
  ASSERT_FALSE(exec.empty());
  // The unit's arguments, with the installed paths mapped into this build and a temporary log.
  const fs::path log = fs::temp_directory_path() / "lagrange_unit_test.log";
  fs::remove(log);
  std::vector<std::string> argv;
  std::istringstream words(exec);
  for (std::string w; words >> w;) {
    if (w == "/usr/local/bin/lagranged") w = LAGRANGED_PATH;
    else if (w == "/usr/local/share/lagrange/config/default.yaml") w = std::string(LAGRANGE_SOURCE_DIR) + "/config/default.yaml";
    else if (w == "/var/log/lagrange/lagranged.log") w = log.string();
    argv.push_back(w);
  }
  ASSERT_EQ(argv.front(), LAGRANGED_PATH);
  for (const std::string& extra : {std::string("--lcm-url"), url_, std::string("--duration"), std::string("0.3")}) {
    argv.push_back(extra);
  }
  BackgroundProcess daemon(argv);
  EXPECT_EQ(daemon.Wait(20.0), 0) << daemon.Stderr();
  std::ifstream in(log);
  std::stringstream text;
  text << in.rdbuf();
  EXPECT_NE(text.str().find("stopped after 300 ticks"), std::string::npos) << text.str();
  fs::remove(log);
}

}  // namespace
}  // namespace lagrange
