// The tick's protocol: setpoints, timeouts, commands, modes and faults, and
// a loop driven by a fake clock that allocates nothing.

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "daemon/loop.hpp"
#include "daemon/runtime.hpp"
#include "sim/health.hpp"
#include "tests/support/alloc_counter.hpp"
#include "tests/support/fake_clock.hpp"

namespace lagrange {
namespace {

constexpr Nanoseconds kMs = 1'000'000;

Scene TwoInstances(const std::string& arm_extra = "") {
  return ParseScene(R"(
instances:
  - name: arm
    plant: {type: arm2}
    initial: {q: [0.5, 0.3]}
    controller: {type: computed-torque, kp: 100, kd: 20}
    controllers: [{type: pd, kp: 50, kd: 5}]
    torque_limits: [40, 15]
    setpoint_timeout: 0.05
)" + arm_extra + R"(
  - name: cartpole
    plant: {type: cartpole}
    initial: {q: [0, 3.1]}
    controller: {type: lqr}
    setpoint: {q: [0, 3.141592653589793]}
)",
                    "inline");
}

class RuntimeTest : public ::testing::Test {
 protected:
  explicit RuntimeTest(const Scene& scene = TwoInstances()) : runtime(scene), record(runtime.MakeRecord()) {}
  void Ticks(int n) {
    for (int k = 0; k < n; ++k) {
      now += kMs;
      runtime.Tick(now, record);
    }
  }
  void SendSetpoint(std::size_t i, std::initializer_list<double> q) {
    SetpointMessage& m = runtime.channels(i).setpoints.back();
    int j = 0;
    for (double x : q) m.setpoint.q[j++] = x;
    m.setpoint.qd.setZero();
    m.setpoint.qdd.setZero();
    runtime.channels(i).setpoints.Publish();
  }
  void SendCommand(std::size_t i, CommandKind kind, int controller = -1, double kp = 0, double kd = 0) {
    CommandMessage* c = runtime.channels(i).commands.BeginPush();
    ASSERT_NE(c, nullptr);
    c->kind = kind;
    c->controller = controller;
    c->gains.kp.setConstant(kp);
    c->gains.kd.setConstant(kd);
    runtime.channels(i).commands.Push();
  }
  const InstanceRecord& Arm() const { return record.instances[0]; }

