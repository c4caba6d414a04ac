// What the external-controller and external-plant tests share (external_*_test.cpp, one program,
// external_tests): the shipped two-process scenes' run ids and timeouts, the messages a client or a
// plant sends, one lagranged in this process over InProcessBus objects (Daemon: real Receiver, Runtime
// ticked by Loop on its own FakeClock, Publisher), a link between two of them, and the fixture of the
// simulated arm under an external controller. Deterministic: every count and every tick is a fact,
// not a sample of UDP delivery or of a machine's speed.
#pragma once

#include <gtest/gtest.h>
#include <lagrange/reply_t.hpp>
#include <lagrange/state_t.hpp>
#include <lagrange/status_t.hpp>
#include <lagrange/torque_t.hpp>

#include <cstdint>
#include <limits>
#include <ostream>
#include <string>
#include <vector>

#include "daemon/loop.hpp"
#include "daemon/publisher.hpp"
#include "daemon/receiver.hpp"
#include "daemon/runtime.hpp"
#include "protocol/bus.hpp"
#include "sim/scene.hpp"
#include "tests/support/fake_clock.hpp"

namespace lagrange {

// GoogleTest prints a Mode by its name (internal linkage: each test file's own).
[[maybe_unused]] static void PrintTo(Mode mode, std::ostream* os) { *os << ToString(mode); }

namespace external_test {

using Bytes = std::vector<std::uint8_t>;

constexpr Nanoseconds kMs = 1'000'000;
constexpr std::int64_t kPlantRunId = 0x0123456789abcdef;       // P, the simulated arm
constexpr std::int64_t kControllerRunId = 0x7edcba9876543210;  // C, the controller of the external arm
constexpr std::int64_t kClientRunId = 0xc11e47;                // a torque client of the test's own
// torque_timeout of arm_external_plant.yaml and state_timeout of
// arm_external_controller.yaml (0.05 s), in 1 ms ticks.
constexpr int kTimeoutTicks = 50;
constexpr double kExact = 1e-12;  // N·m or rad: values copied or clipped, not computed
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

// A shipped scene's path: config/NAME.
std::string Config(const std::string& name);

VectorXd Vec(const std::vector<double>& v);
bool Finite(const std::vector<double>& v);
bool Finite(const state_t& s);
// Every value within kExact of zero.
bool AllZero(const std::vector<double>& v);

// The arm of the shipped two-process scenes, simulated under `controller`,
// with a gravity-compensation controller to fall back on or switch to.
Scene ArmScene(const std::string& controller, const std::string& extra = "", const std::string& limits = "[40, 15]");

// A torque from `run_id`, sent at `utime` (µs).
torque_t MakeTorque(std::vector<double> tau, std::int64_t sequence, std::int64_t utime,
                    std::int64_t run_id = kClientRunId);

// A measured state of tick `tick` from the plant `run_id`, sent at `utime` (µs).
state_t MakeState(std::vector<double> q, std::vector<double> qd, std::int64_t tick, std::int64_t utime,
                  std::int64_t run_id = kPlantRunId);

// Puts a measured state of the plant kPlantRunId straight into an external
// plant's mailbox, as the receiver would: (q, qd), the sender's tick, and when
// it was sent and arrived (monotonic; kSentUnknown: when the tick takes it).
void PostMeasured(Runtime& runtime, const VectorXd& q, const VectorXd& qd, std::int64_t tick,
                  Nanoseconds arrived = kSentUnknown);

// One lagranged in this process: input bus → receiver → runtime (ticked by
// Loop on its own fake clock) → publisher → output bus. It records what it
// publishes for its first instance (state_t, torque_t, reply_t) and its
// status, and whether every state and torque it published was finite.
class Daemon {
 public:
  Daemon(Scene scene, const std::string& prefix, std::int64_t run_id);

  // The receiver handles everything on the input bus.
  void Receive();
  // Receive, then `n` ticks of 1 ms; then everything they published is out
  // (and delivered to whatever listens on the output bus).
  void Ticks(int n = 1);

  std::int64_t WallMicros() { return clock_.WallMicros(); }
  void SendTorque(const torque_t& t) { input_.PublishMessage(channels_.torque_in, t); }
  void SendState(const state_t& s) { input_.PublishMessage(channels_.measured_in, s); }
  void SendCommand(int8_t kind, std::int64_t request_id, const std::string& controller = "");
  void SendBytes(const std::string& channel, const Bytes& bytes) {
    input_.Publish(channel, bytes.data(), bytes.size());
  }

  Runtime& runtime() { return runtime_; }
  const InstanceChannelNames& channels() const { return channels_; }
  const ReceiverStats& stats() const { return stats_; }
  InProcessBus& input() { return input_; }
  InProcessBus& output() { return output_; }
  const std::vector<state_t>& states() const { return states_; }
  const std::vector<torque_t>& torques() const { return torques_; }
  const std::vector<reply_t>& replies() const { return replies_; }
  const status_t& status() const { return last_status_; }
  // Why instance 0 is not running, as the latest status says ("" when running).
  std::string reason() const { return last_status_.instance_reasons.empty() ? "?" : last_status_.instance_reasons[0]; }
  bool all_finite() const { return all_finite_; }

 private:
  static constexpr int kRing = 2048;
  std::int64_t run_id_;
  Scene scene_;
  Runtime runtime_;
  InstanceChannelNames channels_;  // the first instance's
  testing::FakeClock clock_;
  ReceiverStats stats_;
  InProcessBus input_, output_;
  Receiver receiver_;
  SpscRing<TickRecord> ring_;
  Loop loop_;
  Publisher publisher_;
  std::vector<state_t> states_;
  std::vector<torque_t> torques_;
  std::vector<reply_t> replies_;
  status_t last_status_;
  bool all_finite_ = true;
};

// Every message `from` publishes on `channel` is put on `to`'s input bus (a link of the LCM network).
void Link(Daemon& from, const std::string& channel, Daemon& to);

// P, the simulated arm under an external controller (config/arm_external_plant.yaml unless a
// fixture derived from it gives another scene), and the torque client's stream to it.
class ExternalControllerLoop : public ::testing::Test {
 protected:
  explicit ExternalControllerLoop(Scene scene = LoadScene(Config("arm_external_plant.yaml")))
      : arm_(std::move(scene), "", kPlantRunId) {}
  void TearDown() override { EXPECT_TRUE(arm_.all_finite()); }

  // The client's next torque, sent now (`age_us` ago; < 0: ahead).
  torque_t Next(std::vector<double> tau, std::int64_t age_us = 0, std::int64_t run_id = kClientRunId) {
    return MakeTorque(std::move(tau), ++sequence_, arm_.WallMicros() - age_us, run_id);
  }
  void SendTorque(std::vector<double> tau) { arm_.SendTorque(Next(std::move(tau))); }
  // The applied torque and the state of the latest tick.
  VectorXd Tau() const { return Vec(arm_.states().back().tau); }
  VectorXd Q() const { return Vec(arm_.states().back().q); }
  // G(q) of the arm's model.
  VectorXd Gravity(const VectorXd& q);

  Daemon arm_;
  std::int64_t sequence_ = 0;
};

}  // namespace external_test
}  // namespace lagrange
