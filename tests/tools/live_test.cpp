// lagrangectl send, command and watch against a running lagranged on a
// private LCM port, including bad input to each; and against a fake
// publisher with no daemon, which lagrangectl must not believe.

#include <gtest/gtest.h>

#include <algorithm>
#include <signal.h>
#include <lagrange/command_t.hpp>
#include <lagrange/forces_t.hpp>
#include <lagrange/pose_setpoint_t.hpp>
#include <lagrange/reply_t.hpp>
#include <lagrange/state_t.hpp>
#include <lagrange/status_t.hpp>
#include <lagrange/task_state_t.hpp>
#include <lagrange/telemetry_t.hpp>
#include <lagrange/torque_t.hpp>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <thread>

#include "daemon/runtime.hpp"
#include "protocol/format.hpp"
#include "protocol/ids.hpp"
#include "tests/support/lcm_testing.hpp"
#include "tests/support/process.hpp"
#include "tests/tools/run_ctl.hpp"

namespace lagrange {
namespace {

using testing::BackgroundProcess;
using testing::LcmCollector;
using testing::RunCtl;

// One line on stderr that names the command and contains `what`.
void ExpectOneLine(const testing::CtlResult& r, const std::string& command, int status, const std::string& what) {
  EXPECT_EQ(r.status, status) << r.err;
  ASSERT_EQ(testing::Lines(r.err).size(), 1u) << r.err;
  EXPECT_EQ(r.err.rfind("lagrangectl " + command + ": ", 0), 0u) << r.err;
  EXPECT_NE(r.err.find(what), std::string::npos) << "got: " << r.err << "expected: " << what;
}

class LiveDaemon : public ::testing::Test {
 protected:
  void Start(int port, std::vector<std::string> extra = {}) {
    ASSERT_EQ(testing::PrepareLoopbackMulticast(port), "");
    url_ = testing::TestLcmUrl(port);
    collector_ = std::make_unique<LcmCollector>(url_);
    std::vector<std::string> argv = {LAGRANGED_PATH, "--lcm-url", url_, "--log-level", "warn"};
    argv.insert(argv.end(), extra.begin(), extra.end());
    daemon_ = std::make_unique<BackgroundProcess>(argv);
    ASSERT_TRUE(collector_->WaitFor(
        "LAGRANGE_STATUS", [](const auto& m) { return !m.empty(); }, 20.0));
  }
  void TearDown() override {
    if (daemon_) {
      daemon_->Signal(SIGTERM);
      EXPECT_EQ(daemon_->Wait(10.0), 0) << daemon_->Stderr();
    }
  }
  testing::CtlResult Ctl(std::vector<std::string> args) {
    args.push_back("--lcm-url");
    args.push_back(url_);
    return RunCtl(args);
  }
  state_t LastState(const std::string& channel) {
    const auto states = collector_->Decoded<state_t>(channel);
    EXPECT_FALSE(states.empty());
    return states.empty() ? state_t{} : states.back();
  }
  std::string url_;
  std::unique_ptr<LcmCollector> collector_;
  std::unique_ptr<BackgroundProcess> daemon_;
};

TEST_F(LiveDaemon, SendStreamsAFixedSetpointThatTheArmReaches) {
  Start(7821);
  const auto r = Ctl({"send", "arm", "--q", "0.5,0.4", "--for", "2.5"});
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(r.out.rfind("sent ", 0), 0u);
  EXPECT_NE(r.out.find("to ARM_SETPOINT"), std::string::npos);
  const state_t s = LastState("ARM_STATE");
  EXPECT_NEAR(s.q[0], 0.5, 1e-3);
  EXPECT_NEAR(s.q[1], 0.4, 1e-3);
}

TEST_F(LiveDaemon, SendMinimumJerkStartsFromTheCurrentStateAndEndsOnTheTarget) {
  Start(7822);
  const state_t before = LastState("ARM_STATE");
  const std::size_t skip = collector_->Count("ARM_STATE");
  const auto r = Ctl({"send", "arm", "--min-jerk", "1.0", "--q", "1.2,-0.6"});
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.out.find("minimum-jerk move in 1 s"), std::string::npos);
  const auto states = collector_->Decoded<state_t>("ARM_STATE");
  // The streamed setpoints leave from where the arm was, move monotonically, and end on the target.
  std::vector<double> q0_des;
  for (std::size_t k = skip; k < states.size(); ++k) {
    if (states[k].mode == state_t::MODE_RUNNING && states[k].q_des[0] != before.q_des[0])
      q0_des.push_back(states[k].q_des[0]);
  }
  ASSERT_GT(q0_des.size(), 500u);
  EXPECT_NEAR(q0_des.front(), before.q[0], 1e-3);
  for (std::size_t k = 1; k < q0_des.size(); ++k) ASSERT_GE(q0_des[k], q0_des[k - 1] - 1e-12);
  EXPECT_NEAR(q0_des.back(), 1.2, 1e-12);
  const state_t after = states.back();
  EXPECT_NEAR(after.q[0], 1.2, 1e-3);
  EXPECT_NEAR(after.q[1], -0.6, 1e-3);
}

TEST_F(LiveDaemon, SendSineOscillatesAroundItsCenter) {
  Start(7823);
  const std::size_t skip = collector_->Count("ARM_STATE");
  const auto r = Ctl({"send", "arm", "--sine", "0.2,1", "--q", "0.6,0.1", "--for", "2"});
  ASSERT_EQ(r.status, 0) << r.err;
  const auto states = collector_->Decoded<state_t>("ARM_STATE");
  double lo = 1e9, hi = -1e9;
  for (std::size_t k = skip; k < states.size(); ++k) {
    if (states[k].mode != state_t::MODE_RUNNING || states[k].q_des[1] == 0.0) continue;
    lo = std::min(lo, states[k].q_des[1]);
    hi = std::max(hi, states[k].q_des[1]);
  }
  EXPECT_NEAR(lo, 0.1 - 0.2, 1e-3);  // two full periods reach both extremes
  EXPECT_NEAR(hi, 0.1 + 0.2, 1e-3);
}

// The two numbers of "lagranged rejected R of N setpoints".
std::pair<long, long> RejectedOf(const std::string& err) {
  long rejected = -1, of = -1;
  const std::size_t at = err.find("lagranged rejected ");
  if (at != std::string::npos) std::sscanf(err.c_str() + at, "lagranged rejected %ld of %ld", &rejected, &of);
  return {rejected, of};
}

TEST_F(LiveDaemon, SendRefusesBadInputWithOneLine) {
  Start(7824);
  ExpectOneLine(Ctl({"send", "robot", "--q", "1,2", "--wait", "0.5"}), "send", 1,
                "no state from instance 'robot' on ROBOT_STATE");
  ExpectOneLine(Ctl({"send", "arm", "--q", "0.5,abc"}), "send", 2,
                "--q: expected comma-separated finite numbers, got 'abc'");
  ExpectOneLine(Ctl({"send", "arm", "--q", "0.5,nan"}), "send", 2,
                "--q: expected comma-separated finite numbers, got 'nan'");
  ExpectOneLine(Ctl({"send", "arm", "--q", "1,2,3"}), "send", 2, "--q: expected 2 values (one per joint), got 3");
  ExpectOneLine(Ctl({"send", "arm", "--min-jerk", "2"}), "send", 2, "--min-jerk: needs the target --q");
  ExpectOneLine(Ctl({"send", "arm", "--q", "1,1", "--rate", "0"}), "send", 2,
                "--rate: expected a number in (0, 10000], got '0'");
  ExpectOneLine(Ctl({"send", "arm", "--sine", "0.2"}), "send", 2, "--sine: expected AMPLITUDE,FREQ (2 numbers");
  ExpectOneLine(Ctl({"send", "arm", "--sine", "0.2,1", "--min-jerk", "1"}), "send", 2, "excludes");
  ExpectOneLine(Ctl({"send", "arm", "--sine", "0.2,1", "--qd", "1,1"}), "send", 2,
                "--qd: only for a fixed setpoint (--sine sets its own velocities");
  ExpectOneLine(Ctl({"send", "arm", "--min-jerk", "1", "--q", "1,1", "--qdd", "1,1"}), "send", 2,
                "--qdd: only for a fixed setpoint (--min-jerk sets its own velocities");
  ExpectOneLine(Ctl({"send", "arm"}), "send", 2, "--q or --tau is required");
  ExpectOneLine(Ctl({"send", "arm", "--tau", "1,x"}), "send", 2,
                "--tau: expected comma-separated finite numbers, got 'x'");
  ExpectOneLine(Ctl({"send", "arm", "--tau", "1", "--q", "1,1"}), "send", 2, "--q excludes --tau");
  ExpectOneLine(Ctl({"send", "arm", "--tau", "1", "--sine", "0.2,1"}), "send", 2, "--sine excludes --tau");
  ExpectOneLine(Ctl({"send", "arm", "--q", "1,1", "--torque-channel", "MY_TORQUE"}), "send", 2,
                "--torque-channel requires --tau");
  ExpectOneLine(Ctl({"send", "arm", "--tau", "1", "--torque-channel", "MY TORQUE"}), "send", 2,
                "--torque-channel: expected an LCM channel name of printable ASCII without spaces, got 'MY TORQUE'");
}

TEST_F(LiveDaemon, SendCountsRejectionsFromTheDaemonsOwnTotals) {
  Start(7928);
  // Every setpoint lies outside the limits: whatever arrived was rejected, so both counts agree.
  const auto r = Ctl({"send", "arm", "--q", "9,0", "--for", "0.3"});
  ExpectOneLine(r, "send", 1, "arm: q[0] = 9 is outside the setpoint limits");
  const auto [rejected, of] = RejectedOf(r.err);
  EXPECT_GT(rejected, 0) << r.err;
  EXPECT_EQ(rejected, of) << r.err;
}

TEST_F(LiveDaemon, SendFailsWhenTheInstanceDoesNotFollow) {
  Start(7920);
  ASSERT_EQ(Ctl({"command", "arm", "estop"}).status, 0);
  const auto r = Ctl({"send", "arm", "--q", "0.5,0.4", "--for", "0.3"});
  ExpectOneLine(r, "send", 1, "arm is in estop mode, not running");
  EXPECT_NE(r.err.find(std::string(" (") + kEstopped + "; command arm clear)"), std::string::npos) << r.err;
  EXPECT_EQ(r.out, "");
}

std::string SceneFile(const char* name) { return std::string(LAGRANGE_SOURCE_DIR) + "/config/" + name; }

std::string JoinNumbers(const std::vector<double>& v) {
  std::string s;
  for (double x : v) {
    if (!s.empty()) s += ',';
    s += FormatDouble(x);
  }
  return s;
}

// The arm of arm_external_plant.yaml holds under gravity compensation
// until a torque comes, so at rest its torque is G(q). `send --tau` streams
// G(q) + (lift, 0): applied exactly as sent, it lifts the shoulder, for at
// rest M q̈ = τ − G = (lift, 0) and M⁻¹ has a positive diagonal. A torque of
// the wrong size never leaves lagrangectl.
TEST_F(LiveDaemon, SendTauStreamsATorqueTheArmIsDrivenByUnderItsExternalController) {
  Start(7710, {"--config", SceneFile("arm_external_plant.yaml")});
  ASSERT_TRUE(collector_->WaitForLatest<state_t>(
      "ARM_STATE", [](const state_t& s) { return s.mode == state_t::MODE_HOLD; }, 5.0));
  ExpectOneLine(Ctl({"send", "arm", "--tau", "1,2,3"}), "send", 2,
                "--tau: expected 2 values (one for every joint, or one per joint), got 3");
  const state_t held = LastState("ARM_STATE");
  constexpr double kLift = 4.0;  // N·m beyond gravity on the shoulder
  const std::vector<double> tau = {held.tau[0] + kLift, held.tau[1]};
  const auto r = Ctl({"send", "arm", "--tau", JoinNumbers(tau), "--for", "0.3"});
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(r.out.rfind("sent ", 0), 0u) << r.out;
  EXPECT_NE(r.out.find(" (tau " + JoinNumbers(tau) + ") to ARM_TORQUE; lagranged accepted "), std::string::npos)
      << r.out;

  // One sender: one non-zero run_id, a growing sequence, no measured state, the torque as given.
  const auto torques = collector_->Decoded<torque_t>("ARM_TORQUE");
  ASSERT_FALSE(torques.empty());
  for (std::size_t k = 0; k < torques.size(); ++k) {
    EXPECT_NE(torques[k].run_id, 0);
    EXPECT_EQ(torques[k].run_id, torques.front().run_id);
    if (k > 0) {
      EXPECT_GT(torques[k].sequence, torques[k - 1].sequence);
    }
    EXPECT_EQ(torques[k].state_tick, -1);
    ASSERT_EQ(torques[k].num_dofs, 2);
    EXPECT_EQ(torques[k].tau, tau);
  }
  EXPECT_GE(torques.front().sequence, 1);

  std::vector<state_t> driven;
  for (const state_t& s : collector_->Decoded<state_t>("ARM_STATE")) {
    if (s.mode == state_t::MODE_RUNNING && s.controller == "external") driven.push_back(s);
  }
  ASSERT_FALSE(driven.empty());
  constexpr double kExact = 1e-12;
  for (const state_t& s : driven) {
    EXPECT_NEAR(s.tau[0], tau[0], kExact);  // within the torque limits: applied as sent
    EXPECT_NEAR(s.tau[1], tau[1], kExact);
  }
  EXPECT_GT(driven.back().q[0], held.q[0] + 0.02) << "the shoulder did not rise";

  // The stream over, the torque times out: back in hold, and nothing was rejected.
  EXPECT_TRUE(collector_->WaitForLatest<state_t>(
      "ARM_STATE", [](const state_t& s) { return s.mode == state_t::MODE_HOLD; }, 5.0));
  const std::size_t statuses = collector_->Count("LAGRANGE_STATUS");
  ASSERT_TRUE(collector_->WaitFor(
      "LAGRANGE_STATUS", [&](const auto& m) { return m.size() >= statuses + 2; }, 5.0));
  const status_t status = collector_->Decoded<status_t>("LAGRANGE_STATUS").back();
  EXPECT_GT(status.torques_accepted, 0);
  EXPECT_EQ(status.torques_rejected, 0) << status.last_rejection;
}

TEST_F(LiveDaemon, SendTauIsRefusedUnlessTheExternalControllerIsActiveAndSaysHowToSwitch) {
  Start(7711, {"--config", SceneFile("arm_external_plant.yaml")});
  ASSERT_EQ(Ctl({"command", "arm", "controller", "gravity-compensation"}).status, 0);
  auto r = Ctl({"send", "arm", "--tau", "1", "--for", "0.2"});
  ExpectOneLine(r, "send", 1,
                "arm: torque: the instance is not running its external controller (active: gravity-compensation); "
                "switch with `lagrangectl command arm controller external`");
  EXPECT_NE(r.err.find("lagranged rejected "), std::string::npos) << r.err;
  EXPECT_EQ(r.out, "");
  // As the message says: switched back, the same instance takes torques (here about G(q) at rest).
  ASSERT_EQ(Ctl({"command", "arm", "controller", "external"}).status, 0);
  const state_t s = LastState("ARM_STATE");
  r = Ctl({"send", "arm", "--tau", JoinNumbers({s.tau[0], s.tau[1]}), "--for", "0.2"});
  EXPECT_EQ(r.status, 0) << r.err;
}

TEST_F(LiveDaemon, SendTauToAnInstanceWhoseSceneHasNoExternalControllerSaysSo) {
  Start(7712);
  const auto r = Ctl({"send", "arm", "--tau", "1,1", "--for", "0.2"});
  ExpectOneLine(r, "send", 1, "counted none of the ");
  EXPECT_NE(r.err.find(" sent on ARM_TORQUE: no external controller of arm listens there (arm runs computed-torque; "
                       "its scene lists no external controller"),
            std::string::npos)
      << r.err;
  EXPECT_EQ(r.out, "");
}

// An external plant's controller waits for a measured state nobody sends.
TEST_F(LiveDaemon, WatchShowsANewModeWithItsReasonAndTheTorqueAndMeasuredCounters) {
  Start(7713, {"--config", SceneFile("arm_external_controller.yaml")});
  const auto r = Ctl({"watch", "--frames", "1"});
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.out.find(std::string("\narm_controller   waiting (") + kWaitingForState + ")   computed-torque   t "),
            std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find(" rejected   torques 0 accepted, 0 rejected   measured states "), std::string::npos) << r.out;
}

