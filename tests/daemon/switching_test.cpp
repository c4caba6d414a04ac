// Issue 14 in the tick: the energy-balance residual and the integrator's
// work per tick (telemetry), per-effect forces on demand, and switching the
// integrator, an effect or the method at a tick boundary, with the scene
// reader's refusals.

#include <gtest/gtest.h>

#include <cmath>

#include "daemon/runtime.hpp"
#include "sim/instance.hpp"
#include "sim/scene.hpp"
#include "sim/yaml_reader.hpp"

namespace lagrange {
namespace {

constexpr Nanoseconds kMs = 1'000'000;

// The default scene's arm, swinging: computed torque after a 1 rad, 0.5 Hz sine on both joints.
std::string SwingingArm(const std::string& integrator, const std::string& extra = "") {
  return R"(
instances:
  - name: arm
    plant: {type: arm2}
    initial: {q: [0.785, 0.0]}
    integrator: )" +
         integrator + R"(
    controller: {type: computed-torque, kp: 100, kd: 20}
    controllers: [{type: pd, kp: 60, kd: 8}]
    setpoint: {type: sine, amplitude: [1.0, 1.0], frequency: [0.5, 0.5]}
)" + extra;
}

InstanceConfig ArmConfig(const std::string& integrator, const std::string& extra = "") {
  return ParseScene(SwingingArm(integrator, extra), "inline").instances[0];
}

void StepN(Instance& inst, int ticks, double dt = 1e-3) {
  for (int k = 0; k < ticks; ++k) ASSERT_EQ(inst.Step(dt), nullptr);
}

// ε takes the work of every non-conservative force out of the energy change
// (the held torque's exactly), so it measures the integrator alone: the arm
// swinging under computed torque for 3 s, where the controller moves 5.7 J
// in and out.
TEST(EnergyBalance, TheResidualIsTheIntegratorsAndShrinksWithItsOrder) {
  Instance euler(ArmConfig("{type: explicit-euler}"));
  Instance rk4(ArmConfig("{type: rk4}"));
  Instance rk4x4(ArmConfig("{type: rk4, substeps: 4}"));
  StepN(euler, 3000);
  StepN(rk4, 3000);
  StepN(rk4x4, 3000);
  const EnergyBalance& r = rk4.energy_balance();
  EXPECT_EQ(r.ticks(), 3000);
  EXPECT_GT(std::abs(r.work()), 1.0);
  EXPECT_EQ(r.quadrature_bound(),
            0.0);  // no damping, friction, stops or pushes: nothing went through the trapezoid rule
  EXPECT_GT(std::abs(euler.energy_balance().residual()), 1e-3);
  EXPECT_LT(std::abs(r.residual()), 1e-9);
  // Four sub-steps: at least 4³ smaller for a fourth-order method (measured 150).
  EXPECT_LT(std::abs(rk4x4.energy_balance().residual()), std::abs(r.residual()) / 64.0);
}

// The work theorem on a damped, uncontrolled arm: everything dissipated is
// in W, so E(T) − E(0) = W to within the (small) residual, and W < 0.
TEST(EnergyBalance, DissipationIsAccountedAsNegativeWork) {
  InstanceConfig c = ArmConfig("{type: rk4, substeps: 2}", "    effects: {damping: 0.5, friction: {coulomb: 0.2}}\n");
  c.controller = ControllerConfig{};  // none: the arm falls and swings
  Instance inst(c);
  StepN(inst, 2000);
  const EnergyBalance& b = inst.energy_balance();
  EXPECT_LT(b.work(), -0.5);
  // What is left is the trapezoid rule's error on the dissipated power, which the bound covers.
  EXPECT_GT(b.quadrature_bound(), 0.0);
  EXPECT_LT(std::abs(b.residual()), b.quadrature_bound()) << b.residual() << " " << b.quadrature_bound();
  EXPECT_NEAR(b.energy_change(), b.work(), 1e-5 * std::abs(b.work()));
}

