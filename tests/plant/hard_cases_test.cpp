// Numerical hard cases (README, "Hard cases"): each stays finite and keeps
// its error within the stated bound.

#include <gtest/gtest.h>

#include <cstdio>

#include <cmath>
#include <numbers>

#include "plant/eigenvalues.hpp"
#include "plant/integrators.hpp"
#include "plant/plant_factory.hpp"
#include "tests/support/full_length.hpp"

namespace lagrange {
namespace {

constexpr double kPi = std::numbers::pi;

// K(k) from the complementary modulus k' = √(1 − k²) by the arithmetic-geometric
// mean: exact near k = 1, where std::comp_ellint_1(k) loses digits because k
// itself cannot carry them.
double EllipticKFromComplement(double k_complement) {
  double a = 1.0, b = k_complement;
  for (int i = 0; i < 60 && a != b; ++i) {
    const double next = 0.5 * (a + b);
    b = std::sqrt(a * b);
    a = next;
  }
  return kPi / (2.0 * a);
}

struct Simulation {
  std::unique_ptr<PlantModel> model;
  std::unique_ptr<Integrator> integrator;
  VectorXd q, qd, tau;
};

Simulation Make(const PlantSpec& spec, IntegratorType type, int substeps = 1, EffectsConfig effects = {},
                Method method = Method::kClosedForm) {
  const int n = spec.num_dofs();
  IntegratorConfig c;
  c.type = type;
  c.substeps = substeps;
  return {std::make_unique<PlantModel>(MakeDynamics(spec, HasMethod(spec.type(), method) ? method : Method::kRecursive),
                                       std::move(effects)),
          MakeIntegrator(c, n), VectorXd::Zero(n), VectorXd::Zero(n), VectorXd::Zero(n)};
}

// Released at rest 1e-6 rad from upright, the pendulum reaches the bottom
// after exactly a quarter of its period, 4√(L/g) K(cos(δ/2)) ≈ 20.3 s. (A
// whole period is ill-posed here: the second approach to the top turns an
// energy error of 1e-12 J into an O(1) change of the distance from upright.)
TEST(HardCases, PendulumReleasedAMicroradianFromUprightKeepsTheEllipticQuarterPeriod) {
  const PendulumParams p;
  for (const auto& [delta, type, h, bound] : {std::tuple{1e-6, IntegratorType::kRk4, 1e-3, 1e-8},
                                              std::tuple{1e-6, IntegratorType::kDormandPrince, 1e-3, 1e-8},
                                              std::tuple{1e-6, IntegratorType::kVariational, 1e-4, 1e-7},
                                              std::tuple{1e-3, IntegratorType::kRk4, 1e-3, 1e-10}}) {
    Simulation r = Make({p}, type);
    r.q[0] = kPi - delta;
    double t = 0.0, crossing = -1.0;
    while (crossing < 0.0 && t < 30.0) {
      const double before = r.q[0];
      ASSERT_TRUE(r.integrator->Step(*r.model, t, h, r.tau, r.q, r.qd));
      if (r.q[0] < 0.0) crossing = t + h * before / (before - r.q[0]);  // θ is nearly linear in t at the bottom
      t += h;
    }
    const double expected = 4.0 * std::sqrt(p.L / p.g) * EllipticKFromComplement(std::sin(delta / 2.0));
    EXPECT_NEAR(4.0 * crossing, expected, bound * expected) << ToString(type) << " delta " << delta;
  }
}

TEST(HardCases, ArmFullyFoldedAndFullyStretchedStaysWellPosed) {
  const PlantSpec arm = DefaultPlantSpec(PlantType::kArm2);
  for (double q2 : {kPi, 0.0, -kPi}) {
    VectorXd q(2), qd(2), tau = VectorXd::Zero(2);
    q << 0.4, q2;
    qd << 1.5, -2.0;
    // The mass matrix stays positive definite and every method agrees there.
    MatrixXd M(2, 2), M_ref(2, 2);
    VectorXd qdd(2), qdd_ref(2);
    auto reference = MakeDynamics(arm, Method::kLagrangian);
    const std::unique_ptr<DynamicsData> reference_data = reference->MakeData();
    reference->ComputeMassMatrix(*reference_data, q, M_ref);
    reference->ComputeForwardDynamics(*reference_data, q, qd, tau, DynamicsTerms{}, qdd_ref);
    EXPECT_GT(SymmetricEigenvalues(M_ref).minCoeff(), 1e-3);
    for (Method m : {Method::kClosedForm, Method::kRecursive}) {
      auto d = MakeDynamics(arm, m);
      const std::unique_ptr<DynamicsData> d_data = d->MakeData();
      d->ComputeForwardDynamics(*d_data, q, qd, tau, DynamicsTerms{}, qdd);
      EXPECT_LE((qdd - qdd_ref).norm(), 1e-12 * qdd_ref.norm()) << q2;
    }
    // And it swings through the singular-looking poses conserving energy.
    Simulation r = Make(arm, IntegratorType::kRk4);
    r.q = q;
    r.qd = qd;
    const double e0 = r.model->Energy(r.q, r.qd);
    for (int k = 0; k < 5000; ++k) r.integrator->Step(*r.model, k * 1e-3, 1e-3, r.tau, r.q, r.qd);
    EXPECT_LT(std::abs(r.model->Energy(r.q, r.qd) - e0), 1e-6 * std::abs(e0) + 1e-6);
  }
}

// 100 rad/s on both joints (about 2 kJ): energy error after 2 s, relative.
TEST(HardCases, HundredRadiansPerSecondConserveEnergy) {
  const std::tuple<IntegratorType, int, double> cases[] = {
      {IntegratorType::kRk4, 1, 1e-3},           {IntegratorType::kRk4, 10, 1e-8},
      {IntegratorType::kDormandPrince, 1, 1e-7}, {IntegratorType::kVariational, 1, 1e-2},
      {IntegratorType::kVariational, 10, 1e-4},
  };
  for (const auto& [type, substeps, bound] : cases) {
    Simulation r = Make(DefaultPlantSpec(PlantType::kArm2), type, substeps);
    r.q << 0.3, 0.2;
    r.qd << 100.0, -100.0;
    const double e0 = r.model->Energy(r.q, r.qd);
    double worst = 0.0;
    for (int k = 0; k < 2000; ++k) {
      r.integrator->Advance(*r.model, k * 1e-3, 1e-3, r.tau, r.q, r.qd);
      worst = std::max(worst, std::abs(r.model->Energy(r.q, r.qd) - e0) / e0);
    }
    EXPECT_LT(worst, bound) << ToString(type) << " x" << substeps;
    EXPECT_TRUE(r.q.allFinite());
  }
}

// After a million revolutions an angle is a large number with an ulp of ~1e-9
// rad; the dynamics and the motion stay those of the wrapped angle.
TEST(HardCases, AMillionRevolutionsChangeNothingButTheAngleItself) {
  const double turns = 2.0 * kPi * 1e6;
  const double representation = 1e-8;  // a few ulps of 6.3e6, in rad
  for (PlantType type : {PlantType::kPendulum, PlantType::kArm2}) {
    const PlantSpec spec = DefaultPlantSpec(type);
    const int n = spec.num_dofs();
    VectorXd q = VectorXd::Constant(n, 0.3), qd = VectorXd::Constant(n, 0.7), qdd(n), qdd_far(n);
    const VectorXd far = q.array() + turns;
    auto d = MakeDynamics(spec, Method::kClosedForm);
    const std::unique_ptr<DynamicsData> d_data = d->MakeData();
    d->ComputeForwardDynamics(*d_data, q, qd, VectorXd::Zero(n), DynamicsTerms{}, qdd);
    d->ComputeForwardDynamics(*d_data, far, qd, VectorXd::Zero(n), DynamicsTerms{}, qdd_far);
    EXPECT_LT((qdd - qdd_far).norm(), 100.0 * representation * (1.0 + qdd.norm())) << ToString(type);
    // The same swing, offset by whole turns, up to the rounding of a 6.3e6 rad angle
    // (~5e-10 rad per step). The arm is chaotic: after a second that rounding grows,
    // so from there on only its energy is compared.
    Simulation near_run = Make(spec, IntegratorType::kRk4);
    Simulation far_run = Make(spec, IntegratorType::kRk4);
    near_run.q = q;
    far_run.q = far;
    const int comparable = type == PlantType::kPendulum ? 5000 : 1000;
    for (int k = 0; k < 5000; ++k) {
      near_run.integrator->Step(*near_run.model, k * 1e-3, 1e-3, near_run.tau, near_run.q, near_run.qd);
      far_run.integrator->Step(*far_run.model, k * 1e-3, 1e-3, far_run.tau, far_run.q, far_run.qd);
      if (k + 1 == comparable) {
        EXPECT_LT(((far_run.q.array() - turns).matrix() - near_run.q).norm(), 1e-6) << ToString(type);
      }
    }
    EXPECT_NEAR(far_run.model->Energy(far_run.q, far_run.qd), near_run.model->Energy(near_run.q, near_run.qd), 1e-6);
  }
}

// Of the energy scale |E(0)| + T(0), at every step. dopri5 at its default
// rtol 1e-8 bounds each step's local error relative to the state, so over the
// 3000 steps the energy may drift by up to about 3000 × 1e-8 = 3e-5 of it and
// the integrator still did what it promised; measured, the worst case (the
// chain) peaks at 1.09e-6 (t = 2.565 s). 2e-6 is twice that peak, 15× inside
// the tolerance's allowance: a regression in the mass matrix's conditioning
// shows long before the tolerance would.
constexpr double kMassRatioEnergyTol = 2e-6;

TEST(HardCases, ExtremeMassRatiosKeepAPositiveDefiniteMassMatrixAndEnergy) {
  struct Case {
    std::string name;
    PlantSpec spec;
  };
  Arm2Params light_tip, heavy_tip;
  light_tip.m2 = 1e-6 * light_tip.m1;
  heavy_tip.m2 = 1e6 * heavy_tip.m1;
  CartPoleParams light_pole, light_cart;
  light_pole.mp = 1e-6 * light_pole.mc;
  light_cart.mc = 1e-6 * light_cart.mp;
  ChainParams ratios;
  ratios.links = {ChainLink{.m = 1e-6, .L = 0.5, .com = {}, .I = {}}, ChainLink{.m = 1.0, .L = 0.5, .com = {}, .I = {}},
                  ChainLink{.m = 1e6, .L = 0.5, .com = {}, .I = {}}};
  const std::vector<Case> cases = {{"arm m2/m1 = 1e-6", {light_tip}},
                                   {"arm m2/m1 = 1e6", {heavy_tip}},
                                   {"cartpole mp/mc = 1e-6", {light_pole}},
                                   {"cartpole mc/mp = 1e-6", {light_cart}},
                                   {"chain 1e-6 : 1 : 1e6", {ratios}}};
  for (const Case& c : cases) {
    const int n = c.spec.num_dofs();
    auto reference = MakeDynamics(c.spec, Method::kLagrangian);
    const std::unique_ptr<DynamicsData> reference_data = reference->MakeData();
    MatrixXd M(n, n);
    VectorXd q = VectorXd::Constant(n, 0.4);
    reference->ComputeMassMatrix(*reference_data, q, M);
    EXPECT_GT(SymmetricEigenvalues(M).minCoeff(), 0.0) << c.name;
    Simulation r = Make(c.spec, IntegratorType::kDormandPrince, 1, {}, FastestMethod(c.spec.type()));
    r.q = q;
    r.qd = VectorXd::Constant(n, 0.5);
    const double e0 = r.model->Energy(r.q, r.qd);
    double scale = std::abs(e0) + r.model->KineticEnergy(r.q, r.qd);
    // At every step, not only at the end (the chain's error peaks mid-run: 1.09e-6 at t = 2.565 s).
    double worst = 0.0;
    for (int k = 0; k < 3000; ++k) {
      r.integrator->Step(*r.model, k * 1e-3, 1e-3, r.tau, r.q, r.qd);
      ASSERT_TRUE(r.q.allFinite() && r.qd.allFinite()) << c.name << " at step " << k;
      worst = std::max(worst, std::abs(r.model->Energy(r.q, r.qd) - e0) / scale);
    }
    EXPECT_LT(worst, kMassRatioEnergyTol) << c.name;
    char text[32];
    std::snprintf(text, sizeof text, "%.3g", worst);
    RecordProperty(c.name + " largest energy error", text);
  }
}

// A near-massless cart under a point-mass pole at θ = 0 makes cond(M) ≈ 6e10:
// every method's solve keeps the backward residual at round-off.
TEST(HardCases, IllConditionedMassMatrixIsSolvedWithARoundOffResidual) {
  CartPoleParams p;
  p.mc = 1e-10;
  p.mp = 1.0;
  p.I = 0.0;
  VectorXd q(2), qd(2), tau(2), c(2), G(2), qdd(2);
  q << 0.0, 0.0;
  qd << 0.1, 0.2;
  tau << 0.3, 0.0;
  for (Method m : {Method::kClosedForm, Method::kLagrangian, Method::kRecursive}) {
    auto d = MakeDynamics({p}, m);
    const std::unique_ptr<DynamicsData> d_data = d->MakeData();
    MatrixXd M(2, 2);
    d->ComputeMassMatrix(*d_data, q, M);
    const auto eig = SymmetricEigenvalues(M);
    ASSERT_GE(eig.maxCoeff() / eig.minCoeff(), 1e10);
    d->ComputeCoriolisForce(*d_data, q, qd, c);
    d->ComputeGravityForce(*d_data, q, G);
    d->ComputeForwardDynamics(*d_data, q, qd, tau, DynamicsTerms{}, qdd);
    const VectorXd rhs = tau - c - G;
    const double residual = (M * qdd - rhs).norm() / (M.norm() * qdd.norm() + rhs.norm());
    EXPECT_LT(residual, 1e-15) << ToString(m);  // measured: 2e-17 for all three
  }
}

// 10⁷ steps (2.8 simulated hours) at full length, 10⁶ in CI: the variational
// integrator's energy error on the undamped arm is no larger at the end.
TEST(HardCases, VariationalIntegratorKeepsTheArmsEnergyBoundedForHours) {
  const int steps = testing::Length(1'000'000, 10'000'000);
  Simulation r = Make(DefaultPlantSpec(PlantType::kArm2), IntegratorType::kVariational);
  r.q << 1.0, 0.5;
  const double e0 = r.model->Energy(r.q, r.qd);
  double first = 0.0, last = 0.0;
  for (int k = 0; k < steps; ++k) {
    ASSERT_TRUE(r.integrator->Step(*r.model, k * 1e-3, 1e-3, r.tau, r.q, r.qd)) << k;
    const double err = std::abs(r.model->Energy(r.q, r.qd) - e0);
    if (k < steps / 10) first = std::max(first, err);         // the first tenth of the run
    if (k >= steps - steps / 10) last = std::max(last, err);  // the last tenth
  }
  EXPECT_LT(first, 1e-2);        // of 8 J: O(h²); the README quotes the full-length run's figures
  EXPECT_LT(last, 2.0 * first);  // no secular growth
  char text[64];
  std::snprintf(text, sizeof text, "first tenth %.3g J, last tenth %.3g J", first, last);
  RecordProperty("largest energy error", text);
}

// Fifty links released horizontally fall and whip for 10 s (the tip's
// kinetic energy reaches about 6 kJ): finite, energy kept to 1e-3 J.
TEST(HardCases, FiftyLinkChainFallsFreelyForTenSeconds) {
  ChainParams p;
  p.links.resize(50);
  Simulation r = Make({p}, IntegratorType::kDormandPrince, 1, {}, Method::kRecursive);
  const double e0 = r.model->Energy(r.q, r.qd);
  double worst = 0.0, peak_kinetic = 0.0;
  for (int k = 0; k < 10000; ++k) {
    ASSERT_TRUE(r.integrator->Step(*r.model, k * 1e-3, 1e-3, r.tau, r.q, r.qd)) << k;
    worst = std::max(worst, std::abs(r.model->Energy(r.q, r.qd) - e0));
    peak_kinetic = std::max(peak_kinetic, r.model->KineticEnergy(r.q, r.qd));
  }
  EXPECT_TRUE(r.q.allFinite() && r.qd.allFinite());
  EXPECT_GT(peak_kinetic, 1000.0);  // it really fell
  EXPECT_LT(worst, 1e-3);           // measured 5e-5 J
}

}  // namespace
}  // namespace lagrange