  Runtime runtime;
  TickRecord record;
  Nanoseconds now = 0;
};

TEST_F(RuntimeTest, FollowsTheSceneTrajectoryUntilASetpointStreamsIn) {
  Ticks(100);
  EXPECT_EQ(Arm().mode, Mode::kRunning);
  EXPECT_NEAR(Arm().q_des[0], 0.5, 0.0);  // hold of the initial pose
  SendSetpoint(0, {0.8, -0.2});
  Ticks(1);
  EXPECT_EQ(Arm().q_des[0], 0.8);
  EXPECT_EQ(Arm().q_des[1], -0.2);
  for (int k = 0; k < 80; ++k) {  // keep streaming within the timeout, 2 s
    SendSetpoint(0, {0.8, -0.2});
    Ticks(25);
  }
  EXPECT_EQ(Arm().mode, Mode::kRunning);
  EXPECT_NEAR(Arm().q[0], 0.8, 1e-6);
}

TEST_F(RuntimeTest, SetpointsStoppingSendTheInstanceToHoldAndTheNextResumes) {
  SendSetpoint(0, {0.8, -0.2});
  Ticks(50);  // taken at the first tick: 49 ms old, within the 0.05 s timeout
  EXPECT_EQ(Arm().mode, Mode::kRunning);
  Ticks(1);  // 50 ms: not older than the timeout yet
  EXPECT_EQ(Arm().mode, Mode::kRunning);
  Ticks(1);  // 51 ms
  EXPECT_EQ(Arm().mode, Mode::kHold);
  const VectorXd held = Arm().q_des;
  EXPECT_LT((held - Arm().q).norm(), 0.05);  // holds where it was, not the old setpoint
  Ticks(200);
  EXPECT_EQ(Arm().mode, Mode::kHold);
  EXPECT_EQ(Arm().q_des, held);
  SendSetpoint(0, {0.1, 0.1});
  Ticks(1);
  EXPECT_EQ(Arm().mode, Mode::kRunning);
  EXPECT_EQ(Arm().q_des[0], 0.1);
  EXPECT_EQ(record.instances[1].mode, Mode::kRunning);  // the other instance never noticed
}

// A stale setpoint never reaches the tick (the receiver refuses it without
// sending the instance to hold): tests/daemon/bridge_test.cpp.

TEST(RuntimeZeroTorque, ZeroTorqueHoldAppliesNoTorque) {
  Runtime runtime(TwoInstances("    on_timeout: zero-torque\n"));
  TickRecord record = runtime.MakeRecord();
  SetpointMessage& m = runtime.channels(0).setpoints.back();
  m.setpoint.q << 0.5, 0.3;
  runtime.channels(0).setpoints.Publish();
  Nanoseconds now = 0;
  for (int k = 0; k < 60; ++k) runtime.Tick(now += kMs, record);
  EXPECT_EQ(record.instances[0].mode, Mode::kHold);
  EXPECT_EQ(record.instances[0].tau.norm(), 0.0);
}

TEST_F(RuntimeTest, CommandsSwitchControllersAndChangeGains) {
  SendCommand(0, CommandKind::kSwitchController, 1);
  Ticks(1);
  EXPECT_EQ(Arm().controller, 1);
  EXPECT_EQ(runtime.instance(0).controller().name(), "pd");
  EXPECT_EQ(Arm().commands_accepted, 1);
  SendCommand(0, CommandKind::kSetGains, 1, 70.0, 7.0);
  Ticks(1);
  EXPECT_EQ(runtime.instance(0).controller().gains().kp[0], 70.0);
  SendCommand(0, CommandKind::kSetGains, 1, -1.0, 7.0);  // PD gains must be >= 0: the tick refuses
  Ticks(1);
  EXPECT_EQ(Arm().commands_rejected, 1);
  EXPECT_STREQ(Arm().command_error, "the gains do not fit the controller");
  EXPECT_EQ(runtime.instance(0).controller().gains().kp[0], 70.0);
  EXPECT_EQ(runtime.channels(0).active_controller.load(), 1);
}

TEST_F(RuntimeTest, PauseFreezesTimeAndStateAndResumeContinues) {
  Ticks(10);
  SendCommand(0, CommandKind::kPause);
  Ticks(1);
  const double t = Arm().t;
  const VectorXd q = Arm().q;
  Ticks(100);
  EXPECT_EQ(Arm().mode, Mode::kPaused);
  EXPECT_EQ(Arm().t, t);
  EXPECT_EQ(Arm().q, q);
  EXPECT_GT(record.instances[1].t, t + 0.09);  // the cart-pole ran on
  SendCommand(0, CommandKind::kResume);
  Ticks(1);
  EXPECT_EQ(Arm().mode, Mode::kRunning);
  EXPECT_GT(Arm().t, t);
  SendCommand(0, CommandKind::kResume);
  Ticks(1);
  EXPECT_STREQ(Arm().command_error, "resume: the instance is not paused");
}

TEST_F(RuntimeTest, EmergencyStopBrakesTheJointsAndClearingHolds) {
  SendCommand(0, CommandKind::kSwitchController, 2);  // none: the arm falls
  Ticks(300);
  EXPECT_GT(Arm().qd.norm(), 1.0);
  SendCommand(0, CommandKind::kEstop);
  Ticks(1);
  EXPECT_EQ(Arm().mode, Mode::kEstop);
  Ticks(2000);
  EXPECT_LT(Arm().qd.norm(), 0.2);      // braked (gravity still pulls it down slowly)
  SendCommand(0, CommandKind::kReset);  // reset keeps the emergency stop
  Ticks(1);
  EXPECT_EQ(Arm().mode, Mode::kEstop);
  EXPECT_EQ(Arm().controller, 0);
  SendCommand(0, CommandKind::kClearEstop);
  Ticks(1);
  EXPECT_EQ(Arm().mode, Mode::kHold);
  const VectorXd held = Arm().q_des;
  Ticks(1000);
  EXPECT_LT((Arm().q - held).norm(), 1e-3);  // holding where it was cleared
  SendCommand(0, CommandKind::kClearEstop);
  Ticks(1);
  EXPECT_STREQ(Arm().command_error, "clear_estop: the instance is not in an emergency stop");
}

// The stop is sacred: a clear_estop in the same tick as an estop is refused
// whichever came first, a flood of them included; a clear in a later tick
// leaves the estop.
TEST_F(RuntimeTest, AClearInTheSameTickAsAnEstopNeverCancelsIt) {
  Ticks(10);
  for (const bool clear_first : {true, false}) {
    if (clear_first) runtime.PostUrgent(0, Urgent::kClearEstop, 1);
    runtime.PostUrgent(0, Urgent::kEstop, 2);
    for (int k = 0; k < 1000; ++k) runtime.PostUrgent(0, Urgent::kClearEstop, 3 + k);  // a flood of clears
    Ticks(1);
    EXPECT_EQ(Arm().mode, Mode::kEstop) << "clear first: " << clear_first;
    EXPECT_STREQ(Arm().command_error, kClearWithEstop);
    Ticks(499);  // the estop's dwell (0.5 s) out
    EXPECT_EQ(Arm().mode, Mode::kEstop);
    runtime.PostUrgent(0, Urgent::kClearEstop, 9000);  // deliberate, in a tick of its own
    Ticks(1);
    EXPECT_EQ(Arm().mode, Mode::kHold);
  }
}

// Nor can a flood shorten an estop: with a clear_estop posted before every
// tick, the estop lasts exactly the scene's estop_dwell (0.5 s: 500 ticks of
// 1 ms) and ends at the first tick after it; a second estop starts a dwell of
// its own.
TEST_F(RuntimeTest, AFloodOfClearsCannotShortenAnEstopBelowItsDwell) {
  Ticks(10);
  runtime.PostUrgent(0, Urgent::kEstop, 1);
  Ticks(1);
  const Nanoseconds estop_at = now;
  int estop_ticks = 1;
  for (std::int64_t k = 2; Arm().mode == Mode::kEstop && k < 2000; ++k) {
    runtime.PostUrgent(0, Urgent::kClearEstop, k);
    Ticks(1);
    if (Arm().mode == Mode::kEstop) {
      ++estop_ticks;
      EXPECT_STREQ(Arm().command_error, kClearWithinDwell);
    }
  }
  EXPECT_EQ(Arm().mode, Mode::kHold);
  EXPECT_EQ(estop_ticks, 500);
  EXPECT_EQ(now - estop_at, 500 * kMs) << "left at the first tick a dwell after the estop";
  // A later estop: its own dwell, however long the instance was stopped before.
  runtime.PostUrgent(0, Urgent::kEstop, 3000);
  Ticks(1);
  runtime.PostUrgent(0, Urgent::kClearEstop, 3001);
  Ticks(499);
  EXPECT_EQ(Arm().mode, Mode::kEstop);
  runtime.PostUrgent(0, Urgent::kClearEstop, 3002);
  Ticks(1);
  EXPECT_EQ(Arm().mode, Mode::kHold);
}

class FaultTest : public RuntimeTest {
 protected:
  FaultTest() : RuntimeTest(TwoInstances("    max_energy: 8.0\n")) {}
};

TEST_F(FaultTest, EnergyOutOfBoundFaultsOnlyThatInstanceUntilReset) {
  // A PD swinging the arm up to the vertical pours in more than 8 J (it starts at about 5 J).
  SendCommand(0, CommandKind::kSwitchController, 1);
  int faulted_at = -1;
  for (int k = 0; k < 2000 && faulted_at < 0; ++k) {
    if (k % 20 == 0) SendSetpoint(0, {1.5707963267948966, 0.0});  // streamed within the timeout
    Ticks(1);
    if (Arm().fault) faulted_at = k;
  }
  ASSERT_GE(faulted_at, 0);
  EXPECT_STREQ(Arm().fault, "the energy left its bound (max_energy)");
  EXPECT_EQ(Arm().mode, Mode::kFault);
  EXPECT_LE(std::abs(Arm().kinetic_energy + Arm().potential_energy), 8.0);  // the last good state is published
  EXPECT_EQ(Arm().tau.norm(), 0.0);
  const VectorXd frozen = Arm().q;
  Ticks(100);
  EXPECT_EQ(Arm().q, frozen);
  EXPECT_EQ(record.instances[1].mode, Mode::kRunning);
  SendCommand(0, CommandKind::kEstop);
  Ticks(1);
  EXPECT_STREQ(Arm().command_error, "estop: the instance is faulted (frozen); reset it");
  SendCommand(0, CommandKind::kReset);
  Ticks(1);
  EXPECT_EQ(Arm().mode, Mode::kRunning);
  EXPECT_NEAR(Arm().q[0], 0.5, 1e-3);
}

// A free pendulum swinging from 1.5 rad: explicit Euler pumps energy in
// (|ε| passes 0.1 J within seconds at 1 ms) while every state stays finite;
// rk4 keeps |ε| far below it. Only the scene's energy_balance bound shows it.
Scene EulerPendulum(const std::string& integrator, const std::string& on_exceed, bool telemetry = false) {
  return ParseScene(R"(
instances:
  - name: p
    plant: {type: pendulum}
    initial: {q: [1.5]}
    integrator: {type: )" + integrator + R"(}
    energy_balance: {bound: 0.1, on_exceed: )" + on_exceed + R"(}
    telemetry: )" + (telemetry ? "true" : "false") + R"(
  - name: q
    plant: {type: pendulum}
    initial: {q: [1.5]}
    integrator: {type: explicit-euler}
)",
                    "inline");
}
constexpr double kResidualBound = 0.1;  // J, as in EulerPendulum
constexpr int kTenSeconds = 10000;      // ticks of 1 ms

