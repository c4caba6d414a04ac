#pragma once
// Pendulum: one revolute joint, θ = 0 hanging straight down, counter-clockwise
// positive. A point mass m at distance L, or a uniform rod of mass m and
// length L (centre of mass at L/2, inertia mL²/12 about it).
//   T = ½ m |ṗ_c|² + ½ I_c θ̇²,  p_c = l_c (sin θ, −cos θ)
//   V = −m g l_c cos θ          (zero at the pivot's height)

#include <numbers>
#include <span>
#include <vector>

#include "plant/dynamics.hpp"
#include "plant/rigid_tree.hpp"

namespace lagrange {

enum class PendulumBody : std::uint8_t { kPointMass, kRod };

struct PendulumParams {
  double m = 1.0;  // kg
  double L = 1.0;  // m
  PendulumBody body = PendulumBody::kPointMass;
  double g = kStandardGravity;

  double com() const { return body == PendulumBody::kRod ? 0.5 * L : L; }  // m
  double com_inertia() const { return body == PendulumBody::kRod ? m * L * L / 12.0 : 0.0; }
  double pivot_inertia() const { return m * com() * com() + com_inertia(); }  // kg·m²
};

class Pendulum {
 public:
  explicit Pendulum(PendulumParams p) : p_(p) {}
  const PendulumParams& params() const { return p_; }
  std::vector<JointType> joint_types() const { return {JointType::kRevolute}; }

  template <class S>
  S KineticEnergy(std::span<const S> q, std::span<const S> qd) const {
    using std::cos;
    using std::sin;
    const double l = p_.com();
    const S xd = l * cos(q[0]) * qd[0];
    const S yd = l * sin(q[0]) * qd[0];
    return 0.5 * p_.m * (xd * xd + yd * yd) + 0.5 * p_.com_inertia() * qd[0] * qd[0];
  }
  template <class S>
  S PotentialEnergy(std::span<const S> q) const {
    using std::cos;
    return -(p_.m * p_.g * p_.com()) * cos(q[0]);
  }

 private:
  PendulumParams p_;
};

// The pendulum as a tree: joint "theta" at the origin, its link pointing along −y at θ = 0.
// Frame "bob" at the link's end, L (sin θ, −cos θ, 0), x along the link, z out of the plane.
RigidTree ToRigidTree(const PendulumParams& p);

class PendulumClosedForm final : public Dynamics {
 public:
  explicit PendulumClosedForm(PendulumParams p);
  Method method() const override { return Method::kClosedForm; }
  void ComputeMassMatrix(DynamicsData& data, ConstVecRef q, MatRef M) const override;
  void ComputeCoriolisMatrix(DynamicsData& data, ConstVecRef q, ConstVecRef qd, MatRef C) const override;
  void ComputeCoriolisForce(DynamicsData& data, ConstVecRef q, ConstVecRef qd, VecRef c) const override;
  void ComputeGravityForce(DynamicsData& data, ConstVecRef q, VecRef G) const override;
  void ComputeKineticEnergyGradient(DynamicsData& data, ConstVecRef q, ConstVecRef qd, VecRef dTdq) const override;
  double ComputeKineticEnergy(DynamicsData& data, ConstVecRef q, ConstVecRef qd) const override;
  double ComputePotentialEnergy(DynamicsData& data, ConstVecRef q) const override;
  void ComputeForwardDynamics(DynamicsData& data, ConstVecRef q, ConstVecRef qd, ConstVecRef tau, DynamicsTerms terms,
                              VecRef qdd) const override;
  void ComputeInverseDynamicsDerivatives(DynamicsData& data, ConstVecRef q, ConstVecRef qd, ConstVecRef qdd,
                                         DynamicsTerms terms, MatRef dtau_dq, MatRef dtau_dqd,
                                         MatRef dtau_dqdd) const override;
  void ComputeGravityDerivatives(DynamicsData& data, ConstVecRef q, MatRef dG_dq) const override;

 private:
  double inertia_;  // about the pivot, kg·m²
  double mgl_;      // m g l_c, N·m
};

}  // namespace lagrange
