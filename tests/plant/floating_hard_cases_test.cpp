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

TEST(FloatingHardCases, FreeFallCentreOfMassIsAParabolaWhateverTheJointsDo) {
  // Gravity alone acts from outside; the joints are driven by torques (internal,
  // the base wrench zero), and the tree tumbles: c(t) = c0 + ċ0 t + ½ g t².
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
  FloatingIntegrator integrator(IntegratorType::kRk4, model);
  const double h = 1e-4;
  double worst = 0.0;
  for (int s = 1; s <= 10000; ++s) {
    for (int j = 0; j < model.num_dofs(); ++j) tau[6 + j] = 2.0 * std::sin(3.0 * s * h + j);  // N·m or N
    integrator.Step(h, tau, {}, q, v);
    if (s % 10 != 0) continue;
    const double t = s * h;
    const Eigen::Vector3d c = model.ComputeCenterOfMass(*data, q, Jc);
    worst = std::max(worst, (c - (c0 + cd0 * t + 0.5 * model.tree().gravity * t * t)).norm());
  }
  EXPECT_LT(worst, kFreeFallTol);
  char text[32];
  std::snprintf(text, sizeof text, "%.3g m", worst);
  RecordProperty("centre_of_mass_error", text);
}

}  // namespace
}  // namespace lagrange