// The last refused input has a line of its own under the input counters,
// never run on after the measured states' count.
TEST_F(LiveDaemon, WatchPrintsTheLastRejectedInputOnItsOwnLine) {
  Start(7852);
  const auto sent = Ctl({"send", "arm", "--q", "10,0"});  // beyond setpoint_limits (±3.1416)
  EXPECT_EQ(sent.status, 1) << sent.err;
  const auto r = Ctl({"watch", "--frames", "1"});
  ASSERT_EQ(r.status, 0) << r.err;
  const std::vector<std::string> lines = testing::Lines(r.out);
  const auto inputs = std::find_if(lines.begin(), lines.end(), [](const std::string& l) { return l.rfind("inputs ", 0) == 0; });
  ASSERT_NE(inputs, lines.end()) << r.out;
  EXPECT_NE(inputs->find(" rejected   measured states 0 accepted, 0 rejected"), std::string::npos) << *inputs;
  EXPECT_EQ(inputs->substr(inputs->size() - std::string("0 rejected").size()), "0 rejected") << *inputs;
  ASSERT_NE(inputs + 1, lines.end());
  EXPECT_EQ((inputs + 1)->rfind("          last input rejected: arm: ", 0), 0u) << *(inputs + 1);
}

TEST(LiveOneJoint, SendSineDrivesAOneJointPlant) {
  ASSERT_EQ(testing::PrepareLoopbackMulticast(7921), "");
  const std::string url = testing::TestLcmUrl(7921);
  LcmCollector collector(url, "PENDULUM_STATE");
  BackgroundProcess daemon({LAGRANGED_PATH, "--lcm-url", url, "--log-level", "warn", "--config",
                            std::string(LAGRANGE_SOURCE_DIR) + "/config/pendulum.yaml"});
  ASSERT_TRUE(collector.WaitFor(
      "PENDULUM_STATE", [](const auto& m) { return !m.empty(); }, 20.0));
  const auto r = RunCtl({"send", "pendulum", "--sine", "0.2,1", "--for", "0.5", "--lcm-url", url});
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.out.find("(sine 0.2 at 1 Hz) to PENDULUM_SETPOINT"), std::string::npos) << r.out;
  daemon.Signal(SIGTERM);
  EXPECT_EQ(daemon.Wait(10.0), 0) << daemon.Stderr();
}

