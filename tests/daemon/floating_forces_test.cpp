// A floating base's forces and energy balance (lagrange's own plant: a scene's
// urdf plant with floating_base: true).
//
// Forces (Instance::ComputeForces, what <NAME>_FORCES carries): the joints'
// rows of the floating model's G(q) and C(q, v) v, so that on the joints' rows
//   [M(q) v̇]_joints = tau_applied + disturbance + damping + friction + limits − coriolis − gravity
// with v̇ (nv) the instance's own acceleration, the base's six rows included,
// while the base's rows, unactuated, add up to zero. Checked against the
// Euler–Poincaré path (FloatingLagrangian: M, G and C v by dual numbers of the
// energies), an implementation independent of the recursive one the instance
// runs, and G against the centre of mass's Jacobian, −m J_cᵀ g.
//
// Energy balance: E = T + V of the whole robot, W the joints' held forces'
// work; ε = E − E(0) − W is rk4's truncation (it shrinks about 16-fold at half
// the step), far below explicit Euler's. Measured bounds in brackets (Release,
// g++ 12, x86-64).

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>
#include <string>

#include "plant/floating_lagrangian.hpp"
#include "sim/health.hpp"
#include "sim/instance.hpp"
#include "sim/scene.hpp"
#include "tests/support/alloc_counter.hpp"

