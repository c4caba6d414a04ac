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
#include "controllers/mpc.hpp"
#include "plant/plant_factory.hpp"
#include "plant/urdf.hpp"
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

// The tick's law between knots (MpcPolicy::Evaluate): the planned state and
// force followed linearly from knot k to knot k + 1 by the time within the
// knot, the knot's gain held; at the horizon's end the plan's last state, the
// last knot's force held. Here one joint, two knots of 0.1 s from t = 1 s.
TEST(MpcPolicy, BetweenKnotsFollowsThePlannedStateAndForceLinearlyWithTheKnotsGainHeld) {
  MpcPolicy policy(1, 1, 2);
  policy.sequence = 1;
  policy.start = 1.0;
  policy.dt = 0.1;
  policy.u << 2.0, 4.0;                      // ū_0, ū_1 (N·m)
  policy.K << -10.0, -1.0, -20.0, -2.0;      // K_0 = [−10, −1], K_1 = [−20, −2]
  policy.x << 0.0, 0.5, 0.8, 1.0, 3.0, 3.0;  // q̄_0..2 (rad) in the first row, q̄d_0..2 (rad/s) in the second
  const VectorXd lower = V({-100.0}), upper = V({100.0});
  const VectorXd q = V({0.3}), qd = V({2.0});
  const auto law = [&](double t) {
    VectorXd u(1);
    policy.Evaluate(t, q, qd, lower, upper, u);
    return u[0];
  };
  // ū + K (x − x̄) for a knot's (ū, K) about the planned state (q̄, q̄d).
  const auto affine = [&](double u_bar, double k_q, double k_qd, double q_bar, double qd_bar) {
    return u_bar + k_q * (q[0] - q_bar) + k_qd * (qd[0] - qd_bar);
  };
  constexpr double kTolerance = 1e-12, kJustBefore = 1e-9;  // N·m; s before knot 1
  EXPECT_NEAR(law(1.0), affine(2.0, -10.0, -1.0, 0.0, 1.0), kTolerance) << "knot 0's start: knot 0";
  EXPECT_NEAR(law(1.05), affine(3.0, -10.0, -1.0, 0.25, 2.0), kTolerance) << "its middle: halfway, K_0";
  EXPECT_NEAR(law(1.1 - kJustBefore), affine(4.0, -10.0, -1.0, 0.5, 3.0), 1e-6) << "its end: knot 1's ū, x̄; K_0";
  EXPECT_NEAR(law(1.1), affine(4.0, -20.0, -2.0, 0.5, 3.0), kTolerance) << "knot 1's start: knot 1";
  EXPECT_NEAR(law(1.15), affine(4.0, -20.0, -2.0, 0.65, 3.0), kTolerance) << "the last knot: its ū held";
  EXPECT_NEAR(law(1.5), affine(4.0, -20.0, -2.0, 0.8, 3.0), kTolerance) << "past the horizon: x̄_N";
  EXPECT_NEAR(law(0.9), affine(2.0, -10.0, -1.0, 0.0, 1.0), kTolerance) << "before the start: knot 0's";
}

// A flag already set ends the solve at once, in its first rollout's first
// knot, with no nominal of its own; cleared, the next solve runs.
TEST(Ddp, AStopFlagSetBeforeTheSolveEndsItAtOnce) {
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
  EXPECT_TRUE(std::isnan(stopped.cost)) << "no rollout finished";
  stop = false;
  const DdpResult& resumed = SolveDdp(model, data, V({0.0, 0.0}), V({0.0, 0.0}));
  EXPECT_GE(resumed.iterations, 1);
  EXPECT_NE(resumed.status, DdpStatus::kStopped);
}

// A plant that counts its forward-dynamics evaluations (what the line
// search's rollouts step by), or with `derivatives` those of their
// derivatives (what the first rollout and the linearisation step by), and
// sets a stop flag at the `at`-th, in the middle of a pass.
class StopAtForwardDynamics final : public Dynamics {
 public:
  StopAtForwardDynamics(std::shared_ptr<const Dynamics> inner, std::atomic<bool>& stop, long at,
                        bool derivatives = false)
      : Dynamics(inner->joint_types()), inner_(std::move(inner)), stop_(stop), at_(at), derivatives_(derivatives) {}
  long calls() const { return calls_; }