TEST_F(LiveDaemon, CommandChangesControllersGainsAndModesAndSaysSo) {
  Start(7825);
  auto r = Ctl({"command", "arm", "controller", "pd"});
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(r.out, "arm: controller pd done; now running with pd\n");
  r = Ctl({"command", "arm", "gains", "--kp", "200", "--kd", "30"});  // one value for every joint
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(r.out, "arm: gains done; now running with pd\n");
  r = Ctl({"command", "arm", "gains", "--kp", "70,30", "--kd", "7,3"});  // one per joint
  ASSERT_EQ(r.status, 0) << r.err;
  for (const auto& [verb, mode] : std::vector<std::pair<std::string, int>>{{"pause", state_t::MODE_PAUSED},
                                                                           {"resume", state_t::MODE_RUNNING},
                                                                           {"estop", state_t::MODE_ESTOP},
                                                                           {"clear", state_t::MODE_HOLD},
                                                                           {"reset", state_t::MODE_RUNNING}}) {
    r = Ctl({"command", "arm", verb});
    ASSERT_EQ(r.status, 0) << verb << ": " << r.err;
    ASSERT_TRUE(collector_->WaitForLatest<state_t>(
        "ARM_STATE", [&](const state_t& s) { return s.mode == mode; }, 5.0))
        << verb;
  }
  EXPECT_EQ(LastState("ARM_STATE").controller, "computed-torque");  // reset restores the scene's controller
}

TEST_F(LiveDaemon, CommandRefusesBadInputWithOneLine) {
  Start(7826);
  auto r = Ctl({"command", "arm", "controller", "mpc"});
  ExpectOneLine(r, "command", 1, "refused: ");
  EXPECT_NE(r.err.find("unknown controller 'mpc'"), std::string::npos) << r.err;
  r = Ctl({"command", "arm", "resume"});  // not paused
  ExpectOneLine(r, "command", 1, "refused: ");
  EXPECT_NE(r.err.find("not paused"), std::string::npos) << r.err;
  EXPECT_EQ(r.out, "");
  ExpectOneLine(Ctl({"command", "arm", "gains", "--kp", "1,x", "--kd", "1,1"}), "command", 2,
                "--kp: expected finite numbers >= 0, got 'x'");
  ExpectOneLine(Ctl({"command", "arm", "gains", "--kp", "1,-2", "--kd", "1,1"}), "command", 2,
                "--kp: expected finite numbers >= 0, got '-2'");
  ExpectOneLine(Ctl({"command", "arm", "gains", "--kp", "1,2,3", "--kd", "1"}), "command", 2,
                "--kp: expected 2 values (one for every joint, or one per joint), got 3");
  ExpectOneLine(Ctl({"command", "arm", "gains", "--kp", "1"}), "command", 2, "gains: needs both --kp and --kd");
  ExpectOneLine(Ctl({"command", "arm", "gains", "Kp=200,Kd=30"}), "command", 2,
                "gains: expected --kp A[,B..] --kd C[,D..]");
  ExpectOneLine(Ctl({"command", "arm", "pause", "--kp", "1"}), "command", 2, "--kp, --kd: only for gains");
  ExpectOneLine(Ctl({"command", "arm", "fly"}), "command", 2, "unknown action 'fly'");
  ExpectOneLine(Ctl({"command", "robot", "reset", "--wait", "0.5"}), "command", 1, "no state from instance 'robot'");
  ExpectOneLine(RunCtl({"command", "arm", "reset", "--lcm-url", "udpm://239.255.76.67"}), "command", 2,
                "udpm://239.255.76.67");
}

TEST_F(LiveDaemon, WatchShowsEveryInstanceRunIdsAndTheLoopsTiming) {
  Start(7827);
  auto r = Ctl({"watch", "--frames", "2", "--rate", "10"});
  ASSERT_EQ(r.status, 0) << r.err;
  for (const char* text :
       {"lagranged run ", "wake latency us", "compute us", "setpoints ", "\narm   running   computed-torque",
        "\ncartpole   running   lqr", "joint  name          q        q_des          tau", "\n      0  q1  ",
        "\n      1  theta ", "kernel drops ", "fragments dropped ", "foreign messages "}) {
    EXPECT_NE(r.out.find(text), std::string::npos) << text << "\n" << r.out;
  }
  EXPECT_EQ(r.out.find("STALE"), std::string::npos) << r.out;
  // The run id in the header is the one on every state.
  const std::string run = RunIdText(LastState("ARM_STATE").run_id);
  EXPECT_NE(r.out.find("lagranged run " + run), std::string::npos) << run << "\n" << r.out;
  EXPECT_NE(r.out.find("run " + run + "\n"), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("\x1b["), std::string::npos);  // no screen control codes when not on a terminal
  r = Ctl({"watch", "--frames", "1", "--instance", "cartpole"});
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(r.out.find("\narm"), std::string::npos);
  EXPECT_NE(r.out.find("\ncartpole"), std::string::npos);
  ExpectOneLine(Ctl({"watch", "--frames", "1", "--instance", "robot", "--wait", "0.5"}), "watch", 1,
                "no state from instance 'robot' on ROBOT_STATE");
  ExpectOneLine(Ctl({"watch", "--rate", "fast"}), "watch", 2, "--rate: expected a number in (0, 50], got 'fast'");
  ExpectOneLine(RunCtl({"watch", "--frames", "1", "--wait", "0.3", "--lcm-url", testing::TestLcmUrl(7899)}), "watch", 1,
                "no LAGRANGE_STATUS within 0.3 s");
}

// A 7-joint robot from URDF, live: watch names its joints, send takes seven
// values (and refuses six), gains take one value or seven.
TEST_F(LiveDaemon, SendCommandAndWatchWorkWithTheSevenJointPanda) {
  Start(7938, {"--config", std::string(LAGRANGE_SOURCE_DIR) + "/config/panda_minjerk.yaml"});
  auto r = Ctl({"watch", "--frames", "1", "--instance", "panda"});
  ASSERT_EQ(r.status, 0) << r.err;
  for (int j = 0; j < 7; ++j) {
    EXPECT_NE(r.out.find("\n      " + std::to_string(j) + "  panda_joint" + std::to_string(j + 1) + " "),
              std::string::npos)
        << r.out;
  }
  const std::vector<double> target = {0.6, -0.3, -0.4, -1.9, 0.5, 2.1, 0.3};
  r = Ctl({"send", "panda", "--q", "0.6,-0.3,-0.4,-1.9,0.5,2.1,0.3", "--for", "1.5"});
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.out.find("to PANDA_SETPOINT; lagranged accepted "), std::string::npos) << r.out;
  const state_t s = LastState("PANDA_STATE");
  ASSERT_EQ(s.num_dofs, 7);
  for (std::size_t j = 0; j < 7; ++j) EXPECT_NEAR(s.q[j], target[j], 1e-3) << j;
  ExpectOneLine(Ctl({"send", "panda", "--q", "0,0,0,0,0,0"}), "send", 2,
                "--q: expected 7 values (one per joint), got 6");
  r = Ctl({"command", "panda", "gains", "--kp", "300", "--kd", "30"});
  ASSERT_EQ(r.status, 0) << r.err;
  r = Ctl({"command", "panda", "gains", "--kp", "400,400,400,400,300,300,200", "--kd", "40,40,40,40,30,30,20"});
  ASSERT_EQ(r.status, 0) << r.err;
  ExpectOneLine(Ctl({"command", "panda", "gains", "--kp", "1,2", "--kd", "1,2"}), "command", 2,
                "--kp: expected 7 values (one for every joint, or one per joint), got 2");
  r = Ctl({"command", "panda", "controller", "gravity-compensation"});
  ASSERT_EQ(r.status, 0) << r.err;
  // Running, or holding where the stream left it once its setpoint timed out.
  EXPECT_EQ(r.out.rfind("panda: controller gravity-compensation done; now ", 0), 0u) << r.out;
  EXPECT_NE(r.out.find(" with gravity-compensation\n"), std::string::npos) << r.out;
}