namespace lagrange {
namespace {

const std::string kForcesFixtures = std::string(LAGRANGE_SOURCE_DIR) + "/tests/fixtures/scenes/";

// The identity and the rows agree with the Lagrangian path to round-off, relative to the largest term.
constexpr double kIdentityTol = 1e-9;
constexpr double kRowTol = 1e-10;

// ../urdf/floating_tree.urdf on a floating base, gravity along −z, `integrator`, `effects` (a YAML
// mapping's body) and `controller` (a YAML mapping).
Scene FloatingTree(const std::string& integrator, const std::string& effects, const std::string& controller) {
  return ParseScene(R"(
period: 0.001
instances:
  - name: tree
    plant: {type: urdf, file: ../urdf/floating_tree.urdf, floating_base: true}
    initial:
      q: [0.3, -0.2, -0.4, 0.5, 0.02]
      qd: [0.5, 0, -0.5, 1, 0]
      base_q: [0, 0, 1, 0, 0, 0, 1]
      base_v: [0.2, 0, 0.5, 0.3, -0.2, 0.4]
    integrator: {type: )" + integrator + R"(}
    effects: {)" + effects + R"(}
    controller: )" + controller + R"(
    setpoint: {type: hold, q: [0, 0, 0, 0, 0]}
)",
                    kForcesFixtures + "inline.yaml");
}

// Every effect lagrange's plant has, on (the stops the file's, its tail's at ±0.1 m).
constexpr char kEveryEffect[] =
    "damping: 0.05, friction: {coulomb: 0.02, velocity_scale: 0.05}, saturation: 3, "
    "disturbance: [{start: 0, duration: 10, tau: [0.1, -0.2, 0.05, 0.1, 0.3]}]";
constexpr char kPd[] = "{type: pd, kp: 2, kd: 0.05}";

// A seeded random state of the tree: joints within their stops, the base anywhere, turned, moving.
void PlaceRandomly(Instance& inst, std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  VectorXd q(5), qd(5), base_q(7), base_v(6);
  for (int i = 0; i < 5; ++i) q[i] = (i == 4 ? 0.08 : 1.2) * u(rng);
  for (int i = 0; i < 5; ++i) qd[i] = 2.0 * u(rng);
  base_q << u(rng), u(rng), 1.0 + u(rng), u(rng), u(rng), u(rng), u(rng);
  base_q.tail<4>().normalize();
  for (int i = 0; i < 6; ++i) base_v[i] = 2.0 * u(rng);
  inst.SetState(q, qd, base_q, base_v);
}

struct LagrangianTerms {
  MatrixXd M;       // (nv x nv)
  VectorXd G, Cv;   // (nv)
};

// M, G and C v at the instance's state by the Euler–Poincaré path.
LagrangianTerms Lagrangian(const Instance& inst) {
  const FloatingLagrangian model(inst.instance_model().floating->tree());
  auto data = model.MakeData();
  const int nv = model.num_v();
  LagrangianTerms t{MatrixXd(nv, nv), VectorXd(nv), VectorXd(nv)};
  model.ComputeMassMatrix(*data, inst.floating_q(), t.M);
  model.ComputeBias(*data, inst.floating_q(), inst.floating_v(), {.gravity = true, .coriolis = false}, t.G);
  model.ComputeBias(*data, inst.floating_q(), inst.floating_v(), {.gravity = false, .coriolis = true}, t.Cv);
  return t;
}

double Largest(std::initializer_list<const VectorXd*> vectors) {
  double m = 0.0;
  for (const VectorXd* v : vectors) m = std::max(m, v->cwiseAbs().maxCoeff());
  return m;
}

TEST(FloatingForces, TheJointRowsAddUpToTheJointRowsOfMTimesTheInstancesAcceleration) {
  const Scene scene = FloatingTree("rk4", kEveryEffect, kPd);
  Instance inst(scene.instances[0]);
  const int n = inst.num_dofs();
  EffectForces f(n);
  VectorXd net(n);
  std::mt19937 rng{42};
  double worst_joints = 0.0, worst_base = 0.0;
  for (int trial = 0; trial < 20; ++trial) {
    PlaceRandomly(inst, rng);
    for (int k = 0; k < 5; ++k) ASSERT_EQ(inst.Step(scene.period), nullptr);  // a command, at a stepped state
    inst.ComputeForces(f);
    ASSERT_TRUE(f.active.gravity && f.active.coriolis && f.active.damping && f.active.friction && f.active.limits);
    f.NetForce(net);
    const LagrangianTerms L = Lagrangian(inst);
    const VectorXd Ma = L.M * inst.floating_a();
    const VectorXd joints = Ma.tail(n);
    const VectorXd base = Ma.head<6>() + L.Cv.head<6>() + L.G.head<6>();  // the base's rows: no force acts there
    const double scale = Largest({&Ma, &L.G, &L.Cv, &f.tau_applied, &f.damping});
    worst_joints = std::max(worst_joints, (joints - net).cwiseAbs().maxCoeff() / scale);
    worst_base = std::max(worst_base, base.cwiseAbs().maxCoeff() / scale);
    EXPECT_EQ(inst.floating_a().tail(n), inst.qdd());
    EXPECT_GT(f.gravity.norm(), 0.1);   // N·m: the rows carry the floating model's terms
    EXPECT_GT(f.coriolis.norm(), 1e-3);
  }
  EXPECT_LT(worst_joints, kIdentityTol);
  EXPECT_LT(worst_base, kIdentityTol);
  char text[120];
  std::snprintf(text, sizeof text, "joint rows %.3g, base rows %.3g (relative)", worst_joints, worst_base);
  RecordProperty("identity_residual", text);
}

// G's joint rows are ∂V/∂q of the whole robot: −m J_cᵀ g (the centre of mass's
// Jacobian), and the Lagrangian path's; C v's the Lagrangian path's.
TEST(FloatingForces, TheGravityAndCoriolisRowsAreTheFloatingModelsJointRows) {
  const Scene scene = FloatingTree("rk4", "", kPd);
  Instance inst(scene.instances[0]);
  const int n = inst.num_dofs();
  const FloatingDynamics& model = *inst.instance_model().floating;
  auto data = model.MakeData();
  double mass = model.tree().base.mass;
  for (const RigidBody& b : model.tree().bodies) mass += b.mass;
  EffectForces f(n);
  MatrixXd Jc(3, model.num_v());
  std::mt19937 rng{7};
  for (int trial = 0; trial < 20; ++trial) {
    PlaceRandomly(inst, rng);
    inst.ComputeForces(f);
    const LagrangianTerms L = Lagrangian(inst);
    model.ComputeCenterOfMass(*data, inst.floating_q(), Jc);
    const VectorXd G = -mass * Jc.transpose() * model.tree().gravity;
    const double g_scale = G.cwiseAbs().maxCoeff(), c_scale = L.Cv.cwiseAbs().maxCoeff();
    EXPECT_LT((f.gravity - G.tail(n)).cwiseAbs().maxCoeff(), kRowTol * g_scale) << trial;
    EXPECT_LT((f.gravity - L.G.tail(n)).cwiseAbs().maxCoeff(), kRowTol * g_scale) << trial;
    EXPECT_LT((f.coriolis - L.Cv.tail(n)).cwiseAbs().maxCoeff(), kRowTol * c_scale) << trial;
  }
}

// An effect that is off is zeros and was not computed; the identity holds without it.
TEST(FloatingForces, AnEffectSwitchedOffIsAZeroRowNotComputed) {
  const Scene scene = FloatingTree("rk4", "damping: 0.05", kPd);
  for (const EffectKind kind : {EffectKind::kGravity, EffectKind::kCoriolis}) {
    Instance inst(scene.instances[0]);
    const int n = inst.num_dofs();
    ASSERT_EQ(inst.SetEffect(kind, false), nullptr);
    for (int k = 0; k < 10; ++k) ASSERT_EQ(inst.Step(scene.period), nullptr);
    EffectForces f(n);
    const StageCounts before = inst.floating_counts();
    inst.ComputeForces(f);
    const StageCounts after = inst.floating_counts();
    const bool gravity = kind != EffectKind::kGravity;
    EXPECT_EQ(f.active.gravity, gravity);
    EXPECT_EQ(f.active.coriolis, !gravity);
    EXPECT_EQ(after.gravity - before.gravity, gravity ? 1 : 0);  // one RNEA per row that is on
    EXPECT_EQ(after.coriolis - before.coriolis, gravity ? 0 : 1);
    const VectorXd& off = gravity ? f.coriolis : f.gravity;
    const VectorXd& on = gravity ? f.gravity : f.coriolis;
    EXPECT_EQ(off, VectorXd::Zero(n));
    EXPECT_GT(on.norm(), 1e-3);
    VectorXd net(n);
    f.NetForce(net);
    const LagrangianTerms L = Lagrangian(inst);
    const VectorXd Ma = L.M * inst.floating_a();
    const VectorXd joints = Ma.tail(n);
    EXPECT_LT((joints - net).cwiseAbs().maxCoeff(), kIdentityTol * Largest({&Ma, &on, &f.tau_applied}));
  }
}

// ---- The energy balance ----

struct Balance {
  double residual = 0.0;      // ε at the end, J
  double worst = 0.0;         // max |ε| over the run, J
  double work = 0.0;          // W, J
  double energy_change = 0.0; // E − E(0), J
  double work_recomputed = 0.0;  // W from the public state alone: Σ (τ − b∘q̇_k)·Δq, J
};

// The tree spun up tenfold (its joints' rates and base twist: rk4's truncation then shows above round-off)
// under held torques `tau` (and the scene's damping b, one value), `seconds` at `period`.
Balance RunHeld(const Scene& scene, double period, const VectorXd& tau, double b, double seconds) {
  Instance inst(scene.instances[0]);
  EXPECT_TRUE(inst.accounting());
  inst.SetState(inst.q(), 10.0 * inst.qd(), inst.floating_q().head<7>(), 10.0 * inst.floating_v().head<6>());
  Balance r;
  const int steps = static_cast<int>(std::lround(seconds / period));
  for (int k = 0; k < steps; ++k) {
    const VectorXd q0 = inst.q(), qd0 = inst.qd();
    EXPECT_EQ(inst.StepWithTorque(period, tau), nullptr);
    r.work_recomputed += (tau - b * qd0).dot(inst.q() - q0);
    r.worst = std::max(r.worst, std::abs(inst.energy_balance().residual()));
  }
  r.residual = inst.energy_balance().residual();
  r.work = inst.energy_balance().work();
  r.energy_change = inst.energy_balance().energy_change();
  EXPECT_DOUBLE_EQ(inst.energy_balance().quadrature_bound(), 0.0);  // nothing went through the trapezoid rule
  return r;
}

// Held torques (seeded) and damping, no stops, gravity on: 3 s at 1 kHz under rk4.
constexpr double kHeldRk4Tol = 1e-7;      // J, max |ε| over 3 s at 1 ms [1.27e-8; 7.3e-10 at half the step]
constexpr double kHeldWorkTol = 1e-12;    // relative: W against its recomputation from the states

TEST(FloatingBalance, HeldTorquesAndDampingOnAFloatingTreeBalanceToRk4sTruncation) {
  constexpr double kDamping = 0.2;
  const std::string effects = "damping: 0.2, limits: off";
  std::mt19937 rng{42};
  std::uniform_real_distribution<double> u(-2.0, 2.0);
  VectorXd tau(5);
  for (int i = 0; i < 5; ++i) tau[i] = u(rng);
  tau[4] *= 0.1;  // N on the tail, which has no stop here
  const Scene rk4 = FloatingTree("rk4", effects, "{type: none}");
  const Balance h = RunHeld(rk4, 1e-3, tau, kDamping, 3.0);
  const Balance half = RunHeld(rk4, 5e-4, tau, kDamping, 3.0);
  const Balance euler = RunHeld(FloatingTree("explicit-euler", effects, "{type: none}"), 1e-3, tau, kDamping, 3.0);
  EXPECT_GT(std::abs(h.work), 0.05);           // J: the torques and the damping did work
  EXPECT_GT(std::abs(h.energy_change), 0.05);  // and the energy moved
  EXPECT_LT(h.worst, kHeldRk4Tol);
  EXPECT_GT(h.worst / half.worst, 10.0);       // rk4's truncation: halving the step cuts it about 16-fold
  EXPECT_GT(euler.worst, 1e3 * h.worst);       // and explicit Euler's drift is far larger
  EXPECT_LT(std::abs(h.work - h.work_recomputed), kHeldWorkTol * std::abs(h.work));
  char text[200];
  std::snprintf(text, sizeof text, "W %.4g J, E - E0 %.4g J, max |eps| %.3g J (half step %.3g J, explicit Euler %.3g J)",
                h.work, h.energy_change, h.worst, half.worst, euler.worst);
  RecordProperty("held_torques_and_damping", text);
  std::printf("%s\n", text);
}

// No torque, no damping, no stops: E is kept; W stays exactly zero and ε is rk4's drift.
constexpr double kFreeRk4Tol = 2e-8;  // J, max |E − E(0)| over 3 s at 1 ms [2.2e-9; 1.4e-10 at half the step]

TEST(FloatingBalance, AFreeTumblingTreeKeepsItsEnergyToRk4sTruncation) {
  const Scene scene = FloatingTree("rk4", "limits: off", "{type: none}");
  const VectorXd zero = VectorXd::Zero(5);
  const Balance h = RunHeld(scene, 1e-3, zero, 0.0, 3.0);
  const Balance half = RunHeld(scene, 5e-4, zero, 0.0, 3.0);
  EXPECT_EQ(h.work, 0.0);
  EXPECT_LT(h.worst, kFreeRk4Tol);
  EXPECT_GT(h.worst / half.worst, 10.0);
  char text[120];
  std::snprintf(text, sizeof text, "max |E - E0| %.3g J (half step %.3g J)", h.worst, half.worst);
  RecordProperty("free_tumble", text);
  std::printf("%s\n", text);
}

// config/quadruped_free_fall.yaml as shipped: the A1 tumbling, its legs under PD (held each tick), the file's
// stops on. Over 1 s at its 1 ms the PD does work and ε stays rk4's.
constexpr double kQuadrupedBalanceTol = 5e-6;  // J, max |ε| over 1 s at 1 ms [7.1e-7; 4.0e-8 at half the step]

TEST(FloatingBalance, TheShippedQuadrupedsResidualIsRk4sUnderItsPd) {
  const Scene scene = LoadScene(std::string(LAGRANGE_SOURCE_DIR) + "/config/quadruped_free_fall.yaml");
  double worst[2] = {0.0, 0.0}, work = 0.0;
  for (const int k : {0, 1}) {
    Instance inst(scene.instances[0]);
    ASSERT_TRUE(inst.accounting());
    const double period = scene.period / (k + 1);
    const int steps = static_cast<int>(std::lround(1.0 / period));
    for (int s = 0; s < steps; ++s) {
      ASSERT_EQ(inst.Step(period), nullptr);
      worst[k] = std::max(worst[k], std::abs(inst.energy_balance().residual()));
    }
    if (k == 0) work = inst.energy_balance().work();
  }
  EXPECT_GT(std::abs(work), 1.0);  // J: the legs moved to the posture
  EXPECT_LT(worst[0], kQuadrupedBalanceTol);
  EXPECT_GT(worst[0] / worst[1], 10.0);
  char text[120];
  std::snprintf(text, sizeof text, "W %.4g J, max |eps| %.3g J (half step %.3g J)", work, worst[0], worst[1]);
  RecordProperty("quadruped_free_fall", text);
  std::printf("%s\n", text);
}

// An effect switched or the base moved by hand re-bases E(0): ε runs on continuously.
TEST(FloatingBalance, SwitchingGravityOrMovingTheBaseKeepsTheResidualContinuous) {
  const Scene scene = FloatingTree("rk4", "damping: 0.05, limits: off", kPd);
  Instance inst(scene.instances[0]);
  for (int k = 0; k < 100; ++k) ASSERT_EQ(inst.Step(scene.period), nullptr);
  const double before = inst.energy_balance().residual();
  ASSERT_EQ(inst.SetEffect(EffectKind::kGravity, false), nullptr);
  EXPECT_NEAR(inst.energy_balance().residual(), before, 1e-12);
  VectorXd base_q = inst.floating_q().head<7>(), base_v = inst.floating_v().head<6>();
  base_q[2] += 1.0;
  base_v[0] += 0.5;
  inst.SetBaseState(base_q, base_v);
  EXPECT_NEAR(inst.energy_balance().residual(), before, 1e-12);
  for (int k = 0; k < 100; ++k) ASSERT_EQ(inst.Step(scene.period), nullptr);
  EXPECT_LT(std::abs(inst.energy_balance().residual()), kHeldRk4Tol);
}

// A scene's energy_balance bound holds a floating base to it (sim/health.hpp's rule, the tick's and
// simulate's): explicit Euler on the free tree leaves 1e-3 J, and the step faults naming the bound.
TEST(FloatingBalance, ASceneBoundOnTheResidualFaultsAFloatingBaseThatLeavesIt) {
  Scene scene = FloatingTree("explicit-euler", "limits: off", "{type: none}");
  scene.instances[0].energy_balance = EnergyBalanceBound{.bound = 1e-3, .on_exceed = OnResidualExceeded::kFault};
  Instance inst(scene.instances[0]);
  const InstanceModel& m = inst.instance_model();
  StepEnergies energies;
  const char* fault = nullptr;
  int steps = 0;
  while (fault == nullptr && steps < 3000) {
    fault = CheckStepHealth(inst, inst.Step(scene.period), m.max_energy, m.residual_bound, energies);
    ++steps;
  }
  EXPECT_EQ(fault, kResidualOutOfBound);
  EXPECT_GT(std::abs(inst.energy_balance().residual()), 1e-3);
}

// What a tick's integration did, as telemetry publishes it (integrator_work): on a floating base the floating
// integrator's sub-steps, not the joints' integrator's, which never steps there (it read zeros before).
TEST(FloatingForces, ATicksIntegratorWorkIsTheFloatingIntegrators) {
  Instance rk4(FloatingTree("rk4", "", kPd).instances[0]);
  rk4.Step(1e-3);
  EXPECT_EQ(rk4.integrator_work().steps, 1);
  EXPECT_EQ(rk4.integrator_work().evaluations, 4);
  EXPECT_EQ(rk4.integrator().work().evaluations, 0) << "the joints' integrator did not step";
  Instance variational(FloatingTree("variational", "", kPd).instances[0]);
  variational.Step(1e-3);
  EXPECT_EQ(variational.integrator_work().steps, 1);
  EXPECT_GT(variational.integrator_work().newton_iterations, 0);
  EXPECT_GT(variational.integrator_work().evaluations, variational.integrator_work().newton_iterations);
  EXPECT_EQ(variational.integrator_work().failures, 0);
}

TEST(FloatingForces, StepsForcesAndTheBalanceAllocateNothing) {
  for (const char* integrator : {"rk4", "semi-implicit-euler", "variational"}) {
    const Scene scene = FloatingTree(integrator, kEveryEffect, kPd);
    Instance inst(scene.instances[0]);
    ASSERT_TRUE(inst.accounting());
    EffectForces f(inst.num_dofs());
    inst.Step(scene.period);
    testing::AllocationCounter counter;
    for (int k = 0; k < 100; ++k) {
      inst.Step(scene.period);
      inst.ComputeForces(f);
      inst.KineticEnergy();
      inst.PotentialEnergy();
    }
    inst.SetEffect(EffectKind::kGravity, false);
    inst.Step(scene.period);
    inst.ComputeForces(f);
    EXPECT_EQ(counter.count(), 0) << integrator;
  }
}

}  // namespace
}  // namespace lagrange