TEST(RuntimeResidualBound, ExplicitEulerExceedingTheBoundFaultsOnlyThatInstanceWithItsLastGoodState) {
  Runtime runtime(EulerPendulum("explicit-euler", "fault"));
  TickRecord record = runtime.MakeRecord();
  Nanoseconds now = 0;
  int faulted_at = -1;
  for (int k = 0; k < kTenSeconds && faulted_at < 0; ++k) {
    runtime.Tick(now += kMs, record);
    const InstanceRecord& r = record.instances[0];
    ASSERT_TRUE(r.q.allFinite() && r.qd.allFinite() && r.tau.allFinite());
    if (r.fault) faulted_at = k;
  }
  ASSERT_GE(faulted_at, 0) << "explicit Euler stayed within |eps| <= 0.1 J for 10 s";
  const InstanceRecord& p = record.instances[0];
  EXPECT_STREQ(p.fault, kResidualOutOfBound);
  EXPECT_EQ(p.mode, Mode::kFault);
  EXPECT_LE(std::abs(p.energy_residual), kResidualBound);  // the last good state's balance is what is published
  EXPECT_FALSE(p.residual_exceeded);                      // a fault, not a warning
  const VectorXd frozen = p.q;
  for (int k = 0; k < 100; ++k) runtime.Tick(now += kMs, record);
  EXPECT_EQ(record.instances[0].q, frozen);
  EXPECT_EQ(record.instances[0].mode, Mode::kFault);
  EXPECT_EQ(record.instances[1].mode, Mode::kRunning);  // the unbounded instance runs on, as wrong as before
}

