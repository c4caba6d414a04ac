// Integrators against physics: the pendulum's exact period, the article's
// gravity-compensated hold, energy behaviour over 10⁵ steps, convergence
// orders, discrete momentum conservation, adaptive step statistics.

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <numbers>
#include <set>
#include <stdexcept>
#include <string>
#include <utility>

#include "plant/integrators.hpp"
#include "plant/plant_factory.hpp"
#include "tests/support/plant_cases.hpp"

namespace lagrange {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kTick = 1e-3;  // s

std::unique_ptr<PlantModel> MakeModel(const PlantSpec& spec, Method method, EffectsConfig effects = {}) {
  return std::make_unique<PlantModel>(MakeDynamics(spec, method), std::move(effects));
}

std::unique_ptr<Integrator> MakeIntegratorOfType(IntegratorType type, int n, double rtol = 1e-8) {
  IntegratorConfig c;
  c.type = type;
  c.rtol = rtol;
  c.atol = rtol * 1e-2;
  return MakeIntegrator(c, n);
}

// Period of a pendulum released at rest from theta0: twice the time between
// the first and third crossings of θ = 0, located by cubic Hermite
// interpolation between steps.
double MeasurePeriod(const PendulumParams& p, double theta0, double h) {
  auto model = MakeModel({p}, Method::kClosedForm);
  auto rk4 = MakeIntegratorOfType(IntegratorType::kRk4, 1);
  VectorXd q(1), qd(1), tau = VectorXd::Zero(1), qdd(1);
  q << theta0;
  qd << 0.0;
  std::vector<double> crossings;
  double t = 0.0;
  while (crossings.size() < 3) {
    const double q0 = q[0], v0 = qd[0];
    rk4->Step(*model, t, h, tau, q, qd);
    if ((q0 > 0.0) != (q[0] > 0.0)) {
      // Newton on the Hermite cubic through (q0, v0) and (q1, v1) over [t, t + h].
      const double q1 = q[0], v1 = qd[0];
      double s = q0 / (q0 - q1);
      for (int it = 0; it < 20; ++it) {
        const double h00 = 2 * s * s * s - 3 * s * s + 1, h10 = s * s * s - 2 * s * s + s;
        const double h01 = -2 * s * s * s + 3 * s * s, h11 = s * s * s - s * s;
        const double f = h00 * q0 + h10 * h * v0 + h01 * q1 + h11 * h * v1;
        const double df = (6 * s * s - 6 * s) * q0 + (3 * s * s - 4 * s + 1) * h * v0 + (-6 * s * s + 6 * s) * q1 +
                          (3 * s * s - 2 * s) * h * v1;
        s -= f / df;
      }
      crossings.push_back(t + s * h);
    }
    t += h;
  }
  return crossings[2] - crossings[0];
}

TEST(PendulumPeriod, SmallSwingsFollowTwoPiRootLOverG) {
  PendulumParams p;  // point mass, L = 1
  const double expected = 2.0 * kPi * std::sqrt(p.L / p.g);
  EXPECT_NEAR(MeasurePeriod(p, 1e-3, 1e-4), expected, 1e-6 * expected);
}

TEST(PendulumPeriod, LargeSwingsFollowTheCompleteEllipticIntegral) {
  for (PendulumBody body : {PendulumBody::kPointMass, PendulumBody::kRod}) {
    PendulumParams p;
    p.body = body;
    p.L = 0.8;
    // Equivalent simple-pendulum length: I_pivot / (m l_c).
    const double length = p.pivot_inertia() / (p.m * p.com());
    for (double degrees : {10.0, 45.0, 90.0, 135.0, 170.0, 179.0}) {
      const double theta0 = degrees * kPi / 180.0;
      const double expected = 4.0 * std::sqrt(length / p.g) * std::comp_ellint_1(std::sin(theta0 / 2.0));
      EXPECT_NEAR(MeasurePeriod(p, theta0, 1e-4), expected, 1e-6 * expected) << degrees << " degrees";
    }
  }
}

// The article's scenario: the arm at q0 = (π/4, 0), at rest, torques equal to
// the model's own G(q), 3 s at 1 ms: it stays at q0.
TEST(GravityCompensation, ArmHoldsThePoseOfTheArticle) {
  for (Method method : {Method::kClosedForm, Method::kLagrangian, Method::kRecursive}) {
    for (IntegratorType type : {IntegratorType::kSemiImplicitEuler, IntegratorType::kRk4,
                                IntegratorType::kDormandPrince, IntegratorType::kVariational}) {
      auto model = MakeModel(DefaultPlantSpec(PlantType::kArm2), method);
      auto integrator = MakeIntegratorOfType(type, 2);
      VectorXd q0(2), q(2), qd = VectorXd::Zero(2), tau(2);
      q0 << kPi / 4, 0.0;
      q = q0;
      for (int k = 0; k < 3000; ++k) {
        model->dynamics().ComputeGravityForce(model->data(), q, tau);
        integrator->Step(*model, k * kTick, kTick, tau, q, qd);
      }
      EXPECT_LE((q - q0).lpNorm<Eigen::Infinity>(), 1e-9) << ToString(method) << " " << ToString(type);
    }
  }
}

// Maximum |E − E0| over each tenth of a run of `steps` ticks, no torque, no damping.
std::vector<double> EnergyErrorByDecile(const PlantSpec& spec, IntegratorType type, const VectorXd& q0, int steps) {
  auto model = MakeModel(spec, FastestMethod(spec.type()));
  auto integrator = MakeIntegratorOfType(type, spec.num_dofs());
  VectorXd q = q0, qd = VectorXd::Zero(q0.size()), tau = VectorXd::Zero(q0.size());
  const double e0 = model->Energy(q, qd);
  std::vector<double> worst(10, 0.0);
  for (int k = 0; k < steps; ++k) {
    integrator->Step(*model, k * kTick, kTick, tau, q, qd);
    const double err = std::abs(model->Energy(q, qd) - e0);
    double& w = worst[static_cast<std::size_t>(k * 10 / steps)];
    w = std::isfinite(err) ? std::max(w, err) : std::numeric_limits<double>::infinity();
  }
  return worst;
}

double Max(const std::vector<double>& v) { return *std::max_element(v.begin(), v.end()); }

class ArmEnergy : public ::testing::TestWithParam<std::pair<double, double>> {
 protected:
  std::vector<double> Run(IntegratorType type) {
    VectorXd q0(2);
    q0 << GetParam().first, GetParam().second;
    return EnergyErrorByDecile(DefaultPlantSpec(PlantType::kArm2), type, q0, 100000);
  }
};

TEST_P(ArmEnergy, HigherOrderMethodsKeepEnergyFarBetterThanSemiImplicitEuler) {
  const double semi = Max(Run(IntegratorType::kSemiImplicitEuler));
  EXPECT_LT(Max(Run(IntegratorType::kRk4)), 1e-3 * semi);
  EXPECT_LT(Max(Run(IntegratorType::kDormandPrince)), 1e-3 * semi);
}

TEST_P(ArmEnergy, VariationalErrorStaysBoundedWhereSemiImplicitEulerGrows) {
  const std::vector<double> semi = Run(IntegratorType::kSemiImplicitEuler);
  const std::vector<double> vi = Run(IntegratorType::kVariational);
  // Semi-implicit Euler on (q, qd) drifts once M depends on q ...
  EXPECT_GT(semi.back(), 4.0 * semi.front());
  // ... the variational integrator's error in the last tenth is no larger than early on.
  EXPECT_LT(vi.back(), 3.0 * vi.front());
  EXPECT_LT(Max(vi), 1e-2 * Max(semi));
}

INSTANTIATE_TEST_SUITE_P(Releases, ArmEnergy, ::testing::Values(std::pair{0.0, 0.0}, std::pair{1.0, 0.5}));

TEST(PendulumEnergy, SemiImplicitEulerIsSymplecticWhenTheMassIsConstant) {
  // With constant M, semi-implicit Euler is the symplectic Euler method: bounded
  // energy error, where explicit Euler's grows every period.
  VectorXd q0(1);
  q0 << 2.0;
  const PlantSpec spec = DefaultPlantSpec(PlantType::kPendulum);
  const std::vector<double> semi = EnergyErrorByDecile(spec, IntegratorType::kSemiImplicitEuler, q0, 100000);
  const std::vector<double> euler = EnergyErrorByDecile(spec, IntegratorType::kExplicitEuler, q0, 100000);
  EXPECT_LT(semi.back(), 1.5 * semi.front());
  EXPECT_GT(euler.back(), 4.0 * euler.front());
}

// Error at t = 0.5 s against a Dormand–Prince reference at rtol 1e-13.
double GlobalError(IntegratorType type, double h) {
  const PlantSpec spec = DefaultPlantSpec(PlantType::kArm2);
  auto run = [&](IntegratorType t, double step, double rtol) {
    auto model = MakeModel(spec, Method::kClosedForm);
    auto integrator = MakeIntegratorOfType(t, 2, rtol);
    VectorXd q(2), qd(2), tau = VectorXd::Zero(2);
    q << 0.3, 0.8;
    qd << 1.0, -0.5;
    const int steps = static_cast<int>(std::lround(0.5 / step));
    for (int k = 0; k < steps; ++k) integrator->Step(*model, k * step, step, tau, q, qd);
    return q;
  };
  return (run(type, h, 1e-8) - run(IntegratorType::kDormandPrince, 0.05, 1e-13)).norm();
}

TEST(ConvergenceOrder, EachFixedStepMethodConvergesAtItsOrder) {
  const std::pair<IntegratorType, double> expected[] = {
      {IntegratorType::kExplicitEuler, 1.0},
      {IntegratorType::kSemiImplicitEuler, 1.0},
      {IntegratorType::kRk4, 4.0},
      {IntegratorType::kVariational, 2.0},
  };
  for (const auto& [type, order] : expected) {
    const double h = type == IntegratorType::kRk4 ? 1e-2 : 1e-3;
    const double observed = std::log2(GlobalError(type, h) / GlobalError(type, h / 2));
    EXPECT_NEAR(observed, order, 0.25) << ToString(type);
  }
}

TEST(DormandPrince, ErrorFollowsTheToleranceAndStatisticsAddUp) {
  const PlantSpec spec = DefaultPlantSpec(PlantType::kArm2);
  auto run = [&](double rtol, IntegratorStats* stats) {
    auto model = MakeModel(spec, Method::kClosedForm);
    auto integrator = MakeIntegratorOfType(IntegratorType::kDormandPrince, 2, rtol);
    VectorXd q(2), qd(2), tau = VectorXd::Zero(2);
    q << 0.3, 0.8;
    qd << 1.0, -0.5;
    integrator->Step(*model, 0.0, 2.0, tau, q, qd);  // one 2 s interval: the method picks its steps
    *stats = integrator->stats();
    return q;
  };
  IntegratorStats loose, tight, reference;
  const VectorXd exact = run(1e-13, &reference);
  const double err_loose = (run(1e-5, &loose) - exact).norm();
  const double err_tight = (run(1e-9, &tight) - exact).norm();
  EXPECT_LT(err_tight, 1e-2 * err_loose);
  EXPECT_LT(err_loose, 1e-3);
  EXPECT_GT(tight.accepted, loose.accepted);
  // The first trial step spans the whole 2 s and is rejected.
  EXPECT_GE(loose.rejected, 1);
  for (const IntegratorStats& s : {loose, tight, reference}) {
    EXPECT_EQ(s.evaluations, 1 + 6 * (s.accepted + s.rejected));  // first same as last
    EXPECT_EQ(s.failures, 0);
  }
}

TEST(Substeps, AdvanceSplitsATickIntoEqualSteps) {
  const PlantSpec spec = DefaultPlantSpec(PlantType::kCartPole);
  IntegratorConfig c;
  c.type = IntegratorType::kRk4;
  c.substeps = 4;
  auto model = MakeModel(spec, Method::kClosedForm);
  auto split = MakeIntegrator(c, 2);
  c.substeps = 1;
  auto single = MakeIntegrator(c, 2);
  VectorXd qa(2), qda(2), tau(2);
  qa << 0.1, 2.5;
  qda << 0.2, -1.0;
  tau << 1.0, 0.0;
  VectorXd qb = qa, qdb = qda;
  split->Advance(*model, 0.0, 4 * kTick, tau, qa, qda);
  for (int k = 0; k < 4; ++k) single->Step(*model, k * kTick, kTick, tau, qb, qdb);
  EXPECT_EQ(split->stats().steps, 4);
  EXPECT_NEAR((qa - qb).norm(), 0.0, 1e-15);
  EXPECT_NEAR((qda - qdb).norm(), 0.0, 1e-15);
}

// x is cyclic for the cart-pole, so p_x = (mc + mp) ẋ + mp l cos θ θ̇ is
// conserved. The variational integrator conserves the discrete momentum
// exactly (discrete Noether theorem); semi-implicit Euler does not.
TEST(Variational, ConservesTheCartMomentumToRoundOff) {
  const CartPoleParams p;
  auto momentum = [&](const VectorXd& q, const VectorXd& qd) {
    return (p.mc + p.mp) * qd[0] + p.mp * p.l * std::cos(q[1]) * qd[1];
  };
  auto drift = [&](IntegratorType type) {
    auto model = MakeModel({p}, Method::kClosedForm);
    auto integrator = MakeIntegratorOfType(type, 2);
    VectorXd q(2), qd(2), tau = VectorXd::Zero(2);
    q << 0.0, 2.0;
    qd << 0.5, 3.0;
    const double p0 = momentum(q, qd);
    double worst = 0.0;
    for (int k = 0; k < 10000; ++k) {
      integrator->Step(*model, k * kTick, kTick, tau, q, qd);
      worst = std::max(worst, std::abs(momentum(q, qd) - p0));
    }
    return worst;
  };
  EXPECT_LT(drift(IntegratorType::kVariational), 1e-12);
  EXPECT_GT(drift(IntegratorType::kSemiImplicitEuler), 1e-6);
}

TEST(Factory, NamesRoundTripAndBadConfigsAreRefused) {
  for (const auto type : {IntegratorType::kExplicitEuler, IntegratorType::kSemiImplicitEuler, IntegratorType::kRk4,
                          IntegratorType::kDormandPrince, IntegratorType::kVariational}) {
    EXPECT_EQ(ParseIntegratorType(ToString(type)), type);
  }
  EXPECT_FALSE(ParseIntegratorType("rk5"));
  IntegratorConfig c;
  c.substeps = 0;
  EXPECT_THROW(MakeIntegrator(c, 2), std::invalid_argument);
  c.substeps = 1;
  c.rtol = -1.0;
  EXPECT_THROW(MakeIntegrator(c, 2), std::invalid_argument);
}

// A law that returns a fixed torque and counts its evaluations.
class ConstantLaw final : public ControlLaw {
 public:
  explicit ConstantLaw(VectorXd tau) : tau_(std::move(tau)) {}
  void Compute(double, ConstVecRef, ConstVecRef, VecRef tau_cmd) override {
    tau_cmd = tau_;
    ++calls;
  }
  std::int64_t calls = 0;