// A law evaluated at every stage (continuous: true) changes its torque along
// the tick and with the setpoint between ticks: its power goes through the
// trapezoid rule, starting from the law under this tick's setpoint, so ε
// stays within the rule's own error.
TEST(EnergyBalance, UnderAContinuousLawTheResidualStaysWithinItsQuadratureBound) {
  Instance inst(ParseScene(R"(
instances:
  - name: arm
    plant: {type: arm2}
    initial: {q: [0.785, 0.0]}
    integrator: {type: dopri5, rtol: 1.0e-12, atol: 1.0e-14, max_steps: 1000}
    controller: {type: computed-torque, kp: 100, kd: 20, continuous: true}
    setpoint: {type: sine, amplitude: [1.0, 1.0], frequency: [0.5, 0.5]}
)",
                           "inline")
                    .instances[0]);
  StepN(inst, 3000);
  const EnergyBalance& b = inst.energy_balance();
  EXPECT_GT(std::abs(b.work()), 1.0);
  EXPECT_GT(b.quadrature_bound(), 0.0);
  EXPECT_LT(std::abs(b.residual()), b.quadrature_bound()) << b.residual() << " " << b.quadrature_bound();
}

// A switch at a tick boundary gives exactly the run that used the new setting from then on.
TEST(Switching, AnIntegratorSwitchedToRunsExactlyAsOneBuiltWithIt) {
  Instance switched(ArmConfig("{type: explicit-euler}"));
  Instance built(ArmConfig("{type: rk4, substeps: 4}"));
  IntegratorConfig rk4x4;
  rk4x4.type = IntegratorType::kRk4;
  rk4x4.substeps = 4;
  ASSERT_EQ(switched.SetIntegrator(rk4x4), nullptr);
  StepN(switched, 500);
  StepN(built, 500);
  EXPECT_EQ(switched.q(), built.q());
  EXPECT_EQ(switched.qd(), built.qd());
  EXPECT_EQ(switched.integrator().work().evaluations, 16);  // 4 per sub-step
  EXPECT_EQ(switched.integrator().work().steps, 4);
}

TEST(Switching, TheVariationalIntegratorWithoutCoriolisIsRefusedWithTheScenesReason) {
  Instance inst(ArmConfig("{type: rk4}"));
  ASSERT_EQ(inst.SetEffect(EffectKind::kCoriolis, false), nullptr);
  IntegratorConfig variational;
  variational.type = IntegratorType::kVariational;
  const char* refused = inst.SetIntegrator(variational);
  ASSERT_NE(refused, nullptr);
  EXPECT_EQ(inst.integrator().type(), IntegratorType::kRk4);  // nothing changed
  try {
    ParseScene(SwingingArm("{type: variational}", "    effects: {coriolis: false}\n"), "inline");
    FAIL() << "the scene was accepted";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find(refused), std::string::npos) << e.what();
  }
  // And the other order: Coriolis cannot be turned off under the variational integrator.
  ASSERT_EQ(inst.SetEffect(EffectKind::kCoriolis, true), nullptr);
  ASSERT_EQ(inst.SetIntegrator(variational), nullptr);
  EXPECT_STREQ(inst.SetEffect(EffectKind::kCoriolis, false), refused);
  EXPECT_TRUE(inst.model().effects().flags().coriolis);
}

TEST(Switching, AnEffectTheSceneGivesNoParametersForIsRefused) {
  Instance inst(ArmConfig("{type: rk4}"));
  const char* refused = inst.SetEffect(EffectKind::kFriction, true);
  ASSERT_NE(refused, nullptr);
  EXPECT_STREQ(refused, NotConfiguredReason(EffectKind::kFriction));  // as the scene reader says it of effects.off
  EXPECT_FALSE(inst.model().effects().flags().friction);
  EXPECT_EQ(inst.SetEffect(EffectKind::kFriction, false), nullptr);  // off is always possible
}