TEST(RuntimeResidualBound, UnderWarnTheInstanceRunsOnAndItsRecordSaysItExceeds) {
  Runtime runtime(EulerPendulum("explicit-euler", "warn"));
  TickRecord record = runtime.MakeRecord();
  Nanoseconds now = 0;
  bool exceeded = false;
  for (int k = 0; k < kTenSeconds; ++k) {
    runtime.Tick(now += kMs, record);
    const InstanceRecord& p = record.instances[0];
    ASSERT_EQ(p.mode, Mode::kRunning);
    ASSERT_EQ(p.residual_exceeded, std::abs(p.energy_residual) > kResidualBound) << k;
    exceeded = exceeded || p.residual_exceeded;
    EXPECT_FALSE(record.instances[1].residual_exceeded);  // no bound: never
  }
  EXPECT_TRUE(exceeded);
  // A reset starts the balance over: within the bound again.
  CommandMessage* c = runtime.channels(0).commands.BeginPush();
  ASSERT_NE(c, nullptr);
  c->kind = CommandKind::kReset;
  runtime.channels(0).commands.Push();
  runtime.Tick(now += kMs, record);
  EXPECT_FALSE(record.instances[0].residual_exceeded);
}

TEST(RuntimeResidualBound, Rk4StaysWithinTheBoundExplicitEulerBreaks) {
  Runtime runtime(EulerPendulum("rk4", "fault", true));
  TickRecord record = runtime.MakeRecord();
  Nanoseconds now = 0;
  for (int k = 0; k < kTenSeconds; ++k) {
    runtime.Tick(now += kMs, record);
    ASSERT_EQ(record.instances[0].mode, Mode::kRunning) << k;
  }
  EXPECT_LT(std::abs(record.instances[0].energy_residual), 1e-6 * kResidualBound);
}