// What a status says of one instance's integrator, method, effects and forces ("" / false when it does not say).
struct Settings {
  std::string integrator, method, effects;
  bool forces = false;
};
Settings SettingsOf(const status_t& s, const std::string& instance) {
  for (std::size_t i = 0; i < s.instance_names.size() && i < s.instance_integrators.size(); ++i) {
    if (s.instance_names[i] == instance)
      return {s.instance_integrators[i], s.instance_methods[i], s.instance_effects[i], s.instance_forces[i] != 0};
  }
  return {};
}

// RK4 evaluates the dynamics four times per sub-step: one tick in four
// sub-steps is 16 evaluations. The command goes out with the tolerances at 0
// (the daemon's defaults), and telemetry and status show the switch.
TEST_F(LiveDaemon, IntegratorCommandRunsRk4InFourSubStepsAsTelemetryAndStatusShow) {
  Start(7730);
  ASSERT_TRUE(collector_->WaitFor(
      "ARM_TELEMETRY", [](const auto& m) { return !m.empty(); }, 10.0));
  const telemetry_t before = collector_->Decoded<telemetry_t>("ARM_TELEMETRY").back();
  EXPECT_EQ(before.integrator, "rk4");
  EXPECT_EQ(before.substeps, 1);
  EXPECT_EQ(before.evaluations, 4);

  const auto r = Ctl({"command", "arm", "integrator", "rk4", "--substeps", "4"});
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(r.out, "arm: integrator rk4 done; now running with computed-torque\n");
  const auto commands = collector_->Decoded<command_t>("ARM_COMMAND");
  ASSERT_FALSE(commands.empty());
  const command_t& sent = commands.back();
  EXPECT_EQ(sent.command, command_t::SET_INTEGRATOR);
  EXPECT_EQ(sent.setting, "rk4");
  EXPECT_EQ(sent.substeps, 4);
  EXPECT_EQ(sent.rtol, 0.0);  // 0: the default, exactly
  EXPECT_EQ(sent.atol, 0.0);
  EXPECT_EQ(sent.max_steps, 0);

  ASSERT_TRUE(collector_->WaitForLatest<telemetry_t>(
      "ARM_TELEMETRY", [](const telemetry_t& t) { return t.substeps == 4; }, 5.0));
  constexpr double kExact = 1e-15;
  int switched = 0;
  for (const telemetry_t& t : collector_->Decoded<telemetry_t>("ARM_TELEMETRY")) {
    if (t.substeps != 4) continue;
    ++switched;
    EXPECT_EQ(t.integrator, "rk4");
    EXPECT_EQ(t.mode, state_t::MODE_RUNNING);
    EXPECT_EQ(t.evaluations, 16) << "tick " << t.tick;
    EXPECT_EQ(t.steps_accepted, 4);
    EXPECT_EQ(t.steps_rejected, 0);
    EXPECT_EQ(t.failures, 0);
    EXPECT_EQ(t.error_estimate, -1.0);  // a fixed-step method has none
    EXPECT_NEAR(t.step, 0.001 / 4, kExact);
  }
  EXPECT_GT(switched, 0);
  EXPECT_TRUE(collector_->WaitForLatest<status_t>(
      "LAGRANGE_STATUS", [](const status_t& s) { return SettingsOf(s, "arm").integrator == "rk4 x4"; }, 5.0));
  const status_t status = collector_->Decoded<status_t>("LAGRANGE_STATUS").back();
  EXPECT_EQ(SettingsOf(status, "cartpole").integrator, "rk4");  // the other instance untouched
}

// The variational integrator integrates the full Lagrangian: with coriolis
// off the daemon refuses it and says why; with coriolis back on it takes it.
TEST_F(LiveDaemon, VariationalIntegratorIsRefusedWhileCoriolisIsOff) {
  Start(7731);
  auto r = Ctl({"command", "arm", "effect", "coriolis", "off"});
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(r.out, "arm: effect coriolis off done; now running with computed-torque\n");
  r = Ctl({"command", "arm", "integrator", "variational"});
  ExpectOneLine(r, "command", 1, "refused: ");
  EXPECT_NE(r.err.find("needs effects.coriolis on"), std::string::npos) << r.err;
  EXPECT_EQ(r.out, "");
  ASSERT_TRUE(collector_->WaitForLatest<status_t>(
      "LAGRANGE_STATUS",
      [](const status_t& s) { return SettingsOf(s, "arm").effects.find("gravity") != std::string::npos; }, 5.0));
  const Settings arm = SettingsOf(collector_->Decoded<status_t>("LAGRANGE_STATUS").back(), "arm");
  EXPECT_EQ(arm.effects.find("coriolis"), std::string::npos) << arm.effects;
  EXPECT_EQ(arm.integrator, "rk4");  // unchanged by the refusal

  ASSERT_EQ(Ctl({"command", "arm", "effect", "coriolis", "on"}).status, 0);
  r = Ctl({"command", "arm", "integrator", "variational"});
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_TRUE(collector_->WaitForLatest<telemetry_t>(
      "ARM_TELEMETRY", [](const telemetry_t& t) { return t.integrator == "variational"; }, 5.0));
}

// The largest tick among `messages` (-1 for none).
template <class Message>
std::int64_t LastTick(const std::vector<Message>& messages) {
  std::int64_t last = -1;
  for (const Message& m : messages) last = std::max(last, m.tick);
  return last;
}

