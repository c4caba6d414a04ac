// External controllers and external plants, deterministic: real Receivers,
// Runtimes (ticked by Loop, each on its own FakeClock) and Publishers over
// InProcessBus objects, so every count and every tick below is a fact, not a
// sample of UDP delivery or of a machine's speed.
//
//   P  a simulated arm under an external controller (config/arm_external_plant.yaml):
//      hold until a torque, torques applied within the limits, the timeout, the fallback,
//      what its receiver refuses, and the line logged when it holds on for a new reason;
//   C  the controller of an external plant (config/arm_external_controller.yaml): its watchdog;
//   P + C  closing the loop in one process, one tick apart;
// and the ticks of both allocate nothing.

#include <gtest/gtest.h>
#include <lagrange/command_t.hpp>
#include <lagrange/reply_t.hpp>
#include <lagrange/state_t.hpp>
#include <lagrange/status_t.hpp>
#include <lagrange/torque_t.hpp>

#include <spdlog/sinks/ostream_sink.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>
#include <ostream>
#include <sstream>
#include <string>
#include <string_view>
#include <vector>

#include "daemon/loop.hpp"
#include "daemon/publisher.hpp"
#include "daemon/receiver.hpp"
#include "daemon/runtime.hpp"
#include "protocol/bus.hpp"
#include "protocol/channels.hpp"
#include "sim/scene.hpp"
#include "sim/scene_channels.hpp"
#include "sim/yaml_reader.hpp"
#include "tests/support/alloc_counter.hpp"
#include "tests/support/fake_clock.hpp"
#include "tests/support/lcm_messages.hpp"
#include "tests/support/process.hpp"

namespace lagrange {

// GoogleTest prints a Mode by its name (internal linkage: this file's alone).
[[maybe_unused]] static void PrintTo(Mode mode, std::ostream* os) { *os << ToString(mode); }

namespace {

using Bytes = std::vector<std::uint8_t>;
using testing::Encode;

constexpr Nanoseconds kMs = 1'000'000;
constexpr std::int64_t kPlantRunId = 0x0123456789abcdef;       // P, the simulated arm
constexpr std::int64_t kControllerRunId = 0x7edcba9876543210;  // C, the controller of the external arm
constexpr std::int64_t kClientRunId = 0xc11e47;                // a torque client of the test's own
// torque_timeout of arm_external_plant.yaml and state_timeout of
// arm_external_controller.yaml (0.05 s), in 1 ms ticks.
constexpr int kTimeoutTicks = 50;
constexpr double kExact = 1e-12;  // N·m or rad: values copied or clipped, not computed
const double kNaN = std::numeric_limits<double>::quiet_NaN();
const double kInf = std::numeric_limits<double>::infinity();

std::string Config(const std::string& name) { return std::string(LAGRANGE_SOURCE_DIR) + "/config/" + name; }

template <class T>
bool Decode(const std::uint8_t* data, std::size_t size, T& out) {
  return out.decode(data, 0, static_cast<int>(size)) >= 0;
}

VectorXd Vec(const std::vector<double>& v) {
  return Eigen::Map<const VectorXd>(v.data(), static_cast<Eigen::Index>(v.size()));
}

bool Finite(const std::vector<double>& v) {
  return std::all_of(v.begin(), v.end(), [](double x) { return std::isfinite(x); });
}
bool Finite(const state_t& s) {
  return Finite(s.q) && Finite(s.qd) && Finite(s.qdd) && Finite(s.tau) && Finite(s.q_des) && Finite(s.qd_des) &&
         std::isfinite(s.t) && std::isfinite(s.kinetic_energy) && std::isfinite(s.potential_energy);
}

// The arm of the shipped two-process scenes, simulated under `controller`,
// with a gravity-compensation controller to fall back on or switch to.
Scene ArmScene(const std::string& controller, const std::string& extra = "", const std::string& limits = "[40, 15]") {
  std::string text =
      "period: 0.001\n"
      "instances:\n"
      "  - name: arm\n"
      "    plant: {type: arm2, params: {m1: 1.0, m2: 0.8, L1: 0.6, L2: 0.5, g: 9.81}}\n"
      "    initial: {q: [0.7853981633974483, 0.0]}\n"
      "    integrator: {type: rk4}\n"
      "    controllers: [{type: gravity-compensation, kp: [60, 20], kd: [8, 3]}]\n";
  text += "    controller: " + controller + "\n";
  text += "    torque_limits: " + limits + "\n";
  return ParseScene(text + extra, "inline");
}

// A torque from `run_id`, sent at `utime` (µs).
torque_t MakeTorque(std::vector<double> tau, std::int64_t sequence, std::int64_t utime,
                    std::int64_t run_id = kClientRunId) {
  torque_t t;
  t.utime = utime;
  t.run_id = run_id;
  t.sequence = sequence;
  t.state_tick = -1;
  t.num_dofs = static_cast<std::int32_t>(tau.size());
  t.tau = std::move(tau);
  return t;
}

// A measured state of tick `tick` from the plant `run_id`, sent at `utime` (µs).
state_t MakeState(std::vector<double> q, std::vector<double> qd, std::int64_t tick, std::int64_t utime,
                  std::int64_t run_id = kPlantRunId) {
  state_t s;
  s.utime = utime;
  s.run_id = run_id;
  s.tick = tick;
  s.t = 0.0;
  s.num_dofs = static_cast<std::int32_t>(q.size());
  const std::vector<double> zeros(q.size(), 0.0);
  s.qdd = s.tau = s.q_des = s.qd_des = zeros;
  s.q = std::move(q);
  s.qd = std::move(qd);
  s.kinetic_energy = s.potential_energy = 0.0;
  s.mode = state_t::MODE_RUNNING;
  return s;
}

// One lagranged in this process: input bus → receiver → runtime (ticked by
// Loop on its own fake clock) → publisher → output bus. It records what it
// publishes for its first instance (state_t, torque_t, reply_t) and its
// status, and whether every state and torque it published was finite.
class Daemon {
 public:
  Daemon(Scene scene, const std::string& prefix, std::int64_t run_id)
      : run_id_(run_id),
        scene_(std::move(scene)),
        runtime_(scene_, BuildOptions::Prefixed(prefix)),
        channels_(runtime_.model().instances[0].channels),
        receiver_(input_, nullptr, output_, runtime_, clock_, stats_, SetpointAge::kWall, run_id),
        ring_(kRing, runtime_.MakeRecord()),
        loop_(runtime_, clock_, {kMs, OverrunPolicy::kSkip, 0}, ring_),
        publisher_(output_, runtime_, ring_, loop_, stats_, -1, run_id) {
    output_.Subscribe(channels_.state, [this](std::string_view, const std::uint8_t* d, std::size_t n) {
      state_t s;
      if (!Decode(d, n, s) || s.run_id != run_id_) return;
      all_finite_ = all_finite_ && Finite(s);
      states_.push_back(std::move(s));
    });
    if (!channels_.torque_out.empty()) {
      output_.Subscribe(channels_.torque_out, [this](std::string_view, const std::uint8_t* d, std::size_t n) {
        torque_t t;
        if (!Decode(d, n, t) || t.run_id != run_id_) return;
        all_finite_ = all_finite_ && Finite(t.tau);
        torques_.push_back(std::move(t));
      });
    }
    output_.Subscribe(channels_.reply, [this](std::string_view, const std::uint8_t* d, std::size_t n) {
      reply_t r;
      if (Decode(d, n, r)) replies_.push_back(r);
    });
    output_.Subscribe(runtime_.model().status_channel, [this](std::string_view, const std::uint8_t* d, std::size_t n) {
      status_t s;
      if (Decode(d, n, s) && s.run_id == run_id_) last_status_ = s;
    });
  }