TEST(RuntimeFaults, ADivergingIntegrationIsFaultedAndNothingNonFiniteIsRecorded) {
  // Explicit Euler on a stiff joint-limit spring at 1 ms blows up.
  Runtime runtime(ParseScene(R"(
instances:
  - name: p
    plant: {type: pendulum}
    initial: {q: [1.2], qd: [30]}
    effects: {limits: {lower: [-1], upper: [1], stiffness: 1.0e8, damping: 0}}
    integrator: {type: explicit-euler}
    max_energy: 1.0e300
)",
                             "inline"));
  TickRecord record = runtime.MakeRecord();
  Nanoseconds now = 0;
  bool faulted = false;
  for (int k = 0; k < 5000; ++k) {
    runtime.Tick(now += kMs, record);
    const InstanceRecord& r = record.instances[0];
    ASSERT_TRUE(r.q.allFinite() && r.qd.allFinite() && r.qdd.allFinite() && r.tau.allFinite());
    ASSERT_TRUE(std::isfinite(r.kinetic_energy) && std::isfinite(r.potential_energy));
    faulted = faulted || r.mode == Mode::kFault;
  }
  EXPECT_TRUE(faulted);
}

TEST(Loop, TicksAreConsecutiveAndAFullRingDropsRecordsWithoutStopping) {
  Runtime runtime(TwoInstances());
  testing::FakeClock clock;
  SpscRing<TickRecord> ring(8, runtime.MakeRecord());
  Loop loop(runtime, clock, {kMs, OverrunPolicy::kSkip, 0}, ring);
  std::atomic<bool> stop{false};
  loop.Run(stop, 20);
  EXPECT_EQ(loop.ticks(), 20);
  EXPECT_EQ(loop.records_dropped(), 12);  // nobody drained the ring
  for (std::int64_t k = 0; k < 8; ++k) {
    ASSERT_NE(ring.Front(), nullptr);
    EXPECT_EQ(ring.Front()->tick, k);
    ring.Pop();
  }
  EXPECT_EQ(runtime.instance(0).steps(), 20);
}

// A loop on a fake clock that counts the heap allocations of the ticks it
// runs, and posts commands to an instance as the receiver would.
class CountedLoop {
 public:
  explicit CountedLoop(Runtime& runtime)
      : runtime_(runtime),
        ring_(4096, runtime.MakeRecord()),
        loop_(runtime, clock_, {kMs, OverrunPolicy::kCatchUp, 3}, ring_) {}

  // Runs `ticks` more ticks, adding their allocations to allocations().
  void Run(std::int64_t ticks) {
    testing::AllocationCounter counter;
    loop_.Run(stop_, loop_.ticks() + ticks);
    allocations_ += counter.count();
  }
  void Command(std::size_t instance, CommandKind kind, int controller = -1) {
    CommandMessage* c = runtime_.channels(instance).commands.BeginPush();
    c->kind = kind;
    c->controller = controller;
    c->gains.kp.setConstant(10.0);
    c->gains.kd.setConstant(1.0);
    runtime_.channels(instance).commands.Push();
  }
  // A switch command (integrator, effect, method, forces) as the receiver checked it.
  void Switch(std::size_t instance, const CommandMessage& message) {
    CommandMessage* c = runtime_.channels(instance).commands.BeginPush();
    c->kind = message.kind;
    c->integrator = message.integrator;
    c->default_max_steps = message.default_max_steps;
    c->effect = message.effect;
    c->method = message.method;
    c->on = message.on;
    runtime_.channels(instance).commands.Push();
  }
  std::int64_t allocations() const { return allocations_; }
  std::int64_t ticks() const { return loop_.ticks(); }

