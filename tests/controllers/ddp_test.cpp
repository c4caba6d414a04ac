// Box-constrained DDP: one iteration on a linear-quadratic problem is the
// Riccati recursion; on nonlinear plants the cost never increases, the limits
// hold and the solution satisfies KKT; a warm start saves iterations; a
// second solve allocates nothing.

#include <gtest/gtest.h>

#include <atomic>

#include <cmath>
#include <numbers>
#include <random>

#include "controllers/ddp.hpp"
#include "controllers/lqr.hpp"
#include "plant/plant_factory.hpp"
#include "tests/support/alloc_counter.hpp"

namespace lagrange {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kGainTolerance = 1e-10;  // relative, DDP gains against the Riccati recursion

std::shared_ptr<const Dynamics> Plant(PlantParams params) {
  const PlantSpec spec{std::move(params)};
  return MakeDynamics(spec, FastestMethod(spec.type()));
}

DdpWeights Weights(VectorXd q, VectorXd qd, VectorXd tau, VectorXd q_terminal, VectorXd qd_terminal) {
  return {std::move(q), std::move(qd), std::move(tau), std::move(q_terminal), std::move(qd_terminal)};
}

VectorXd V(std::initializer_list<double> xs) {
  VectorXd v(static_cast<Eigen::Index>(xs.size()));
  Eigen::Index i = 0;
  for (double x : xs) v[i++] = x;
  return v;
}

// A linear plant: two prismatic joints along x (constant M, no gravity, no
// Coriolis) with viscous damping, so that every integrator's step is linear
// in (x, u) and the cost is quadratic.
struct LinearProblem {
  std::shared_ptr<const Dynamics> dynamics;
  DdpConfig config;
};

LinearProblem MakeLinearProblem(IntegratorType integrator, int horizon) {
  ChainParams chain;
  chain.g = 0.0;
  chain.links[0].joint = JointType::kPrismatic;
  chain.links[1].joint = JointType::kPrismatic;
  chain.links[1].m = 0.6;
  LinearProblem p{Plant(chain), {}};
  p.config.integrator = integrator;
  p.config.dt = 0.05;
  p.config.horizon = horizon;
  p.config.weights = Weights(V({2.0, 1.0}), V({0.1, 0.2}), V({0.5, 0.3}), V({10.0, 5.0}), V({1.0, 1.5}));
  p.config.effects.damping = V({0.3, 0.5});
  return p;
}

// A, B of the plant's step (linear: the same at every point).
void StepMatrices(const LinearProblem& p, MatrixXd& A, MatrixXd& B) {
  PlantModel plant(p.dynamics, p.config.effects);
  StepDerivatives step(p.config.integrator, 2);
  A.resize(4, 4);
  B.resize(4, 2);
  step.Advance(plant, 0.0, p.config.dt, 1, V({0.3, -0.2}), V({0.1, 0.4}), V({1.0, -2.0}), A, B);
}

TEST(Ddp, OneIterationOnALinearQuadraticProblemGivesTheRiccatiGains) {
  for (IntegratorType integrator :
       {IntegratorType::kExplicitEuler, IntegratorType::kSemiImplicitEuler, IntegratorType::kRk4}) {
    LinearProblem p = MakeLinearProblem(integrator, 30);
    p.config.options.max_iterations = 1;
    const DdpModel model(p.dynamics, p.config);
    DdpData data(model);
    data.q_ref.colwise() = V({0.5, -0.3});  // an offset target: the gains do not depend on it
    SolveDdp(model, data, V({0.0, 0.1}), V({0.2, 0.0}));
    ASSERT_EQ(data.result().iterations, 1);

    // The backward Riccati recursion: S_N = Q_N, K_k = (R + BᵀSB)⁻¹ BᵀSA, S ← Q + AᵀSA − AᵀSB K_k.
    MatrixXd A, B;
    StepMatrices(p, A, B);
    const DdpWeights& w = p.config.weights;
    MatrixXd Q = MatrixXd::Zero(4, 4), S = MatrixXd::Zero(4, 4);
    Q.diagonal() << w.q, w.qd;
    S.diagonal() << w.q_terminal, w.qd_terminal;
    const Eigen::Matrix2d R = w.tau.asDiagonal();
    for (int k = p.config.horizon - 1; k >= 0; --k) {
      const Eigen::Matrix2d H = R + B.transpose() * S * B;
      const MatrixXd K = H.inverse() * (B.transpose() * S * A);
      EXPECT_LE((data.K(k) + K).norm(), kGainTolerance * K.norm()) << ToString(integrator) << " knot " << k;
      const MatrixXd next = Q + A.transpose() * S * A - A.transpose() * S * B * K;
      S = next;
    }
  }
}

TEST(Ddp, FirstGainOfALongHorizonIsTheDiscreteLqrGain) {
  LinearProblem p = MakeLinearProblem(IntegratorType::kRk4, 600);
  p.config.options.max_iterations = 1;
  const DdpModel model(p.dynamics, p.config);
  DdpData data(model);
  SolveDdp(model, data, V({0.1, 0.0}), V({0.0, 0.0}));
  MatrixXd A, B;
  StepMatrices(p, A, B);
  const DdpWeights& w = p.config.weights;
  MatrixXd Q = MatrixXd::Zero(4, 4);
  Q.diagonal() << w.q, w.qd;
  const MatrixXd R = w.tau.asDiagonal();
  const LqrResult lqr = DiscreteLinearQuadraticRegulator(A, B, Q, R);
  EXPECT_LE((data.K(0) + lqr.K).norm(), kGainTolerance * lqr.K.norm());
}

// The cart-pole from hanging down, asked to stand the pole up at x = 0 over 2 s.
DdpConfig CartPoleSwingUp(double force_limit) {
  DdpConfig c;
  c.dt = 0.02;
  c.horizon = 100;
  c.actuated = {0};
  c.tau_lower = V({-force_limit});
  c.tau_upper = V({force_limit});
  c.weights = Weights(V({1.0, 1.0}), V({0.01, 0.01}), V({0.01}), V({100.0, 300.0}), V({10.0, 10.0}));
  return c;
}

TEST(Ddp, CostNeverIncreasesFromOneIterationToTheNext) {
  const DdpConfig config = CartPoleSwingUp(10.0);
  const DdpModel model(Plant(CartPoleParams{}), config);
  DdpData data(model);
  data.q_ref.row(1).setConstant(kPi);
  const DdpResult& r = SolveDdp(model, data, V({0.0, 0.0}), V({0.0, 0.0}));
  ASSERT_GE(r.iterations, 5) << ToString(r.status);
  for (int i = 0; i < r.iterations; ++i) EXPECT_LE(r.cost_history[i + 1], r.cost_history[i]) << i;
  EXPECT_LT(r.cost, 0.2 * r.cost_history[0]);
  // The plan swings the pole up.
  EXPECT_LT(std::abs(data.x()(1, config.horizon) - kPi), 0.1);
}

TEST(Ddp, LimitsHoldAndTheSolutionSatisfiesKkt) {
  // A pendulum that cannot lift itself directly (3 N·m against m g L = 9.81 N·m) must pump.
  constexpr double kLimit = 3.0;
  DdpConfig config;
  config.dt = 0.02;
  config.horizon = 200;
  config.tau_lower = V({-kLimit});
  config.tau_upper = V({kLimit});
  config.weights = Weights(V({0.1}), V({0.01}), V({0.01}), V({100.0}), V({10.0}));
  config.options.tolerance = 1e-12;
  config.options.max_iterations = 200;
  const DdpModel model(Plant(PendulumParams{}), config);
  DdpData data(model);
  data.q_ref.setConstant(kPi);
  {
    // Iteration by iteration (each solve of one iteration resumes from the last policy): never outside.
    DdpConfig one = config;
    one.options.max_iterations = 1;
    const DdpModel stepwise(Plant(PendulumParams{}), one);
    DdpData d(stepwise);
    d.q_ref.setConstant(kPi);
    for (int it = 0; it < 20; ++it) {
      SolveDdp(stepwise, d, V({0.0}), V({0.0}));
      ASSERT_LE(d.u().cwiseAbs().maxCoeff(), kLimit) << "iteration " << it;
    }
  }
  const DdpResult& r = SolveDdp(model, data, V({0.0}), V({0.0}));
  ASSERT_EQ(r.status, DdpStatus::kConverged) << ToString(r.status);
  EXPECT_LT(std::abs(data.x()(0, config.horizon) - kPi), 0.2);

  constexpr double kBound = 1e-12;  // on a bound: within round-off of it
  const double gradient_tolerance = 1e-5 * (1.0 + data.Qu().cwiseAbs().maxCoeff());
  int active = 0;
  VectorXd u(1);
  for (int k = 0; k < config.horizon; ++k) {
    const double uk = data.u()(0, k), g = data.Qu()(0, k);
    ASSERT_GE(uk, -kLimit) << k;
    ASSERT_LE(uk, kLimit) << k;
    if (uk >= kLimit - kBound) {
      EXPECT_LE(g, gradient_tolerance) << "knot " << k << " at the upper bound";
      ++active;
    } else if (uk <= -kLimit + kBound) {
      EXPECT_GE(g, -gradient_tolerance) << "knot " << k << " at the lower bound";
      ++active;
    } else {
      EXPECT_LE(std::abs(g), gradient_tolerance) << "knot " << k << " free";
    }
    // The policy around the plan stays within the limits too, far from it.
    data.EvaluatePolicy(k, V({data.x()(0, k) + 0.5}), V({data.x()(1, k) - 2.0}), u);
    EXPECT_LE(std::abs(u[0]), kLimit) << k;
  }
  EXPECT_GE(active, 10) << "the limits were meant to bind";
}

TEST(Ddp, WarmStartReachesTheSameCostInFewerIterations) {
  // The arm reaching a pose against gravity, then re-planned 5 knots later.
  DdpConfig config;
  config.dt = 0.02;
  config.horizon = 60;
  config.weights = Weights(V({1.0, 1.0}), V({0.05, 0.05}), V({1e-3, 1e-3}), V({100.0, 100.0}), V({10.0, 10.0}));
  config.options.tolerance = 1e-10;
  const DdpModel model(Plant(Arm2Params{}), config);
  const VectorXd target = V({0.3, 1.2});
  DdpData first(model), warm(model), cold(model);
  for (DdpData* d : {&first, &warm, &cold}) d->q_ref.colwise() = target;
  ASSERT_EQ(SolveDdp(model, first, V({-kPi / 2, 0.0}), V({0.0, 0.0})).status, DdpStatus::kConverged);

  constexpr int kShift = 5;
  const VectorXd q5 = first.x().col(kShift).head(2) + V({0.01, -0.01}), qd5 = first.x().col(kShift).tail(2);
  SolveDdp(model, warm, V({-kPi / 2, 0.0}), V({0.0, 0.0}));
  warm.ShiftSolution(kShift);
  const DdpResult& w = SolveDdp(model, warm, q5, qd5);
  const DdpResult& c = SolveDdp(model, cold, q5, qd5);
  ASSERT_EQ(w.status, DdpStatus::kConverged);
  ASSERT_EQ(c.status, DdpStatus::kConverged);
  EXPECT_NEAR(w.cost, c.cost, 1e-6 * c.cost);
  EXPECT_LT(w.iterations, c.iterations);
}

TEST(Ddp, SecondSolveAllocatesNothing) {
  const DdpConfig config = CartPoleSwingUp(5.0);
  const DdpModel model(Plant(CartPoleParams{}), config);
  DdpData data(model);
  data.q_ref.row(1).setConstant(kPi);
  SolveDdp(model, data, V({0.0, 0.0}), V({0.0, 0.0}));
  const VectorXd q = V({0.01, 0.05}), qd = V({0.0, 0.1});
  VectorXd u(1);
  testing::AllocationCounter counter;
  data.ShiftSolution(3);
  SolveDdp(model, data, q, qd);
  data.ShiftSolution(1.5);
  data.EvaluatePolicy(0, q, qd, u);
  data.Reset();
  SolveDdp(model, data, q, qd);
  EXPECT_EQ(counter.count(), 0);
}

// Model-predictive control of the cart-pole, offline: every two knots (40 ms
// of simulated time) the plan is shifted by two knots and re-solved (2
// iterations) from the simulated state; between solves the plant (RK4, 1 ms)
// runs under the plan's affine policy of the knot the time falls in,
// evaluated every millisecond. The optimiser's model steps by semi-implicit
// Euler, the plant by RK4.
TEST(Ddp, RecedingHorizonSwingsTheCartPoleUpAndKeepsTheCartOnItsRail) {
  constexpr double kRail = 0.5, kUpright = 0.05, kTick = 0.001, kDuration = 5.0;
  DdpConfig config = CartPoleSwingUp(10.0);
  config.integrator = IntegratorType::kSemiImplicitEuler;
  config.weights = Weights(V({30.0, 0.3}), V({0.01, 0.01}), V({0.01}), V({300.0, 300.0}), V({1.0, 1.0}));
  config.options.max_iterations = 2;
  const DdpModel model(Plant(CartPoleParams{}), config);
  constexpr int kKnotsPerSolve = 2;
  const int ticks_per_knot = static_cast<int>(std::lround(config.dt / kTick));
  std::mt19937 rng{42};
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  for (int run = 0; run < 3; ++run) {
    VectorXd q = V({0.1 * unit(rng), 0.2 * unit(rng)}), qd = V({0.1 * unit(rng), 0.2 * unit(rng)});
    DdpData plan(model);
    plan.q_ref.row(1).setConstant(kPi);
    PlantModel plant(model.dynamics(), EffectsConfig{});
    const std::unique_ptr<Integrator> rk4 = MakeIntegrator(IntegratorConfig{}, 2);
    VectorXd u(1), tau = VectorXd::Zero(2);
    double worst_x = 0.0;
    for (int tick = 0; tick < static_cast<int>(std::lround(kDuration / kTick)); ++tick) {
      const int since_solve = tick % (kKnotsPerSolve * ticks_per_knot);
      if (since_solve == 0) {
        if (tick > 0) plan.ShiftSolution(kKnotsPerSolve);
        SolveDdp(model, plan, q, qd);
      }
      plan.EvaluatePolicy(since_solve / ticks_per_knot, q, qd, u);
      tau[0] = u[0];
      rk4->Advance(plant, tick * kTick, kTick, tau, q, qd);
      worst_x = std::max(worst_x, std::abs(q[0]));
    }
    EXPECT_LT(std::abs(std::remainder(q[1] - kPi, 2.0 * kPi)), kUpright) << "run " << run;
    EXPECT_LE(worst_x, kRail) << "run " << run;
  }
}

// A plan that starts between knots: the whole knots shifted as by the integer
// shift, then every knot moved the fraction of the way to the next.
TEST(Ddp, AFractionalShiftInterpolatesBetweenTheWholeKnotShifts) {
  const DdpConfig config = CartPoleSwingUp(10.0);
  const DdpModel model(Plant(CartPoleParams{}), config);
  const auto solved = [&] {  // the same solve each time (deterministic)
    DdpData d(model);
    d.q_ref.row(1).setConstant(kPi);
    SolveDdp(model, d, V({0.0, 0.0}), V({0.0, 0.0}));
    return d;
  };
  DdpData two = solved(), three = solved(), between = solved();
  two.ShiftSolution(2);
  three.ShiftSolution(3);
  between.ShiftSolution(2.25);
  constexpr double kTolerance = 1e-12;
  for (const int k : {0, 10, 50, config.horizon - 2}) {
    EXPECT_NEAR(between.u()(0, k), 0.75 * two.u()(0, k) + 0.25 * three.u()(0, k), kTolerance) << k;
    EXPECT_NEAR(between.x()(1, k), 0.75 * two.x()(1, k) + 0.25 * three.x()(1, k), kTolerance) << k;
    EXPECT_NEAR(between.K(k)(0, 1), 0.75 * two.K(k)(0, 1) + 0.25 * three.K(k)(0, 1), kTolerance) << k;
  }
  DdpData whole = solved();
  whole.ShiftSolution(2.0);
  EXPECT_TRUE(whole.u() == two.u() && whole.x() == two.x()) << "a whole number of knots is the integer shift";
}

// A thread that plans is stopped within one iteration: the flag is polled
// between iterations, and a set flag ends the solve with the nominal it has.
TEST(Ddp, AStopFlagEndsTheSolveBetweenIterations) {
  DdpConfig config = CartPoleSwingUp(10.0);
  config.options.max_iterations = 50;
  const DdpModel model(Plant(CartPoleParams{}), config);
  DdpData data(model);
  data.q_ref.row(1).setConstant(kPi);
  std::atomic<bool> stop{true};
  data.stop = &stop;
  const DdpResult& stopped = SolveDdp(model, data, V({0.0, 0.0}), V({0.0, 0.0}));
  EXPECT_EQ(stopped.status, DdpStatus::kStopped);
  EXPECT_EQ(stopped.iterations, 0);
  EXPECT_EQ(stopped.cost, stopped.cost_history[0]) << "the first rollout's nominal";
  stop = false;
  const DdpResult& resumed = SolveDdp(model, data, V({0.0, 0.0}), V({0.0, 0.0}));
  EXPECT_GE(resumed.iterations, 1);
  EXPECT_NE(resumed.status, DdpStatus::kStopped);
}

TEST(Ddp, RefusesAProblemItCannotSolveNamingTheField) {
  DdpConfig config = CartPoleSwingUp(5.0);
  const auto refusal = [&](const DdpConfig& c) {
    try {
      DdpModel(Plant(CartPoleParams{}), c);
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  DdpConfig bad = config;
  bad.integrator = IntegratorType::kDormandPrince;
  EXPECT_NE(refusal(bad).find("integrator"), std::string::npos);
  bad = config;
  bad.weights.tau = V({0.0});
  EXPECT_NE(refusal(bad).find("weights.tau"), std::string::npos);
  bad = config;
  bad.tau_lower = V({6.0});  // above tau_upper
  EXPECT_NE(refusal(bad).find("tau_lower"), std::string::npos);
  bad = config;
  bad.actuated = {2};
  EXPECT_NE(refusal(bad).find("actuated"), std::string::npos);
  EXPECT_EQ(refusal(config), "accepted");
}

}  // namespace
}  // namespace lagrange