  Method method() const override { return inner_->method(); }
  std::unique_ptr<DynamicsData> MakeData() const override { return inner_->MakeData(); }
  void ComputeMassMatrix(DynamicsData& d, ConstVecRef q, MatRef M) const override {
    inner_->ComputeMassMatrix(d, q, M);
  }
  void ComputeCoriolisMatrix(DynamicsData& d, ConstVecRef q, ConstVecRef qd, MatRef C) const override {
    inner_->ComputeCoriolisMatrix(d, q, qd, C);
  }
  void ComputeCoriolisForce(DynamicsData& d, ConstVecRef q, ConstVecRef qd, VecRef c) const override {
    inner_->ComputeCoriolisForce(d, q, qd, c);
  }
  void ComputeGravityForce(DynamicsData& d, ConstVecRef q, VecRef G) const override {
    inner_->ComputeGravityForce(d, q, G);
  }
  void ComputeKineticEnergyGradient(DynamicsData& d, ConstVecRef q, ConstVecRef qd, VecRef g) const override {
    inner_->ComputeKineticEnergyGradient(d, q, qd, g);
  }
  double ComputeKineticEnergy(DynamicsData& d, ConstVecRef q, ConstVecRef qd) const override {
    return inner_->ComputeKineticEnergy(d, q, qd);
  }
  double ComputePotentialEnergy(DynamicsData& d, ConstVecRef q) const override {
    return inner_->ComputePotentialEnergy(d, q);
  }
  void ComputeInverseDynamics(DynamicsData& d, ConstVecRef q, ConstVecRef qd, ConstVecRef qdd, DynamicsTerms terms,
                              VecRef tau) const override {
    inner_->ComputeInverseDynamics(d, q, qd, qdd, terms, tau);
  }
  void ComputeForwardDynamics(DynamicsData& d, ConstVecRef q, ConstVecRef qd, ConstVecRef tau, DynamicsTerms terms,
                              VecRef qdd) const override {
    if (!derivatives_ && ++calls_ == at_) stop_ = true;
    inner_->ComputeForwardDynamics(d, q, qd, tau, terms, qdd);
  }
  void ComputeInverseDynamicsDerivatives(DynamicsData& d, ConstVecRef q, ConstVecRef qd, ConstVecRef qdd,
                                         DynamicsTerms terms, MatRef a, MatRef b, MatRef c) const override {
    inner_->ComputeInverseDynamicsDerivatives(d, q, qd, qdd, terms, a, b, c);
  }
  void ComputeForwardDynamicsDerivatives(DynamicsData& d, ConstVecRef q, ConstVecRef qd, ConstVecRef tau,
                                         DynamicsTerms terms, VecRef qdd, MatRef a, MatRef b,
                                         MatRef c) const override {
    if (derivatives_ && ++calls_ == at_) stop_ = true;
    inner_->ComputeForwardDynamicsDerivatives(d, q, qd, tau, terms, qdd, a, b, c);
  }
  void ComputeGravityDerivatives(DynamicsData& d, ConstVecRef q, MatRef dG_dq) const override {
    inner_->ComputeGravityDerivatives(d, q, dG_dq);
  }

 private:
  std::shared_ptr<const Dynamics> inner_;
  std::atomic<bool>& stop_;
  long at_;
  bool derivatives_;
  mutable long calls_ = 0;  // one solve on one thread
};

// Evaluations per knot (forward dynamics, or with `derivatives` their
// derivatives) in one unstopped solve of `config` from rest toward the pole
// upright; 0 when they are not a whole number per knot.
long EvaluationsPerKnot(const DdpConfig& config, bool derivatives) {
  std::atomic<bool> never{false};
  const auto counting =
      std::make_shared<const StopAtForwardDynamics>(Plant(CartPoleParams{}), never, -1, derivatives);
  const DdpModel model(counting, config);
  DdpData data(model);
  data.q_ref.row(1).setConstant(kPi);
  SolveDdp(model, data, V({0.0, 0.0}), V({0.0, 0.0}));
  return counting->calls() % config.horizon == 0 ? counting->calls() / config.horizon : 0;
}

// The stop is polled at every knot of every pass: set in the
// middle of the first line search's rollout, the solve ends within that knot's
// step (not after the rollout, the line search and the iteration), with the
// first rollout's nominal, and no iteration counted.
TEST(Ddp, AStopSetInTheMiddleOfARolloutEndsTheSolveWithinThatKnot) {
  const DdpConfig config = CartPoleSwingUp(10.0);
  // Forward-dynamics evaluations in one rollout: one line-search step of one iteration, unstopped.
  DdpConfig one = config;
  one.options.max_iterations = 1;
  one.options.line_search_steps = 1;
  const long per_knot = EvaluationsPerKnot(one, false);
  ASSERT_GT(per_knot, 0) << "the line search's rollout steps by forward dynamics, the same per knot";

  std::atomic<bool> stop{false};
  const long at = per_knot * (config.horizon / 2) + 1;  // the first evaluation of the middle knot
  const auto stopping = std::make_shared<const StopAtForwardDynamics>(Plant(CartPoleParams{}), stop, at);
  DdpConfig many = config;
  many.options.max_iterations = 50;
  const DdpModel model(stopping, many);
  DdpData data(model);
  data.q_ref.row(1).setConstant(kPi);
  data.stop = &stop;
  const DdpResult& r = SolveDdp(model, data, V({0.0, 0.0}), V({0.0, 0.0}));
  EXPECT_EQ(r.status, DdpStatus::kStopped);
  EXPECT_EQ(r.iterations, 0) << "the iteration in progress is not finished";
  EXPECT_EQ(r.cost, r.cost_history[0]) << "the first rollout's nominal";
  EXPECT_LE(stopping->calls() - at, per_knot - 1) << "no evaluation past the knot the stop was set in";
}