 private:
  Runtime& runtime_;
  testing::FakeClock clock_;
  SpscRing<TickRecord> ring_;
  Loop loop_;
  std::atomic<bool> stop_{false};
  std::int64_t allocations_ = 0;
};

TEST(Loop, TheTickAllocatesNothingInAnyMode) {
  Runtime runtime(TwoInstances());
  CountedLoop loop(runtime);
  loop.Run(50);  // running on the scene trajectory
  SetpointMessage& m = runtime.channels(0).setpoints.back();
  m.setpoint.q << 0.7, 0.1;
  runtime.channels(0).setpoints.Publish();
  loop.Run(20);   // streamed setpoint
  loop.Run(100);  // timed out: hold
  loop.Command(0, CommandKind::kSwitchController, 1);
  loop.Command(0, CommandKind::kSetGains, 1);
  loop.Command(0, CommandKind::kPause);
  loop.Run(10);
  loop.Command(0, CommandKind::kResume);
  runtime.PostUrgent(0, Urgent::kEstop, 5);  // the urgent path, as the receiver posts it
  loop.Run(10);
  runtime.PostUrgent(0, Urgent::kClearEstop, 6);
  loop.Command(0, CommandKind::kSetGains, 0);  // refused by the tick: formats nothing
  loop.Command(0, CommandKind::kReset);
  loop.Run(10);
  EXPECT_EQ(loop.allocations(), 0);
  EXPECT_EQ(loop.ticks(), 200);
}

// A floating base's tick allocates nothing either (its full state stepped on
// the manifold, its base record for base_state_t): streamed, held, estopped,
// reset, its integrators switched (dopri5 refused) and its forces published.
TEST(Loop, AFloatingBasesTickAllocatesNothingInAnyMode) {
  Runtime runtime(LoadScene(std::string(LAGRANGE_SOURCE_DIR) + "/tests/fixtures/scenes/floating_fall.yaml"));
  CountedLoop loop(runtime);
  loop.Run(20);
  SetpointMessage& m = runtime.channels(0).setpoints.back();
  m.setpoint.q.setConstant(0.1);
  runtime.channels(0).setpoints.Publish();
  loop.Run(20);
  CommandMessage forces;
  forces.kind = CommandKind::kSetForces;
  forces.on = true;
  loop.Switch(0, forces);
  for (const IntegratorType type : {IntegratorType::kExplicitEuler, IntegratorType::kDormandPrince,
                                    IntegratorType::kSemiImplicitEuler, IntegratorType::kRk4}) {
    CommandMessage c;
    c.kind = CommandKind::kSetIntegrator;
    c.integrator.type = type;
    c.integrator.substeps = 2;
    loop.Switch(0, c);
    loop.Run(5);
  }
  runtime.PostUrgent(0, Urgent::kEstop, 5);
  loop.Run(10);
  runtime.PostUrgent(0, Urgent::kClearEstop, 6);
  loop.Command(0, CommandKind::kReset);
  loop.Run(10);
  EXPECT_EQ(loop.allocations(), 0);
  EXPECT_TRUE(runtime.instance(0).floating_base());
  EXPECT_EQ(runtime.instance(0).integrator().type(), IntegratorType::kRk4);
}