// ARM_FORCES flows only while asked. Its rows are the tick's: tau_applied is
// the state's applied torque of the same tick. After `forces off`, states
// keep coming and no forces come with them.
TEST_F(LiveDaemon, ForcesOnPublishesTheArmsForcesAndForcesOffStopsThem) {
  Start(7732);
  ASSERT_TRUE(collector_->WaitFor(
      "ARM_STATE", [](const auto& m) { return m.size() >= 200; }, 10.0));
  EXPECT_EQ(collector_->Count("ARM_FORCES"), 0u);  // the default scene does not ask for them

  auto r = Ctl({"command", "arm", "forces", "on"});
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(r.out, "arm: forces on done; now running with computed-torque\n");
  ASSERT_TRUE(collector_->WaitFor(
      "ARM_FORCES", [](const auto& m) { return m.size() >= 100; }, 10.0));
  EXPECT_TRUE(collector_->WaitForLatest<status_t>(
      "LAGRANGE_STATUS", [](const status_t& s) { return SettingsOf(s, "arm").forces; }, 5.0));
  EXPECT_EQ(collector_->Count("CARTPOLE_FORCES"), 0u);  // asked of the arm alone

  std::map<std::int64_t, state_t> states;
  for (state_t& s : collector_->Decoded<state_t>("ARM_STATE")) states[s.tick] = std::move(s);
  constexpr double kExact = 1e-12;
  int matched = 0;
  for (const forces_t& f : collector_->Decoded<forces_t>("ARM_FORCES")) {
    ASSERT_EQ(f.num_dofs, 2);
    EXPECT_TRUE(f.gravity_on);
    EXPECT_TRUE(f.coriolis_on);
    EXPECT_FALSE(f.damping_on);  // the default scene's arm has no damping: its row is zeros
    EXPECT_EQ(f.damping, std::vector<double>(2, 0.0));
    const auto s = states.find(f.tick);
    if (s == states.end()) continue;  // its state was lost or is yet to come
    ++matched;
    EXPECT_EQ(f.run_id, s->second.run_id);
    for (std::size_t j = 0; j < 2; ++j) EXPECT_NEAR(f.tau_applied[j], s->second.tau[j], kExact) << "tick " << f.tick;
  }
  EXPECT_GT(matched, 0);

  r = Ctl({"command", "arm", "forces", "off"});
  ASSERT_EQ(r.status, 0) << r.err;
  // Were forces still on, each new state would come with its forces: 500
  // states beyond the last forces' tick cannot arrive.
  constexpr std::int64_t kStatesBeyond = 500;
  bool stopped = false;
  for (const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
       !stopped && std::chrono::steady_clock::now() < deadline;) {
    stopped = LastTick(collector_->Decoded<state_t>("ARM_STATE")) >=
              LastTick(collector_->Decoded<forces_t>("ARM_FORCES")) + kStatesBeyond;
    if (!stopped) std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  EXPECT_TRUE(stopped);
  EXPECT_TRUE(collector_->WaitForLatest<status_t>(
      "LAGRANGE_STATUS", [](const status_t& s) { return !SettingsOf(s, "arm").forces; }, 5.0));
}

// watch shows each instance's integrator, method and effects from the status,
// and from its telemetry ε and the cost per tick.
TEST_F(LiveDaemon, WatchShowsTheResidualTheCostAndTheIntegratorOfEachInstance) {
  Start(7733);
  ASSERT_EQ(Ctl({"command", "arm", "integrator", "rk4", "--substeps", "4"}).status, 0);
  const auto r = Ctl({"watch", "--frames", "3", "--rate", "5"});
  ASSERT_EQ(r.status, 0) << r.err;
  const std::size_t last = r.out.rfind("lagranged run ");
  ASSERT_NE(last, std::string::npos) << r.out;
  const std::string frame = r.out.substr(last);
  const std::size_t arm = frame.find("\narm   "), cartpole = frame.find("\ncartpole   ");
  ASSERT_NE(arm, std::string::npos) << frame;
  ASSERT_NE(cartpole, std::string::npos) << frame;
  const std::string arm_lines = frame.substr(arm, cartpole - arm), cartpole_lines = frame.substr(cartpole);
  for (const char* text : {"\n  integrator rk4 x4   method ", "   effects gravity,coriolis", "   forces off\n",
                           "\n  ε ", " J (quadrature bound ", "   evaluations 16/tick   compute "}) {
    EXPECT_NE(arm_lines.find(text), std::string::npos) << text << "\n" << arm_lines;
  }
  for (const char* text : {"\n  integrator rk4   method ", "\n  ε ", "   evaluations 4/tick   compute "})
    EXPECT_NE(cartpole_lines.find(text), std::string::npos) << text << "\n" << cartpole_lines;
  EXPECT_EQ(frame.find("no telemetry"), std::string::npos) << frame;
}

// A floating base (its <NAME>_BASE beside its state): watch shows where the base is, its centre of mass and momentum.
TEST_F(LiveDaemon, WatchShowsAFloatingBasesPoseCentreOfMassAndMomentum) {
  Start(9031, {"--config", std::string(LAGRANGE_SOURCE_DIR) + "/tests/fixtures/scenes/floating_fall.yaml"});
  ASSERT_TRUE(collector_->WaitFor("TREE_BASE", [](const auto& m) { return m.size() >= 5; }, 20.0));
  const auto r = Ctl({"watch", "--frames", "2", "--rate", "5"});
  ASSERT_EQ(r.status, 0) << r.err;
  const std::size_t last = r.out.rfind("\ntree   ");
  ASSERT_NE(last, std::string::npos) << r.out;
  const std::string frame = r.out.substr(last);
  for (const char* text : {"\n  base p (", " m   quat (x y z w) (", ") rad/s\n", "\n  com (", " N·s   about com ("}) {
    EXPECT_NE(frame.find(text), std::string::npos) << text << "\n" << frame;
  }
}

TEST(LiveStale, WatchMarksADaemonThatStoppedAsStale) {
  ASSERT_EQ(testing::PrepareLoopbackMulticast(7929), "");
  const std::string url = testing::TestLcmUrl(7929);
  LcmCollector collector(url, "LAGRANGE_STATUS");
  BackgroundProcess daemon({LAGRANGED_PATH, "--lcm-url", url, "--log-level", "warn", "--duration", "1.5"});
  ASSERT_TRUE(collector.WaitFor(
      "LAGRANGE_STATUS", [](const auto& m) { return !m.empty(); }, 20.0));
  // Frames for 5 s: the daemon stops 1.5 s of ticks after it started, so the last frames come long after.
  const auto r = RunCtl({"watch", "--frames", "15", "--rate", "3", "--lcm-url", url});
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(daemon.Wait(30.0), 0) << daemon.Stderr();
  const std::size_t last = r.out.rfind("lagranged run ");
  ASSERT_NE(last, std::string::npos) << r.out;
  const std::string final_frame = r.out.substr(last);
  EXPECT_NE(final_frame.find("STALE: no status for"), std::string::npos) << final_frame;
  EXPECT_NE(final_frame.find("\narm   STALE (no state for"), std::string::npos) << final_frame;
  EXPECT_EQ(final_frame.find("   running   "), std::string::npos) << final_frame;
}

// A publisher of ARM_STATE and LAGRANGE_STATUS with made-up run ids and no
// daemon behind it; optionally it answers commands with a reply_t of its choosing.
class FakeDaemon {
 public:
  struct Config {
    std::vector<std::int64_t> run_ids = {0x1234};  // states alternate between these
    std::string controller = "pd";
    std::int8_t mode = state_t::MODE_RUNNING;
    std::string mode_reason;        // the status's instance_reasons
    bool answer = false;            // reply to every command
    std::int64_t reply_run_id = 0;  // 0: the first run id
    bool every_run_answers = false;  // one reply per run id (as several daemons would)
    bool wrong_request_id = false;  // answer with another request_id than the command's
    bool accept = true;
    std::string reason;
    bool estop_stays = true;  // an accepted estop shows in the states after it (false: a daemon that lost it)
  };
  FakeDaemon(const std::string& url, Config config) : lcm_(url), config_(std::move(config)) {
    lcm_.subscribeFunction("ARM_COMMAND", &FakeDaemon::OnCommand, this);
    lcm_.subscribeFunction("ARM_SETPOINT", &FakeDaemon::OnSetpoint, this);
    thread_ = std::thread([this] { Loop(); });
  }
  ~FakeDaemon() {
    stop_ = true;
    thread_.join();
  }
  int commands() const { return commands_.load(); }
  int setpoints() const { return setpoints_.load(); }

 private:
  static void OnCommand(const lcm::ReceiveBuffer* rbuf, const std::string&, FakeDaemon* self) {
    ++self->commands_;
    command_t c;
    if (!self->config_.answer || c.decode(rbuf->data, 0, static_cast<int>(rbuf->data_size)) < 0) return;
    reply_t r;
    r.utime = testing::WallMicros();
    r.run_id = self->config_.reply_run_id ? self->config_.reply_run_id : self->config_.run_ids.front();
    r.request_id = self->config_.wrong_request_id ? c.request_id + 1 : c.request_id;
    r.command = c.command;
    r.accepted = self->config_.accept;
    r.reason = self->config_.reason;
    // An applied estop stays, as lagranged's does: the states after it say so (lagrangectl watches them).
    if (r.accepted && c.command == command_t::ESTOP && self->config_.estop_stays) {
      self->config_.mode = state_t::MODE_ESTOP;
    }
    self->lcm_.publish("ARM_REPLY", &r);
    if (!self->config_.every_run_answers) return;
    for (std::size_t k = 1; k < self->config_.run_ids.size(); ++k) {
      r.run_id = self->config_.run_ids[k];
      self->lcm_.publish("ARM_REPLY", &r);
    }
  }
  static void OnSetpoint(const lcm::ReceiveBuffer*, const std::string&, FakeDaemon* self) { ++self->setpoints_; }
  void Loop() {
    std::int64_t tick = 0;
    while (!stop_) {
      state_t s{};
      s.utime = testing::WallMicros();
      s.run_id = config_.run_ids[static_cast<std::size_t>(tick) % config_.run_ids.size()];
      s.tick = tick++;
      s.t = 0.005 * static_cast<double>(tick);
      s.num_dofs = 2;
      for (auto* v : {&s.q, &s.qd, &s.qdd, &s.tau, &s.q_des, &s.qd_des}) v->assign(2, 0.1);
      s.controller = config_.controller;
      s.mode = config_.mode;
      lcm_.publish("ARM_STATE", &s);
      if (tick % 10 == 0) {
        status_t st{};
        st.utime = s.utime;
        st.run_id = config_.run_ids.front();
        st.ticks = tick;
        st.period = 0.001;
        st.last_rejection = "";
        st.last_command_error = "";
        st.datagrams_dropped_kernel = 7;
        st.datagrams_malformed = 8;
        st.fragments_dropped = 9;
        st.foreign_messages = 11;
        st.last_foreign_run_id = 0xbad;
        st.num_instances = 1;
        st.instance_names = {"arm"};
        st.instance_modes = {config_.mode};
        st.instance_dofs = {2};
        st.instance_reasons = {config_.mode_reason};
        st.instance_integrators = {"rk4"};
        st.instance_methods = {"closed-form"};
        st.instance_effects = {"gravity,coriolis"};
        st.instance_forces = {0};
        st.num_joints = 2;
        st.joint_names = {"q1", "q2"};
        lcm_.publish("LAGRANGE_STATUS", &st);
      }
      lcm_.handleTimeout(5);
    }
  }

  lcm::LCM lcm_;
  Config config_;
  std::atomic<bool> stop_{false};
  std::atomic<int> commands_{0}, setpoints_{0};
  std::thread thread_;
};

std::string Url(int port) {
  EXPECT_EQ(testing::PrepareLoopbackMulticast(port), "");
  return testing::TestLcmUrl(port);
}

TEST(BelievesNobody, CommandFailsWhenNothingAnswersThoughStateAndStatusFlow) {
  const std::string url = Url(7922);
  FakeDaemon fake(url, {});
  const auto r = RunCtl({"command", "arm", "estop", "--wait", "1", "--lcm-url", url});
  ExpectOneLine(r, "command", 1, "no verdict from lagranged (run 0000000000001234) within 1 s");
  EXPECT_EQ(r.out.find("done"), std::string::npos) << r.out;
}

TEST(BelievesNobody, AReplyFromAnotherRunOrWithAnotherRequestIdProvesNothing) {
  const std::string url = Url(7923);
  for (const bool other_run : {true, false}) {
    FakeDaemon::Config config;
    config.answer = true;
    if (other_run)
      config.reply_run_id = 0x5678;  // not the run publishing ARM_STATE
    else
      config.wrong_request_id = true;  // the right run, answering another command
    FakeDaemon fake(url, config);
    const auto r = RunCtl({"command", "arm", "estop", "--wait", "1", "--lcm-url", url});
    ExpectOneLine(r, "command", 1, "no verdict from lagranged (run 0000000000001234) within 1 s");
    EXPECT_EQ(r.out, "");
  }
}

TEST(BelievesNobody, ARefusalIsReportedWithItsReasonEscaped) {
  const std::string url = Url(7924);
  FakeDaemon::Config config;
  config.answer = true;
  config.accept = false;
  config.reason = "nope\x1b[2J\nlagrangectl command: forged";
  FakeDaemon fake(url, config);
  const auto r = RunCtl({"command", "arm", "pause", "--wait", "2", "--lcm-url", url});
  ExpectOneLine(r, "command", 1, "refused: nope\\x1b[2J\\nlagrangectl command: forged");
  EXPECT_EQ(r.err.find('\x1b'), std::string::npos);
}

TEST(BelievesNobody, AnAnswerFromTheOneRunWithItsOwnRequestIdIsSuccessPrintedEscaped) {
  const std::string url = Url(7925);
  FakeDaemon::Config config;
  config.answer = true;
  config.controller = "pd\x07\x1b]0;owned\x07";
  FakeDaemon fake(url, config);
  const auto r = RunCtl({"command", "arm", "pause", "--wait", "2", "--lcm-url", url});
  ASSERT_EQ(r.status, 0) << r.err;  // a consistent publisher that answers is all lagrangectl can check
  EXPECT_EQ(r.out, "arm: pause done; now running with pd\\x07\\x1b]0;owned\\x07\n");
}

TEST(BelievesNobody, TwoRunsOnOneStateChannelMakeSendAndCommandRefuseToAct) {
  const std::string url = Url(7926);
  FakeDaemon::Config config;
  config.run_ids = {0xaa, 0xbb};
  config.answer = true;
  FakeDaemon fake(url, config);
  const std::string two =
      "two lagranged runs publish ARM_STATE (ids 00000000000000aa and 00000000000000bb): refusing to act";
  auto r = RunCtl({"command", "arm", "pause", "--lcm-url", url});
  ExpectOneLine(r, "command", 1, two);
  r = RunCtl({"send", "arm", "--min-jerk", "1", "--q", "0.3,0.3", "--lcm-url", url});
  ExpectOneLine(r, "send", 1, two);
  EXPECT_EQ(fake.commands(), 0);  // nothing was sent
  EXPECT_EQ(fake.setpoints(), 0);
}

TEST(BelievesNobody, AnEstopGoesToEveryRunOnTheStateChannelAndReportsEachVerdict) {
  const std::string url = Url(7848);
  FakeDaemon::Config config;
  config.run_ids = {0xaa, 0xbb};
  config.answer = true;
  config.every_run_answers = true;
  FakeDaemon fake(url, config);
  const auto r = RunCtl({"command", "arm", "estop", "--wait", "2", "--lcm-url", url});
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(r.out,
            "arm: run 00000000000000aa: estop done; now estop with pd\n"
            "arm: run 00000000000000bb: estop done; now estop with pd\n");
  EXPECT_GE(fake.commands(), 1);
}

TEST(BelievesNobody, AnEstopThatOneRunDidNotApplyIsNamedAndFails) {
  const std::string url = Url(7849);
  FakeDaemon::Config config;
  config.run_ids = {0xaa, 0xbb};
  config.answer = true;  // only 0xaa answers
  FakeDaemon fake(url, config);
  const auto r = RunCtl({"command", "arm", "estop", "--wait", "1", "--lcm-url", url});
  ExpectOneLine(r, "command", 1,
                "estop applied by 1 of the 2 runs publishing ARM_STATE (ids 00000000000000aa, 00000000000000bb)");
  EXPECT_EQ(r.out,
            "arm: run 00000000000000aa: estop done; now estop with pd\n"
            "arm: run 00000000000000bb: estop no verdict within 1 s\n");
}

// Issue 32: a daemon that answers "accepted" to an estop whose states then
// show it running (its estop cleared at once, as a flood of clears did) is
// not reported as done: lagrangectl says the estop did not stay, exit 1.
TEST(BelievesNobody, AnEstopWhoseStatesDoNotKeepItIsNotReportedDone) {
  const std::string url = Url(8560);
  FakeDaemon::Config config;
  config.answer = true;
  config.estop_stays = false;
  FakeDaemon fake(url, config);
  const auto r = RunCtl({"command", "arm", "estop", "--wait", "2", "--lcm-url", url});
  ExpectOneLine(r, "command", 1, "estop applied, but the estop did not stay: running with pd");
  EXPECT_EQ(r.out, "");
}

// A gain refusal names the per-joint bounds before anything cuts it: whole in
// lagrangectl's line, and within the status's last_command_error.
TEST_F(LiveDaemon, AGainRefusalKeepsItsPerJointBoundsInTheReplyAndTheStatus) {
  Start(7852);
  ASSERT_EQ(Ctl({"command", "arm", "controller", "pd"}).status, 0);
  const auto r = Ctl({"command", "arm", "gains", "--kp", "1e6", "--kd", "1"});
  ExpectOneLine(r, "command", 1, "refused: gains for pd: kp[0]: expected |gain| <= ");
  EXPECT_NE(r.err.find("; or every kp within its joint's bound ["), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("], but kp[0] = 1e+06 ("), std::string::npos) << r.err;
  EXPECT_EQ(r.err.substr(r.err.size() - 2), ")\n") << r.err;  // the rules' end: nothing cut
  ASSERT_TRUE(collector_->WaitForLatest<status_t>(
      "LAGRANGE_STATUS", [](const status_t& s) { return s.last_command_error.find("], but kp[0] = 1e+06") != std::string::npos; },
      5.0));
}

// The daemon's status is heard but not the instance's state: lagrangectl says
// so, and what it heard, as soon as the state is overdue (kNoStateGrace), not
// when --wait ends: the message is the early one, "though a lagranged is
// publishing there", never "within 30 s".
TEST_F(LiveDaemon, AMistypedInstanceOrAForgottenPrefixIsNamedWithoutWaitingOutTheWait) {
  Start(7851);
  ExpectOneLine(Ctl({"command", "amr", "pause", "--wait", "30"}), "command", 1,
                "no state from instance 'amr' on AMR_STATE on " + url_ +
                    ", though a lagranged is publishing there; state channels heard: ARM_STATE, CARTPOLE_STATE; did "
                    "you mean 'arm'?");
  ExpectOneLine(Ctl({"send", "arm", "--q", "0,0", "--channel-prefix", "LEFT_", "--wait", "30"}), "send", 1,
                ", though a lagranged is publishing there; a lagranged publishes ARM_STATE: without --channel-prefix?");
  ExpectOneLine(Ctl({"watch", "--frames", "1", "--channel-prefix", "LEFT_", "--wait", "1"}), "watch", 1,
                "no LEFT_LAGRANGE_STATUS within 1 s on " + url_ +
                    "; a lagranged publishes LAGRANGE_STATUS: without --channel-prefix?");
}

// A forger publishing ARM_STATE under another run id cannot keep an estop
// from the real daemon: lagrangectl sends it, the daemon applies it, and the
// forger's silence is reported beside the daemon's verdict.
TEST_F(LiveDaemon, AnEstopLandsOnTheDaemonThoughAForgerPublishesItsStateChannel) {
  Start(7850);
  const std::int64_t daemon_run = LastState("ARM_STATE").run_id;
  FakeDaemon::Config config;
  config.run_ids = {0xbad};
  FakeDaemon forger(url_, config);
  const auto r = Ctl({"command", "arm", "estop", "--wait", "1"});
  EXPECT_EQ(r.status, 1) << r.err;
  EXPECT_NE(r.out.find("arm: run " + RunIdText(daemon_run) + ": estop done; now estop with "), std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("arm: run 0000000000000bad: estop no verdict within 1 s"), std::string::npos) << r.out;
  EXPECT_NE(r.err.find("estop applied by 1 of the 2 runs publishing ARM_STATE"), std::string::npos) << r.err;
  // The daemon's own states say it: in estop.
  ASSERT_TRUE(collector_->WaitFor(
      "ARM_STATE",
      [&](const std::vector<testing::LcmCollector::Message>& m) {
        for (const auto& message : m) {
          state_t s;
          if (s.decode(message.data.data(), 0, static_cast<int>(message.data.size())) > 0 &&
              s.run_id == daemon_run && s.mode == state_t::MODE_ESTOP)
            return true;
        }
        return false;
      },
      5.0));
  // Other commands still refuse.
  const auto pause = Ctl({"command", "arm", "pause", "--wait", "1"});
  ExpectOneLine(pause, "command", 1, "two lagranged runs publish ARM_STATE");
}

TEST(BelievesNobody, WatchEscapesBusStringsAndShowsTheStatusCounters) {
  const std::string url = Url(7927);
  FakeDaemon::Config config;
  config.controller = "evil\x1b]0;title\x07\nforged line";
  config.mode = state_t::MODE_HOLD;
  config.mode_reason = "stuck\x1b[2J\nlagrangectl: forged";
  FakeDaemon fake(url, config);
  const auto r = RunCtl({"watch", "--frames", "1", "--lcm-url", url});
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(r.out.find('\x1b'), std::string::npos);
  EXPECT_EQ(r.out.find('\x07'), std::string::npos);
  for (const char* text :
       {"evil\\x1b]0;title\\x07\\nforged line", "\narm   hold (stuck\\x1b[2J\\nlagrangectl: forged)   evil",
        "run 0000000000001234", "kernel drops 7", "malformed 8", "fragments dropped 9",
        "foreign messages 11 (last from run 0000000000000bad)"}) {
    EXPECT_NE(r.out.find(text), std::string::npos) << text << "\n" << r.out;
  }
}

TEST(Lagrangectl, SuggestsTheNearestCommandAndPrintsItsVersion) {
  auto r = RunCtl({"evl"});
  EXPECT_EQ(r.status, 2);
  EXPECT_EQ(r.err, "lagrangectl: unknown command 'evl'; did you mean 'eval'?\n");
  r = RunCtl({"watc"});
  EXPECT_EQ(r.err, "lagrangectl: unknown command 'watc'; did you mean 'watch'?\n");
  r = RunCtl({"frobnicate"});
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("unknown command 'frobnicate' (expected one of eval, simulate, send"), std::string::npos)
      << r.err;
  r = RunCtl({"--version"});
  EXPECT_EQ(r.status, 0);
  EXPECT_EQ(r.out, std::string("lagrangectl ") + LAGRANGE_VERSION + "\n");
}

}  // namespace
}  // namespace lagrange