TEST(Switching, AnExternalPlantRefusesAnIntegratorAsItsSceneWould) {
  const Scene scene = ParseScene(R"(
instances:
  - name: arm
    plant: {type: external, model: {type: arm2}, state_channel: S, torque_channel: T}
    controller: {type: pd, kp: 10, kd: 1}
)",
                                 "inline");
  Instance inst(scene.instances[0]);
  IntegratorConfig rk4;
  const char* refused = inst.SetIntegrator(rk4);
  ASSERT_NE(refused, nullptr);
  try {
    ParseScene(R"(
instances:
  - name: arm
    plant: {type: external, model: {type: arm2}, state_channel: S, torque_channel: T}
    integrator: {type: rk4}
)",
               "inline");
    FAIL() << "the scene was accepted";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find(refused), std::string::npos) << e.what();
  }
}

// An effect switched off is not evaluated: its stage count stands still.
TEST(Switching, AnEffectSwitchedOffIsNotComputed) {
  Instance inst(ArmConfig("{type: rk4}", "    effects: {damping: 0.3}\n"));
  StepN(inst, 10);
  const std::int64_t before = inst.model().counts().damping;
  EXPECT_GT(before, 0);
  ASSERT_EQ(inst.SetEffect(EffectKind::kDamping, false), nullptr);
  StepN(inst, 100);
  EXPECT_EQ(inst.model().counts().damping, before);
  ASSERT_EQ(inst.SetEffect(EffectKind::kDamping, true), nullptr);
  StepN(inst, 1);
  EXPECT_GT(inst.model().counts().damping, before);
}

// An effect may start off (effects.off) and be switched on later; a run that
// switches it on at tick k equals one that had it on... from tick k on.
TEST(Switching, AnEffectTheSceneStartsOffCanBeSwitchedOn) {
  Instance inst(ArmConfig("{type: rk4}", "    effects: {damping: 0.3, off: [damping]}\n"));
  Instance undamped(ArmConfig("{type: rk4}"));
  EXPECT_FALSE(inst.model().effects().flags().damping);
  StepN(inst, 100);
  StepN(undamped, 100);
  EXPECT_EQ(inst.q(), undamped.q());
  ASSERT_EQ(inst.SetEffect(EffectKind::kDamping, true), nullptr);
  StepN(inst, 100);
  StepN(undamped, 100);
  EXPECT_NE(inst.q(), undamped.q());
}

// Gravity switched off takes its potential out of E: the balance is re-based
// so that ε runs on continuously while E jumps by V.
TEST(Switching, SwitchingGravityKeepsTheResidualContinuous) {
  Instance inst(ArmConfig("{type: rk4}"));
  StepN(inst, 200);
  const double residual = inst.energy_balance().residual();
  const double energy = inst.model().Energy(inst.q(), inst.qd());
  const double potential = inst.PotentialEnergy();
  ASSERT_GT(std::abs(potential), 0.1);
  ASSERT_EQ(inst.SetEffect(EffectKind::kGravity, false), nullptr);
  EXPECT_EQ(inst.energy_balance().residual(), residual);
  EXPECT_NEAR(inst.model().Energy(inst.q(), inst.qd()), energy - potential, 1e-12);
  StepN(inst, 500);
  EXPECT_LT(std::abs(inst.energy_balance().residual() - residual), 1e-6);
}

// The methods derive the same dynamics: a switch mid-run keeps the trajectory
// to round-off.
TEST(Switching, SwitchingTheMethodKeepsTheTrajectory) {
  Instance switched(ArmConfig("{type: rk4}"));
  Instance closed(ArmConfig("{type: rk4}"));
  StepN(switched, 200);
  StepN(closed, 200);
  for (const Method m : {Method::kRecursive, Method::kLagrangian}) {
    ASSERT_EQ(switched.SetMethod(m), nullptr);
    EXPECT_EQ(switched.method(), m);
    StepN(switched, 200);
    StepN(closed, 200);
    EXPECT_LT((switched.q() - closed.q()).norm(), 1e-9);
  }
}