  // The receiver handles everything on the input bus.
  void Receive() {
    for (;;) {
      const std::int64_t before = input_.stats().received;
      receiver_.Poll(0);
      if (input_.stats().received == before) return;
    }
  }
  // Receive, then `n` ticks of 1 ms; then everything they published is out
  // (and delivered to whatever listens on the output bus).
  void Ticks(int n = 1) {
    Receive();
    while (n > 0) {
      const int chunk = std::min(n, kRing / 2);
      std::atomic<bool> stop{false};
      loop_.Run(stop, loop_.ticks() + chunk);
      publisher_.Drain();
      while (output_.Drain() > 0) {
      }
      n -= chunk;
    }
  }

  std::int64_t WallMicros() { return clock_.WallMicros(); }
  void SendTorque(const torque_t& t) { input_.PublishMessage(channels_.torque_in, t); }
  void SendState(const state_t& s) { input_.PublishMessage(channels_.measured_in, s); }
  void SendCommand(int8_t kind, std::int64_t request_id, const std::string& controller = "") {
    input_.PublishMessage(channels_.command, testing::MakeCommand(kind, request_id, 0, controller));
  }
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
void Link(Daemon& from, const std::string& channel, Daemon& to) {
  from.output().Subscribe(channel, [&to, channel](std::string_view, const std::uint8_t* d, std::size_t n) {
    to.input().Publish(channel, d, n);
  });
}

// ------------------------------------------------------------------ A. external controller, simulated plant

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
  VectorXd Gravity(const VectorXd& q) {
    VectorXd g(q.size());
    PlantModel& model = arm_.runtime().instance(0).model();
    model.dynamics().ComputeGravityForce(model.data(), q, g);
    return g;
  }