namespace lagrange {
namespace {

// The Panda under Cartesian impedance takes pose targets on PANDA_POSE and
// publishes its frame on PANDA_TASK; lagrangectl send --pose drives it, and
// every bad pose, from lagrangectl or raw off the bus, is refused by name.
class LivePose : public LiveDaemon {
 protected:
  void StartPanda(int port) {
    Start(port, {"--config", std::string(LAGRANGE_SOURCE_DIR) + "/config/panda_cartesian_impedance.yaml"});
  }
  // A pose_setpoint_t sent raw (as any program on the bus may), stamped
  // `age_us` ago, then the daemon's last rejection once its count moved.
  std::string RawPoseRejection(pose_setpoint_t pose, std::int64_t age_us = 0) {
    const std::int64_t before = RejectedSetpoints();
    lcm::LCM lcm(url_);
    pose.utime = WallMicros() - age_us;
    lcm.publish("PANDA_POSE", &pose);
    std::string reason;
    collector_->WaitForLatest<status_t>(
        "LAGRANGE_STATUS",
        [&](const status_t& s) {
          reason = s.last_rejection;
          return s.setpoints_rejected > before;
        },
        10.0);
    return reason;
  }
  std::int64_t RejectedSetpoints() {
    const auto statuses = collector_->Decoded<status_t>("LAGRANGE_STATUS");
    return statuses.empty() ? 0 : statuses.back().setpoints_rejected;
  }
  static std::int64_t WallMicros() {
    return std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::system_clock::now().time_since_epoch())
        .count();
  }
  static pose_setpoint_t Pose(double x, double y, double z) {
    pose_setpoint_t p{};
    p.position[0] = x;
    p.position[1] = y;
    p.position[2] = z;
    p.orientation[1] = 0.9238795325112867;  // the ready pose's hand: (w, x, y, z)
    p.orientation[2] = -0.3826834323650898;
    return p;
  }
};

TEST_F(LivePose, SendPoseMovesThePandasFrameThereAndItsTaskStateShowsTargetAndError) {
  StartPanda(7995);
  ASSERT_TRUE(collector_->WaitForLatest<task_state_t>(
      "PANDA_TASK", [](const task_state_t& t) { return t.frame == "panda_link8"; }, 20.0));
  // The scene's own 2 s move ends first: from then on the target stands still.
  ASSERT_TRUE(collector_->WaitForLatest<task_state_t>("PANDA_TASK", [](const task_state_t& t) { return t.t > 2.2; },
                                                      20.0));
  const task_state_t first = collector_->Decoded<task_state_t>("PANDA_TASK").back();
  EXPECT_EQ(first.controller, "cartesian-impedance");
  EXPECT_NEAR(Eigen::Map<const Eigen::Vector4d>(first.orientation).norm(), 1.0, 1e-12);

  const auto r = Ctl({"send", "panda", "--pose", "0.45,0.05,0.45", "--min-jerk", "1"});
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.out.find("over 1 s, minimum jerk to PANDA_POSE; lagranged accepted it; panda_link8 is "),
            std::string::npos)
      << r.out;
  // The target is latched as sent (the orientation kept), and the hand gets there.
  const Eigen::Vector3d target(0.45, 0.05, 0.45);
  constexpr double kThere = 1e-3;  // m: well past the move, the impedance has the hand within this
  ASSERT_TRUE(collector_->WaitForLatest<task_state_t>(
      "PANDA_TASK",
      [&](const task_state_t& t) {
        return (Eigen::Map<const Eigen::Vector3d>(t.position_des) - target).norm() < 1e-12 &&
               (Eigen::Map<const Eigen::Vector3d>(t.position) - target).norm() < kThere;
      },
      20.0));
  const task_state_t t = collector_->Decoded<task_state_t>("PANDA_TASK").back();
  for (int k = 0; k < 4; ++k) EXPECT_NEAR(t.orientation_des[k], first.orientation_des[k], 1e-12) << k;
  // error = desired − measured, position part.
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(t.error[k], t.position_des[k] - t.position[k], 1e-12) << k;
}