TEST(Switching, AMethodThePlantLacksIsRefused) {
  InstanceConfig c =
      ParseScene("instances:\n  - name: chain\n    plant: {type: chain, params: {links: 3}}\n", "inline").instances[0];
  Instance inst(c);
  EXPECT_NE(inst.SetMethod(Method::kClosedForm), nullptr);
  EXPECT_EQ(inst.method(), Method::kRecursive);
}

// ---- the runtime: commands, verdicts, the record ----

class SwitchingRuntime : public ::testing::Test {
 protected:
  explicit SwitchingRuntime(const std::string& scene = SwingingArm("{type: rk4}", "    effects: {damping: 0.2}\n"),
                            const BuildOptions& options = {})
      : runtime(ParseScene(scene, "inline"), options), record(runtime.MakeRecord()) {}
  void Ticks(int n) {
    for (int k = 0; k < n; ++k) {
      now += kMs;
      runtime.Tick(now, record);
    }
  }
  CommandMessage& Command(CommandKind kind) {
    CommandMessage* c = runtime.channels(0).commands.BeginPush();
    c->kind = kind;
    c->request_id = ++request;
    return *c;
  }
  void Push() { runtime.channels(0).commands.Push(); }
  // Sends one command and runs a tick: its verdict (null: applied).
  const char* Verdict() {
    Push();
    Ticks(1);
    EXPECT_EQ(Arm().num_verdicts, 1u);
    return Arm().verdicts[0].error;
  }
  const char* SetIntegrator(IntegratorType type, int substeps = 1, bool default_max_steps = false) {
    CommandMessage& c = Command(CommandKind::kSetIntegrator);
    c.integrator = IntegratorConfig{};
    c.integrator.type = type;
    c.integrator.substeps = substeps;
    c.default_max_steps = default_max_steps;
    return Verdict();
  }
  const InstanceRecord& Arm() const { return record.instances[0]; }

  Runtime runtime;
  TickRecord record;
  Nanoseconds now = 0;
  std::int64_t request = 0;
};

TEST_F(SwitchingRuntime, TheRecordCarriesTheBalanceAndThisTicksIntegratorWork) {
  Ticks(100);
  EXPECT_TRUE(Arm().telemetry);
  EXPECT_TRUE(Arm().integrated);
  EXPECT_EQ(Arm().integrator_work.evaluations, 4);
  EXPECT_TRUE(std::isnan(Arm().integrator_work.error_estimate));
  EXPECT_EQ(Arm().energy_residual, runtime.instance(0).energy_balance().residual());
  EXPECT_NE(Arm().work, 0.0);  // the controller moves the arm
  EXPECT_EQ(Arm().integrator.type, IntegratorType::kRk4);
  EXPECT_TRUE(Arm().effects.damping);
  EXPECT_FALSE(Arm().publish_forces);
  // Paused: nothing integrated, no work this tick.
  Command(CommandKind::kPause);
  ASSERT_EQ(Verdict(), nullptr);
  EXPECT_FALSE(Arm().integrated);
  EXPECT_EQ(Arm().integrator_work.evaluations, 0);
}

TEST_F(SwitchingRuntime, IntegratorCommandsTakeEffectAtTheNextTick) {
  Ticks(10);
  ASSERT_EQ(SetIntegrator(IntegratorType::kRk4, 4), nullptr);
  EXPECT_EQ(Arm().integrator_work.evaluations, 16);  // the tick that applied it already ran it
  EXPECT_EQ(Arm().integrator.substeps, 4);
  ASSERT_EQ(SetIntegrator(IntegratorType::kDormandPrince), nullptr);
  Ticks(5);
  EXPECT_GE(Arm().integrator_work.accepted, 1);
  EXPECT_LE(Arm().integrator_work.error_estimate, 1.0);
  ASSERT_EQ(SetIntegrator(IntegratorType::kVariational), nullptr);
  Ticks(5);
  EXPECT_GT(Arm().integrator_work.newton_iterations, 0);
}