  Daemon arm_;
  std::int64_t sequence_ = 0;
};

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

// ------------------------------------------------------------------ A3. what the receiver refuses

TEST_F(ExternalControllerLoop, EveryBadTorqueIsRefusedCountedWithItsReasonAndNeverApplied) {
  SendTorque({1.0, 0.5});
  arm_.Ticks(1);
  struct Bad {
    std::vector<double> tau;
    std::int64_t age_us;  // sent this long ago (< 0: ahead)
    std::int64_t run_id;
    std::string reason;  // the status's last_rejection begins with it
  };
  const std::vector<Bad> bad = {
      {{1.0, 2.0, 3.0}, 0, kClientRunId, "arm: torque: num_dofs is 3, expected 2"},
      {{5.0}, 0, kClientRunId, "arm: torque: num_dofs is 1, expected 2"},
      {{}, 0, kClientRunId, "arm: torque: num_dofs is 0, expected 2"},
      {{kNaN, 0.0}, 0, kClientRunId, "arm: torque: non-finite value in tau[0]"},
      {{0.0, -kInf}, 0, kClientRunId, "arm: torque: non-finite value in tau[1]"},
      {{2e6, 0.0}, 0, kClientRunId, "arm: torque: tau[0] = 2e+06 is out of range (|x| <= 1e+06)"},
      {{0.0, -1.5e6}, 0, kClientRunId, "arm: torque: tau[1] = -1.5e+06 is out of range"},
      {{3.0, 3.0}, 1'000'000, kClientRunId, "arm: torque: stale: sent 1 s ago (torque_timeout 0.05 s)"},
      {{3.0, 3.0}, 51'000, kClientRunId, "arm: torque: stale: sent 0.051 s ago"},
      {{3.0, 3.0}, -1'000'000, kClientRunId, "arm: torque: timestamp 1 s in the future"},
      {{3.0, 3.0}, 0, 0, "arm: torque: run_id 0: expected the sender's non-zero id"},
  };
  for (std::size_t k = 0; k < bad.size(); ++k) {
    arm_.SendTorque(Next(bad[k].tau, bad[k].age_us, bad[k].run_id));
    arm_.Ticks(1);
    EXPECT_EQ(arm_.stats().torques_rejected.load(), static_cast<std::int64_t>(k + 1));
    EXPECT_EQ(arm_.status().last_rejection.rfind(bad[k].reason, 0), 0u) << arm_.status().last_rejection;
    ASSERT_EQ(arm_.runtime().mode(0), Mode::kRunning);
    EXPECT_LT((Tau() - Vec({1.0, 0.5})).cwiseAbs().maxCoeff(), kExact) << "case " << k;  // the last good one
  }
  EXPECT_EQ(arm_.stats().torques_accepted.load(), 1);
  EXPECT_EQ(arm_.stats().decode_errors.load(), 0);
  EXPECT_EQ(arm_.status().torques_rejected, static_cast<std::int64_t>(bad.size()));
}

TEST_F(ExternalControllerLoop, ASecondSenderIsRefusedWhileTheFirstStreamsAndAcceptedOnceItLapses) {
  SendTorque({1.0, 0.5});  // received at W
  arm_.Ticks(1);
  const std::int64_t second = kClientRunId + 1;
  std::int64_t second_sequence = 0;
  for (int ms = 1; ms <= kTimeoutTicks; ++ms) {  // received at W + ms: the first still streams
    arm_.SendTorque(MakeTorque({-2.0, 1.0}, ++second_sequence, arm_.WallMicros(), second));
    arm_.Ticks(1);
    ASSERT_EQ(arm_.stats().torques_rejected.load(), ms);
    // Applied until it is torque_timeout old (counted from its send at W), then the fallback holds.
    if (ms < kTimeoutTicks) {
      ASSERT_LT((Tau() - Vec({1.0, 0.5})).cwiseAbs().maxCoeff(), kExact);
    }
  }
  EXPECT_EQ(arm_.runtime().mode(0), Mode::kHold);
  EXPECT_EQ(arm_.status().last_rejection.rfind("arm: torque: from a second sender (run_id 0000000000c11e48) while "
                                               "0000000000c11e47 streams",
                                               0),
            0u)
      << arm_.status().last_rejection;
  arm_.SendTorque(MakeTorque({-2.0, 1.0}, ++second_sequence, arm_.WallMicros(), second));  // W + 51 ms: lapsed
  arm_.Ticks(1);
  EXPECT_EQ(arm_.stats().torques_rejected.load(), kTimeoutTicks);
  EXPECT_EQ(arm_.stats().torques_accepted.load(), 2);
  EXPECT_EQ(arm_.runtime().mode(0), Mode::kRunning);
  EXPECT_LT((Tau() - Vec({-2.0, 1.0})).cwiseAbs().maxCoeff(), kExact);
  // Now the first is the second sender.
  SendTorque({1.0, 0.5});
  arm_.Ticks(1);
  EXPECT_EQ(arm_.stats().torques_rejected.load(), kTimeoutTicks + 1);
  EXPECT_LT((Tau() - Vec({-2.0, 1.0})).cwiseAbs().maxCoeff(), kExact);
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

TEST_F(ExternalControllerLoop, ATorqueWhoseSequenceDoesNotGrowIsRefused) {
  arm_.SendTorque(MakeTorque({1.0, 0.5}, 5, arm_.WallMicros()));
  arm_.Ticks(1);
  arm_.SendTorque(MakeTorque({3.0, 3.0}, 5, arm_.WallMicros()));  // a duplicate
  arm_.Ticks(1);
  EXPECT_EQ(arm_.status().last_rejection,
            "arm: torque: sequence 5 does not grow (last 5): a duplicate or reordered packet");
  arm_.SendTorque(MakeTorque({3.0, 3.0}, 4, arm_.WallMicros()));  // reordered
  arm_.Ticks(1);
  EXPECT_EQ(arm_.status().last_rejection.rfind("arm: torque: sequence 4 does not grow (last 5)", 0), 0u);
  EXPECT_EQ(arm_.stats().torques_rejected.load(), 2);
  EXPECT_LT((Tau() - Vec({1.0, 0.5})).cwiseAbs().maxCoeff(), kExact);
  arm_.SendTorque(MakeTorque({2.0, 1.0}, 9, arm_.WallMicros()));  // a gap is a loss, not a refusal
  arm_.Ticks(1);
  EXPECT_EQ(arm_.stats().torques_accepted.load(), 2);
  EXPECT_LT((Tau() - Vec({2.0, 1.0})).cwiseAbs().maxCoeff(), kExact);
}

TEST_F(ExternalControllerLoop, TorquesAreRefusedWhileAnotherControllerIsActive) {
  SendTorque({1.0, 0.5});
  arm_.Ticks(1);
  arm_.SendCommand(command_t::SWITCH_CONTROLLER, 1, "gravity-compensation");
  arm_.Ticks(1);
  ASSERT_EQ(arm_.states().back().controller, "gravity-compensation");
  SendTorque({3.0, 3.0});
  arm_.Ticks(1);
  EXPECT_EQ(arm_.stats().torques_rejected.load(), 1);
  EXPECT_EQ(arm_.status().last_rejection,
            "arm: torque: the instance is not running its external controller (active: gravity-compensation)");
  EXPECT_EQ(arm_.runtime().mode(0), Mode::kRunning);
  ExternalController* external = arm_.runtime().instance(0).external_controller(0);
  ASSERT_NE(external, nullptr);
  EXPECT_LT((external->torque() - Vec({1.0, 0.5})).cwiseAbs().maxCoeff(), kExact);  // never reached it
}

TEST_F(ExternalControllerLoop, EveryMalformedOrTruncatedTorqueIsExactlyOneDecodeError) {
  const Bytes whole = Encode(Next({1.0, 0.5}));
  std::int64_t expected = 0;
  for (std::size_t len = 0; len < whole.size(); ++len) {
    arm_.SendBytes("ARM_TORQUE", Bytes(whole.begin(), whole.begin() + static_cast<long>(len)));
    ++expected;
  }
  Bytes longer = whole;
  longer.push_back(0);
  arm_.SendBytes("ARM_TORQUE", longer);
  Bytes crafted = whole;  // num_dofs (after fingerprint, utime, run_id, sequence, state_tick) = 2³¹ − 1
  crafted[40] = 0x7f, crafted[41] = crafted[42] = crafted[43] = 0xff;
  arm_.SendBytes("ARM_TORQUE", crafted);
  arm_.SendBytes("ARM_TORQUE", Encode(MakeState({0.1, 0.2}, {0.0, 0.0}, 1, arm_.WallMicros())));  // another type
  expected += 3;
  arm_.Ticks(1);
  EXPECT_EQ(arm_.stats().decode_errors.load(), expected);
  EXPECT_EQ(arm_.status().decode_errors, expected);
  EXPECT_EQ(arm_.stats().torques_accepted.load(), 0);
  EXPECT_EQ(arm_.stats().torques_rejected.load(), 0);
  EXPECT_EQ(arm_.runtime().mode(0), Mode::kHold);
  arm_.SendBytes("ARM_TORQUE", whole);  // the whole packet passes
  arm_.Ticks(1);
  EXPECT_EQ(arm_.stats().torques_accepted.load(), 1);
  EXPECT_EQ(arm_.runtime().mode(0), Mode::kRunning);
}

// ------------------------------------------------------------------ A4. switching controllers

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

// ------------------------------------------------------------------ C. the watchdog of an external plant

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

bool AllZero(const std::vector<double>& v) {
  return std::all_of(v.begin(), v.end(), [](double x) { return std::abs(x) <= kExact; });
}

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

// ------------------------------------------------------------------ B. two runtimes closing the loop

// P (the simulated arm under an external controller) and C (computed torque
// for the external arm, following a sine) in one process, each on its own
// fake clock. Each step P ticks, its state crosses to C, C ticks, its torque
// crosses to P:
//
//   P tick k:    applies C's latest τ to x_k, integrates to x_{k+1}, publishes it (state tick k)
//   C tick k:    measures x_{k+1}, publishes τ_k = CT(x_{k+1}, q_d(t_C)) (state_tick k)
//   P tick k+1:  applies τ_k from x_{k+1}
//
// The torque answering state tick k is applied one tick later, to the very
// state it was computed from: the tick is the time the state spends on the
// bus, and it costs nothing on the measurement. What it costs is on the
// setpoint's clock. C's trajectory starts with its first measured state, one
// tick after P started (P's first tick is a hold, which at rest under an
// exact gravity compensation leaves x_1 = x_0), so from then on P is the
// single-process loop S (the same model, gains, integrator and zero-order
// hold in one runtime) one tick late, x_P(t) = x_S(t − h), state for state.
// P follows q_d(t − h) where S follows q_d(t), and per joint
//
//   e2(t) = |q_d(t) − q_P(t)| ≤ |q_d(t) − q_d(t − h)| + |q_d(t − h) − q_S(t − h)|
//         ≤ max|q̇_d|·h + max e1          (mean value theorem: no term in h²)
//
// up to round-off and e1's window moving by h (the 3 s window holds 1.5
// periods of the 0.5 Hz sine, so its maximum does not move). A delayed
// measurement would cost more: q(t − h) ≈ q − q̇h and q̇(t − h) ≈ q̇ − q̈h offset
// the PD law by q̇h + (Kd/Kp)·q̈h, a bound of max|q̇_d|·h·(1 + Kd/Kp·max|q̈_d|/max|q̇_d|);
// this loop must meet the tighter one above, which a second tick of delay
// (another max|q̇_d|·h) would break. And the delay cannot help: e2(t) ≥
// |q_d(t) − q_d(t − h)| − e1(t − h), so max e2 ≥ max|Δq_d| − max e1 ≥ max e1
// whenever max|Δq_d| ≥ 2·max e1, which the test checks before relying on it.
class TwoProcessLoop : public ::testing::Test {
 protected:
  TwoProcessLoop()
      : plant_scene_(LoadScene(Config("arm_external_plant.yaml"))),
        controller_scene_(LoadScene(Config("arm_external_controller.yaml"))),
        plant_(plant_scene_, "", kPlantRunId),
        controller_(controller_scene_, "CTRL_", kControllerRunId),
        single_(SingleProcessScene(plant_scene_, controller_scene_), "", kPlantRunId),
        desired_(MakeTrajectory(controller_scene_.instances[0])) {}
  void TearDown() override {
    EXPECT_TRUE(plant_.all_finite());
    EXPECT_TRUE(controller_.all_finite());
  }

  void LinkStates() { Link(plant_, plant_.channels().state, controller_); }
  void LinkTorques() { Link(controller_, controller_.channels().torque_out, plant_); }
  void Steps(int n) {
    for (int k = 0; k < n; ++k) {
      plant_.Ticks(1);
      controller_.Ticks(1);
    }
  }
  // P and C linked both ways for kSteps steps, and S alone as long.
  void RunClosedLoopAndSingleProcess() {
    LinkStates();
    LinkTorques();
    Steps(kSteps);
    single_.Ticks(kSteps);
  }

  // C's scene in one runtime: its instance simulated (with P's integrator) instead of measured.
  static Scene SingleProcessScene(const Scene& plant, const Scene& controller) {
    Scene s = controller;
    InstanceConfig& c = s.instances[0];
    c.name = "arm";
    c.external.reset();
    c.integrator = plant.instances[0].integrator;
    return s;
  }

  // max over t in (kSettle, kSettle + kWindow] of |q_d(t) − q(t)|, per joint,
  // from published states (t, q: the state after the tick).
  VectorXd MaxTrackingError(const std::vector<state_t>& states) const {
    Setpoint sp(2);
    VectorXd e = VectorXd::Zero(2);
    for (const state_t& s : states) {
      if (s.t <= kSettle + 1e-9 || s.t > kSettle + kWindow + 1e-9) continue;
      desired_->Sample(s.t, sp);
      e = e.cwiseMax((sp.q - Vec(s.q)).cwiseAbs());
    }
    return e;
  }
  // max |q_d(t) − q_d(t − h)| and max |q̇_d(t)| over the same window, per joint.
  void ShiftAndSpeed(double h, VectorXd& shift, VectorXd& speed) const {
    Setpoint now(2), before(2);
    shift = speed = VectorXd::Zero(2);
    for (double t = kSettle; t <= kSettle + kWindow; t += h / 4) {
      desired_->Sample(t, now);
      desired_->Sample(t - h, before);
      shift = shift.cwiseMax((now.q - before.q).cwiseAbs());
      speed = speed.cwiseMax(now.qd.cwiseAbs());
    }
  }

  static constexpr double kSettle = 1.0;  // s
  static constexpr double kWindow = 3.0;  // s
  static constexpr int kSteps = 4000;     // ticks of 1 ms: settling and window
  Scene plant_scene_, controller_scene_;
  Daemon plant_, controller_;
  Daemon single_;  // S
  std::unique_ptr<Trajectory> desired_;
};

constexpr double kRoundOff = 1e-9;  // rad: the bound's slack for round-off over 4000 ticks

TEST_F(TwoProcessLoop, IsTheSingleProcessLoopOneTickLate) {
  RunClosedLoopAndSingleProcess();
  // The loop ran closed: P ran on C's torques from its second tick on, each
  // applied one tick after the state it answers, which C measured exactly.
  ASSERT_EQ(plant_.states().size(), static_cast<std::size_t>(kSteps));
  ASSERT_EQ(controller_.torques().size(), static_cast<std::size_t>(kSteps));
  EXPECT_EQ(plant_.states()[0].mode, state_t::MODE_HOLD);
  for (int k = 1; k < kSteps; ++k) ASSERT_EQ(plant_.states()[k].mode, state_t::MODE_RUNNING) << "tick " << k;
  EXPECT_EQ(controller_.runtime().mode(0), Mode::kRunning);
  EXPECT_EQ(plant_.stats().torques_accepted.load(), kSteps - 1);  // the last one is still on its way
  EXPECT_EQ(plant_.stats().torques_rejected.load(), 0);
  EXPECT_EQ(controller_.stats().measured_rejected.load(), 0);
  for (int k = 0; k + 1 < kSteps; ++k) {
    const torque_t& t = controller_.torques()[k];
    ASSERT_EQ(t.state_tick, k);
    ASSERT_LT((Vec(controller_.states()[k].q) - Vec(plant_.states()[k].q)).cwiseAbs().maxCoeff(), kExact);
    ASSERT_LT((Vec(plant_.states()[k + 1].tau) - Vec(t.tau)).cwiseAbs().maxCoeff(), kExact) << "tick " << k + 1;
  }
  // P's hold tick left the arm where it was, at rest; from there P is S one tick late.
  ASSERT_LT((Vec(plant_.states()[0].q) - plant_scene_.instances[0].q0).cwiseAbs().maxCoeff(), kExact);
  ASSERT_LT(Vec(plant_.states()[0].qd).cwiseAbs().maxCoeff(), kExact);
  for (int k = 0; k + 1 < kSteps; ++k) {
    ASSERT_LT((Vec(plant_.states()[k + 1].q) - Vec(single_.states()[k].q)).cwiseAbs().maxCoeff(), kExact) << k;
    ASSERT_LT((Vec(plant_.states()[k + 1].qd) - Vec(single_.states()[k].qd)).cwiseAbs().maxCoeff(), kExact) << k;
  }
}

TEST_F(TwoProcessLoop, TracksWithinTheSingleProcessErrorPlusWhatOneTickOfDelayCosts) {
  RunClosedLoopAndSingleProcess();
  const VectorXd e1 = MaxTrackingError(single_.states());
  const VectorXd e2 = MaxTrackingError(plant_.states());
  const double h = plant_scene_.period;
  VectorXd shift, speed;
  ShiftAndSpeed(h, shift, speed);
  for (int j = 0; j < 2; ++j) {
    SCOPED_TRACE("joint " + std::to_string(j));
    EXPECT_LE(e2[j], e1[j] + speed[j] * h + kRoundOff) << "e1 " << e1[j] << ", max|q̇_d|·h " << speed[j] * h;
    ASSERT_GE(shift[j], 2.0 * e1[j] + kRoundOff);  // so the delay cannot help (above)
    EXPECT_GE(e2[j], e1[j]);
  }
}

TEST_F(TwoProcessLoop, WithoutTheTorqueLinkThePlantStaysInHoldAndTracksNothing) {
  LinkStates();  // C hears P and commands in vain
  Steps(kSteps);
  EXPECT_EQ(controller_.runtime().mode(0), Mode::kRunning);
  EXPECT_EQ(controller_.torques().size(), static_cast<std::size_t>(kSteps));
  EXPECT_EQ(plant_.runtime().mode(0), Mode::kHold);
  EXPECT_EQ(plant_.reason(), kNoTorqueYet);
  for (const state_t& s : plant_.states()) ASSERT_EQ(s.mode, state_t::MODE_HOLD);
  const VectorXd amplitude = controller_scene_.instances[0].setpoint.amplitude;
  const VectorXd e = MaxTrackingError(plant_.states());
  for (int j = 0; j < 2; ++j) EXPECT_GT(e[j], 0.9 * amplitude[j]);  // the sine goes by, the arm stays
}

TEST_F(TwoProcessLoop, WithoutTheStateLinkTheControllerWaitsAndThePlantHolds) {
  LinkTorques();
  Steps(500);
  EXPECT_EQ(controller_.runtime().mode(0), Mode::kWaiting);
  EXPECT_TRUE(controller_.torques().empty());
  EXPECT_EQ(plant_.runtime().mode(0), Mode::kHold);
  EXPECT_EQ(plant_.stats().torques_accepted.load(), 0);
}

// ------------------------------------------------------------------ timeouts on odd periods

// A timeout of exactly two ticks at a period whose nanoseconds are not a
// whole double product: 0.00026 s × 1e9 = 259999.99999999997, and the tick
// (lagranged rounds the period: 130000 ns) must not see it as 259999 ns and
// time out after two ticks instead of after more than two.
constexpr double kOddPeriod = 0.00013;           // s
constexpr Nanoseconds kOddTick = 130'000;        // ns, llround(kOddPeriod × 1e9) as service.cpp
constexpr const char* kTwoOddTicks = "0.00026";  // s, = 2 × kOddPeriod in doubles

// Puts a measured state of the plant kPlantRunId straight into an external
// plant's mailbox, as the receiver would: (q, qd), the sender's tick, and when
// it was sent and arrived (monotonic; kSentUnknown: when the tick takes it).
void PostMeasured(Runtime& runtime, const VectorXd& q, const VectorXd& qd, std::int64_t tick,
                  Nanoseconds arrived = kSentUnknown) {
  MeasuredMessage& m = runtime.channels(0).measured.back();
  m.q = q;
  m.qd = qd;
  m.tick = tick;
  m.run_id = kPlantRunId;
  m.sent = arrived;
  m.arrived = arrived;
  runtime.channels(0).measured.Publish();
}

// The tick that takes a message at T, then ticks of kOddTick: running while
// now − T <= 260000 ns (the two-tick timeout), `after` at the first tick past it.
void ExpectTwoOddTicksThen(Runtime& runtime, TickRecord& record, Mode after) {
  Nanoseconds now = 0;
  runtime.Tick(now += kOddTick, record);  // takes it at T
  ASSERT_EQ(runtime.mode(0), Mode::kRunning);
  runtime.Tick(now += kOddTick, record);
  EXPECT_EQ(runtime.mode(0), Mode::kRunning);
  runtime.Tick(now += kOddTick, record);  // now − T = 260000 ns: not more than the timeout
  EXPECT_EQ(runtime.mode(0), Mode::kRunning);
  runtime.Tick(now += kOddTick, record);
  EXPECT_EQ(runtime.mode(0), after);
}

TEST(ExternalTimeouts, ATorqueTimeoutOfTwoTicksLastsTwoTicksWhateverTheRoundOff) {
  Runtime runtime(ParseScene(std::string(R"(
period: 0.00013
instances:
  - name: arm
    plant: {type: arm2}
    controller: {type: external, torque_timeout: )") +
                                 kTwoOddTicks + "}\n",
                             "inline"));
  ASSERT_NEAR(runtime.period(), kOddPeriod, 1e-18);
  TickRecord record = runtime.MakeRecord();
  runtime.channels(0).torques.back().tau << 1.0, 0.5;
  runtime.channels(0).torques.Publish();
  ExpectTwoOddTicksThen(runtime, record, Mode::kHold);
}

TEST(ExternalTimeouts, AStateTimeoutOfTwoTicksLastsTwoTicksWhateverTheRoundOff) {
  Runtime runtime(ParseScene(std::string(R"(
period: 0.00013
instances:
  - name: arm_controller
    plant: {type: external, model: {type: arm2}, state_channel: ARM_STATE, torque_channel: ARM_TORQUE, state_timeout: )") +
                                 kTwoOddTicks + R"(}
    controller: {type: pd, kp: 10, kd: 1}
)",
                             "inline"));
  TickRecord record = runtime.MakeRecord();
  PostMeasured(runtime, Vec({0.1, 0.2}), Vec({0.0, 0.0}), 1);
  ExpectTwoOddTicksThen(runtime, record, Mode::kStopped);
}

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

// ------------------------------------------------------------------ phase lock

// An external plant with phase_lock, fed states that arrive on their own 1 kHz
// grid at an arbitrary phase: the loop (as Loop::Run does it: the next deadline
// one period on, moved by PhaseShift) settles each tick phase_lag after its
// state arrived, moving at most kMaxPhaseStep a tick; without phase_lock it
// stays where it started.
std::vector<Nanoseconds> WaitsOfALoopFedOnAGrid(bool phase_lock) {
  const std::string scene = std::string(R"(
period: 0.001
instances:
  - name: arm_controller
    plant: {type: external, model: {type: arm2}, state_channel: ARM_STATE, torque_channel: ARM_TORQUE, state_timeout: 0.05, phase_lock: )") +
                            (phase_lock ? "true" : "false") + R"(}
    controller: {type: pd, kp: 10, kd: 1}
)";
  Runtime runtime(ParseScene(scene, "inline"));
  TickRecord record = runtime.MakeRecord();
  constexpr Nanoseconds kPeriod = 1'000'000;
  const Nanoseconds grid = 123'456;  // the plant's states arrive at grid + k·period
  std::vector<Nanoseconds> waits;
  Nanoseconds deadline = 50 * kPeriod;
  for (int k = 0; k < 200; ++k) {
    const Nanoseconds arrived = grid + ((deadline - grid) / kPeriod) * kPeriod;  // the latest state by now
    PostMeasured(runtime, Vec({0.1, 0.2}), Vec({0.0, 0.0}), k + 1, arrived);
    runtime.Tick(deadline, record);
    EXPECT_LE(std::abs(runtime.PhaseShift()), Runtime::kMaxPhaseStep);
    waits.push_back(deadline - arrived);
    deadline += kPeriod + runtime.PhaseShift();
  }
  EXPECT_EQ(runtime.mode(0), Mode::kRunning);
  return waits;
}

TEST(ExternalPhaseLock, TheLoopSettlesPhaseLagAfterEachMeasuredState) {
  const std::vector<Nanoseconds> locked = WaitsOfALoopFedOnAGrid(true);
  EXPECT_GT(locked.front(), 800'000);  // started 876.5 µs after the state
  for (std::size_t k = 100; k < locked.size(); ++k) EXPECT_NEAR(locked[k], 200'000, 1'000) << k;
  const std::vector<Nanoseconds> free = WaitsOfALoopFedOnAGrid(false);
  for (const Nanoseconds w : free) EXPECT_EQ(w, free.front());
}

TEST(ExternalPhaseLock, APhaseLagOfAPeriodOrMoreIsRefused) {
  EXPECT_THROW(ParseScene(R"(
period: 0.001
instances:
  - name: arm_controller
    plant: {type: external, model: {type: arm2}, state_channel: S, torque_channel: T, phase_lock: true, phase_lag: 0.001}
    controller: {type: pd, kp: 10, kd: 1}
)",
                          "inline"),
               ConfigError);
}

// ------------------------------------------------------------------ D. the ticks allocate nothing

// Heap allocations of `ticks` ticks of `runtime`, 1 ms apart from `now`,
// after `before_each` (the receiver's part, not counted) each time.
template <class F>
std::int64_t TickAllocations(Runtime& runtime, TickRecord& record, Nanoseconds& now, int ticks, F before_each) {
  std::int64_t total = 0;
  for (int k = 0; k < ticks; ++k) {
    before_each(k);
    testing::AllocationCounter counter;
    runtime.Tick(now += kMs, record);
    total += counter.count();
  }
  return total;
}

TEST(ExternalTickAllocation, APlantTickAllocatesNothingRunningOnTorquesOrHoldingOnItsFallback) {
  const auto none = [](int) {};
  for (const Scene& scene : {LoadScene(Config("arm_external_plant.yaml")),
                             ArmScene("{type: external, torque_timeout: 0.05, fallback: brake}"),
                             LoadScene(Config("arm_impedance_client.yaml"))}) {
    Runtime runtime(scene);
    {  // the counter sees this binary's allocations, so the zero below means something
      testing::AllocationCounter counter;
      const TickRecord probe = runtime.MakeRecord();
      ASSERT_GT(counter.count(), 0);
    }
    TickRecord record = runtime.MakeRecord();
    Nanoseconds now = 0;
    std::int64_t allocations = TickAllocations(runtime, record, now, 20, none);  // hold: no torque yet
    ASSERT_EQ(runtime.mode(0), Mode::kHold);
    allocations += TickAllocations(runtime, record, now, 100, [&](int k) {
      runtime.channels(0).torques.back().tau << 0.01 * k, -0.005 * k;
      runtime.channels(0).torques.Publish();
    });
    ASSERT_EQ(runtime.mode(0), Mode::kRunning);
    allocations += TickAllocations(runtime, record, now, 100, none);  // timed out: the fallback holds
    ASSERT_EQ(runtime.mode(0), Mode::kHold);
    EXPECT_EQ(allocations, 0) << scene.instances[0].controller.external.fallback.value_or("(default)");
  }
}

TEST(ExternalTickAllocation, AControllerTickAllocatesNothingRunningOrStopped) {
  Runtime runtime(LoadScene(Config("arm_external_controller.yaml")));
  TickRecord record = runtime.MakeRecord();
  Nanoseconds now = 0;
  const auto none = [](int) {};
  const VectorXd qd = Vec({0.2, -0.1});
  VectorXd q = Vec({0.8, 0.1});
  const auto measure = [&](int k) {
    q[0] = 0.8 + 0.001 * k;
    PostMeasured(runtime, q, qd, k);
  };
  std::int64_t allocations = TickAllocations(runtime, record, now, 20, none);  // waiting
  ASSERT_EQ(runtime.mode(0), Mode::kWaiting);
  allocations += TickAllocations(runtime, record, now, 100, measure);
  ASSERT_EQ(runtime.mode(0), Mode::kRunning);
  ASSERT_TRUE(record.instances[0].publish_torque);
  allocations += TickAllocations(runtime, record, now, 100, none);  // timed out: stopped
  ASSERT_EQ(runtime.mode(0), Mode::kStopped);
  runtime.PostUrgent(0, Urgent::kClearEstop, 1);
  allocations += TickAllocations(runtime, record, now, 50, measure);  // re-armed, running
  ASSERT_EQ(runtime.mode(0), Mode::kRunning);
  runtime.channels(0).measured_problem.store(static_cast<std::uint8_t>(MeasuredProblem::kNotFinite));
  allocations += TickAllocations(runtime, record, now, 50, measure);  // tripped: stopped
  ASSERT_EQ(runtime.mode(0), Mode::kStopped);
  EXPECT_EQ(allocations, 0);
}

}  // namespace
}  // namespace lagrange