// A task-space controller's gains are one per task axis (x, y, z, rx, ry,
// rz): lagrangectl sends six, and the daemon holds them to the impedance's
// bound through Λ with the joint controllers' wording.
TEST_F(LivePose, GainsForATaskSpaceControllerAreOnePerTaskAxisWithinItsBound) {
  StartPanda(7997);
  auto r = Ctl({"command", "panda", "gains", "--kp", "300,300,300,10,10,10", "--kd", "30,30,30,0.5,0.5,0.5"});
  ASSERT_EQ(r.status, 0) << r.err;
  ExpectOneLine(Ctl({"command", "panda", "gains", "--kp", "1,2,3,4,5,6,7", "--kd", "1"}), "command", 2,
                "--kp: expected 6 values (one for every task axis, or one per task axis: x, y, z, rx, ry, rz), got 7");
  ExpectOneLine(Ctl({"command", "panda", "gains", "--kp", "5e7,300,300,10,10,10", "--kd", "30,30,30,0.5,0.5,0.5"}),
                "command", 1, "gains for cartesian-impedance: kp[0]: expected |gain| <= ");
}

TEST_F(LivePose, EveryBadPoseIsRefusedByNameFromLagrangectlOrRawOffTheBus) {
  StartPanda(7996);
  ASSERT_TRUE(collector_->WaitForLatest<task_state_t>("PANDA_TASK", [](const task_state_t&) { return true; }, 20.0));
  ExpectOneLine(Ctl({"send", "panda", "--pose", "0.4,0,0.5,0.5,0.5,0,0"}), "send", 2,
                "--pose: expected a unit quaternion QW,QX,QY,QZ, got norm 0.7071067811865476");
  ExpectOneLine(Ctl({"send", "panda", "--pose", "0.4,0"}), "send", 2,
                "--pose: expected X,Y,Z or X,Y,Z,QW,QX,QY,QZ (3 or 7 numbers), got 2");
  ExpectOneLine(Ctl({"send", "panda", "--pose", "1.5,0,0.5"}), "send", 1,
                "lagranged rejected the pose: panda: pose: position[0] = 1.5 m is outside the workspace [-0.9, 0.9]");
  ExpectOneLine(Ctl({"send", "panda", "--pose", "0.4,0,0.5", "--frame", "panda_link7"}), "send", 1,
                "panda: pose: frame 'panda_link7': the task-space controller moves 'panda_link8'");

  pose_setpoint_t not_unit = Pose(0.4, 0.0, 0.5);
  not_unit.orientation[1] = 2.0;
  EXPECT_NE(RawPoseRejection(not_unit).find("panda: pose: orientation: expected a unit quaternion"), std::string::npos);
  pose_setpoint_t nan = Pose(0.4, 0.0, 0.5);
  nan.position[2] = std::nan("");
  EXPECT_EQ(RawPoseRejection(nan), "panda: pose: non-finite value in position[2]");
  pose_setpoint_t moving = Pose(0.4, 0.0, 0.5);
  moving.duration = 1.0;
  moving.twist[0] = 0.5;
  EXPECT_EQ(RawPoseRejection(moving), "panda: pose: twist with duration 1 s: a timed move ends at rest (send zeros)");
  const std::string stale = RawPoseRejection(Pose(0.4, 0.0, 0.5), 10'000'000);  // beyond setpoint_timeout (0.5 s)
  EXPECT_EQ(stale.rfind("panda: pose: stale: sent ", 0), 0u) << stale;

  // Under a joint-space controller a pose is refused, and lagrangectl says why before sending.
  ASSERT_EQ(Ctl({"command", "panda", "controller", "gravity-compensation"}).status, 0);
  EXPECT_EQ(RawPoseRejection(Pose(0.4, 0.0, 0.5)),
            "panda: pose: the instance is not running a controller that moves a frame (active: "
            "gravity-compensation; pose setpoints need a task-space controller or an mpc with a frame)");
  ExpectOneLine(Ctl({"send", "panda", "--pose", "0.4,0,0.5"}), "send", 1,
                "panda publishes no task state on PANDA_TASK: it runs gravity-compensation, not a task-space "
                "controller");
  // Still alive and finite after all of it.
  const state_t s = LastState("PANDA_STATE");
  for (double q : s.q) EXPECT_TRUE(std::isfinite(q));
}

