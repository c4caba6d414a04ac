// LQR: the Riccati solution against known closed forms and its own equation;
// the cart-pole's closed loop is stable, recovers from offsets, and swings up.

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>

#include "controllers/factory.hpp"
#include "controllers/lqr.hpp"
#include "plant/eigenvalues.hpp"
#include "tests/controllers/closed_loop.hpp"

namespace lagrange {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kInf = std::numeric_limits<double>::infinity();

MatrixXd M(std::initializer_list<std::initializer_list<double>> rows) {
  MatrixXd m(static_cast<int>(rows.size()), static_cast<int>(rows.begin()->size()));
  int i = 0;
  for (const auto& r : rows) {
    int j = 0;
    for (double x : r) m(i, j++) = x;
    ++i;
  }
  return m;
}

TEST(Riccati, ScalarSystemMatchesTheClosedForm) {
  // ẋ = a x + b u, cost q x² + r u²: S = r (a + √(a² + b² q / r)) / b².
  for (double a : {-2.0, 0.0, 1.5}) {
    const double b = 0.7, q = 3.0, r = 0.5;
    const LqrResult res = LinearQuadraticRegulator(M({{a}}), M({{b}}), M({{q}}), M({{r}}));
    EXPECT_NEAR(res.S(0, 0), r * (a + std::sqrt(a * a + b * b * q / r)) / (b * b), 1e-10) << a;
  }
}

TEST(Riccati, DoubleIntegratorMatchesTheClosedForm) {
  // q̈ = u, Q = I, R = 1: K = [1, √3].
  const LqrResult res =
      LinearQuadraticRegulator(M({{0, 1}, {0, 0}}), M({{0}, {1}}), MatrixXd::Identity(2, 2), M({{1}}));
  EXPECT_NEAR(res.K(0, 0), 1.0, 1e-10);
  EXPECT_NEAR(res.K(0, 1), std::sqrt(3.0), 1e-10);
}

TEST(Riccati, RandomStabilizableSystemsSatisfyTheEquationWithStableClosedLoops) {
  std::mt19937 rng{42};
  std::normal_distribution<double> normal;
  for (int trial = 0; trial < 50; ++trial) {
    const int n = 2 + trial % 5, m = 1 + trial % 2;
    MatrixXd A(n, n), B(n, m), L(n, n);
    for (double* x : {A.data(), B.data(), L.data()}) (void)x;
    for (int i = 0; i < A.size(); ++i) A.data()[i] = normal(rng);
    for (int i = 0; i < B.size(); ++i) B.data()[i] = normal(rng);
    for (int i = 0; i < L.size(); ++i) L.data()[i] = normal(rng);
    const MatrixXd Q = L * L.transpose() + 0.1 * MatrixXd::Identity(n, n);
    const MatrixXd R = MatrixXd::Identity(m, m) * 0.5;
    const LqrResult res = LinearQuadraticRegulator(A, B, Q, R);
    const MatrixXd residual = A.transpose() * res.S + res.S * A - res.S * B * R.inverse() * B.transpose() * res.S + Q;
    EXPECT_LT(residual.norm(), 1e-8 * std::max(1.0, res.S.norm())) << trial;
    EXPECT_GT(SymmetricEigenvalues(res.S).minCoeff(), 0.0) << trial;
    EXPECT_LT(Eigenvalues(A - B * res.K).real().maxCoeff(), 0.0) << trial;
  }
}

TEST(Riccati, RefusesWeightsThatAreNotDefiniteAndSystemsThatCannotBeStabilized) {
  const MatrixXd A = M({{0, 1}, {0, 0}}), B = M({{0}, {1}});
  EXPECT_THROW(LinearQuadraticRegulator(A, B, M({{1, 0}, {0, -1}}), M({{1}})), std::invalid_argument);
  EXPECT_THROW(LinearQuadraticRegulator(A, B, MatrixXd::Identity(2, 2), M({{0}})), std::invalid_argument);
  EXPECT_THROW(LinearQuadraticRegulator(A, B, MatrixXd::Identity(2, 2), M({{1, 0}})), std::invalid_argument);
  // An unstable mode the input cannot reach.
  EXPECT_THROW(LinearQuadraticRegulator(M({{1, 0}, {0, -1}}), M({{0}, {1}}), MatrixXd::Identity(2, 2), M({{1}})),
               std::invalid_argument);
}

// The one Q/R check: the scene validator (ValidateController) and the LQR core
// agree on every matrix, including rank-deficient Q written out in full.
TEST(LqrWeights, ValidatorAndCoreAcceptRankOnePsdQAndRefuseIndefiniteQWithOneMessage) {
  const PlantSpec cartpole = DefaultPlantSpec(PlantType::kCartPole);
  ControllerConfig c;
  c.type = ControllerType::kLqr;
  c.lqr.R = M({{1}});
  // A stable system: any PSD Q has a stabilizing Riccati solution.
  const MatrixXd A = -MatrixXd::Identity(4, 4), B = M({{0}, {0}, {1}, {0.5}});
  std::mt19937 rng{42};
  std::normal_distribution<double> normal;
  const auto random_vector = [&] {
    VectorXd v(4);
    for (int i = 0; i < 4; ++i) v[i] = normal(rng);
    return v;
  };
  int accepted_by_validator = 0, accepted_by_core = 0;
  for (int trial = 0; trial < 1000; ++trial) {
    const VectorXd v = random_vector();
    c.lqr.Q = v * v.transpose();
    accepted_by_validator += !ValidateController(c, cartpole).has_value();
    accepted_by_core += !CheckLqrWeights(c.lqr.Q, c.lqr.R).has_value();
    EXPECT_NO_THROW(LinearQuadraticRegulator(A, B, c.lqr.Q, c.lqr.R)) << trial;
  }
  EXPECT_EQ(accepted_by_validator, 1000);
  EXPECT_EQ(accepted_by_core, 1000);

  constexpr double kClearlyIndefinite = 0.01;  // λ_min(Q) below −1 % of ‖Q‖
  const std::string expected = "Q: expected a symmetric positive semi-definite matrix";
  for (int trial = 0; trial < 100; ++trial) {
    const VectorXd v = random_vector(), w = random_vector();
    c.lqr.Q = v * v.transpose() - w * w.transpose();
    ASSERT_LT(SymmetricEigenvalues(c.lqr.Q).minCoeff(),
              -kClearlyIndefinite * c.lqr.Q.norm());
    const std::optional<std::string> validator = ValidateController(c, cartpole);
    ASSERT_TRUE(validator.has_value()) << trial;
    EXPECT_EQ(*validator, expected);
    try {
      LinearQuadraticRegulator(A, B, c.lqr.Q, c.lqr.R);
      ADD_FAILURE() << "the LQR core accepted an indefinite Q, trial " << trial;
    } catch (const std::invalid_argument& e) {
      EXPECT_EQ(std::string(e.what()), expected);
    }
  }
}

// x⁺ = a x + b u, cost Σ q x² + r u²: b² S² + (r − q b² − a² r) S − q r = 0, the positive root.
TEST(DiscreteRiccati, ScalarSystemMatchesTheClosedForm) {
  for (double a : {-1.5, 0.5, 1.0, 1.3}) {
    const double b = 0.7, q = 3.0, r = 0.5;
    const LqrResult res = DiscreteLinearQuadraticRegulator(M({{a}}), M({{b}}), M({{q}}), M({{r}}));
    const double p = r - q * b * b - a * a * r;
    EXPECT_NEAR(res.S(0, 0), (-p + std::sqrt(p * p + 4.0 * b * b * q * r)) / (2.0 * b * b), 1e-10) << a;
    EXPECT_NEAR(res.K(0, 0), b * res.S(0, 0) * a / (r + b * b * res.S(0, 0)), 1e-10) << a;
  }
}

TEST(DiscreteRiccati, RandomStabilizableSystemsSatisfyTheEquationWithPolesInsideTheUnitCircle) {
  std::mt19937 rng{42};
  std::normal_distribution<double> normal;
  for (int trial = 0; trial < 50; ++trial) {
    const int n = 2 + trial % 5, m = 1 + trial % 2;
    MatrixXd A(n, n), B(n, m), L(n, n);
    for (int i = 0; i < A.size(); ++i) A.data()[i] = 0.6 * normal(rng);
    for (int i = 0; i < B.size(); ++i) B.data()[i] = normal(rng);
    for (int i = 0; i < L.size(); ++i) L.data()[i] = normal(rng);
    const MatrixXd Q = L * L.transpose() + 0.1 * MatrixXd::Identity(n, n);
    const MatrixXd R = MatrixXd::Identity(m, m) * 0.5;
    const LqrResult res = DiscreteLinearQuadraticRegulator(A, B, Q, R);
    const MatrixXd S = res.S;
    const MatrixXd residual =
        A.transpose() * S * A - S -
        A.transpose() * S * B * (R + B.transpose() * S * B).inverse() * B.transpose() * S * A + Q;
    EXPECT_LT(residual.norm(), 1e-8 * std::max(1.0, S.norm())) << trial;
    EXPECT_GT(SymmetricEigenvalues(S).minCoeff(), 0.0) << trial;
    EXPECT_LT(Eigenvalues(A - B * res.K).cwiseAbs().maxCoeff(), 1.0) << trial;
  }
}

TEST(DiscreteRiccati, RefusesWeightsThatAreNotDefiniteAndSystemsThatCannotBeStabilized) {
  const MatrixXd A = M({{1, 0.01}, {0, 1}}), B = M({{0}, {0.01}});
  EXPECT_THROW(DiscreteLinearQuadraticRegulator(A, B, M({{1, 0}, {0, -1}}), M({{1}})), std::invalid_argument);
  EXPECT_THROW(DiscreteLinearQuadraticRegulator(A, B, MatrixXd::Identity(2, 2), M({{0}})), std::invalid_argument);
  EXPECT_THROW(DiscreteLinearQuadraticRegulator(A, B, MatrixXd::Identity(2, 2), M({{1, 0}})), std::invalid_argument);
  // An unstable mode (|λ| = 1.2) the input cannot reach.
  EXPECT_THROW(DiscreteLinearQuadraticRegulator(M({{1.2, 0}, {0, 0.5}}), M({{0}, {1}}), MatrixXd::Identity(2, 2),
                                                M({{1}})),
               std::invalid_argument);
}

TEST(CartPoleLqr, LinearisationMatchesTheTextbookUprightModel) {
  // About upright with φ = θ − π: ẍ = (mp l)² g / D · φ + Ip/D · u, φ̈ = mt mp g l / D · φ + mp l / D · u,
  // D = mt Ip − (mp l)², Ip = mp l² + I.
  const CartPoleParams p;
  auto model = MakeDynamics({p}, Method::kClosedForm);
  VectorXd q0(2);
  q0 << 0.0, kPi;
  const double ml = p.mp * p.l, Ip = p.mp * p.l * p.l + p.pole_inertia(), mt = p.mc + p.mp;
  const double D = mt * Ip - ml * ml;
  // Exact derivatives: to round-off, for every method (central differences were good to about 1e-9).
  for (Method method : {Method::kClosedForm, Method::kLagrangian, Method::kRecursive}) {
    const LinearModel lin = Linearize(*MakeDynamics({p}, method), q0, {0});
    EXPECT_NEAR(lin.A(2, 1), ml * ml * p.g / D, 1e-14) << ToString(method);
    EXPECT_NEAR(lin.A(3, 1), mt * ml * p.g / D, 1e-13) << ToString(method);
    EXPECT_NEAR(lin.B(2, 0), Ip / D, 1e-15) << ToString(method);
    EXPECT_NEAR(lin.B(3, 0), ml / D, 1e-15) << ToString(method);
    EXPECT_EQ(lin.A(0, 2), 1.0);
    EXPECT_EQ(lin.A.bottomRightCorner(2, 2).norm(), 0.0) << ToString(method);  // at rest: no velocity terms
  }
}

// The tick's own map (x⁺ = A x + B u of RK4 with u held): as the tick
// shrinks, the discrete design tends to the continuous one, linearly in h.
TEST(DiscreteLqr, TheGainTendsToTheContinuousOneAsTheTickShrinks) {
  const std::shared_ptr<const Dynamics> model =
      MakeDynamics(DefaultPlantSpec(PlantType::kCartPole), Method::kClosedForm);
  VectorXd q0(2);
  q0 << 0.0, kPi;
  const LinearModel continuous = Linearize(*model, q0, {0});
  const MatrixXd K = LinearQuadraticRegulator(continuous.A, continuous.B, MatrixXd::Identity(4, 4), M({{1}})).K;
  double previous = 0.0;
  for (double h : {1e-2, 1e-3, 1e-4}) {
    const LinearModel lin = LinearizeStep(model, q0, {0}, IntegratorType::kRk4, 1, h);
    EXPECT_EQ(lin.u0, continuous.u0);
    const MatrixXd Kd = DiscreteLinearQuadraticRegulator(lin.A, lin.B, MatrixXd::Identity(4, 4), M({{1}})).K;
    const double difference = (Kd - K).norm() / K.norm();
    EXPECT_LT(difference, 5.0 * h) << h;
    if (previous > 0.0) {
      EXPECT_GT(difference, 0.05 * previous) << h;  // first order: about 10 × smaller per decade
      EXPECT_LT(difference, 0.2 * previous) << h;
    }
    previous = difference;
  }
}

// A tick of 0.25 s (RK4 in 10 sub-steps): the continuous gain held over it
// destabilises the upright pole (the sampled loop's spectral radius is 1.46:
// with the force bounded at 30 N it swings without settling), the discrete
// design of the same tick balances it (0.82). Below 0.2 s both
// hold (0.86 and 0.85 there); config/cartpole_lqr_discrete.yaml shows it.
TEST(DiscreteLqr, AtACoarseTickTheDiscreteDesignBalancesWhereTheContinuousOneFalls) {
  const PlantSpec plant = DefaultPlantSpec(PlantType::kCartPole);
  const double h = 0.25;
  const int substeps = 10;
  for (bool discrete : {false, true}) {
    ControllerConfig c;
    c.type = ControllerType::kLqr;
    c.period = h;
    c.integrator.substeps = substeps;
    c.lqr.discrete = discrete;
    auto controller = MakeController(c, plant, VectorXd::Constant(2, 30.0));
    const MatrixXd K = dynamic_cast<StateFeedbackController&>(*controller).K();
    VectorXd q0(2);
    q0 << 0.0, kPi;
    const LinearModel lin =
        LinearizeStep(MakeDynamics(plant, Method::kClosedForm), q0, {0}, IntegratorType::kRk4, substeps, h);
    const double radius = Eigenvalues(lin.A - lin.B * K).cwiseAbs().maxCoeff();
    q0[1] += 0.05;
    testing::ClosedLoop loop(plant, std::move(controller), q0, EffectsConfig{}, substeps);
    loop.setpoint.q << 0.0, kPi;
    double worst = 0.0;  // the largest angle from upright over the last 10 s
    ASSERT_TRUE(loop.Run(20.0, h, nullptr, [&](double t) {
      if (t > 10.0) worst = std::max(worst, std::abs(JointError(JointType::kRevolute, kPi, loop.q[1])));
    }));
    if (discrete) {
      EXPECT_LT(radius, 0.9);
      EXPECT_LT(worst, 1e-4);
    } else {
      EXPECT_GT(radius, 1.4);
      EXPECT_GT(worst, 0.1);  // never settles: it swings by ±0.3 rad, the 30 N bound keeping it up
    }
  }
}

TEST(DiscreteLqr, ADesignForAnIntegratorWithoutStepDerivativesIsRefusedNamingThoseWithThem) {
  ControllerConfig c;
  c.type = ControllerType::kLqr;
  c.lqr.discrete = true;
  c.integrator.type = IntegratorType::kDormandPrince;
  const std::optional<std::string> err = ValidateController(c, DefaultPlantSpec(PlantType::kCartPole));
  ASSERT_TRUE(err.has_value());
  EXPECT_EQ(*err,
            "design: discrete needs the step derivatives of the instance's integrator: integrator dopri5 has no step "
            "derivatives (explicit-euler, semi-implicit-euler or rk4 have)");
  c.integrator.type = IntegratorType::kRk4;
  c.continuous = true;
  EXPECT_EQ(ValidateController(c, DefaultPlantSpec(PlantType::kCartPole)).value_or(""),
            "design: discrete is the design of a law held over the tick (continuous: false)");
}

std::unique_ptr<Controller> CartPoleLqr() {
  ControllerConfig c;
  c.type = ControllerType::kLqr;
  return MakeController(c, DefaultPlantSpec(PlantType::kCartPole), VectorXd::Constant(2, kInf));
}

TEST(CartPoleLqr, ClosedLoopPolesAreInTheOpenLeftHalfPlane) {
  auto model = MakeDynamics(DefaultPlantSpec(PlantType::kCartPole), Method::kClosedForm);
  VectorXd q0(2);
  q0 << 0.0, kPi;
  const LinearModel lin = Linearize(*model, q0, {0});
  auto controller = CartPoleLqr();
  const auto& K = dynamic_cast<StateFeedbackController&>(*controller).K();
  const Eigen::VectorXcd poles = Eigenvalues(lin.A - lin.B * K);
  EXPECT_LT(poles.real().maxCoeff(), 0.0);
  EXPECT_GT(Eigenvalues(lin.A).real().maxCoeff(), 0.0);  // the open loop is unstable
}

TEST(CartPoleLqr, RecoversFromOffsetsUpToPointTwoRadians) {
  const PlantSpec plant = DefaultPlantSpec(PlantType::kCartPole);
  for (double offset : {-0.2, -0.1, 0.05, 0.1, 0.2}) {
    for (double x0 : {0.0, 0.5}) {
      VectorXd q0(2);
      q0 << x0, kPi + offset;
      testing::ClosedLoop loop(plant, CartPoleLqr(), q0);
      loop.setpoint.q << 0.0, kPi;
      ASSERT_TRUE(loop.Run(15.0, 1e-3));
      EXPECT_LT(std::abs(JointError(JointType::kRevolute, kPi, loop.q[1])), 1e-3) << offset;
      EXPECT_LT(std::abs(loop.q[0]), 1e-2) << offset << " " << x0;
    }
  }
}

TEST(CartPoleSwingUp, FromHangingDownReachesUprightAndStaysWithinFiveHundredthsForTenSeconds) {
  const PlantSpec plant = DefaultPlantSpec(PlantType::kCartPole);
  ControllerConfig c;
  c.type = ControllerType::kSwingUp;
  testing::ClosedLoop loop(plant, MakeController(c, plant, VectorXd::Constant(2, 30.0)), VectorXd::Zero(2));
  loop.setpoint.q << 0.0, kPi;
  double upright_since = -1.0;  // start of the current stretch within 0.05 rad
  double longest = 0.0;
  ASSERT_TRUE(loop.Run(30.0, 1e-3, nullptr, [&](double t) {
    const bool upright = std::abs(JointError(JointType::kRevolute, kPi, loop.q[1])) < 0.05;
    if (upright && upright_since < 0.0) upright_since = t;
    if (!upright) upright_since = -1.0;
    if (upright_since >= 0.0) longest = std::max(longest, t - upright_since);
  }));
  EXPECT_GE(longest, 10.0);
  EXPECT_TRUE(dynamic_cast<SwingUpController&>(*loop.controller).balancing());
}

TEST(CartPolePd, TheArticlesExerciseBalancesAndTheCartMustMove) {
  const PlantSpec plant = DefaultPlantSpec(PlantType::kCartPole);
  ControllerConfig c;
  c.type = ControllerType::kCartPolePd;
  c.gains = {VectorXd(2), VectorXd(2)};
  c.gains.kp << -1.0, 40.0;
  c.gains.kd << -2.0, 8.0;
  VectorXd q0(2);
  q0 << 0.0, kPi - 0.1;
  testing::ClosedLoop loop(plant, MakeController(c, plant, VectorXd::Constant(2, kInf)), q0);
  loop.setpoint.q << 0.0, kPi;
  double farthest = 0.0;
  ASSERT_TRUE(loop.Run(20.0, 1e-3, nullptr, [&](double) { farthest = std::max(farthest, std::abs(loop.q[0])); }));
  EXPECT_LT(std::abs(JointError(JointType::kRevolute, kPi, loop.q[1])), 1e-3);
  EXPECT_GT(farthest, 0.1);              // the cart travels to catch the pole ...
  EXPECT_LT(std::abs(loop.q[0]), 1e-2);  // ... and comes home
  // Positive x gains (the intuitive sign) make the cart run away instead.
  c.gains.kp[0] = 1.0;
  c.gains.kd[0] = 2.0;
  testing::ClosedLoop wrong(plant, MakeController(c, plant, VectorXd::Constant(2, kInf)), q0);
  wrong.setpoint.q << 0.0, kPi;
  wrong.Run(20.0, 1e-3);
  EXPECT_FALSE(std::abs(wrong.q[0]) < 1.0 && std::abs(JointError(JointType::kRevolute, kPi, wrong.q[1])) < 0.1);
}

}  // namespace
}  // namespace lagrange