// The first rollout too: set in its middle knot, the solve ends within that
// knot's step, with no nominal of its own (cost NaN, no iteration) and the
// warm start it was given left as it was.
TEST(Ddp, AStopSetInTheMiddleOfTheFirstRolloutEndsTheSolveWithinThatKnot) {
  DdpConfig config = CartPoleSwingUp(10.0);
  config.options.max_iterations = 1;  // derivative evaluations: the first rollout's alone
  const long per_knot = EvaluationsPerKnot(config, true);
  ASSERT_GT(per_knot, 0) << "the first rollout steps by the forward dynamics' derivatives, the same per knot";

  std::atomic<bool> stop{false};
  const long at = per_knot * (config.horizon / 2) + 1;  // the first evaluation of the middle knot
  const auto stopping = std::make_shared<const StopAtForwardDynamics>(Plant(CartPoleParams{}), stop, at, true);
  config.options.max_iterations = 50;
  const DdpModel model(stopping, config);
  DdpData data(model);
  data.q_ref.row(1).setConstant(kPi);
  data.HoldControls(V({0.5}));
  const MatrixXd warm_u = data.u();
  data.stop = &stop;
  const DdpResult& r = SolveDdp(model, data, V({0.0, 0.0}), V({0.0, 0.0}));
  EXPECT_EQ(r.status, DdpStatus::kStopped);
  EXPECT_EQ(r.iterations, 0);
  EXPECT_TRUE(std::isnan(r.cost)) << "no nominal of this solve";
  EXPECT_TRUE(data.u() == warm_u) << "the warm start is left as it was";
  EXPECT_LE(stopping->calls() - at, per_knot - 1) << "no evaluation past the knot the stop was set in";
}

// The Panda (config/robots/panda.urdf) and its flange's frame, for the frame pose-error cost.
struct DdpPanda {
  PlantSpec spec = UrdfPlantSpec(
      std::make_shared<const UrdfRobot>(LoadUrdf(std::string(LAGRANGE_SOURCE_DIR) + "/config/robots/panda.urdf")));
  std::shared_ptr<const Kinematics> kinematics = std::make_shared<const Kinematics>(MakeRigidTree(spec));
  int frame = *kinematics->FrameIndex("panda_link8");
  VectorXd ready = V({0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785});  // Franka's ready pose

  Pose PoseAt(const VectorXd& q) const {
    const std::unique_ptr<KinematicsData> d = kinematics->MakeData();
    kinematics->ComputeFramePlacement(*d, q, frame);
    return {d->position(frame), Eigen::Quaterniond(d->rotation(frame))};
  }
};

// ½ w_pos |p_d − p|² + ½ w_rot |log(R_d Rᵀ)|²: its gradient −Jᵀ W e is the
// exact one (central differences, away from the target, where the rotation
// error is large and the log map far from linear), and at the target (e = 0)
// its Gauss–Newton Hessian Jᵀ W J is the exact Hessian.
TEST(Ddp, FramePoseCostGradientIsExactAndItsGaussNewtonHessianIsExactAtTheTarget) {
  const DdpPanda panda;
  const std::unique_ptr<KinematicsData> data = panda.kinematics->MakeData();
  constexpr double kWPos = 3.0, kWRot = 0.7, kStep = 1e-6, kGradientTolerance = 1e-6, kHessianTolerance = 1e-4;
  std::mt19937 rng{42};
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  const auto random_q = [&] {
    VectorXd q = panda.ready;
    for (int i = 0; i < 7; ++i) q[i] += 0.4 * unit(rng);
    return q;
  };
  VectorXd none(0);
  MatrixXd no_hessian(0, 0);
  const auto cost = [&](const VectorXd& q, const Pose& target) {
    return FramePoseCost(*panda.kinematics, *data, panda.frame, target, kWPos, kWRot, q, false, none, no_hessian);
  };
  for (int trial = 0; trial < 5; ++trial) {
    const VectorXd q = random_q();
    const Pose target = panda.PoseAt(random_q());
    VectorXd gradient = VectorXd::Zero(7);
    MatrixXd hessian = MatrixXd::Zero(7, 7);
    const double at_q = FramePoseCost(*panda.kinematics, *data, panda.frame, target, kWPos, kWRot, q, true, gradient, hessian);
    EXPECT_NEAR(at_q, cost(q, target), 1e-14 * (1.0 + at_q));
    EXPECT_GT(at_q, 1e-3) << "away from the target";
    for (int i = 0; i < 7; ++i) {
      VectorXd plus = q, minus = q;
      plus[i] += kStep;
      minus[i] -= kStep;
      const double fd = (cost(plus, target) - cost(minus, target)) / (2.0 * kStep);
      EXPECT_NEAR(gradient[i], fd, kGradientTolerance * (1.0 + gradient.norm())) << "trial " << trial << ", joint " << i;
    }
  }
  // At the target the residual is zero, so the Hessian is Jᵀ W J exactly: second differences of the cost.
  const VectorXd q = random_q();
  const Pose target = panda.PoseAt(q);
  VectorXd gradient = VectorXd::Zero(7);
  MatrixXd hessian = MatrixXd::Zero(7, 7);
  FramePoseCost(*panda.kinematics, *data, panda.frame, target, kWPos, kWRot, q, true, gradient, hessian);
  EXPECT_LT(gradient.norm(), 1e-12);
  constexpr double kH = 1e-4;
  for (int i = 0; i < 7; ++i) {
    for (int j = 0; j < 7; ++j) {
      const auto at = [&](double di, double dj) {
        VectorXd x = q;
        x[i] += di;
        x[j] += dj;
        return cost(x, target);
      };
      const double fd = (at(kH, kH) - at(kH, -kH) - at(-kH, kH) + at(-kH, -kH)) / (4.0 * kH * kH);
      EXPECT_NEAR(hessian(i, j), fd, kHessianTolerance * (1.0 + hessian.norm())) << i << ", " << j;
    }
  }
}