TEST_F(SwitchingRuntime, AVariationalSwitchWithoutCoriolisIsRefusedAndChangesNothing) {
  CommandMessage& c = Command(CommandKind::kSetEffect);
  c.effect = EffectKind::kCoriolis;
  c.on = false;
  ASSERT_EQ(Verdict(), nullptr);
  EXPECT_FALSE(Arm().effects.coriolis);
  EXPECT_STREQ(SetIntegrator(IntegratorType::kVariational), kVariationalNeedsCoriolis);
  EXPECT_EQ(Arm().integrator.type, IntegratorType::kRk4);
  EXPECT_EQ(Arm().mode, Mode::kRunning);
}

// The arm with known costs per evaluation: closed form 1 µs, lagrangian 5 µs, recursive 2 µs.
class CostedSwitchingRuntime : public SwitchingRuntime {
 protected:
  CostedSwitchingRuntime()
      : SwitchingRuntime(SwingingArm("{type: rk4}", "    effects: {damping: 0.2}\n"),
                         BuildOptions::WithCosts({1e-6, 5e-6, 2e-6})) {}
};

// The work bound the scene was checked against holds for switches too: the
// instances' worst case per tick within 80 % of the period (0.8 ms here).
TEST_F(CostedSwitchingRuntime, ASwitchWhoseWorstCaseDoesNotFitThePeriodIsRefusedWithItsFigures) {
  Ticks(1);
  EXPECT_STREQ(SetIntegrator(IntegratorType::kRk4, 200), kSwitchDoesNotFit);  // 801 evaluations × 1 µs > 0.8 ms
  EXPECT_NEAR(Arm().verdicts[0].work.worst_s, 801e-6, 1e-12);
  EXPECT_NEAR(Arm().verdicts[0].work.budget_s, 0.8e-3, 1e-12);
  EXPECT_EQ(Arm().integrator.substeps, 1);
  ASSERT_EQ(SetIntegrator(IntegratorType::kRk4, 150), nullptr);  // 601 µs fits
  // ... but not by the lagrangian method at 5 µs.
  CommandMessage& m = Command(CommandKind::kSetMethod);
  m.method = Method::kLagrangian;
  EXPECT_STREQ(Verdict(), kSwitchDoesNotFit);
  EXPECT_EQ(Arm().method, Method::kClosedForm);
  // dopri5 with no max_steps given takes the largest that fits at the costliest
  // method (lagrangian, 5 µs): s·(1 + 6·m) + 1 ≤ 160 gives 26, ...
  ASSERT_EQ(SetIntegrator(IntegratorType::kDormandPrince, 1, /*default_max_steps=*/true), nullptr);
  EXPECT_EQ(Arm().integrator.max_steps, 26);
  // ... so a switch to that method still fits.
  CommandMessage& lagrangian = Command(CommandKind::kSetMethod);
  lagrangian.method = Method::kLagrangian;
  EXPECT_EQ(Verdict(), nullptr);
  EXPECT_EQ(Arm().method, Method::kLagrangian);
}

// The bound is the whole tick's: instances that each fit alone but not
// together are refused (the issue's cart-pole: method lagrangian, then rk4 ×
// 1000, beside the arm).
TEST(WorkBound, IsCheckedOverEveryInstanceNotEachAlone) {
  Runtime runtime(ParseScene(R"(
period: 0.001
instances:
  - {name: arm, plant: {type: arm2}, integrator: {type: rk4, substeps: 90}}
  - {name: cartpole, plant: {type: cartpole}, integrator: {type: rk4, substeps: 90}}
)",
                             "inline"),
                  BuildOptions::WithCosts({1e-6, 5e-6, 2e-6}));  // each: 361 µs, together 722 µs of 800
  TickRecord record = runtime.MakeRecord();
  const auto set = [&](std::size_t i, int substeps) {
    CommandMessage* c = runtime.channels(i).commands.BeginPush();
    c->kind = CommandKind::kSetIntegrator;
    c->integrator = IntegratorConfig{};
    c->integrator.substeps = substeps;
    runtime.channels(i).commands.Push();
    runtime.Tick(kMs, record);
    return record.instances[i].verdicts[0].error;
  };
  EXPECT_STREQ(set(1, 110), kSwitchDoesNotFit);  // 441 µs alone would fit; with the arm's 361 it does not
  EXPECT_EQ(set(0, 10), nullptr);                // the arm down to 41 µs ...
  EXPECT_EQ(set(1, 110), nullptr);               // ... and now the cart-pole's 441 µs fits beside it
}

