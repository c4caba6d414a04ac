// Closing the loop in one process: the simulated arm under an external
// controller (P, config/arm_external_plant.yaml) and the controller of the
// external arm (C, config/arm_external_controller.yaml), one tick apart,
// deterministic (tests/daemon/external_support.hpp).

#include <gtest/gtest.h>

#include <cstddef>
#include <memory>
#include <string>
#include <vector>

#include "tests/daemon/external_support.hpp"

namespace lagrange {
namespace {

using namespace external_test;

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

}  // namespace
}  // namespace lagrange
