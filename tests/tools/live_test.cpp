// lagrangectl send, command and watch against a running lagranged on a
// private LCM port, including bad input to each.

#include <gtest/gtest.h>
#include <lagrange/state_t.hpp>
#include <signal.h>

#include <cmath>

#include "tests/support/lcm_testing.hpp"
#include "tests/support/process.hpp"
#include "tests/tools/run_ctl.hpp"

namespace lagrange {
namespace {

using testing::BackgroundProcess;
using testing::LcmCollector;
using testing::RunCtl;

class LiveDaemon : public ::testing::Test {
 protected:
  void Start(int port, std::vector<std::string> extra = {}) {
    ASSERT_EQ(testing::PrepareLoopbackMulticast(port), "");
    url_ = testing::TestLcmUrl(port);
    collector_ = std::make_unique<LcmCollector>(url_);
    std::vector<std::string> argv = {LAGRANGED_PATH, "--lcm-url", url_, "--log-level", "warn"};
    argv.insert(argv.end(), extra.begin(), extra.end());
    daemon_ = std::make_unique<BackgroundProcess>(argv);
    ASSERT_TRUE(collector_->WaitFor("LAGRANGE_STATUS", [](const auto& m) { return !m.empty(); }, 20.0));
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
  // One line on stderr that names the command and contains `what`.
  static void ExpectOneLine(const testing::CtlResult& r, const std::string& command, int status, const std::string& what) {
    EXPECT_EQ(r.status, status) << r.err;
    ASSERT_EQ(testing::Lines(r.err).size(), 1u) << r.err;
    EXPECT_EQ(r.err.rfind("lagrangectl " + command + ": ", 0), 0u) << r.err;
    EXPECT_NE(r.err.find(what), std::string::npos) << "got: " << r.err << "expected: " << what;
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
    if (states[k].mode == state_t::MODE_RUNNING && states[k].q_des[0] != before.q_des[0]) q0_des.push_back(states[k].q_des[0]);
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

TEST_F(LiveDaemon, SendRefusesBadInputWithOneLine) {
  Start(7824);
  ExpectOneLine(Ctl({"send", "robot", "--q", "1,2", "--wait", "0.5"}), "send", 1,
                "no state from instance 'robot' on ROBOT_STATE within 0.5 s");
  ExpectOneLine(Ctl({"send", "arm", "--q", "0.5,abc"}), "send", 2, "--q: expected comma-separated finite numbers, got 'abc'");
  ExpectOneLine(Ctl({"send", "arm", "--q", "1,2,3"}), "send", 2, "--q: expected 2 values (one per joint), got 3");
  ExpectOneLine(Ctl({"send", "arm", "--q", "9,0", "--once"}), "send", 1,
                "lagranged rejected 1 of 1 setpoints: arm: q[0] = 9 is outside the setpoint limits");
  ExpectOneLine(Ctl({"send", "arm", "--min-jerk", "2"}), "send", 2, "--min-jerk: needs the target --q");
  ExpectOneLine(Ctl({"send", "arm", "--q", "1,1", "--rate", "0"}), "send", 2, "--rate: expected setpoints per second");
  ExpectOneLine(Ctl({"send", "arm", "--sine", "0.2"}), "send", 2, "--sine: expected 2 values");
  ExpectOneLine(Ctl({"send", "arm", "--sine", "0.2,1", "--min-jerk", "1"}), "send", 2, "excludes");
}

TEST_F(LiveDaemon, CommandChangesControllersGainsAndModesAndSaysSo) {
  Start(7825);
  auto r = Ctl({"command", "arm", "controller", "pd"});
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(r.out, "arm: controller pd done; now running with pd\n");
  r = Ctl({"command", "arm", "gains", "Kp=70,30", "Kd=7,3"});
  ASSERT_EQ(r.status, 0) << r.err;
  r = Ctl({"command", "arm", "gains", "Kp=70,30,Kd=7,3"});  // one argument works too
  ASSERT_EQ(r.status, 0) << r.err;
  for (const auto& [verb, mode] : std::vector<std::pair<std::string, int>>{
           {"pause", state_t::MODE_PAUSED}, {"resume", state_t::MODE_RUNNING}, {"estop", state_t::MODE_ESTOP},
           {"clear", state_t::MODE_HOLD}, {"reset", state_t::MODE_RUNNING}}) {
    r = Ctl({"command", "arm", verb});
    ASSERT_EQ(r.status, 0) << verb << ": " << r.err;
    ASSERT_TRUE(collector_->WaitForLatest<state_t>("ARM_STATE", [&](const state_t& s) {
      return s.mode == mode;
    }, 5.0)) << verb;
  }
  EXPECT_EQ(LastState("ARM_STATE").controller, "computed-torque");  // reset restores the scene's controller
}

TEST_F(LiveDaemon, CommandRefusesBadInputWithOneLine) {
  Start(7826);
  ExpectOneLine(Ctl({"command", "arm", "controller", "mpc"}), "command", 1,
                "arm: unknown controller 'mpc' for arm (available: computed-torque, pd, gravity-compensation, none)");
  ExpectOneLine(Ctl({"command", "arm", "gains", "Kp=1,x", "Kd=1,1"}), "command", 2,
                "gains Kp: expected comma-separated finite numbers, got 'x'");
  ExpectOneLine(Ctl({"command", "arm", "gains", "Kp=1,2,3", "Kd=1,1"}), "command", 2, "gains Kp: expected 2 values");
  ExpectOneLine(Ctl({"command", "arm", "gains", "Kp=-1,2", "Kd=1,1"}), "command", 1, "kp: expected finite gains >= 0");
  ExpectOneLine(Ctl({"command", "arm", "resume"}), "command", 1, "arm: resume: the instance is not paused");
  ExpectOneLine(Ctl({"command", "arm", "fly"}), "command", 2, "unknown action 'fly'");
  ExpectOneLine(Ctl({"command", "robot", "reset", "--wait", "0.5"}), "command", 1, "no state from instance 'robot'");
}

TEST_F(LiveDaemon, WatchShowsEveryInstanceAndTheLoopsTiming) {
  Start(7827);
  auto r = Ctl({"watch", "--frames", "2", "--rate", "10"});
  ASSERT_EQ(r.status, 0) << r.err;
  for (const char* text : {"lagranged on " , "wake latency us", "compute us", "setpoints ", "\narm   running   computed-torque",
                           "\ncartpole   running   lqr", "joint          q        q_des          tau"}) {
    EXPECT_NE(r.out.find(text), std::string::npos) << text << "\n" << r.out;
  }
  EXPECT_EQ(r.out.find("\x1b["), std::string::npos);  // no screen control codes when not on a terminal
  r = Ctl({"watch", "--frames", "1", "--instance", "cartpole"});
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(r.out.find("\narm"), std::string::npos);
  EXPECT_NE(r.out.find("\ncartpole"), std::string::npos);
  ExpectOneLine(Ctl({"watch", "--frames", "1", "--instance", "robot", "--wait", "0.5"}), "watch", 1,
                "no state from instance 'robot' on ROBOT_STATE");
  ExpectOneLine(Ctl({"watch", "--rate", "fast"}), "watch", 2, "--rate: expected refreshes per second");
  ExpectOneLine(RunCtl({"watch", "--frames", "1", "--wait", "0.3", "--lcm-url", testing::TestLcmUrl(7899)}), "watch", 1,
                "no LAGRANGE_STATUS within 0.3 s");
}

}  // namespace
}  // namespace lagrange
