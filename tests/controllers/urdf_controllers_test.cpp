// The joint controllers on URDF robots (config/robots/): gravity compensation
// outputs its model's G, computed torque obeys its error law on any number of
// joints, LQR about a pose brings the robot back to it, the PD gain bounds
// keep every mode of the held law within the tick's limit, and the cart-pole
// controllers refuse a robot.

#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <cmath>

#include "controllers/factory.hpp"
#include "plant/urdf.hpp"
#include "tests/controllers/closed_loop.hpp"

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
  MakeDynamics(panda, Method::kRecursive)->ComputeGravityForce(q, G);
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
    MakeDynamics(c.plant, FastestMethod(c.plant.type()))->ComputeMassMatrix(c.q0, M);
    const MatrixXd Minv = M.inverse();
    auto spectral_radius = [&](const VectorXd& k) {  // of M⁻¹ diag(k), via the symmetric K^½ M⁻¹ K^½
      const MatrixXd S = k.cwiseSqrt().asDiagonal() * Minv * k.cwiseSqrt().asDiagonal();
      return Eigen::SelfAdjointEigenSolver<MatrixXd>(S, Eigen::EigenvaluesOnly).eigenvalues().maxCoeff();
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
  EXPECT_NE(message.find("; or every kp within its joint's bound (Kp_i·h²·c/M_ii <= 1"), std::string::npos) << message;
  EXPECT_NE(message.find(", but kp[5] = "), std::string::npos) << message;  // and the per-joint box's
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