 private:
  VectorXd tau_;
};

TEST(ControlLawArgument, AConstantLawStepsLikeItsHeldTorqueAndRunsAtEveryEvaluation) {
  constexpr double kSameArithmeticTol = 1e-15;  // the same operations in the same order
  const PlantSpec spec = DefaultPlantSpec(PlantType::kArm2);
  const VectorXd tau = (VectorXd(2) << 0.3, -0.2).finished();
  const VectorXd ignored = VectorXd::Constant(2, std::nan(""));  // tau_cmd is not read when a law is passed
  for (IntegratorType type : {IntegratorType::kExplicitEuler, IntegratorType::kSemiImplicitEuler, IntegratorType::kRk4,
                              IntegratorType::kDormandPrince, IntegratorType::kVariational}) {
    auto held_model = MakeModel(spec, Method::kClosedForm);
    auto law_model = MakeModel(spec, Method::kClosedForm);
    auto held = MakeIntegratorOfType(type, 2);
    auto with_law = MakeIntegratorOfType(type, 2);
    ConstantLaw law(tau);
    VectorXd qa = (VectorXd(2) << 0.4, -0.3).finished(), qda = (VectorXd(2) << 0.2, 0.1).finished();
    VectorXd qb = qa, qdb = qda;
    for (int k = 0; k < 20; ++k) {
      held->Advance(*held_model, k * kTick, kTick, tau, qa, qda);
      with_law->Advance(*law_model, &law, k * kTick, kTick, ignored, qb, qdb);
    }
    EXPECT_LE((qa - qb).lpNorm<Eigen::Infinity>(), kSameArithmeticTol) << ToString(type);
    EXPECT_LE((qda - qdb).lpNorm<Eigen::Infinity>(), kSameArithmeticTol) << ToString(type);
    EXPECT_EQ(law.calls, with_law->stats().evaluations) << ToString(type);
  }
}

// ----- Work per call (IntegratorWork) -----

constexpr IntegratorType kEveryIntegrator[] = {IntegratorType::kExplicitEuler, IntegratorType::kSemiImplicitEuler,
                                               IntegratorType::kRk4, IntegratorType::kDormandPrince,
                                               IntegratorType::kVariational};

std::unique_ptr<Integrator> MakeWithSubsteps(IntegratorType type, int n, int substeps, double rtol = 1e-8) {
  IntegratorConfig c;
  c.type = type;
  c.substeps = substeps;
  c.rtol = rtol;
  c.atol = rtol * 1e-2;
  return MakeIntegrator(c, n);
}

// A pendulum released from rest at theta0, no torque.
struct PendulumRun {
  explicit PendulumRun(double theta0)
      : model(MakeModel(DefaultPlantSpec(PlantType::kPendulum), Method::kClosedForm)),
        q(VectorXd::Constant(1, theta0)),
        qd(VectorXd::Zero(1)),
        tau(VectorXd::Zero(1)) {}
  std::unique_ptr<PlantModel> model;
  VectorXd q, qd, tau;
};

TEST(IntegratorWork, FixedStepMethodsCountTheirEvaluationsPerSubStep) {
  const std::pair<IntegratorType, int> per_substep[] = {
      {IntegratorType::kExplicitEuler, 1}, {IntegratorType::kSemiImplicitEuler, 1}, {IntegratorType::kRk4, 4}};
  for (const auto& [type, evaluations] : per_substep) {
    for (int substeps : {1, 2, 3, 8}) {
      PendulumRun run(1.0);
      auto integrator = MakeWithSubsteps(type, 1, substeps);
      for (int k = 0; k < 3; ++k) {  // every call reports its own work, not the running total
        integrator->Advance(*run.model, k * kTick, kTick, run.tau, run.q, run.qd);
        const IntegratorWork& w = integrator->work();
        EXPECT_EQ(w.evaluations, evaluations * substeps) << ToString(type) << " substeps " << substeps;
        EXPECT_EQ(w.steps, substeps);
        EXPECT_EQ(w.accepted, substeps);
        EXPECT_EQ(w.rejected, 0);
        EXPECT_EQ(w.newton_iterations, 0);
        EXPECT_EQ(w.failures, 0);
        EXPECT_TRUE(std::isnan(w.error_estimate));  // no estimate, not "exact"
        EXPECT_DOUBLE_EQ(w.step, kTick / substeps);
      }
    }
  }
}

TEST(IntegratorWork, DormandPrinceTakesFewStepsAtALooseToleranceAndMoreAtATightOne) {
  constexpr double kInterval = 0.1;  // s per call: long enough for the tolerance to choose the steps
  constexpr int kCalls = 10;
  auto run = [&](double rtol) {
    PendulumRun pendulum(1.0);
    auto integrator = MakeWithSubsteps(IntegratorType::kDormandPrince, 1, 1, rtol);
    std::int64_t most_accepted = 0;
    for (int k = 0; k < kCalls; ++k) {
      integrator->Advance(*pendulum.model, k * kInterval, kInterval, pendulum.tau, pendulum.q, pendulum.qd);
      const IntegratorWork& w = integrator->work();
      EXPECT_TRUE(w.error_estimate > 0.0 && w.error_estimate <= 1.0) << "rtol " << rtol << ": " << w.error_estimate;
      EXPECT_EQ(w.evaluations, 1 + 6 * (w.accepted + w.rejected));  // first same as last
      EXPECT_GT(w.step, 0.0);
      EXPECT_LE(w.step, kInterval * (1.0 + 1e-12));  // t_end − t: the interval up to round-off
      EXPECT_EQ(w.failures, 0);
      if (k > 0) most_accepted = std::max(most_accepted, w.accepted);  // the first call finds its step size
    }
    return most_accepted;
  };
  const std::int64_t loose = run(1e-4);
  const std::int64_t tight = run(1e-11);
  EXPECT_LE(loose, 3);
  EXPECT_GE(tight, 4 * loose);
}

TEST(IntegratorWork, VariationalIteratesNewtonAtLeastOncePerSubStepAndOnlyAFewTimesNearRest) {
  constexpr int kSubsteps = 2;
  constexpr std::int64_t kHandful =
      3;  // Newton iterations per sub-step near rest (measured: 1, 2 with a Jacobian rebuild)
  PendulumRun run(1e-3);
  auto integrator = MakeWithSubsteps(IntegratorType::kVariational, 1, kSubsteps);
  for (int k = 0; k < 100; ++k) {
    integrator->Advance(*run.model, k * kTick, kTick, run.tau, run.q, run.qd);
    const IntegratorWork& w = integrator->work();
    EXPECT_GE(w.newton_iterations, kSubsteps);
    EXPECT_LE(w.newton_iterations, kHandful * kSubsteps) << "call " << k;
    // Per sub-step the predictor, the first residual and one per iteration, plus n + 1 = 2 per Jacobian rebuild.
    const std::int64_t rebuild_evaluations = w.evaluations - 2 * kSubsteps - w.newton_iterations;
    EXPECT_GE(rebuild_evaluations, 0);
    EXPECT_EQ(rebuild_evaluations % 2, 0);
    EXPECT_LE(rebuild_evaluations, k == 0 ? 2 * 2 * kSubsteps : 2 * kSubsteps);  // the first call builds it
    EXPECT_DOUBLE_EQ(w.step, kTick / kSubsteps);
    EXPECT_EQ(w.failures, 0);
  }
}

TEST(IntegratorWork, IsPerCallAndAddsUpToTheCumulativeStatistics) {
  for (IntegratorType type : kEveryIntegrator) {
    auto model = MakeModel(DefaultPlantSpec(PlantType::kArm2), Method::kClosedForm, testing::AllEffectsOn(2));
    auto integrator = MakeWithSubsteps(type, 2, 3);
    VectorXd q = (VectorXd(2) << 0.4, -0.3).finished(), qd = (VectorXd(2) << 0.2, 0.1).finished();
    const VectorXd tau = (VectorXd(2) << 0.3, -0.2).finished();
    for (int k = 0; k < 20; ++k) {
      const IntegratorStats before = integrator->stats();
      if (k % 2 == 0) {
        integrator->Advance(*model, k * kTick, kTick, tau, q, qd);
      } else {
        integrator->Step(*model, k * kTick, kTick, tau, q, qd);  // a Step call is a call too
      }
      const IntegratorWork& w = integrator->work();
      const IntegratorStats& after = integrator->stats();
      EXPECT_EQ(w.steps, k % 2 == 0 ? 3 : 1) << ToString(type);
      EXPECT_EQ(after.steps - before.steps, w.steps) << ToString(type);
      EXPECT_EQ(after.evaluations - before.evaluations, w.evaluations) << ToString(type);
      EXPECT_EQ(after.accepted - before.accepted, w.accepted) << ToString(type);
      EXPECT_EQ(after.rejected - before.rejected, w.rejected) << ToString(type);
      EXPECT_EQ(after.newton_iterations - before.newton_iterations, w.newton_iterations) << ToString(type);
      EXPECT_EQ(after.failures - before.failures, w.failures) << ToString(type);
    }
  }
}

// ---- run-time reconfiguration ------------------------------------------------

bool SameConfig(const IntegratorConfig& a, const IntegratorConfig& b) {
  return a.type == b.type && a.substeps == b.substeps && a.rtol == b.rtol && a.atol == b.atol &&
         a.max_steps == b.max_steps && a.newton_tol == b.newton_tol &&
         a.newton_max_iterations == b.newton_max_iterations;
}

// Exact equality, element by element: the same operations on the same numbers.
bool BitIdentical(const VectorXd& a, const VectorXd& b) {
  return a.size() == b.size() && (a.array() == b.array()).all();
}

struct Trajectory {
  VectorXd q, qd;
  std::int64_t accepted = 0;
};

// `ticks` ticks of length `tick` of the arm under every effect, from a fixed state.
Trajectory RunArm(Integrator& integrator, int ticks, double tick = kTick) {
  auto model = MakeModel(DefaultPlantSpec(PlantType::kArm2), Method::kClosedForm, testing::AllEffectsOn(2));
  Trajectory r{(VectorXd(2) << 0.9, -0.7).finished(), (VectorXd(2) << 1.5, -2.0).finished()};
  const VectorXd tau = (VectorXd(2) << 0.8, -0.3).finished();
  for (int k = 0; k < ticks; ++k) {
    integrator.Advance(*model, k * tick, tick, tau, r.q, r.qd);
    r.accepted += integrator.work().accepted;
  }
  return r;
}

TEST(Reconfigure, Rk4ReconfiguredToFourSubstepsStepsBitIdenticallyToAFreshOne) {
  auto reconfigured = MakeWithSubsteps(IntegratorType::kRk4, 2, 1);
  RunArm(*reconfigured, 50);  // some history under the old config
  IntegratorConfig c = reconfigured->config();
  c.substeps = 4;
  ASSERT_EQ(reconfigured->Reconfigure(c), nullptr);
  EXPECT_EQ(reconfigured->config().substeps, 4);
  auto fresh = MakeWithSubsteps(IntegratorType::kRk4, 2, 4);
  const Trajectory a = RunArm(*reconfigured, 500), b = RunArm(*fresh, 500);
  EXPECT_TRUE(BitIdentical(a.q, b.q));
  EXPECT_TRUE(BitIdentical(a.qd, b.qd));
  EXPECT_EQ(reconfigured->work().steps, 4);
}

// From a tight tolerance to a loose one over 10 ms ticks, where the tight
// tolerance's step proposal is well below a tick: that proposal is not
// carried over, and the loose tolerance takes fewer steps.
TEST(Reconfigure, Dopri5ReconfiguredToNewTolerancesStepsBitIdenticallyToAFreshOne) {
  constexpr double kLongTick = 10 * kTick;
  auto reconfigured = MakeWithSubsteps(IntegratorType::kDormandPrince, 2, 1, 1e-10);
  auto tight = MakeWithSubsteps(IntegratorType::kDormandPrince, 2, 1, 1e-10);
  RunArm(*reconfigured, 50, kLongTick);
  IntegratorConfig c = reconfigured->config();
  c.rtol = 1e-4;
  c.atol = 1e-6;
  ASSERT_EQ(reconfigured->Reconfigure(c), nullptr);
  EXPECT_EQ(reconfigured->config().rtol, 1e-4);
  EXPECT_EQ(reconfigured->config().atol, 1e-6);
  auto fresh = MakeIntegrator(c, 2);
  const Trajectory a = RunArm(*reconfigured, 200, kLongTick), b = RunArm(*fresh, 200, kLongTick),
                   t = RunArm(*tight, 200, kLongTick);
  EXPECT_TRUE(BitIdentical(a.q, b.q));
  EXPECT_TRUE(BitIdentical(a.qd, b.qd));
  EXPECT_EQ(a.accepted, b.accepted);
  EXPECT_LT(a.accepted, t.accepted);  // the looser tolerance took effect
}

// What a step carries to the next (dopri5's proposal, the variational
// Jacobian) starts over, so every type steps as a fresh one of the new config.
TEST(Reconfigure, EveryIntegratorStepsAsAFreshOneOfTheNewConfig) {
  for (IntegratorType type : kEveryIntegrator) {
    IntegratorConfig old_config;
    old_config.type = type;
    old_config.substeps = 2;  // the same sub-step: the variational Jacobian would still fit it
    old_config.rtol = 1e-6;
    old_config.atol = 1e-8;
    old_config.newton_tol = 1e-10;
    IntegratorConfig new_config;
    new_config.type = type;
    new_config.substeps = 2;
    new_config.rtol = 1e-9;
    new_config.atol = 1e-11;
    new_config.max_steps = 5000;
    new_config.newton_tol = 1e-13;
    new_config.newton_max_iterations = 20;
    auto reconfigured = MakeIntegrator(old_config, 2);
    RunArm(*reconfigured, 30);
    ASSERT_EQ(reconfigured->Reconfigure(new_config), nullptr) << ToString(type);
    EXPECT_TRUE(SameConfig(reconfigured->config(), new_config)) << ToString(type);
    auto fresh = MakeIntegrator(new_config, 2);
    const Trajectory a = RunArm(*reconfigured, 100), b = RunArm(*fresh, 100);
    EXPECT_TRUE(BitIdentical(a.q, b.q)) << ToString(type);
    EXPECT_TRUE(BitIdentical(a.qd, b.qd)) << ToString(type);
  }
}

TEST(Reconfigure, RefusesATypeMismatchOrABadNumberAndChangesNothing) {
  IntegratorConfig original;
  original.type = IntegratorType::kDormandPrince;
  original.substeps = 2;
  original.rtol = 1e-7;
  auto integrator = MakeIntegrator(original, 2);

  IntegratorConfig other_type = original;
  other_type.type = IntegratorType::kRk4;
  other_type.substeps = 5;
  EXPECT_STREQ(integrator->Reconfigure(other_type), "integrator.type differs from this integrator's");
  EXPECT_TRUE(SameConfig(integrator->config(), original));

  IntegratorConfig bad = original;
  bad.substeps = 0;
  bad.rtol = 1e-3;  // a good number beside a bad one is not taken either
  EXPECT_STREQ(integrator->Reconfigure(bad), "integrator.substeps: expected 1 to 1000");
  EXPECT_TRUE(SameConfig(integrator->config(), original));
  bad = original;
  bad.atol = std::nan("");
  EXPECT_STREQ(integrator->Reconfigure(bad), "integrator.atol: expected a finite number > 0");
  EXPECT_TRUE(SameConfig(integrator->config(), original));
}

TEST(Reconfigure, CheckIntegratorConfigGivesOneReasonPerRuleAndTheFactoryThrowsIt) {
  EXPECT_EQ(CheckIntegratorConfig(IntegratorConfig{}), nullptr);
  IntegratorConfig edges;
  edges.substeps = 1000;
  edges.max_steps = 10000000;
  edges.newton_max_iterations = 1000;
  edges.rtol = 1e-300;
  EXPECT_EQ(CheckIntegratorConfig(edges), nullptr);

  struct Rule {
    void (*spoil)(IntegratorConfig&);
    const char* reason;
  };
  constexpr double kInf = std::numeric_limits<double>::infinity();
  const Rule rules[] = {
      {[](IntegratorConfig& c) { c.substeps = 0; }, "integrator.substeps: expected 1 to 1000"},
      {[](IntegratorConfig& c) { c.substeps = 1001; }, "integrator.substeps: expected 1 to 1000"},
      {[](IntegratorConfig& c) { c.rtol = 0.0; }, "integrator.rtol: expected a finite number > 0"},
      {[](IntegratorConfig& c) { c.rtol = kInf; }, "integrator.rtol: expected a finite number > 0"},
      {[](IntegratorConfig& c) { c.atol = -1e-9; }, "integrator.atol: expected a finite number > 0"},
      {[](IntegratorConfig& c) { c.atol = std::nan(""); }, "integrator.atol: expected a finite number > 0"},
      {[](IntegratorConfig& c) { c.max_steps = 0; }, "integrator.max_steps: expected 1 to 10000000"},
      {[](IntegratorConfig& c) { c.max_steps = 10000001; }, "integrator.max_steps: expected 1 to 10000000"},
      {[](IntegratorConfig& c) { c.newton_tol = 0.0; }, "integrator.newton_tol: expected a finite number > 0"},
      {[](IntegratorConfig& c) { c.newton_tol = kInf; }, "integrator.newton_tol: expected a finite number > 0"},
      {[](IntegratorConfig& c) { c.newton_max_iterations = 0; },
       "integrator.newton_max_iterations: expected 1 to 1000"},
      {[](IntegratorConfig& c) { c.newton_max_iterations = 1001; },
       "integrator.newton_max_iterations: expected 1 to 1000"},
  };
  std::set<std::string> distinct;
  for (const Rule& rule : rules) {
    IntegratorConfig c;
    rule.spoil(c);
    const char* reason = CheckIntegratorConfig(c);
    ASSERT_NE(reason, nullptr) << rule.reason;
    EXPECT_STREQ(reason, rule.reason);
    distinct.insert(reason);
    try {
      MakeIntegrator(c, 2);
      ADD_FAILURE() << "MakeIntegrator took a config with " << rule.reason;
    } catch (const std::invalid_argument& e) {
      EXPECT_STREQ(e.what(), rule.reason);
    }
  }
  EXPECT_EQ(distinct.size(), 6u);  // one reason per key
}

// The variational integrator reads gravity's switch, not the scene's config.
TEST(Variational, GravitySwitchedOffStepsAsAModelBuiltWithout) {
  const PlantSpec spec = DefaultPlantSpec(PlantType::kArm2);
  auto switched = MakeModel(spec, Method::kClosedForm, testing::AllEffectsOn(2));
  EffectsConfig without = testing::AllEffectsOn(2);
  without.gravity = false;
  auto built = MakeModel(spec, Method::kClosedForm, without);
  ASSERT_TRUE(switched->effects().SetEnabled(EffectKind::kGravity, false));
  auto a = MakeIntegratorOfType(IntegratorType::kVariational, 2);
  auto b = MakeIntegratorOfType(IntegratorType::kVariational, 2);
  VectorXd qa = (VectorXd(2) << 0.5, -0.2).finished(), qda = (VectorXd(2) << 0.3, 0.1).finished();
  VectorXd qb = qa, qdb = qda;
  const VectorXd tau = VectorXd::Zero(2);
  for (int k = 0; k < 200; ++k) {
    a->Step(*switched, k * kTick, kTick, tau, qa, qda);
    b->Step(*built, k * kTick, kTick, tau, qb, qdb);
  }
  EXPECT_TRUE(BitIdentical(qa, qb));
  EXPECT_TRUE(BitIdentical(qda, qdb));
}

}  // namespace
}  // namespace lagrange