// Switching at run time allocates nothing: every integrator (with new
// sub-steps and tolerances), every effect off and on again (with forces
// published), every method, and the refusals (which format nothing).
TEST(Loop, SwitchingIntegratorsEffectsAndMethodsAllocatesNothing) {
  Runtime runtime(
      TwoInstances("    effects: {damping: 0.1, friction: {coulomb: 0.05}, limits: {lower: [-3, -3], upper: [3, 3]},\n"
                   "              saturation: [40, 15], disturbance: [{start: 0.01, duration: 0.05, tau: [1, 0]}]}\n"),
      BuildOptions::WithCosts({1e-7, 1e-6, 5e-7}));  // the work bound is checked too
  CountedLoop loop(runtime);
  loop.Run(10);
  CommandMessage forces;
  forces.kind = CommandKind::kSetForces;
  forces.on = true;
  loop.Switch(0, forces);
  for (const IntegratorType type :
       {IntegratorType::kExplicitEuler, IntegratorType::kSemiImplicitEuler, IntegratorType::kRk4,
        IntegratorType::kDormandPrince, IntegratorType::kVariational}) {
    CommandMessage c;
    c.kind = CommandKind::kSetIntegrator;
    c.integrator.type = type;
    c.integrator.substeps = 2;
    c.integrator.rtol = 1e-7;
    c.integrator.max_steps = 50;
    c.default_max_steps = type == IntegratorType::kDormandPrince;
    loop.Switch(0, c);
    loop.Run(5);
  }
  for (int k = 0; k < kNumEffectKinds; ++k) {
    CommandMessage c;
    c.kind = CommandKind::kSetEffect;
    c.effect = static_cast<EffectKind>(k);
    c.on = false;  // coriolis off under the variational integrator: refused
    loop.Switch(0, c);
    loop.Run(2);
    c.on = true;
    loop.Switch(0, c);
    loop.Run(2);
  }
  for (const Method m : {Method::kLagrangian, Method::kRecursive, Method::kClosedForm}) {
    CommandMessage c;
    c.kind = CommandKind::kSetMethod;
    c.method = m;
    loop.Switch(0, c);
    loop.Run(5);
  }
  CommandMessage lacking;
  lacking.kind = CommandKind::kSetEffect;  // the cart-pole has no friction: refused
  lacking.effect = EffectKind::kFriction;
  lacking.on = true;
  loop.Switch(1, lacking);
  loop.Run(5);
  EXPECT_EQ(loop.allocations(), 0);
  EXPECT_EQ(runtime.instance(0).method(), Method::kClosedForm);
  EXPECT_EQ(runtime.instance(0).integrator().type(), IntegratorType::kVariational);
  EXPECT_TRUE(runtime.instance(0).model().effects().flags().coriolis);
}

// A URDF robot's tick allocates nothing either: the Panda by both of its
// derivations, under each controller a command can switch to (computed torque,
// PD with gravity compensation, PD with acceleration feed-forward, LQR about a
// pose), in every mode.
TEST(Loop, TheTickOfAUrdfRobotAllocatesNothingInAnyMode) {
  const std::string panda = std::string(LAGRANGE_SOURCE_DIR) + "/config/robots/panda.urdf";
  const std::string pose = "[0.3, -0.5, -0.2, -2.0, 0.1, 1.6, 0.6]";
  std::string text = "instances:\n";
  for (const char* method : {"recursive", "lagrangian"}) {
    text += std::string("  - name: panda_") + method + "\n    plant: {type: urdf, file: " + panda +
            ", method: " + method + "}\n    initial: {q: " + pose + "}\n" +
            "    effects: {limits: {stiffness: 2000, damping: 2}, damping: 0.1, friction: {coulomb: 0.05}}\n"
            "    controller: {type: computed-torque, kp: 100, kd: 20}\n"
            "    controllers:\n"
            "      - {type: gravity-compensation, kp: 50, kd: 1}\n"
            "      - {type: pd, kp: 20, kd: 1, acceleration_feedforward: true}\n"
            "      - {type: lqr, equilibrium: " +
            pose +
            "}\n"
            "    setpoint_timeout: 0.05\n";
  }
  Runtime runtime(ParseScene(text, "inline"));
  CountedLoop loop(runtime);
  loop.Run(20);  // computed torque on the scene trajectory
  for (std::size_t i = 0; i < 2; ++i) {
    SetpointMessage& m = runtime.channels(i).setpoints.back();
    m.setpoint.q[0] += 0.1;
    runtime.channels(i).setpoints.Publish();
  }
  loop.Run(10);  // streamed setpoint
  for (int controller = 1; controller <= 3; ++controller) {
    for (std::size_t i = 0; i < 2; ++i) loop.Command(i, CommandKind::kSwitchController, controller);
    loop.Run(10);
  }
  loop.Run(60);  // timed out: hold, under LQR
  for (std::size_t i = 0; i < 2; ++i) {
    loop.Command(i, CommandKind::kSwitchController, 1);
    loop.Command(i, CommandKind::kSetGains, 1);
    runtime.PostUrgent(i, Urgent::kEstop, 7);
  }
  loop.Run(10);
  for (std::size_t i = 0; i < 2; ++i) {
    runtime.PostUrgent(i, Urgent::kClearEstop, 8);
    loop.Command(i, CommandKind::kReset);
  }
  loop.Run(10);
  EXPECT_EQ(loop.allocations(), 0);
  EXPECT_EQ(loop.ticks(), 140);
  for (std::size_t i = 0; i < 2; ++i) EXPECT_NE(runtime.mode(i), Mode::kFault) << runtime.instance(i).name();
}

