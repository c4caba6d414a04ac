// A floating base in a scene (plant: {type: urdf, floating_base: true}): the
// instance carries q (nq) and v (nv), steps them on the manifold with the
// scene's integrator and effects, its joints under pd or none; physics facts
// of the free tree hold (the centre of mass's parabola, momentum without
// gravity, a unit quaternion) and its step allocates nothing. The refusals
// are tests/fixtures/scenes/invalid/floating_base_*.yaml (InvalidScenes).

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "sim/instance.hpp"
#include "sim/offline.hpp"
#include "tests/support/alloc_counter.hpp"

namespace lagrange {
namespace {

const std::string kFloatingFixtures = std::string(LAGRANGE_SOURCE_DIR) + "/tests/fixtures/scenes/";
const Eigen::Vector3d kFloatingGravity(0.0, 0.0, -9.81);

Scene FloatingFall() { return LoadScene(kFloatingFixtures + "floating_fall.yaml"); }

// The fixture's scene with `integrator` and gravity (gx, gy, gz) in its plant.
Scene FloatingVariant(const std::string& integrator, const std::string& gravity) {
  return ParseScene(R"(
period: 0.001
instances:
  - name: tree
    plant: {type: urdf, file: ../urdf/floating_tree.urdf, floating_base: true, gravity: )" +
                        gravity + R"(}
    initial:
      q: [0.3, -0.2, -0.4, 0.5, 0.05]
      qd: [0.5, 0, -0.5, 1, 0]
      base_q: [0, 0, 1, 0, 0, 0, 1]
      base_v: [0.2, 0, 0.5, 0.3, -0.2, 0.4]
    integrator: {type: )" + integrator + R"(}
    effects: {damping: 0.01}
    controller: {type: pd, kp: 2, kd: 0.05}
    setpoint: {type: hold, q: [0, 0, 0, 0, 0]}
)",
                    kFloatingFixtures + "inline.yaml");
}

double TotalMass(const Instance& inst) {
  const RigidTree& tree = inst.instance_model().floating->tree();
  double m = tree.base.mass;
  for (const RigidBody& b : tree.bodies) m += b.mass;
  return m;
}

TEST(FloatingScene, TheInstanceCarriesTheFullStateAndTheJointsApart) {
  const Scene scene = FloatingFall();
  ASSERT_EQ(scene.instances.size(), 1u);
  const InstanceConfig& c = scene.instances[0];
  ASSERT_TRUE(c.floating.has_value());
  EXPECT_EQ(c.plant.num_dofs(), 5);
  EXPECT_EQ(c.method, Method::kRecursive);
  Instance inst(c);
  ASSERT_TRUE(inst.floating_base());
  EXPECT_EQ(inst.num_dofs(), 5);
  EXPECT_EQ(inst.floating_q().size(), 12);
  EXPECT_EQ(inst.floating_v().size(), 11);
  EXPECT_DOUBLE_EQ(inst.floating_q()[2], 1.0);        // the base starts at z = 1 m
  EXPECT_DOUBLE_EQ(inst.floating_q()[6], 1.0);        // unrotated (w = 1)
  EXPECT_DOUBLE_EQ(inst.floating_v()[2], 0.5);        // rising at 0.5 m/s in base axes
  EXPECT_EQ(inst.floating_q().tail(5), c.q0);         // the joints' part is the scene's q
  ASSERT_EQ(inst.Step(scene.period), nullptr);
  EXPECT_EQ(inst.floating_q().tail(5), inst.q());     // and stays the instance's q after a step
  EXPECT_EQ(inst.floating_v().tail(5), inst.qd());
  EXPECT_GT(inst.floating_q()[2], 1.0);                // it rose
}

// Whatever the joints do, m c̈ = m g: c(t) = c0 + ċ0 t + ½ g t², ċ0 the
// linear momentum over the mass. RK4's error on it is the stages' round-off;
// the Euler integrators' is first order (ċ at the step's start or end).
TEST(FloatingScene, TheCentreOfMassFollowsTheParabolaUnderEveryIntegrator) {
  const struct {
    const char* integrator;
    double tolerance;  // m over 1 s at 1 kHz
  } cases[] = {{"rk4", 1e-9}, {"variational", 1e-4}, {"explicit-euler", 1e-2}, {"semi-implicit-euler", 1e-2}};
  for (const auto& k : cases) {
    const Scene scene = FloatingVariant(k.integrator, "[0, 0, -9.81]");
    Instance inst(scene.instances[0]);
    const double m = TotalMass(inst);
    const Instance::BaseMotion start = inst.ComputeBaseMotion();
    const Eigen::Vector3d cd0 = start.linear / m;
    double worst = 0.0, worst_angular = 0.0;
    for (int step = 1; step <= 1000; ++step) {
      ASSERT_EQ(inst.Step(scene.period), nullptr) << k.integrator;
      const double t = inst.t();
      const Eigen::Vector3d expected = start.com + cd0 * t + 0.5 * kFloatingGravity * t * t;
      const Instance::BaseMotion now = inst.ComputeBaseMotion();
      worst = std::max(worst, (now.com - expected).norm());
      worst_angular = std::max(worst_angular, (now.angular - start.angular).norm());
    }
    EXPECT_LT(worst, k.tolerance) << k.integrator;
    // Gravity acts at the centre of mass: the momentum about it stays.
    if (std::string(k.integrator) == "rk4") {
      EXPECT_LT(worst_angular, 1e-9);
    }
    EXPECT_GT((inst.q() - scene.instances[0].q0).norm(), 0.1) << k.integrator;  // the joints moved meanwhile
  }
}

// No gravity: nothing outside acts (the PD torques and the damping are
// internal), so the spatial momentum stays what it was while the tree
// tumbles, to RK4's truncation: the momentum is not a linear function of the
// state, so the step keeps it only to O(h⁴), and halving the step cuts the
// drift about sixteenfold (more than ten here). The quaternion stays unit.
struct FloatingDrift {
  double angular = 0.0, linear = 0.0, quaternion = 0.0;  // the largest over 2 s
  Eigen::Vector3d start_angular, start_linear;
  double turned = 0.0;  // |w − 1| at the end
};

FloatingDrift TumbleWithoutGravity(double period) {
  Scene scene = FloatingVariant("rk4", "[0, 0, 0]");
  Instance inst(scene.instances[0]);
  const Instance::BaseMotion start = inst.ComputeBaseMotion();
  FloatingDrift d{0.0, 0.0, 0.0, start.angular, start.linear, 0.0};
  const int steps = static_cast<int>(std::lround(2.0 / period));
  for (int step = 0; step < steps; ++step) {
    EXPECT_EQ(inst.Step(period), nullptr);
    const Instance::BaseMotion now = inst.ComputeBaseMotion();
    d.angular = std::max(d.angular, (now.angular - start.angular).norm());
    d.linear = std::max(d.linear, (now.linear - start.linear).norm());
    d.quaternion = std::max(d.quaternion, std::abs(inst.floating_q().segment<4>(3).norm() - 1.0));
  }
  d.turned = std::abs(inst.floating_q()[6] - 1.0);
  return d;
}

TEST(FloatingScene, AZeroGravityTumblingTreeKeepsItsMomentumToRk4sOrderAndAUnitQuaternion) {
  const FloatingDrift h = TumbleWithoutGravity(1e-3), half = TumbleWithoutGravity(5e-4);
  ASSERT_GT(h.start_angular.norm(), 0.01);
  ASSERT_GT(h.start_linear.norm(), 1.0);
  EXPECT_LT(h.angular / h.start_angular.norm(), 1e-8);  // relative, over 2 s at 1 kHz
  EXPECT_LT(h.linear / h.start_linear.norm(), 1e-8);
  EXPECT_GT(h.angular / half.angular, 10.0);
  EXPECT_GT(h.linear / half.linear, 10.0);
  EXPECT_LT(h.quaternion, 1e-12);
  EXPECT_GT(h.turned, 1e-3);  // it turned
}

// config/quadruped_free_fall.yaml, as shipped: the A1 thrown up tumbling, its
// legs under PD to a standing posture. Over 1 s under rk4 the centre of mass
// stays on c0 + ċ0 t + ½ g t², the momentum about it stays what it was
// (gravity has no moment about it; everything else is internal), the
// quaternion stays unit, while the trunk tumbles and the legs reach the
// posture. The drifts are rk4's truncation (the legs' PD modes are fast: up
// to kd / M_ii ≈ 250 /s on a calf): halving the step cuts them more than
// tenfold. Bounds (README, "Floating base"), measured on g++ 12 Release
// x86-64 in brackets; the figures are the test's recorded properties.
constexpr double kQuadrupedParabolaTol = 1e-7;     // m, at the scene's 1 ms [1.0e-8]
constexpr double kQuadrupedMomentumTol = 1e-7;     // relative to |L0|, at 1 ms [1.0e-8]
constexpr double kQuadrupedQuaternionTol = 1e-12;  // |‖quaternion‖ − 1| [2.2e-16]

struct QuadrupedFall {
  double parabola = 0.0, momentum = 0.0, quaternion = 0.0;  // the largest over 1 s
  double turned = 0.0;                                      // rad: the largest angle from the start's axes
  double posture = 0.0;                                     // rad: max |q − the posture| at the end
};

QuadrupedFall FallOneSecond(const Scene& scene, double period) {
  const InstanceConfig& c = scene.instances[0];
  Instance inst(c);
  const Eigen::Vector3d gravity = inst.instance_model().floating->tree().gravity;
  const double m = TotalMass(inst);
  const Instance::BaseMotion start = inst.ComputeBaseMotion();
  const Eigen::Vector3d cd0 = start.linear / m;
  QuadrupedFall f;
  const int steps = static_cast<int>(std::lround(1.0 / period));
  for (int step = 1; step <= steps; ++step) {
    EXPECT_EQ(inst.Step(period), nullptr) << "t = " << inst.t();
    const double t = inst.t();
    const Instance::BaseMotion now = inst.ComputeBaseMotion();
    f.parabola = std::max(f.parabola, (now.com - (start.com + cd0 * t + 0.5 * gravity * t * t)).norm());
    f.momentum = std::max(f.momentum, (now.angular - start.angular).norm() / start.angular.norm());
    const Eigen::Vector4d quat = inst.floating_q().segment<4>(3);
    f.quaternion = std::max(f.quaternion, std::abs(quat.norm() - 1.0));
    f.turned = std::max(f.turned, 2.0 * std::acos(std::min(1.0, std::abs(quat[3]))));
  }
  f.posture = (inst.q() - *c.setpoint.q).cwiseAbs().maxCoeff();
  return f;
}

TEST(FloatingScene, TheShippedQuadrupedTumblesOnTheParabolaKeepingItsMomentumAboutTheCentreOfMass) {
  const Scene scene = LoadScene(std::string(LAGRANGE_SOURCE_DIR) + "/config/quadruped_free_fall.yaml");
  ASSERT_EQ(scene.instances.size(), 1u);
  const InstanceConfig& c = scene.instances[0];
  ASSERT_TRUE(c.floating.has_value());
  ASSERT_EQ(c.integrator.type, IntegratorType::kRk4);
  ASSERT_EQ(c.plant.num_dofs(), 12);
  ASSERT_TRUE(c.setpoint.q.has_value());
  {
    Instance inst(c);
    ASSERT_LT((inst.instance_model().floating->tree().gravity - kFloatingGravity).norm(), 1e-12);
    ASSERT_GT(inst.ComputeBaseMotion().angular.norm(), 0.1);  // thrown turning
  }
  const QuadrupedFall h = FallOneSecond(scene, scene.period), half = FallOneSecond(scene, scene.period / 2);
  EXPECT_LT(h.parabola, kQuadrupedParabolaTol);
  EXPECT_LT(h.momentum, kQuadrupedMomentumTol);
  EXPECT_LT(h.quaternion, kQuadrupedQuaternionTol);
  EXPECT_GT(h.parabola / half.parabola, 10.0);  // rk4's truncation, not a modelling error
  EXPECT_GT(h.momentum / half.momentum, 10.0);
  EXPECT_GT(h.turned, 2.0);    // it tumbled (rad)
  EXPECT_LT(h.posture, 0.05);  // the legs reached the posture (rad)
  char text[200];
  std::snprintf(text, sizeof text,
                "parabola %.3g m, momentum %.3g relative, quaternion %.3g, turned %.3g rad, posture %.3g rad; "
                "at half the step: parabola %.3g m, momentum %.3g",
                h.parabola, h.momentum, h.quaternion, h.turned, h.posture, half.parabola, half.momentum);
  RecordProperty("quadruped_free_fall", text);
}

TEST(FloatingScene, ZeroTorqueLeavesTheJointsToThePhysics) {
  Scene scene = FloatingVariant("rk4", "[0, 0, 0]");
  scene.instances[0].controller = ControllerConfig{};  // none
  scene.instances[0].effects.damping.reset();
  scene.instances[0].qd0.setZero();
  scene.instances[0].floating->v0.setZero();
  Instance inst(scene.instances[0]);
  for (int step = 0; step < 100; ++step) ASSERT_EQ(inst.Step(scene.period), nullptr);
  // At rest, no gravity, no torque: nothing moves.
  EXPECT_LT(inst.floating_v().norm(), 1e-12);
  EXPECT_LT((inst.q() - scene.instances[0].q0).norm(), 1e-12);
}

TEST(FloatingScene, TheRunTimeSwitchesRefuseWhatAFloatingBaseCannotRun) {
  Instance inst(FloatingFall().instances[0]);
  IntegratorConfig dopri;
  dopri.type = IntegratorType::kDormandPrince;
  EXPECT_STREQ(inst.SetIntegrator(dopri), kFloatingIntegrators);
  EXPECT_STREQ(inst.SetMethod(Method::kLagrangian), kFloatingMethod);
  IntegratorConfig euler;
  euler.type = IntegratorType::kSemiImplicitEuler;
  euler.substeps = 2;
  EXPECT_EQ(inst.SetIntegrator(euler), nullptr);
  EXPECT_EQ(inst.Step(1e-3), nullptr);
  IntegratorConfig variational;
  variational.type = IntegratorType::kVariational;
  EXPECT_EQ(inst.SetIntegrator(variational), nullptr);
  EXPECT_EQ(inst.Step(1e-3), nullptr);
  EXPECT_STREQ(inst.SetEffect(EffectKind::kCoriolis, false), kVariationalNeedsCoriolis);
  EXPECT_EQ(inst.SetEffect(EffectKind::kGravity, false), nullptr);
  EXPECT_DOUBLE_EQ(inst.PotentialEnergy(), 0.0);
}

TEST(FloatingScene, RestoreAndResetPutTheBaseBackToo) {
  const Scene scene = FloatingFall();
  Instance inst(scene.instances[0]);
  for (int step = 0; step < 10; ++step) ASSERT_EQ(inst.Step(scene.period), nullptr);
  const Instance::Saved saved = inst.MakeSaved();
  const VectorXd q = inst.floating_q();
  for (int step = 0; step < 10; ++step) ASSERT_EQ(inst.Step(scene.period), nullptr);
  inst.Restore(saved);
  EXPECT_EQ(inst.floating_q(), q);
  inst.Reset();
  EXPECT_DOUBLE_EQ(inst.floating_q()[2], 1.0);
  EXPECT_EQ(inst.floating_q().tail(5), scene.instances[0].q0);
}

TEST(FloatingScene, StepsAllocateNothing) {
  for (const char* integrator : {"rk4", "explicit-euler", "semi-implicit-euler"}) {
    const Scene scene = FloatingVariant(integrator, "[0, 0, -9.81]");
    Instance inst(scene.instances[0]);
    Setpoint sp(inst.num_dofs());
    Instance::Saved saved = inst.MakeSaved();
    inst.Step(scene.period);
    testing::AllocationCounter counter;
    for (int k = 0; k < 100; ++k) {
      inst.SampleTrajectory(sp);
      inst.Step(scene.period, sp);
      inst.KineticEnergy();
      inst.PotentialEnergy();
      inst.ComputeBaseMotion();
    }
    inst.Save(saved);
    inst.Restore(saved);
    inst.Reset();
    inst.Step(scene.period);
    EXPECT_EQ(counter.count(), 0) << integrator;
  }
}

}  // namespace
}  // namespace lagrange
