// Joint-space controllers against control theory: computed torque yields the
// second-order error response its gains predict; PD + gravity compensation
// has no steady-state error where plain PD keeps the offset G/Kp.

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <string>

#include "controllers/factory.hpp"
#include "tests/controllers/closed_loop.hpp"
#include "tests/support/alloc_counter.hpp"
#include "tests/support/plant_cases.hpp"

namespace lagrange {
namespace {

using testing::ClosedLoop;
constexpr double kInf = std::numeric_limits<double>::infinity();

ControllerConfig Joint(ControllerType type, double kp, double kd, int n = 2) {
  ControllerConfig c;
  c.type = type;
  c.gains = {VectorXd::Constant(n, kp), VectorXd::Constant(n, kd)};
  return c;
}

VectorXd Vec2(double a, double b) {
  VectorXd v(2);
  v << a, b;
  return v;
}

// With an exact model the error obeys ë + Kd ė + Kp e = 0. Released at rest
// from e0 with Kp = ω², Kd = 2ζω (ζ < 1): e(t) = e0 e^{−ζωt} (cos ω_d t + ζω/ω_d sin ω_d t).
double PredictedError(double e0, double kp, double kd, double t) {
  const double w = std::sqrt(kp), zeta = kd / (2.0 * w), wd = w * std::sqrt(1.0 - zeta * zeta);
  return e0 * std::exp(-zeta * w * t) * (std::cos(wd * t) + zeta * w / wd * std::sin(wd * t));
}

TEST(ComputedTorque, ExactModelErrorFollowsTheSecondOrderResponseOfItsGains) {
  const PlantSpec arm = DefaultPlantSpec(PlantType::kArm2);
  const double kp = 100.0, kd = 8.0;  // ω = 10 rad/s, ζ = 0.4
  // The controller holds each tick's torque; the fit to the continuous
  // response tightens with the tick: 1 ms within 2 %, 0.1 ms within 0.2 % of e0.
  for (const auto& [tick, tolerance] : {std::pair{1e-3, 2e-2}, std::pair{1e-4, 2e-3}}) {
    const VectorXd target = Vec2(0.5, -0.3), e0 = Vec2(0.2, -0.15);
    ClosedLoop loop(arm,
                    MakeController(Joint(ControllerType::kComputedTorque, kp, kd), arm, VectorXd::Constant(2, kInf)),
                    target - e0);
    loop.setpoint.q = target;
    double worst = 0.0;
    ASSERT_TRUE(loop.Run(2.0, tick, nullptr, [&](double t) {
      for (int i = 0; i < 2; ++i) {
        const double e = target[i] - loop.q[i];
        worst = std::max(worst, std::abs(e - PredictedError(e0[i], kp, kd, t)) / std::abs(e0[i]));
      }
    }));
    EXPECT_LT(worst, tolerance) << "tick " << tick;
  }
}

TEST(ComputedTorque, TenPercentMassErrorKeepsTrackingErrorBounded) {
  const PlantSpec arm = DefaultPlantSpec(PlantType::kArm2);
  ControllerConfig c = Joint(ControllerType::kComputedTorque, 100.0, 20.0);
  Arm2Params wrong;  // the controller believes every mass is 10 % heavier
  wrong.m1 *= 1.1;
  wrong.m2 *= 1.1;
  c.model = PlantSpec{wrong};
  ClosedLoop loop(arm, MakeController(c, arm, VectorXd::Constant(2, kInf)), Vec2(0.3, 0.4));
  // Track a sine on both joints for 20 s.
  const double amplitude = 0.5, w = 2.0 * std::numbers::pi * 0.5;
  double first_half = 0.0, second_half = 0.0;
  ASSERT_TRUE(loop.Run(
      20.0, 1e-3,
      [&](double t, Setpoint& sp) {
        sp.q = Vec2(0.3, 0.4) + VectorXd::Constant(2, amplitude * std::sin(w * t));
        sp.qd = VectorXd::Constant(2, amplitude * w * std::cos(w * t));
        sp.qdd = VectorXd::Constant(2, -amplitude * w * w * std::sin(w * t));
      },
      [&](double t) {
        const double s = amplitude * std::sin(w * t);
        const double e = std::max(std::abs(0.3 + s - loop.q[0]), std::abs(0.4 + s - loop.q[1]));
        (t < 10.0 ? first_half : second_half) = std::max(t < 10.0 ? first_half : second_half, e);
      }));
  EXPECT_LT(second_half, 0.05);              // bounded, small next to the 0.5 rad motion
  EXPECT_LT(second_half, 1.5 * first_half);  // and not growing
  EXPECT_GT(second_half, 1e-5);              // the model error is felt
}

TEST(GravityCompensation, PdPlusGravityCompensationReachesAStepWithoutSteadyStateError) {
  const PlantSpec arm = DefaultPlantSpec(PlantType::kArm2);
  ClosedLoop loop(
      arm, MakeController(Joint(ControllerType::kGravityCompensation, 60.0, 8.0), arm, VectorXd::Constant(2, kInf)),
      Vec2(0.0, 0.0));
  loop.setpoint.q = Vec2(1.0, -0.5);
  ASSERT_TRUE(loop.Run(10.0, 1e-3));
  EXPECT_LT((loop.setpoint.q - loop.q).lpNorm<Eigen::Infinity>(), 1e-8);
}

TEST(GravityCompensation, PlainPdKeepsTheOffsetGravityOverKp) {
  const PlantSpec arm = DefaultPlantSpec(PlantType::kArm2);
  const double kp = 60.0;
  ClosedLoop loop(arm, MakeController(Joint(ControllerType::kPd, kp, 8.0), arm, VectorXd::Constant(2, kInf)),
                  Vec2(0.0, 0.0));
  loop.setpoint.q = Vec2(1.0, -0.5);
  ASSERT_TRUE(loop.Run(20.0, 1e-3));
  // At rest, Kp e = G(q): the offset theory predicts, with q the settled pose.
  auto model = MakeDynamics(arm, Method::kClosedForm);
  const std::unique_ptr<DynamicsData> model_data = model->MakeData();
  VectorXd G(2);
  model->ComputeGravityForce(*model_data, loop.q, G);
  const VectorXd offset = loop.setpoint.q - loop.q;
  EXPECT_LT((offset - G / kp).norm(), 1e-8);
  EXPECT_GT(offset.norm(), 0.05);  // and it is far from zero
}

TEST(GravityCompensation, GravityCompensationAloneHoldsAnyPose) {
  const PlantSpec chain = DefaultPlantSpec(PlantType::kChain);
  ClosedLoop loop(
      chain, MakeController(Joint(ControllerType::kGravityCompensation, 0.0, 0.0), chain, VectorXd::Constant(2, kInf)),
      Vec2(0.7, -1.1));
  const VectorXd q0 = loop.q;
  ASSERT_TRUE(loop.Run(3.0, 1e-3));
  EXPECT_LT((loop.q - q0).lpNorm<Eigen::Infinity>(), 1e-9);
}

TEST(Pd, AngleErrorsAreWrappedToMinusPiPi) {
  EXPECT_NEAR(JointError(JointType::kRevolute, std::numbers::pi - 0.1, -std::numbers::pi + 0.1), -0.2, 1e-12);
  EXPECT_NEAR(JointError(JointType::kRevolute, 0.0, 2.0 * std::numbers::pi * 1e6 + 0.3), -0.3, 1e-6);
  EXPECT_DOUBLE_EQ(JointError(JointType::kRevolute, std::numbers::pi, 0.0), std::numbers::pi);  // (−π, π]
  EXPECT_DOUBLE_EQ(JointError(JointType::kPrismatic, 10.0, 1.0), 9.0);  // no wrapping for a slide
  // A PD on an arm that has turned a full revolution does not unwind it.
  const PlantSpec arm = DefaultPlantSpec(PlantType::kArm2);
  auto pd = MakeController(Joint(ControllerType::kPd, 10.0, 0.0), arm, VectorXd::Constant(2, kInf));
  Setpoint sp(2);
  VectorXd tau(2);
  ASSERT_TRUE(pd->Compute(0.0, Vec2(2.0 * std::numbers::pi, 0.0), Vec2(0.0, 0.0), sp, tau));
  EXPECT_NEAR(tau.norm(), 0.0, 1e-12);
}

TEST(Limits, TorqueLimitsApplyAfterEveryController) {
  const PlantSpec arm = DefaultPlantSpec(PlantType::kArm2);
  const VectorXd limits = Vec2(2.0, 0.5);
  for (ControllerType type :
       {ControllerType::kPd, ControllerType::kGravityCompensation, ControllerType::kComputedTorque}) {
    auto c = MakeController(Joint(type, 1000.0, 10.0), arm, limits);
    Setpoint sp(2);
    sp.q = Vec2(3.0, -3.0);
    VectorXd tau(2);
    ASSERT_TRUE(c->Compute(0.0, Vec2(0.0, 0.0), Vec2(0.0, 0.0), sp, tau));
    // Both laws ask for far more than the limits: each joint sits on its limit.
    EXPECT_EQ(std::abs(tau[0]), 2.0) << ToString(type);
    EXPECT_EQ(std::abs(tau[1]), 0.5) << ToString(type);
  }
}

TEST(Faults, ANonFiniteLawReportsAFaultAndOutputsZeros) {
  const PlantSpec arm = DefaultPlantSpec(PlantType::kArm2);
  for (ControllerType type :
       {ControllerType::kPd, ControllerType::kGravityCompensation, ControllerType::kComputedTorque}) {
    auto c = MakeController(Joint(type, 10.0, 1.0), arm, VectorXd::Constant(2, kInf));
    Setpoint sp(2);
    sp.qd[1] = std::numeric_limits<double>::quiet_NaN();
    VectorXd tau = Vec2(7.0, 7.0);
    EXPECT_FALSE(c->Compute(0.0, Vec2(0.1, 0.2), Vec2(0.0, 0.0), sp, tau)) << ToString(type);
    EXPECT_EQ(tau, Vec2(0.0, 0.0));
  }
}

TEST(Gains, ChangingGainsTakesEffectAndBadGainsAreRefused) {
  const PlantSpec arm = DefaultPlantSpec(PlantType::kArm2);
  auto pd = MakeController(Joint(ControllerType::kPd, 10.0, 1.0), arm, VectorXd::Constant(2, kInf));
  EXPECT_TRUE(pd->SetGains({Vec2(20.0, 30.0), Vec2(2.0, 3.0)}));
  Setpoint sp(2);
  sp.q = Vec2(0.1, 0.1);
  VectorXd tau(2);
  ASSERT_TRUE(pd->Compute(0.0, Vec2(0.0, 0.0), Vec2(0.0, 0.0), sp, tau));
  EXPECT_NEAR(tau[0], 2.0, 1e-12);
  EXPECT_NEAR(tau[1], 3.0, 1e-12);
  const Gains too_many{VectorXd::Constant(3, 1.0), Vec2(1.0, 1.0)}, negative{Vec2(-1.0, 1.0), Vec2(1.0, 1.0)};
  EXPECT_FALSE(pd->SetGains(too_many));
  EXPECT_FALSE(pd->SetGains(negative));
  EXPECT_EQ(pd->gains().kp, Vec2(20.0, 30.0));  // unchanged by the refused ones
  EXPECT_EQ(*CheckGains(ControllerType::kPd, 2, too_many), "kp: expected 2 gains (one per joint), got 3");
  EXPECT_EQ(*CheckGains(ControllerType::kComputedTorque, 2, negative), "kp: expected finite gains >= 0");
  EXPECT_FALSE(CheckGains(ControllerType::kCartPolePd, 2, negative));  // the cart-pole PD takes negative x gains
  auto none = MakeController(ControllerConfig{}, arm, VectorXd::Constant(2, kInf));
  EXPECT_FALSE(none->SetGains({Vec2(1.0, 1.0), Vec2(1.0, 1.0)}));
  EXPECT_EQ(*CheckGains(ControllerType::kNone, 2, too_many), "none has no adjustable gains");
  EXPECT_EQ(*CheckGains(ControllerType::kLqr, 2, too_many), "lqr has no adjustable gains");
}

// The tick bounds the gains (ComputeGainBounds): the largest allowed gains
// run the arm for 2 s at 1 kHz (RK4, the instances' integrator) without a
// fault, and gains ten times a bound are refused, by the scene check and by
// SetGains, with a message naming the bound.
TEST(Gains, TheLargestAllowedGainsDoNotFaultTheArmAndTenTimesTheBoundIsRefused) {
  const PlantSpec arm = DefaultPlantSpec(PlantType::kArm2);
  constexpr double kTick = 1e-3;
  const VectorXd q0 = Vec2(0.7853981633974483, 0.0);  // config/default.yaml's arm
  const double max_energy = DefaultMaxEnergy(arm);    // above it the runtime faults the instance
  for (ControllerType type :
       {ControllerType::kComputedTorque, ControllerType::kPd, ControllerType::kGravityCompensation}) {
    ControllerConfig c = Joint(type, 0.0, 0.0);
    c.period = kTick;
    c.q0 = q0;
    const GainBounds bounds = ComputeGainBounds(c, arm);
    c.gains = {bounds.kp_max, bounds.kd_max};
    ASSERT_FALSE(ValidateController(c, arm)) << ToString(type);
    ClosedLoop loop(arm, MakeController(c, arm, VectorXd::Constant(2, kInf)), q0);
    loop.setpoint.q = q0 + Vec2(0.1, -0.1);
    double peak_energy = 0.0;
    ASSERT_TRUE(loop.Run(2.0, kTick, nullptr, [&](double) {
      peak_energy = std::max(peak_energy, std::abs(loop.model.Energy(loop.q, loop.qd)));
    })) << ToString(type);
    EXPECT_TRUE(loop.q.allFinite() && loop.qd.allFinite()) << ToString(type);
    EXPECT_LT(peak_energy, max_energy) << ToString(type);
    if (type != ControllerType::kComputedTorque) {  // the PD's second box: its corner runs the arm too
      ASSERT_EQ(bounds.kp_max_per_joint.size(), 2);
      c.gains = {bounds.kp_max_per_joint, bounds.kd_max_per_joint};
      ASSERT_FALSE(ValidateController(c, arm)) << ToString(type);
      ClosedLoop per_joint(arm, MakeController(c, arm, VectorXd::Constant(2, kInf)), q0);
      per_joint.setpoint.q = q0 + Vec2(0.1, -0.1);
      ASSERT_TRUE(per_joint.Run(2.0, kTick, nullptr, [&](double) {
        peak_energy = std::max(peak_energy, std::abs(per_joint.model.Energy(per_joint.q, per_joint.qd)));
      })) << ToString(type);
      EXPECT_LT(peak_energy, max_energy) << ToString(type);
    }

    for (const bool kd : {false, true}) {
      Gains ten_times = {bounds.kp_max, bounds.kd_max};  // beyond both boxes (the arm's per-joint M_22 box is lower)
      (kd ? ten_times.kd : ten_times.kp)[1] *= 10.0;
      const std::string rule = kd ? bounds.kd_rule : bounds.kp_rule;
      c.gains = ten_times;
      const std::optional<std::string> err = ValidateController(c, arm);
      ASSERT_TRUE(err) << ToString(type);
      EXPECT_EQ(err->rfind(kd ? "kd[1]: expected |gain| <= " : "kp[1]: expected |gain| <= ", 0), 0u) << *err;
      EXPECT_NE(err->find(rule), std::string::npos) << *err;
      EXPECT_NE(rule.find(type == ControllerType::kComputedTorque ? (kd ? "Kd·h <= 2" : "Kp·h² <= 1")
                                                                  : (kd ? "Kd·h/λmin(M) <= 2" : "Kp·h²/λmin(M) <= 1")),
                std::string::npos)
          << rule;
      EXPECT_EQ(CheckGains(type, ten_times, loop.controller->gain_bounds()), err);
      EXPECT_FALSE(loop.controller->SetGains(ten_times));
    }
  }
}

// Why the bounds use λmin(M), or each joint's M_ii divided by
// c = λmax(M⁻¹ diag M), and not M_ii itself: the arm's coupling makes
// Kp = diag(M)/h², Kd = 2 diag(M)/h blow up within 2 s.
TEST(Gains, PerJointMassDiagonalBoundsWouldFaultTheArm) {
  const PlantSpec arm = DefaultPlantSpec(PlantType::kArm2);
  constexpr double kTick = 1e-3;
  const VectorXd q0 = Vec2(0.7853981633974483, 0.0);
  MatrixXd M(2, 2);
  M = testing::MassMatrixOf(arm, Method::kClosedForm, q0);
  ControllerConfig c = Joint(ControllerType::kPd, 0.0, 0.0);
  c.period = 1e-9;  // bounds far above: this test shows what the 1 ms bound prevents
  c.gains = {M.diagonal() / (kTick * kTick), 2.0 * M.diagonal() / kTick};
  ClosedLoop loop(arm, MakeController(c, arm, VectorXd::Constant(2, kInf)), q0);
  loop.setpoint.q = q0 + Vec2(0.1, -0.1);
  double peak_energy = 0.0;
  loop.Run(2.0, kTick, nullptr, [&](double) {
    if (loop.q.allFinite() && loop.qd.allFinite())
      peak_energy = std::max(peak_energy, loop.model.Energy(loop.q, loop.qd));
    else
      peak_energy = kInf;
  });
  EXPECT_GT(peak_energy, DefaultMaxEnergy(arm));
}

TEST(Factory, ControllersRefuseConfigsThatDoNotFitThePlant) {
  const PlantSpec arm = DefaultPlantSpec(PlantType::kArm2);
  ControllerConfig c = Joint(ControllerType::kComputedTorque, 10.0, 1.0, 3);
  EXPECT_EQ(*ValidateController(c, arm), "kp: expected 2 gains (one per joint), got 3");
  c = Joint(ControllerType::kSwingUp, 1.0, 1.0);
  EXPECT_EQ(*ValidateController(c, arm), "type: swing-up needs a cartpole plant, got arm2");
  c = ControllerConfig{};
  c.type = ControllerType::kLqr;
  EXPECT_EQ(*ValidateController(c, arm),
            "equilibrium: expected the configuration to balance about (one value per joint)");
  EXPECT_THROW(MakeController(c, arm, VectorXd::Constant(2, kInf)), std::invalid_argument);
}

TEST(NoAllocation, EveryControllerComputesWithoutAllocating) {
  const PlantSpec cartpole = DefaultPlantSpec(PlantType::kCartPole);
  const PlantSpec arm = DefaultPlantSpec(PlantType::kArm2);
  std::vector<std::pair<std::unique_ptr<Controller>, VectorXd>> controllers;
  const VectorXd no_limits = VectorXd::Constant(2, kInf);
  for (ControllerType t : {ControllerType::kNone, ControllerType::kPd, ControllerType::kGravityCompensation,
                           ControllerType::kComputedTorque}) {
    ControllerConfig c = Joint(t, 10.0, 1.0);
    c.pd.acceleration_feedforward = t == ControllerType::kPd;
    controllers.emplace_back(MakeController(c, arm, no_limits), Vec2(0.3, 0.2));
  }
  ControllerConfig lqr;
  lqr.type = ControllerType::kLqr;
  controllers.emplace_back(MakeController(lqr, cartpole, no_limits), Vec2(0.1, 3.0));
  lqr.type = ControllerType::kSwingUp;
  controllers.emplace_back(MakeController(lqr, cartpole, no_limits), Vec2(0.1, 0.5));
  controllers.emplace_back(MakeController(lqr, cartpole, no_limits), Vec2(0.1, 3.1));  // balancing branch
  controllers.emplace_back(MakeController(Joint(ControllerType::kCartPolePd, 1.0, 1.0), cartpole, no_limits),
                           Vec2(0.1, 3.0));
  for (auto& [controller, q] : controllers) {
    Setpoint sp(2);
    VectorXd tau(2);
    const VectorXd qd = Vec2(0.5, -0.5);
    testing::AllocationCounter counter;
    for (int k = 0; k < 10; ++k) controller->Compute(k * 1e-3, q, qd, sp, tau);
    EXPECT_EQ(counter.count(), 0) << controller->name();
  }
}

// A PD holding a pose does not try to unwind a million turns, and its error
// is wrapped exactly.
TEST(HardCases, ControllersWrapErrorsAtAMillionRevolutions) {
  const double turns = 2.0 * std::numbers::pi * 1e6;
  ControllerConfig c;
  c.type = ControllerType::kPd;
  const PlantSpec arm = DefaultPlantSpec(PlantType::kArm2);
  c.gains = {VectorXd::Constant(2, 50.0), VectorXd::Constant(2, 5.0)};
  auto pd = MakeController(c, arm, VectorXd::Constant(2, std::numeric_limits<double>::infinity()));
  Setpoint sp(2);
  sp.q << 0.3, -0.2;
  VectorXd q(2), tau(2);
  q << 0.3 + turns, -0.2 - turns;
  ASSERT_TRUE(pd->Compute(0.0, q, VectorXd::Zero(2), sp, tau));
  EXPECT_LT(tau.norm(), 50.0 * 1e-8);  // the error is a few ulps of the large angle, not 2π·1e6
  EXPECT_NEAR(JointError(JointType::kRevolute, 0.3, 0.3 + turns + 0.01), -0.01, 1e-8);
}

// A controller whose model is the plant's shares the plant's model (one
// immutable object) instead of building another; one with a model of its
// own (a model error) builds it.
TEST(ControllerModel, SharesThePlantsModelUnlessItsModelDiffers) {
  const PlantSpec arm = DefaultPlantSpec(PlantType::kArm2);
  const MethodModels models = MakeMethodModels(arm);
  const auto& closed = models[static_cast<std::size_t>(Method::kClosedForm)];
  const VectorXd limits = VectorXd::Constant(2, kInf);
  ASSERT_EQ(closed.use_count(), 1);
  const auto shared = MakeController(Joint(ControllerType::kComputedTorque, 100.0, 20.0), arm, limits, models);
  EXPECT_EQ(closed.use_count(), 2);
  ControllerConfig heavier = Joint(ControllerType::kComputedTorque, 100.0, 20.0);
  heavier.model = arm;
  std::get<Arm2Params>(heavier.model->params).m2 = 1.0;
  const auto own = MakeController(heavier, arm, limits, models);
  EXPECT_EQ(closed.use_count(), 2);
}

}  // namespace
}  // namespace lagrange