// Pose targets reach a task-space controller through the tick's mailbox, a
// move and a target at once, and the record carries the frame for
// task_state_t: none of it allocates, and the controller follows each target.
TEST(Loop, PoseTargetsAndTheTaskRecordAllocateNothing) {
  Runtime runtime(LoadScene(std::string(LAGRANGE_SOURCE_DIR) + "/config/panda_cartesian_impedance.yaml"));
  CountedLoop loop(runtime);
  loop.Run(10);
  const TaskSpaceController& task = *runtime.instance(0).task_space_controller(0);
  Pose target = task.pose();
  target.position.z() += 0.02;
  PoseMessage& move = runtime.channels(0).poses.back();
  move.target = target;
  move.duration = 0.1;
  runtime.channels(0).poses.Publish();
  loop.Run(300);  // the move, and the impedance settling on it
  EXPECT_LT((task.commanded().pose.position - target.position).norm(), 1e-12);
  target.position.x() -= 0.01;
  PoseMessage& step = runtime.channels(0).poses.back();
  step.target = target;
  step.duration = 0.0;
  step.twist.setZero();
  runtime.channels(0).poses.Publish();
  loop.Run(10);
  EXPECT_LT((task.commanded().pose.position - target.position).norm(), 1e-12);
  EXPECT_EQ(loop.allocations(), 0);
  EXPECT_EQ(runtime.mode(0), Mode::kRunning);
}

// A target streamed with a twist that stops coming: after setpoint_timeout
// the target stands where it was, its feed-forward off (it would otherwise
// drag the frame on forever), and the instance holds, as for a joint stream.
TEST(Loop, AStreamedPoseWithATwistThatStopsLeavesTheTargetAtRestAndHolds) {
  Runtime runtime(LoadScene(std::string(LAGRANGE_SOURCE_DIR) + "/config/panda_cartesian_impedance.yaml"));
  CountedLoop loop(runtime);
  loop.Run(10);
  const TaskSpaceController& task = *runtime.instance(0).task_space_controller(0);
  PoseMessage& streamed = runtime.channels(0).poses.back();
  streamed.target = task.pose();
  streamed.duration = 0.0;
  streamed.twist << 0.01, 0.0, 0.0, 0.0, 0.0, 0.0;  // m/s along x
  runtime.channels(0).poses.Publish();
  loop.Run(10);
  EXPECT_EQ(task.commanded().twist[0], 0.01);
  EXPECT_EQ(runtime.mode(0), Mode::kRunning);
  const auto timeout_ticks = static_cast<std::int64_t>(std::ceil(runtime.model().instances[0].config.setpoint_timeout /
                                                                 runtime.period()));
  loop.Run(timeout_ticks + 5);
  EXPECT_TRUE(task.commanded().twist.isZero(0.0));
  EXPECT_EQ(runtime.mode(0), Mode::kHold);
  // A timed move needs no stream: it is never timed out.
  PoseMessage& move = runtime.channels(0).poses.back();
  move.target = task.pose();
  move.target.position.z() += 0.01;
  move.twist.setZero();
  move.duration = 0.2;
  runtime.channels(0).poses.Publish();
  loop.Run(timeout_ticks * 2);
  EXPECT_EQ(runtime.mode(0), Mode::kRunning);
  EXPECT_EQ(loop.allocations(), 0);
}

}  // namespace
}  // namespace lagrange
