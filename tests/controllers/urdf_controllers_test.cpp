// The joint controllers on URDF robots (config/robots/): gravity compensation
// outputs its model's G, computed torque obeys its error law on any number of
// joints, LQR about a pose brings the robot back to it, the PD gain bounds
// keep every mode of the held law within the tick's limit, and the cart-pole
// controllers refuse a robot.

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <numbers>

#include "controllers/factory.hpp"
#include "plant/eigenvalues.hpp"
#include "plant/urdf.hpp"
#include "tests/controllers/closed_loop.hpp"
#include "tests/support/plant_cases.hpp"

namespace lagrange {
namespace {

using testing::ClosedLoop;
constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kTick = 1e-3;

PlantSpec Robot(const std::string& name) {
  return UrdfPlantSpec(std::make_shared<const UrdfRobot>(
      LoadUrdf(std::string(LAGRANGE_SOURCE_DIR) + "/config/robots/" + name + ".urdf")));
}

// Poses well inside each robot's limits, away from singular configurations.
VectorXd PandaPose() { return (VectorXd(7) << 0.3, -0.5, -0.2, -2.0, 0.1, 1.6, 0.6).finished(); }
VectorXd Ur5Pose() { return (VectorXd(6) << 0.2, -1.3, 1.4, -1.6, -1.5, 0.3).finished(); }

ControllerConfig Config(ControllerType type, const VectorXd& kp, const VectorXd& kd, const VectorXd& q0) {
  ControllerConfig c;
  c.type = type;
  c.gains = {kp, kd};
  c.q0 = q0;
  c.period = kTick;
  return c;
}

TEST(UrdfControllers, GravityCompensationOutputsItsModelsGravity) {
  const PlantSpec panda = Robot("panda");
  const VectorXd q = PandaPose(), zero = VectorXd::Zero(7);
  PlantSpec heavier = panda;
  ASSERT_FALSE(SetPlantParam(heavier, "mass_scale", "1.05"));
  ControllerConfig c = Config(ControllerType::kGravityCompensation, zero, zero, q);
  auto exact = MakeController(c, panda, VectorXd::Constant(7, kInf));
  c.model = heavier;
  auto model_error = MakeController(c, panda, VectorXd::Constant(7, kInf));
  Setpoint sp(7);
  sp.q = q;
  VectorXd tau(7), tau_heavier(7), G(7);
  ASSERT_TRUE(exact->Compute(0.0, q, zero, sp, tau));
  ASSERT_TRUE(model_error->Compute(0.0, q, zero, sp, tau_heavier));
  G = testing::GravityOf(panda, Method::kRecursive, q);
  EXPECT_LE((tau - G).norm(), 1e-12 * G.norm());
  EXPECT_LE((tau_heavier - 1.05 * G).norm(), 1e-12 * G.norm());
}

// With an exact model, computed torque makes each joint's error obey
// ë + Kd ė + Kp e = 0 whatever the robot; held over 1 ms ticks it follows
// the continuous solution to O(h). Released from e0 = 0.05 rad on every joint.
TEST(UrdfControllers, ComputedTorqueGivesEveryJointOfTheUr5ItsSecondOrderErrorResponse) {
  const PlantSpec ur5 = Robot("ur5");
  const double kp = 100.0, kd = 12.0;  // ω = 10 rad/s, ζ = 0.6
  const VectorXd q_d = Ur5Pose();
  auto controller =
      MakeController(Config(ControllerType::kComputedTorque, VectorXd::Constant(6, kp), VectorXd::Constant(6, kd), q_d),
                     ur5, VectorXd::Constant(6, kInf));
  ClosedLoop loop(ur5, std::move(controller), q_d - VectorXd::Constant(6, 0.05));
  loop.setpoint.q = q_d;
  double worst = 0.0;
  ASSERT_TRUE(loop.Run(2.0, kTick, nullptr, [&](double t) {
    const double w = std::sqrt(kp), zeta = kd / (2.0 * w), wd = w * std::sqrt(1.0 - zeta * zeta);
    const double predicted = 0.05 * std::exp(-zeta * w * t) * (std::cos(wd * t) + zeta * w / wd * std::sin(wd * t));
    worst = std::max(worst, ((q_d - loop.q).array() - predicted).abs().maxCoeff());
  }));
  EXPECT_LT(worst, 1e-3 * 0.05 * 10);  // O(h·ω) of the initial error
  EXPECT_LT((q_d - loop.q).cwiseAbs().maxCoeff(), 1e-4);
}

// LQR about a pose with u_eq = G(pose) on every joint: from 0.05 rad off on
// every joint the Panda returns to the pose, and stays within the initial
// offset on the way (the closed loop's modes are all damped).
TEST(UrdfControllers, LqrAboutAPandaPoseBringsItBack) {
  const PlantSpec panda = Robot("panda");
  ControllerConfig c;
  c.type = ControllerType::kLqr;
  c.lqr.equilibrium = PandaPose();
  c.period = kTick;
  ASSERT_FALSE(ValidateController(c, panda));
  ClosedLoop loop(panda, MakeController(c, panda, VectorXd::Constant(7, kInf)),
                  PandaPose() + VectorXd::Constant(7, 0.05));
  loop.setpoint.q = PandaPose();
  double worst = 0.0;
  ASSERT_TRUE(loop.Run(10.0, kTick, nullptr,
                       [&](double) { worst = std::max(worst, (loop.q - PandaPose()).cwiseAbs().maxCoeff()); }));
  EXPECT_LT((loop.q - PandaPose()).cwiseAbs().maxCoeff(), 1e-4);
  EXPECT_LT(worst, 0.2);
}

// Both boxes of PD bounds keep ρ(M⁻¹ Kp) h² <= 1 and ρ(M⁻¹ Kd) h <= 2 for
// every gain in them (ρ grows with each diagonal gain: the corner is the
// worst point); for a robot whose last wrist joint is four thousand times
// lighter than its shoulder, the per-joint box lets the shoulder take far
// more. Gains are accepted within either box.
TEST(UrdfControllers, PdGainBoundsKeepEveryModeOfTheHeldLawWithinTheTicksLimit) {
  struct Case {
    PlantSpec plant;
    VectorXd q0;
  };
  const std::vector<Case> cases = {{Robot("panda"), PandaPose()},
                                   {Robot("ur5"), Ur5Pose()},
                                   {DefaultPlantSpec(PlantType::kArm2), (VectorXd(2) << 0.785, 0.0).finished()}};
  for (const Case& c : cases) {
    const int n = c.plant.num_dofs();
    const GainBounds b = ComputeGainBounds(ControllerType::kPd, c.plant, c.q0, kTick);
    MatrixXd M(n, n);
    M = testing::MassMatrixOf(c.plant, FastestMethod(c.plant.type()), c.q0);
    const MatrixXd Minv = M.inverse();
    auto spectral_radius = [&](const VectorXd& k) {  // of M⁻¹ diag(k), via the symmetric K^½ M⁻¹ K^½
      const MatrixXd S = k.cwiseSqrt().asDiagonal() * Minv * k.cwiseSqrt().asDiagonal();
      return SymmetricEigenvalues(S).maxCoeff();
    };
    ASSERT_EQ(b.kp_max_per_joint.size(), n);
    for (const VectorXd* kp : {&b.kp_max, &b.kp_max_per_joint}) {
      EXPECT_LE(spectral_radius(*kp) * kTick * kTick, 1.0 + 1e-9) << ToString(c.plant.type()) << " n " << n;
    }
    for (const VectorXd* kd : {&b.kd_max, &b.kd_max_per_joint}) {
      EXPECT_LE(spectral_radius(*kd) * kTick, 2.0 + 1e-9) << ToString(c.plant.type()) << " n " << n;
    }
  }
  const GainBounds ur5 = ComputeGainBounds(ControllerType::kPd, Robot("ur5"), Ur5Pose(), kTick);
  EXPECT_GT(ur5.kp_max_per_joint[1], 1000.0 * ur5.kp_max[1]);  // the shoulder lift, against the uniform box
  EXPECT_NE(ur5.kp_rule_per_joint.find("Kp_i·h²·c/M_ii <= 1"), std::string::npos) << ur5.kp_rule_per_joint;
  // Either box: the uniform one's corner, the per-joint one's corner; not their mix.
  Gains g{ur5.kp_max, ur5.kd_max};
  EXPECT_FALSE(FindGainFault(g, ur5));
  g = {ur5.kp_max_per_joint, ur5.kd_max_per_joint};
  EXPECT_FALSE(FindGainFault(g, ur5));
  g.kp[5] = ur5.kp_max[5] * 1.01;  // above both boxes' bound on the last wrist joint, with the shoulder's high
  const std::optional<GainFault> fault = FindGainFault(g, ur5);
  ASSERT_TRUE(fault);
  const std::string message = DescribeGainFault(*fault, g, ur5);
  EXPECT_EQ(message.rfind("kp[0]: expected |gain| <= ", 0), 0u) << message;  // the uniform box's first breach
  // The per-joint box's bounds and its breach, before the rules: a status keeps only a reason's first 199 bytes.
  std::string bounds;
  for (int j = 0; j < 6; ++j) {
    char text[32];
    std::snprintf(text, sizeof text, "%s%.4g", j ? ", " : "", ur5.kp_max_per_joint[j]);
    bounds += text;
  }
  const std::size_t per_joint = message.find("; or every kp within its joint's bound [" + bounds + "], but kp[5] = ");
  EXPECT_NE(per_joint, std::string::npos) << message;
  EXPECT_LT(message.find(" (", per_joint), 199u - std::string("ur5: gains for pd: ").size()) << message;
  EXPECT_NE(message.find("; per joint Kp_i·h²·c/M_ii <= 1"), std::string::npos) << message;
  // One joint: one box.
  EXPECT_EQ(ComputeGainBounds(ControllerType::kPd, DefaultPlantSpec(PlantType::kPendulum), VectorXd::Zero(1), kTick)
                .kp_max_per_joint.size(),
            0);
}

TEST(UrdfControllers, CartPoleControllersRefuseARobotAndLqrNeedsAnEquilibrium) {
  const PlantSpec panda = Robot("panda");
  ControllerConfig c;
  c.type = ControllerType::kSwingUp;
  EXPECT_EQ(*ValidateController(c, panda), "type: swing-up needs a cartpole plant, got urdf");
  c.type = ControllerType::kCartPolePd;
  c.gains = {VectorXd::Ones(7), VectorXd::Ones(7)};
  EXPECT_EQ(*ValidateController(c, panda), "type: cartpole-pd needs a cartpole plant, got urdf");
  c = ControllerConfig{};
  c.type = ControllerType::kLqr;
  EXPECT_EQ(*ValidateController(c, panda),
            "equilibrium: expected the configuration to balance about (one value per joint)");
  c.model = Robot("ur5");
  c.lqr.equilibrium = PandaPose();
  EXPECT_EQ(*ValidateController(c, panda), "model: expected the plant's type and size");
}

}  // namespace
}  // namespace lagrange