// The plan of a frame's pose error: from Franka's ready pose at rest (gravity
// held, the cold start), under gravity and its effort limits, the flange
// reaches a pose 12 cm away, turned by a few degrees (the pose of a reachable
// q), at rest by the horizon's end; the cost never increases from one
// iteration to the next.
TEST(Ddp, FramePoseCostPlanBringsTheFrameToAReachableTarget) {
  const DdpPanda panda;
  VectorXd q_target = panda.ready;
  q_target[0] += 0.3;
  q_target[1] += 0.2;
  q_target[3] += 0.25;
  q_target[5] -= 0.1;
  const Pose target = panda.PoseAt(q_target);
  const Pose start = panda.PoseAt(panda.ready);
  ASSERT_GT((target.position - start.position).norm(), 0.1);
  DdpConfig config;
  config.integrator = IntegratorType::kSemiImplicitEuler;
  config.dt = 0.02;
  config.horizon = 50;
  config.tau_upper = V({87, 87, 87, 87, 12, 12, 12});
  config.tau_lower = -config.tau_upper;
  config.weights = Weights(VectorXd::Zero(7), VectorXd::Constant(7, 0.01), VectorXd::Constant(7, 1e-4),
                           VectorXd::Zero(7), VectorXd::Constant(7, 10.0));
  config.frame_cost = {panda.kinematics, panda.frame, 10.0, 1.0, 1e4, 1e3};
  config.options.max_iterations = 60;
  const DdpModel model(MakeDynamics(panda.spec, FastestMethod(panda.spec.type())), config);
  DdpData data(model);
  for (Pose& p : data.pose_ref) p = target;
  VectorXd gravity(7);
  model.dynamics()->ComputeGravityForce(*model.dynamics()->MakeData(), panda.ready, gravity);
  data.HoldControls(gravity);  // the cold start of a robot that holds its pose
  const DdpResult& r = SolveDdp(model, data, panda.ready, VectorXd::Zero(7));
  ASSERT_TRUE(r.status == DdpStatus::kConverged || r.status == DdpStatus::kMaxIterations) << ToString(r.status);
  for (int i = 1; i <= r.iterations; ++i) EXPECT_LE(r.cost_history[i], r.cost_history[i - 1]) << "iteration " << i;
  EXPECT_LT(r.cost, 0.05 * r.cost_history[0]) << ToString(r.status) << " after " << r.iterations;
  const Vector6d e = PoseError(target, panda.PoseAt(data.x().col(config.horizon).head(7)));
  constexpr double kPositionTolerance = 0.005, kRotationTolerance = 0.02;  // m, rad
  EXPECT_LT(e.head<3>().norm(), kPositionTolerance);
  EXPECT_LT(e.tail<3>().norm(), kRotationTolerance);
  EXPECT_LT(data.x().col(config.horizon).tail(7).norm(), 0.1) << "at rest at the end (rad/s)";
  testing::AllocationCounter counter;  // the frame term's kinematics run in the data's buffers
  data.ShiftSolution(1);
  SolveDdp(model, data, data.x().col(1).head(7), data.x().col(1).tail(7));
  EXPECT_EQ(counter.count(), 0);
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
