// The floating base's configuration manifold (plant/free_flyer.hpp) and the
// fixed-step integrators on it (plant/floating_integrator.hpp): Integrate and
// Difference are inverse, Integrate is SE(3)'s exponential (a one-parameter
// subgroup, tangent to q̇), the quaternion stays unit, RK4 is of order 4 on the
// manifold, and a torque-free tumbling body keeps its energy and momentum.

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <cstdio>
#include <random>
#include <stdexcept>

#include "plant/floating_dynamics.hpp"
#include "plant/floating_integrator.hpp"
#include "plant/free_flyer.hpp"
#include "plant/random_tree.hpp"
#include "tests/support/alloc_counter.hpp"
#include "tests/support/plant_cases.hpp"

namespace lagrange {
namespace {

using testing::RandomVector;

constexpr double kRoundTripTol = 1e-12;  // Difference(q, Integrate(q, v)) − v, relative
constexpr double kUnitTol = 1e-12;       // |‖quaternion‖ − 1|
// A torque-free tumbling body and a floating tree, rk4, 10 s at 1 ms. Measured
// on the body (Release, g++ 12, x86-64): energy 8.9e-14, momentum 2.9e-11 (its
// direction turns as the body flips), quaternion norm 2.2e-16.
constexpr double kRk4EnergyTol = 1e-10;   // relative
constexpr double kRk4MomentumTol = 1e-9;  // relative
// N·s, N·m·s: a floating chain at zero momentum over 10 s of rk4 at 1 ms,
// measured 4.5e-11: rk4's truncation, not round-off (rk4 conserves momentum
// only to its order; the variational integrator keeps it to round-off:
// tests/plant/floating_hard_cases_test.cpp).
constexpr double kZeroMomentumTol = 2e-10;    // m: the centre of mass against its parabola over 2 s

VectorXd RandomConfiguration(int joints, std::mt19937& rng) {
  VectorXd q = RandomVector(kFreeFlyerNq + joints, -1.0, 1.0, rng);
  q.segment<4>(3) = Eigen::Quaterniond(RandomRotation(rng)).coeffs();
  return q;
}

double QuaternionNormError(const VectorXd& q) { return std::abs(q.segment<4>(3).norm() - 1.0); }

TEST(FreeFlyer, DifferenceInvertsIntegrate) {
  std::mt19937 rng{42};
  for (int k = 0; k < 200; ++k) {
    const int joints = k % 4;
    const VectorXd q = RandomConfiguration(joints, rng);
    // Twists from 1e-9 to 3 rad (below π: Difference takes the shorter rotation).
    const double scale = std::pow(10.0, -9.0 + 9.4 * (k % 20) / 19.0);
    VectorXd v = RandomVector(kFreeFlyerNv + joints, -1.0, 1.0, rng);
    v.segment<3>(3) *= std::min(scale, 3.0 / v.segment<3>(3).norm());
    v.head<3>() *= scale;
    VectorXd q1(q.size()), back(v.size());
    Integrate(q, v, 1.0, q1);
    Difference(q, q1, back);
    EXPECT_LT((back - v).norm(), kRoundTripTol * std::max(1.0, v.norm())) << "case " << k;
    EXPECT_LT(QuaternionNormError(q1), kUnitTol);
  }
}

TEST(FreeFlyer, IntegrateFollowsAOneParameterSubgroup) {
  // exp is exact for a constant twist: two half steps are one whole step.
  std::mt19937 rng{42};
  for (int k = 0; k < 50; ++k) {
    const VectorXd q = RandomConfiguration(2, rng);
    const VectorXd v = RandomVector(kFreeFlyerNv + 2, -2.0, 2.0, rng);
    VectorXd whole(q.size()), half(q.size());
    Integrate(q, v, 1.0, whole);
    Integrate(q, v, 0.5, half);
    Integrate(half, v, 0.5, half);
    // Compare quaternions up to sign.
    if (whole.segment<4>(3).dot(half.segment<4>(3)) < 0.0) half.segment<4>(3) *= -1.0;
    EXPECT_LT((whole - half).norm(), kRoundTripTol * (1.0 + v.norm())) << "case " << k;
  }
}

TEST(FreeFlyer, IntegrateIsTangentToTheConfigurationRate) {
  // d/dh Integrate(q, v, h) at 0 = (R v_b, ½ quat ⊗ (ω_b, 0), qd), by central differences.
  std::mt19937 rng{42};
  const double eps = 1e-6;
  for (int k = 0; k < 20; ++k) {
    const VectorXd q = RandomConfiguration(1, rng);
    const VectorXd v = RandomVector(kFreeFlyerNv + 1, -2.0, 2.0, rng);
    VectorXd plus(q.size()), minus(q.size()), rate(q.size());
    Integrate(q, v, eps, plus);
    Integrate(q, v, -eps, minus);
    const Eigen::Quaterniond quat(q[6], q[3], q[4], q[5]);
    rate.head<3>() = quat.toRotationMatrix() * v.head<3>();
    rate.segment<4>(3) = 0.5 * (quat * Eigen::Quaterniond(0.0, v[3], v[4], v[5])).coeffs();
    rate.tail(1) = v.tail(1);
    EXPECT_LT(((plus - minus) / (2.0 * eps) - rate).norm(), 1e-8) << "case " << k;
  }
}

// The world momentum (angular about the origin, then linear) of a base momentum
// μ = (linear, angular) in the axes of the base at pose q.
Eigen::Matrix<double, 6, 1> WorldMomentum(const VectorXd& q, const Eigen::Matrix<double, 6, 1>& mu) {
  const Eigen::Matrix3d R = Eigen::Quaterniond(q[6], q[3], q[4], q[5]).toRotationMatrix();
  const Eigen::Vector3d linear = R * mu.head<3>();
  Eigen::Matrix<double, 6, 1> out;
  out << R * mu.tail<3>() + q.head<3>().cross(linear), linear;
  return out;
}

constexpr double kCayleyMomentumTol = 1e-14;  // relative to ‖μ‖ (1 + ‖ξ‖)², measured 1.6e-16

TEST(FreeFlyer, TheCayleyStepsTwoBaseMomentaAreOneInTheWorld) {
  // (dcay⁻¹_ξ)ᵀ μ at g0 and (dcay⁻¹_−ξ)ᵀ μ at g0 cay(ξ) are the same world
  // momentum: the discrete Noether theorem of the variational step.
  std::mt19937 rng{42};
  double worst = 0.0;
  for (int k = 0; k < 200; ++k) {
    const VectorXd q0 = RandomConfiguration(0, rng);
    const Eigen::Matrix<double, 6, 1> xi = RandomVector(6, -2.0, 2.0, rng), mu = RandomVector(6, -3.0, 3.0, rng);
    VectorXd q1(q0.size());
    IntegrateCayley(q0, xi, q1);
    const Eigen::Matrix<double, 6, 1> before = WorldMomentum(q0, CayleyMomentum(xi, mu));
    const Eigen::Matrix<double, 6, 1> after = WorldMomentum(q1, CayleyMomentum(-xi, mu));
    const Eigen::Matrix<double, 6, 1> moved = CayleyTransport(xi, CayleyMomentum(xi, mu));
    const double scale = (1.0 + q0.head<3>().norm()) * mu.norm() * std::pow(1.0 + xi.norm(), 2);
    worst = std::max(worst, (after - before).norm() / scale);
    worst = std::max(worst, (moved - CayleyMomentum(-xi, mu)).norm() / scale);
    EXPECT_LT(QuaternionNormError(q1), kUnitTol);
  }
  EXPECT_LT(worst, kCayleyMomentumTol);
  char text[32];
  std::snprintf(text, sizeof text, "%.3g", worst);
  RecordProperty("relative_error", text);
}

TEST(FreeFlyer, IntegrateCayleyAgreesWithExpToSecondOrder) {
  // cay(ξ) = exp(ξ) + O(‖ξ‖³): a tenth of ξ, a thousandth of the gap.
  std::mt19937 rng{42};
  const VectorXd q = RandomConfiguration(2, rng);
  const VectorXd xi = RandomVector(kFreeFlyerNv + 2, -1.0, 1.0, rng);
  auto gap = [&](double s) {
    VectorXd by_exp(q.size()), by_cayley(q.size());
    Integrate(q, xi, s, by_exp);
    IntegrateCayley(q, s * xi, by_cayley);
    return (by_exp - by_cayley).norm();
  };
  const double ratio = gap(0.1) / gap(0.01);
  EXPECT_GT(ratio, 900.0);
  EXPECT_LT(ratio, 1100.0);
}

// A lone body with an asymmetric inertia (principal moments 0.1, 0.2, 0.25
// kg·m², centre of mass off its origin), no gravity, tumbling.
RigidTree TumblingBody() {
  RigidTree tree;
  tree.floating_base = true;
  tree.base.mass = 2.0;
  tree.base.com = Eigen::Vector3d(0.05, -0.02, 0.03);
  tree.base.inertia = Eigen::Vector3d(0.1, 0.2, 0.25).asDiagonal();
  tree.gravity.setZero();
  return tree;
}

struct Drift {
  double energy = 0.0, momentum = 0.0, unit = 0.0;
};

// rk4 (or `type`) for `steps` of h from (q, v) with zero torques: the largest
// relative energy and momentum errors and quaternion-norm error on the way.
Drift DriftOver(const FloatingDynamics& model, IntegratorType type, double h, int steps, VectorXd q, VectorXd v) {
  FloatingIntegrator integrator(type, model);
  auto data = model.MakeData();
  const VectorXd tau = VectorXd::Zero(model.num_v());
  const double E0 = model.ComputeKineticEnergy(*data, q, v);
  const spatial::Force h0 = model.ComputeMomentum(*data, q, v);
  const double h0_norm = std::hypot(h0.n.norm(), h0.f.norm());
  Drift drift;
  for (int s = 0; s < steps; ++s) {
    integrator.Step(h, tau, {}, q, v);
    const spatial::Force hs = model.ComputeMomentum(*data, q, v);
    drift.energy = std::max(drift.energy, std::abs(model.ComputeKineticEnergy(*data, q, v) - E0) / E0);
    drift.momentum = std::max(drift.momentum, std::hypot((hs.n - h0.n).norm(), (hs.f - h0.f).norm()) / h0_norm);
    drift.unit = std::max(drift.unit, QuaternionNormError(q));
  }
  return drift;
}

TEST(FloatingIntegrator, Rk4KeepsATumblingBodysEnergyAndMomentum) {
  const FloatingDynamics model(TumblingBody());
  std::mt19937 rng{42};
  VectorXd q = RandomConfiguration(0, rng);
  VectorXd v(6);
  v << 0.3, -0.2, 0.1, 0.05, 3.0, 0.05;  // ω near the intermediate principal axis (y), so it flips
  const Drift drift = DriftOver(model, IntegratorType::kRk4, 1e-3, 10000, q, v);
  EXPECT_LT(drift.energy, kRk4EnergyTol);
  EXPECT_LT(drift.momentum, kRk4MomentumTol);
  EXPECT_LT(drift.unit, kUnitTol);
  char text[64];
  std::snprintf(text, sizeof text, "energy %.3g momentum %.3g unit %.3g", drift.energy, drift.momentum, drift.unit);
  RecordProperty("drift", text);
}

TEST(FloatingIntegrator, Rk4KeepsAFloatingTreesEnergyAndMomentum) {
  std::mt19937 rng{42};
  RigidTree tree = RandomFloatingTree(4, rng);
  tree.gravity.setZero();
  const FloatingDynamics model(tree);
  const VectorXd q = RandomConfiguration(4, rng);
  const VectorXd v = RandomVector(model.num_v(), -1.0, 1.0, rng);
  const Drift drift = DriftOver(model, IntegratorType::kRk4, 1e-3, 10000, q, v);
  EXPECT_LT(drift.energy, kRk4EnergyTol);
  EXPECT_LT(drift.momentum, kRk4MomentumTol);
  EXPECT_LT(drift.unit, kUnitTol);
}

// The state's error after 1 s against a run at h/16, measured by Difference.
double ErrorAfterOneSecond(const FloatingDynamics& model, IntegratorType type, double h) {
  std::mt19937 rng{7};
  const VectorXd q0 = RandomConfiguration(model.num_joints(), rng);
  const VectorXd v0 = RandomVector(model.num_v(), -1.5, 1.5, rng);
  auto run = [&](double step) {
    FloatingIntegrator integrator(type, model);
    VectorXd q = q0, v = v0;
    const VectorXd tau = VectorXd::Zero(model.num_v());
    for (int s = 0; s < static_cast<int>(std::lround(1.0 / step)); ++s) integrator.Step(step, tau, {}, q, v);
    return std::pair{q, v};
  };
  const auto [q, v] = run(h);
  const auto [qr, vr] = run(h / 16.0);
  VectorXd dq(model.num_v());
  Difference(qr, q, dq);
  return dq.norm() + (v - vr).norm();
}

// Over 10 s at 1 ms. Measured (Release, g++ 12, x86-64): the body's energy
// 5.3e-7 and the tree's 4.3e-7, bounded (it oscillates, no drift); momentum
// 1.3e-12 and 1.1e-12 relative: round-off, about one ulp a step accumulating
// (the rotations' rounding; a zero momentum stays zero to 1e-14 of the
// joints' momenta: tests/plant/floating_hard_cases_test.cpp); quaternion
// norm 2.2e-16.
constexpr double kVariationalEnergyTol = 1e-5;     // relative: second order, bounded
constexpr double kVariationalMomentumTol = 1e-11;  // relative: round-off over 10⁴ steps

TEST(FloatingIntegrator, VariationalKeepsMomentumToRoundOffAndEnergyBounded) {
  const FloatingDynamics body(TumblingBody());
  std::mt19937 rng{42};
  VectorXd q = RandomConfiguration(0, rng);
  VectorXd v(6);
  v << 0.3, -0.2, 0.1, 0.05, 3.0, 0.05;
  const Drift tumbling = DriftOver(body, IntegratorType::kVariational, 1e-3, 10000, q, v);
  RigidTree tree = RandomFloatingTree(4, rng);
  tree.gravity.setZero();
  const FloatingDynamics model(tree);
  const Drift branching = DriftOver(model, IntegratorType::kVariational, 1e-3, 10000, RandomConfiguration(4, rng),
                                    RandomVector(model.num_v(), -1.0, 1.0, rng));
  for (const Drift& drift : {tumbling, branching}) {
    EXPECT_LT(drift.energy, kVariationalEnergyTol);
    EXPECT_LT(drift.momentum, kVariationalMomentumTol);
    EXPECT_LT(drift.unit, kUnitTol);
  }
  char text[128];
  std::snprintf(text, sizeof text, "body: energy %.3g momentum %.3g unit %.3g; tree: energy %.3g momentum %.3g",
                tumbling.energy, tumbling.momentum, tumbling.unit, branching.energy, branching.momentum);
  RecordProperty("drift", text);
}

TEST(FloatingIntegrator, OrdersHoldOnTheManifold) {
  // Halving the step divides the error by 2^order: rk4 16, the Eulers 2.
  std::mt19937 rng{42};
  const FloatingDynamics model(RandomFloatingTree(3, rng));
  const double rk4 = ErrorAfterOneSecond(model, IntegratorType::kRk4, 0.02) /
                     ErrorAfterOneSecond(model, IntegratorType::kRk4, 0.01);
  EXPECT_GT(rk4, 12.0);
  EXPECT_LT(rk4, 20.0);
  for (const IntegratorType type : {IntegratorType::kExplicitEuler, IntegratorType::kSemiImplicitEuler}) {
    const double ratio = ErrorAfterOneSecond(model, type, 0.002) / ErrorAfterOneSecond(model, type, 0.001);
    EXPECT_GT(ratio, 1.7);
    EXPECT_LT(ratio, 2.5);
  }
  const double variational = ErrorAfterOneSecond(model, IntegratorType::kVariational, 0.02) /
                             ErrorAfterOneSecond(model, IntegratorType::kVariational, 0.01);
  RecordProperty("variational_ratio", std::to_string(variational));
  EXPECT_GT(variational, 3.4);  // order 2
  EXPECT_LT(variational, 4.6);
}

TEST(FloatingIntegrator, AFloatingChainAtZeroMomentumReorientsAndKeepsIt) {
  // The falling cat: no gravity, zero momentum, the joints driven by a PD law
  // to a swinging target (internal torques, held over each 1 ms rk4 step) for
  // 10 s. The momentum stays zero (to rk4's error); the base turns all the same.
  std::mt19937 rng{42};
  RandomTreeOptions options;
  options.bodies = 4;
  options.chain = true;
  options.prismatic_fraction = 0.0;
  RigidTree tree = RandomFloatingTree(options, rng);
  tree.gravity.setZero();
  const FloatingDynamics model(tree);
  auto data = model.MakeData();
  const VectorXd q0 = RandomConfiguration(4, rng);
  VectorXd q = q0, v = VectorXd::Zero(model.num_v()), tau = VectorXd::Zero(model.num_v());
  FloatingIntegrator integrator(IntegratorType::kRk4, model);
  const double h = 1e-3;
  double worst = 0.0;
  for (int s = 0; s < 10000; ++s) {
    const double target = std::sin(2.0 * s * h);
    for (int j = 0; j < 4; ++j) {
      tau[6 + j] = 5.0 * ((j % 2 ? target : -target) - q[kFreeFlyerNq + j]) - 0.5 * v[6 + j];
    }
    integrator.Step(h, tau, {}, q, v);
    const spatial::Force momentum = model.ComputeMomentum(*data, q, v);
    worst = std::max(worst, std::hypot(momentum.n.norm(), momentum.f.norm()));
  }
  EXPECT_LT(worst, kZeroMomentumTol);
  VectorXd turned(model.num_v());
  Difference(q0, q, turned);
  EXPECT_GT(turned.segment<3>(3).norm(), 0.01);  // rad: it reoriented
  char text[64];
  std::snprintf(text, sizeof text, "momentum %.3g N·s, turned %.3g rad", worst, turned.segment<3>(3).norm());
  RecordProperty("zero_momentum", text);
}

TEST(FloatingIntegrator, StepAllocatesNothing) {
  std::mt19937 rng{42};
  const FloatingDynamics model(RandomFloatingTree(5, rng));
  for (const IntegratorType type :
       {IntegratorType::kExplicitEuler, IntegratorType::kSemiImplicitEuler, IntegratorType::kRk4,
        IntegratorType::kVariational}) {
    FloatingIntegrator integrator(type, model);
    VectorXd q = RandomConfiguration(5, rng);
    VectorXd v = RandomVector(model.num_v(), -1.0, 1.0, rng);
    const VectorXd tau = RandomVector(model.num_v(), -1.0, 1.0, rng);
    testing::AllocationCounter counter;
    for (int k = 0; k < 3; ++k) integrator.Step(1e-3, tau, {}, q, v);  // the variational Jacobian built, then kept
    EXPECT_EQ(counter.count(), 0) << ToString(type);
  }
}

TEST(FloatingIntegrator, RefusesIntegratorsNotOnTheManifold) {
  const FloatingDynamics model(TumblingBody());
  EXPECT_THROW(FloatingIntegrator(IntegratorType::kDormandPrince, model), std::invalid_argument);
}

}  // namespace
}  // namespace lagrange