namespace lagrange {
namespace {

// The stops a URDF's <limit lower upper> gives (as a scene's effects.limits would).
JointLimits UrdfStops(const PlantSpec& plant) {
  const UrdfRobot& robot = *std::get<UrdfParams>(plant.params).robot;
  const int n = plant.num_dofs();
  JointLimits l;
  l.lower = VectorXd::Constant(n, -kInf);
  l.upper = VectorXd::Constant(n, kInf);
  for (int i = 0; i < n; ++i) {
    const UrdfJointProperties& p = robot.properties[static_cast<std::size_t>(i)];
    if (p.lower && p.upper) {
      l.lower[i] = *p.lower;
      l.upper[i] = *p.upper;
    }
  }
  return l;
}

// Panda joint 1 has stops at ±2.8973 rad: a step from −2 to +2 is 4 rad the
// way the stops allow (through 0), and −2.28 rad the short way round, which
// runs into the −2.8973 stop. With the stops, its error is not wrapped, and
// computed torque (critically damped, no overshoot) takes joint 1 up through
// 0 to +2 without going below −2.
TEST(UrdfControllers, APandaJointWithStopsReachesASetpointMoreThanPiAwayTheWayItsStopsAllow) {
  const PlantSpec panda = Robot("panda");
  const JointLimits stops = UrdfStops(panda);
  ASSERT_NEAR(stops.lower[0], -2.8973, 1e-9);
  ControllerConfig c =
      Config(ControllerType::kComputedTorque, VectorXd::Constant(7, 100.0), VectorXd::Constant(7, 20.0), PandaPose());
  c.wrap = WrappedJoints(JointTypesOf(panda), stops);
  EXPECT_EQ(c.wrap, std::vector<bool>(7, false));
  EffectsConfig effects;
  effects.limits = stops;
  VectorXd q0 = PandaPose();
  q0[0] = -2.0;
  ClosedLoop loop(panda, MakeController(c, panda, VectorXd::Constant(7, kInf)), q0, effects);
  loop.setpoint.q = q0;
  loop.setpoint.q[0] = 2.0;
  double lowest = q0[0];
  ASSERT_TRUE(loop.Run(3.0, kTick, nullptr, [&](double) { lowest = std::min(lowest, loop.q[0]); }));
  EXPECT_NEAR(loop.q[0], 2.0, 1e-3);
  EXPECT_GE(lowest, -2.0 - 1e-9);  // never towards the −2.8973 stop
  EXPECT_LT((loop.q - loop.setpoint.q).cwiseAbs().maxCoeff(), 1e-3);
}

// A revolute joint without stops (continuous) still takes the short way: a
// pendulum from 3.0 to −3.0 rad goes up through π (0.28 rad) to −3 + 2π,
// not down through 0 (6 rad).
TEST(UrdfControllers, AJointWithoutStopsStillTakesTheShortWayRound) {
  const PlantSpec pendulum = DefaultPlantSpec(PlantType::kPendulum);
  ControllerConfig c = Config(ControllerType::kComputedTorque, VectorXd::Constant(1, 100.0),
                              VectorXd::Constant(1, 20.0), VectorXd::Constant(1, 3.0));
  c.wrap = WrappedJoints(JointTypesOf(pendulum), std::nullopt);
  EXPECT_EQ(c.wrap, std::vector<bool>{true});
  ClosedLoop loop(pendulum, MakeController(c, pendulum, VectorXd::Constant(1, kInf)), VectorXd::Constant(1, 3.0));
  loop.setpoint.q[0] = -3.0;
  double lowest = 3.0;
  ASSERT_TRUE(loop.Run(3.0, kTick, nullptr, [&](double) { lowest = std::min(lowest, loop.q[0]); }));
  EXPECT_NEAR(loop.q[0], -3.0 + 2.0 * std::numbers::pi, 1e-3);
  EXPECT_GE(lowest, 3.0 - 1e-9);
}

// The rule: a revolute joint wraps only when unbounded on both sides; one
// finite stop is enough to stop wrapping; a prismatic joint never wraps.
TEST(UrdfControllers, OnlyRevoluteJointsWithoutStopsWrap) {
  const std::vector<JointType> joints = {JointType::kRevolute, JointType::kRevolute, JointType::kRevolute,
                                         JointType::kPrismatic};
  JointLimits l;
  l.lower = (VectorXd(4) << -kInf, -1.0, -kInf, -kInf).finished();
  l.upper = (VectorXd(4) << kInf, 1.0, 0.5, kInf).finished();
  EXPECT_EQ(WrappedJoints(joints, l), (std::vector<bool>{true, false, false, false}));
  EXPECT_EQ(WrappedJoints(joints, std::nullopt), (std::vector<bool>{true, true, true, false}));
  EXPECT_NEAR(JointError(false, 2.0, -2.0), 4.0, 1e-15);
  EXPECT_NEAR(JointError(true, 2.0, -2.0), 4.0 - 2.0 * std::numbers::pi, 1e-12);
}

// A gain bound that is not a number (M(q0) singular gives inf/NaN) accepts
// no gain: the check fails closed, in either box.
TEST(UrdfControllers, AGainBoundThatIsNotANumberAcceptsNoGain) {
  GainBounds b = GainBounds::Unbounded(2);
  b.kp_max.setConstant(std::numeric_limits<double>::quiet_NaN());
  b.kp_max_per_joint = VectorXd::Constant(2, std::numeric_limits<double>::quiet_NaN());
  b.kd_max_per_joint = VectorXd::Constant(2, kInf);
  const Gains g{VectorXd::Constant(2, 1.0), VectorXd::Constant(2, 1.0)};
  const auto fault = FindGainFault(g, b);
  ASSERT_TRUE(fault);
  EXPECT_EQ(fault->kind, GainFault::Kind::kAboveBound);
  EXPECT_FALSE(fault->kd);
}

// The per-joint box is exact at q0 and left out where M(q0) gives no finite
// scale; the λmin box is always there.
TEST(UrdfControllers, PdGainBoundsAreFiniteAndPositiveAtTheInitialPose) {
  const GainBounds b = ComputeGainBounds(ControllerType::kPd, Robot("panda"), PandaPose(), kTick);
  ASSERT_EQ(b.kp_max_per_joint.size(), 7);
  EXPECT_TRUE(b.kp_max.allFinite());
  EXPECT_TRUE((b.kp_max.array() > 0.0).all());
  EXPECT_TRUE(b.kp_max_per_joint.allFinite());
  EXPECT_TRUE((b.kp_max_per_joint.array() > 0.0).all());
}

}  // namespace
}  // namespace lagrange