// A pose's feed-forward twist is bounded by what the joints' velocity limits
// allow the frame (plant/frame_speed.hpp): the Panda's flange turns at most
// 4 × 2.175 + 3 × 2.61 = 16.53 rad/s. Issue 32: 264 rad/s about z (and anything
// up to 1e6) was accepted, and the wrist spun at 264 rad/s.
TEST_F(LivePose, AFeedForwardTwistBeyondWhatTheJointVelocityLimitsAllowIsRefused) {
  StartPanda(8668);
  ASSERT_TRUE(collector_->WaitForLatest<task_state_t>(
      "PANDA_TASK", [](const task_state_t&) { return true; }, 20.0));
  pose_setpoint_t spin = Pose(0.4, 0.0, 0.5);
  spin.twist[5] = 264.0;
  EXPECT_EQ(RawPoseRejection(spin),
            "panda: pose: twist: angular speed 264 rad/s is more than the joints' velocity limits allow 'panda_link8' "
            "(at most 16.53 rad/s anywhere)");
  pose_setpoint_t huge = Pose(0.4, 0.0, 0.5);
  huge.twist[0] = 1e6;
  EXPECT_EQ(RawPoseRejection(huge).rfind("panda: pose: twist: linear speed 1e+06 m/s is more than", 0), 0u);
  // Within the bound it is taken (and, streamed once, stops at rest after setpoint_timeout).
  const auto accepted = [&] {
    const auto statuses = collector_->Decoded<status_t>("LAGRANGE_STATUS");
    return statuses.empty() ? 0 : statuses.back().setpoints_accepted;
  };
  const std::int64_t before = accepted();
  pose_setpoint_t turn = Pose(0.4, 0.0, 0.5);
  turn.twist[5] = 0.2;
  turn.utime = WallMicros();
  lcm::LCM(url_).publish("PANDA_POSE", &turn);
  EXPECT_TRUE(collector_->WaitForLatest<status_t>(
      "LAGRANGE_STATUS", [&](const status_t& st) { return st.setpoints_accepted > before; }, 10.0));
}

// The mirror of the pose refused by a joint controller: joint setpoints sent
// to the Panda under Cartesian impedance are refused by name (never counted
// as accepted and ignored), so no joint stream can time out under it; and a
// joint stream from before a switch to it cannot either: after a pose the
// instance runs, and keeps running (issue 32: every later pose flipped it back
// to hold for a tick, and lagrangectl said it did not follow the pose).
TEST_F(LivePose, AJointSetpointIsRefusedByATaskSpaceInstanceAndAPoseKeepsItRunning) {
  StartPanda(8660);
  ASSERT_TRUE(collector_->WaitForLatest<task_state_t>(
      "PANDA_TASK", [](const task_state_t&) { return true; }, 20.0));
  const std::string q = "0,-0.785,0,-2.356,0,1.571,0.785";
  ExpectOneLine(Ctl({"send", "panda", "--q", q, "--for", "0.2"}), "send", 1,
                "panda: the instance is running a controller that moves a frame (active: cartesian-impedance), "
                "which follows "
                "pose setpoints (pose_setpoint_t, lagrangectl send --pose), not joint setpoints");

  // A joint stream under gravity compensation, then back to the task-space
  // controller: that stream times out (setpoint_timeout 0.5 s) while the poses decide.
  ASSERT_EQ(Ctl({"command", "panda", "controller", "gravity-compensation"}).status, 0);
  ASSERT_EQ(Ctl({"send", "panda", "--q", q, "--for", "0.2"}).status, 0);
  ASSERT_EQ(Ctl({"command", "panda", "controller", "cartesian-impedance"}).status, 0);
  std::this_thread::sleep_for(std::chrono::milliseconds(800));
  for (const char* pose : {"0.4,0.05,0.5", "0.42,0.05,0.5"}) {
    const auto r = Ctl({"send", "panda", "--pose", pose});
    ASSERT_EQ(r.status, 0) << r.err;
  }
  // Running in every state from here on: no hold, not even for a tick.
  const std::size_t from = collector_->Count("PANDA_STATE");
  std::this_thread::sleep_for(std::chrono::milliseconds(1000));
  const auto states = collector_->Decoded<state_t>("PANDA_STATE");
  ASSERT_GT(states.size(), from + 100) << "states kept coming";
  for (std::size_t k = from; k < states.size(); ++k) {
    ASSERT_EQ(states[k].mode, state_t::MODE_RUNNING) << "tick " << states[k].tick;
  }
}

}  // namespace
}  // namespace lagrange
