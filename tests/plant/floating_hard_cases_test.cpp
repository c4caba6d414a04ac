// Hard cases of a floating base, each a physics fact kept over long runs by
// the manifold integrators (plant/floating_integrator.hpp): the tennis racket
// (Dzhanibekov) flip about the intermediate principal axis and the stable spin
// about the major one, and free fall of the centre of mass under internal
// joint torques. Bounds are the README's ("### Floating base"); each measured
// figure is recorded as a test property.

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <cstdio>
#include <random>

#include "plant/floating_dynamics.hpp"
#include "plant/floating_integrator.hpp"
#include "plant/free_flyer.hpp"
#include "plant/random_tree.hpp"
#include "tests/support/plant_cases.hpp"

namespace lagrange {
namespace {

using testing::RandomVector;

// A free rigid body, no gravity, centre of mass at its origin, principal
// moments 0.1 (x, minor), 0.2 (y, intermediate), 0.25 kg·m² (z, major).
RigidTree Racket() {
  RigidTree tree;
  tree.floating_base = true;
  tree.base.mass = 1.5;
  tree.base.inertia = Eigen::Vector3d(0.1, 0.2, 0.25).asDiagonal();
  tree.gravity.setZero();
  return tree;
}

VectorXd Identity(int nq) {
  VectorXd q = VectorXd::Zero(nq);
  q[6] = 1.0;  // w
  return q;
}

struct Spin {
  int flips = 0;                  // sign changes of ω about the spin axis
  double energy = 0.0;            // max |T − T0| / T0
  double momentum = 0.0;          // max ‖h − h0‖ / ‖h0‖ (world, about the origin)
  double angle = 0.0;             // max angle of ω (body axes) to the spin axis, rad
};

// (type, ω0) for `seconds` at 1 kHz, torque-free: the flips about axis `k` and the drifts.
Spin SpinFor(IntegratorType type, const Eigen::Vector3d& w0, int k, double seconds) {
  const FloatingDynamics model(Racket());
  auto data = model.MakeData();
  FloatingIntegrator integrator(type, model);
  VectorXd q = Identity(model.num_q()), v(6), tau = VectorXd::Zero(6);
  v << 0.0, 0.0, 0.0, w0;
  const double T0 = model.ComputeKineticEnergy(*data, q, v);
  const spatial::Force h0 = model.ComputeMomentum(*data, q, v);
  const double h0_norm = h0.n.norm();
  Spin spin;
  double sign = w0[k] > 0.0 ? 1.0 : -1.0;
  const int steps = static_cast<int>(std::lround(seconds * 1000.0));
  for (int s = 0; s < steps; ++s) {
    integrator.Step(1e-3, tau, {}, q, v);
    const Eigen::Vector3d w = v.segment<3>(3);
    if (w[k] * sign < 0.0) {
      ++spin.flips;
      sign = -sign;
    }
    spin.angle = std::max(spin.angle, std::acos(std::min(1.0, std::abs(w[k]) / w.norm())));
    if (s % 10 == 9) {  // the drifts every 10 ms: the runs stay short under the sanitizers
      const spatial::Force h = model.ComputeMomentum(*data, q, v);
      spin.energy = std::max(spin.energy, std::abs(model.ComputeKineticEnergy(*data, q, v) - T0) / T0);
      spin.momentum = std::max(spin.momentum, std::hypot((h.n - h0.n).norm(), (h.f - h0.f).norm()) / h0_norm);
    }
  }
  return spin;
}

void Record(const char* key, const Spin& s) {
  char text[128];
  std::snprintf(text, sizeof text, "flips %d energy %.3g momentum %.3g angle %.3g rad", s.flips, s.energy, s.momentum,
                s.angle);
  ::testing::Test::RecordProperty(key, text);
}

// Bounds (README, "### Floating base"), over 60 s at 1 kHz; measured on
// g++ 12 Release x86-64 in brackets.
constexpr int kMinFlips = 3;                     // [4 flips of ω_y in 60 s, either integrator]
constexpr double kRk4SpinEnergyTol = 1e-12;      // relative [2.2e-14 intermediate, 1.5e-14 major]
constexpr double kRk4SpinMomentumTol = 1e-10;    // relative [4.3e-13 intermediate, 7.9e-12 major]
constexpr double kSemiImplicitEnergyTol = 5e-2;  // relative [1.1e-2: the explicit update of Euler's equations]
constexpr double kSemiImplicitMomentumTol = 2e-2;  // relative [5.4e-3]
constexpr double kMajorAxisAngleTol = 1e-4;      // rad, from 1.4e-5 at the start [1.6e-5]
constexpr double kFreeFallTol = 1e-12;           // m over 1 s, rk4 at 0.1 ms [2.7e-13; at 1 ms rk4's truncation, ∝ h⁴, is above it]

// The variational integrator, measured the same way. Its momentum error is
// round-off accumulating at about one ulp a step (linear in the number of
// steps, not in h), its energy error bounded (it oscillates, no drift).
constexpr double kVariationalSpinEnergyTol = 1e-5;      // relative, bounded [4.5e-7 intermediate, 1.2e-13 major]
constexpr double kVariationalSpinMomentumTol = 1e-10;   // relative [5.2e-12 intermediate, 2.4e-14 major]
constexpr double kVariationalZeroMomentumTol = 1e-13;   // relative to the momentum the joints alone carry [9.1e-15: 1.6e-13 of 18]
constexpr double kMinTurn = 0.1;                        // rad: the base reorients [1.67 rad]
constexpr double kVariationalFreeFallTol = 1e-5;        // m over 1 s at 1 ms, second order [1.3e-6]
constexpr double kVariationalVsRk4Tol = 1e-6;           // state gap after 0.2 s at 0.1 ms, O(h²) [2.2e-7; 8.9e-7 at 0.2 ms]
constexpr double kUnitQuaternionTol = 1e-12;

const Eigen::Vector3d kIntermediateSpin(1e-3, 3.0, 1e-3);  // rad/s: about y, perturbed
const Eigen::Vector3d kMajorSpin(1e-3, 1e-3, 100.0);       // rad/s: about z, 1.4e-5 rad off it

TEST(FloatingHardCases, IntermediateAxisSpinFlipsRepeatedlyUnderRk4) {
  const Spin spin = SpinFor(IntegratorType::kRk4, kIntermediateSpin, 1, 60.0);
  Record("rk4", spin);
  EXPECT_GE(spin.flips, kMinFlips);
  EXPECT_LT(spin.energy, kRk4SpinEnergyTol);
  EXPECT_LT(spin.momentum, kRk4SpinMomentumTol);
}

TEST(FloatingHardCases, IntermediateAxisSpinFlipsRepeatedlyUnderSemiImplicitEuler) {
  const Spin spin = SpinFor(IntegratorType::kSemiImplicitEuler, kIntermediateSpin, 1, 60.0);
  Record("semi_implicit_euler", spin);
  EXPECT_GE(spin.flips, kMinFlips);
  EXPECT_LT(spin.energy, kSemiImplicitEnergyTol);
  EXPECT_LT(spin.momentum, kSemiImplicitMomentumTol);
}

TEST(FloatingHardCases, MajorAxisSpinAt100RadPerSecondStaysUnderRk4) {
  // The semi-implicit and explicit Euler steps update Euler's equations
  // explicitly: at 100 rad/s and 1 ms they spiral away (README), so rk4 alone.
  const Spin spin = SpinFor(IntegratorType::kRk4, kMajorSpin, 2, 60.0);
  Record("rk4", spin);
  EXPECT_EQ(spin.flips, 0);
  EXPECT_LT(spin.angle, kMajorAxisAngleTol);
  EXPECT_LT(spin.energy, kRk4SpinEnergyTol);
  EXPECT_LT(spin.momentum, kRk4SpinMomentumTol);
}

TEST(FloatingHardCases, IntermediateAxisSpinFlipsRepeatedlyUnderVariational) {
  const Spin spin = SpinFor(IntegratorType::kVariational, kIntermediateSpin, 1, 60.0);
  Record("variational", spin);
  EXPECT_GE(spin.flips, kMinFlips);
  EXPECT_LT(spin.energy, kVariationalSpinEnergyTol);
  EXPECT_LT(spin.momentum, kVariationalSpinMomentumTol);
}

TEST(FloatingHardCases, MajorAxisSpinAt100RadPerSecondStaysUnderVariational) {
  const Spin spin = SpinFor(IntegratorType::kVariational, kMajorSpin, 2, 60.0);
  Record("variational", spin);
  EXPECT_EQ(spin.flips, 0);
  EXPECT_LT(spin.angle, kMajorAxisAngleTol);
  EXPECT_LT(spin.energy, kVariationalSpinEnergyTol);
  EXPECT_LT(spin.momentum, kVariationalSpinMomentumTol);
}

// A 4-link chain hung from a floating base, no gravity.
RigidTree FloatingChain(std::mt19937& rng) {
  RandomTreeOptions options;
  options.bodies = 4;
  options.chain = true;
  options.prismatic_fraction = 0.0;
  RigidTree tree = RandomFloatingTree(options, rng);
  tree.gravity.setZero();
  return tree;
}

TEST(FloatingHardCases, AFloatingChainKeepsZeroMomentumToRoundOffUnderVariational) {
  // The falling cat: at rest, no gravity, the joints driven for 10 s at 1 kHz
  // by a PD law to a swinging target (internal torques, held over each step).
  // The world momentum stays zero to round-off, measured against the momentum
  // the joints' motion alone would carry (the base's rows of M times (0, ṙ)),
  // which the base's motion cancels; the base turns all the same.
  std::mt19937 rng{42};
  const FloatingDynamics model(FloatingChain(rng));
  auto data = model.MakeData();
  const int n = model.num_dofs(), nv = model.num_v();
  VectorXd q0 = Identity(model.num_q());
  q0.tail(n) = RandomVector(n, -1.0, 1.0, rng);
  VectorXd q = q0, v = VectorXd::Zero(nv), tau = VectorXd::Zero(nv);
  MatrixXd M(nv, nv);
  FloatingIntegrator integrator(IntegratorType::kVariational, model);
  const double h = 1e-3;
  double worst = 0.0, scale = 0.0, unit = 0.0;
  for (int s = 0; s < 10000; ++s) {
    const double target = std::sin(2.0 * s * h);
    for (int j = 0; j < n; ++j) tau[6 + j] = 5.0 * ((j % 2 ? target : -target) - q[kFreeFlyerNq + j]) - 0.5 * v[6 + j];
    ASSERT_TRUE(integrator.Step(h, tau, {}, q, v)) << "step " << s;
    const spatial::Force momentum = model.ComputeMomentum(*data, q, v);
    worst = std::max(worst, std::hypot(momentum.n.norm(), momentum.f.norm()));
    model.ComputeMassMatrix(*data, q, M);
    scale = std::max(scale, (M.topRightCorner(6, n) * v.tail(n)).norm());
    unit = std::max(unit, std::abs(q.segment<4>(3).norm() - 1.0));
  }
  VectorXd turned(nv);
  Difference(q0, q, turned);
  EXPECT_LT(worst, kVariationalZeroMomentumTol * scale);
  EXPECT_GT(turned.segment<3>(3).norm(), kMinTurn);
  EXPECT_LT(unit, kUnitQuaternionTol);
  EXPECT_EQ(integrator.stats().failures, 0);
  char text[160];
  std::snprintf(text, sizeof text, "momentum %.3g (N·s, N·m·s) of %.3g: %.3g; turned %.3g rad; unit %.3g; newton %.2f/step",
                worst, scale, worst / scale, turned.segment<3>(3).norm(), unit,
                static_cast<double>(integrator.stats().newton_iterations) / 10000.0);
  RecordProperty("zero_momentum", text);
}

// Gravity alone acts from outside; the joints are driven by torques (internal, the base wrench zero), and a
// random tree tumbles: c(t) = c0 + ċ0 t + ½ g t². The largest distance of its centre of mass from that parabola,
// m, over `steps` steps of h under `type`, looked at every `every` steps.
double FreeFallWorstDeviation(IntegratorType type, double h, int steps, int every) {
  std::mt19937 rng{42};
  RandomTreeOptions options;
  options.bodies = 4;
  const FloatingDynamics model(RandomFloatingTree(options, rng));
  auto data = model.MakeData();
  VectorXd q = RandomVector(model.num_q(), -1.0, 1.0, rng);
  q.segment<4>(3) = Eigen::Quaterniond(RandomRotation(rng)).coeffs();
  VectorXd v = RandomVector(model.num_v(), -1.0, 1.0, rng), tau = VectorXd::Zero(model.num_v());
  MatrixXd Jc(3, model.num_v());
  const Eigen::Vector3d c0 = model.ComputeCenterOfMass(*data, q, Jc), cd0 = Jc * v;
  FloatingIntegrator integrator(type, model);
  double worst = 0.0;
  for (int s = 1; s <= steps; ++s) {
    for (int j = 0; j < model.num_dofs(); ++j) tau[6 + j] = 2.0 * std::sin(3.0 * s * h + j);  // N·m or N
    EXPECT_TRUE(integrator.Step(h, tau, {}, q, v)) << "step " << s;
    if (s % every != 0) continue;
    const double t = s * h;
    const Eigen::Vector3d c = model.ComputeCenterOfMass(*data, q, Jc);
    worst = std::max(worst, (c - (c0 + cd0 * t + 0.5 * model.tree().gravity * t * t)).norm());
  }
  return worst;
}

TEST(FloatingHardCases, FreeFallCentreOfMassIsAParabolaUnderVariational) {
  // As the rk4 case below, at 1 ms: the discrete momentum gains exactly h m g
  // a step, but the centre of mass lags it by the step's O(h²) error.
  const double worst = FreeFallWorstDeviation(IntegratorType::kVariational, 1e-3, 1000, 1);
  EXPECT_LT(worst, kVariationalFreeFallTol);
  char text[32];
  std::snprintf(text, sizeof text, "%.3g m", worst);
  RecordProperty("centre_of_mass_error", text);
}

TEST(FloatingHardCases, VariationalAgreesWithRk4ToItsOrder) {
  // A branching tree under gravity and joint torques, 0.2 s: the gap to rk4
  // (whose error is far smaller) falls fourfold when the step halves.
  std::mt19937 rng{7};
  RandomTreeOptions options;
  options.bodies = 3;
  const FloatingDynamics model(RandomFloatingTree(options, rng));
  VectorXd q0 = RandomVector(model.num_q(), -1.0, 1.0, rng);
  q0.segment<4>(3) = Eigen::Quaterniond(RandomRotation(rng)).coeffs();
  const VectorXd v0 = RandomVector(model.num_v(), -1.5, 1.5, rng);
  auto gap = [&](double h) {
    FloatingIntegrator variational(IntegratorType::kVariational, model), rk4(IntegratorType::kRk4, model);
    VectorXd qa = q0, va = v0, qb = q0, vb = v0, tau = VectorXd::Zero(model.num_v());
    const int steps = static_cast<int>(std::lround(0.2 / h));
    for (int s = 0; s < steps; ++s) {
      for (int j = 0; j < model.num_dofs(); ++j) tau[6 + j] = std::cos(5.0 * s * h + j);
      EXPECT_TRUE(variational.Step(h, tau, {}, qa, va));
      rk4.Step(h, tau, {}, qb, vb);
    }
    VectorXd dq(model.num_v());
    Difference(qb, qa, dq);
    return dq.norm() + (va - vb).norm();
  };
  const double coarse = gap(2e-4), fine = gap(1e-4);
  EXPECT_LT(fine, kVariationalVsRk4Tol);
  EXPECT_GT(coarse / fine, 3.4);
  EXPECT_LT(coarse / fine, 4.6);
  char text[64];
  std::snprintf(text, sizeof text, "gap %.3g at 0.2 ms, %.3g at 0.1 ms", coarse, fine);
  RecordProperty("gap", text);
}

TEST(FloatingHardCases, FreeFallCentreOfMassIsAParabolaWhateverTheJointsDo) {
  const double worst = FreeFallWorstDeviation(IntegratorType::kRk4, 1e-4, 10000, 10);
  EXPECT_LT(worst, kFreeFallTol);
  char text[32];
  std::snprintf(text, sizeof text, "%.3g m", worst);
  RecordProperty("centre_of_mass_error", text);
}

}  // namespace
}  // namespace lagrange