// Publishing the per-effect forces is part of the tick, so it counts toward
// the bound while on: switching them on is refused when it would not fit, and
// a later switch is judged with them on.
TEST(WorkBound, ForcesCountWhileOnAndAreRefusedWhenTheyWouldNotFit) {
  auto model = std::make_shared<DaemonModel>(*BuildDaemonModel(ParseScene(R"(
period: 0.001
instances:
  - {name: arm, plant: {type: arm2}, integrator: {type: rk4, substeps: 190}}
)",
                                                                          "inline"),
                                                               BuildOptions::WithCosts({1e-6, 5e-6, 2e-6})));
  model->instances[0].forces_s = 50e-6;  // 761 µs of evaluations + 50 µs of forces > 800 µs
  Runtime runtime(model);
  TickRecord record = runtime.MakeRecord();
  const auto command = [&](CommandKind kind, bool on, int substeps) {
    CommandMessage* c = runtime.channels(0).commands.BeginPush();
    c->kind = kind;
    c->on = on;
    c->integrator = IntegratorConfig{};
    c->integrator.substeps = substeps;
    runtime.channels(0).commands.Push();
    runtime.Tick(kMs, record);
    return record.instances[0].verdicts[0].error;
  };
  EXPECT_STREQ(command(CommandKind::kSetForces, true, 0), kSwitchDoesNotFit);
  EXPECT_NEAR(record.instances[0].verdicts[0].work.worst_s, 811e-6, 1e-12);
  EXPECT_FALSE(record.instances[0].forces_on);
  EXPECT_EQ(command(CommandKind::kSetIntegrator, false, 150), nullptr);  // 601 µs
  EXPECT_EQ(command(CommandKind::kSetForces, true, 0), nullptr);          // + 50 µs fits
  EXPECT_TRUE(record.instances[0].forces_on);
  EXPECT_STREQ(command(CommandKind::kSetIntegrator, false, 190), kSwitchDoesNotFit);  // with forces on, 811 µs
  EXPECT_EQ(command(CommandKind::kSetForces, false, 0), nullptr);
  EXPECT_EQ(command(CommandKind::kSetIntegrator, false, 190), nullptr);  // without them, 761 µs
}

// Forces only when asked; they add up to M(q) q̈ at the published state.
TEST_F(SwitchingRuntime, ForcesArePublishedOnlyWhenAskedAndSumToTheDynamics) {
  Ticks(300);
  EXPECT_FALSE(Arm().publish_forces);
  CommandMessage& c = Command(CommandKind::kSetForces);
  c.on = true;
  ASSERT_EQ(Verdict(), nullptr);
  ASSERT_TRUE(Arm().publish_forces);
  const EffectForces& f = Arm().forces;
  EXPECT_TRUE(f.active.damping);
  EXPECT_FALSE(f.active.friction);
  EXPECT_EQ(f.friction.norm(), 0.0);
  EXPECT_GT(f.gravity.norm(), 0.1);
  EXPECT_GT(f.damping.norm(), 0.0);
  VectorXd net(2);
  f.NetForce(net);
  MatrixXd M(2, 2);
  PlantModel& model = runtime.instance(0).model();
  model.dynamics().ComputeMassMatrix(model.data(), Arm().q, M);
  EXPECT_LT((M * Arm().qdd - net).norm(), 1e-9 * (1.0 + net.norm()));
  EXPECT_EQ(f.tau_applied, Arm().tau);
  CommandMessage& off = Command(CommandKind::kSetForces);
  off.on = false;
  ASSERT_EQ(Verdict(), nullptr);
  EXPECT_FALSE(Arm().publish_forces);
}

TEST_F(SwitchingRuntime, ResetKeepsTheSwitchedSettingsAndRestartsTheBalance) {
  ASSERT_EQ(SetIntegrator(IntegratorType::kRk4, 2), nullptr);
  Ticks(200);
  ASSERT_NE(Arm().work, 0.0);
  runtime.PostUrgent(0, Urgent::kReset, 99);  // as the receiver posts a reset
  Ticks(1);
  EXPECT_EQ(Arm().integrator.substeps, 2);
  EXPECT_EQ(runtime.instance(0).energy_balance().ticks(), 1);
}

// Paused, nothing steps: an effect switched then still shows in the
// published energies at once (V loses gravity's potential).
TEST_F(SwitchingRuntime, AnEffectSwitchedWhilePausedShowsInThePublishedEnergies) {
  Ticks(100);
  Command(CommandKind::kPause);
  ASSERT_EQ(Verdict(), nullptr);
  ASSERT_GT(std::abs(Arm().potential_energy), 0.1);
  const double kinetic = Arm().kinetic_energy;
  CommandMessage& c = Command(CommandKind::kSetEffect);
  c.effect = EffectKind::kGravity;
  c.on = false;
  ASSERT_EQ(Verdict(), nullptr);
  EXPECT_EQ(Arm().potential_energy, 0.0);
  EXPECT_EQ(Arm().kinetic_energy, kinetic);
}

// A faulted instance is frozen under zero torque: it publishes no forces
// (they would be of the step undone), and a switch while faulted leaves every
// published value finite.
TEST(SwitchingScene, AFaultedInstancePublishesNoForcesAndSwitchesLeaveItFinite) {
  Runtime runtime(ParseScene(R"(
instances:
  - name: arm
    plant: {type: arm2}
    initial: {q: [0.5, 0.3], qd: [0, 0]}
    integrator: {type: explicit-euler}
    controller: {type: pd, kp: 2.0e5, kd: 10, continuous: true}
    setpoint: {q: [1.5, -1.0]}
    forces: true
)",
                             "inline"));
  TickRecord record = runtime.MakeRecord();
  Nanoseconds now = 0;
  for (int k = 0; k < 200 && record.instances[0].mode != Mode::kFault; ++k) runtime.Tick(now += kMs, record);
  ASSERT_EQ(record.instances[0].mode, Mode::kFault);
  EXPECT_FALSE(record.instances[0].publish_forces);
  EXPECT_TRUE(record.instances[0].forces_on);
  for (const Method m : {Method::kRecursive, Method::kLagrangian}) {
    CommandMessage* c = runtime.channels(0).commands.BeginPush();
    c->kind = CommandKind::kSetMethod;
    c->method = m;
    runtime.channels(0).commands.Push();
    runtime.Tick(now += kMs, record);
    const InstanceRecord& r = record.instances[0];
    EXPECT_EQ(r.verdicts[0].error, nullptr);
    EXPECT_TRUE(r.q.allFinite() && r.qd.allFinite() && r.qdd.allFinite() && r.tau.allFinite());
    EXPECT_TRUE(std::isfinite(r.energy_residual));
    EXPECT_EQ(r.tau.norm(), 0.0);
  }
}

TEST(SwitchingScene, TelemetryOffKeepsNoBalance) {
  Runtime runtime(ParseScene(SwingingArm("{type: rk4}", "    telemetry: false\n    forces: true\n"), "inline"));
  TickRecord record = runtime.MakeRecord();
  for (int k = 1; k <= 50; ++k) runtime.Tick(k * kMs, record);
  EXPECT_FALSE(record.instances[0].telemetry);
  EXPECT_FALSE(runtime.instance(0).accounting());
  EXPECT_EQ(runtime.instance(0).energy_balance().ticks(), 0);
  EXPECT_TRUE(record.instances[0].publish_forces);
}

}  // namespace
}  // namespace lagrange
