#pragma once
// Cart-pole: q = (x, θ). The cart slides along x; the pole hangs from the
// cart with θ from the downward vertical, counter-clockwise positive, θ = π
// upright. Pole centre of mass at (x + l sin θ, −l cos θ); I is the pole's
// inertia about its centre of mass (a point-mass pole has I = 0).
//   T = ½ mc ẋ² + ½ mp |ṗ_c|² + ½ I θ̇²
//   V = −mp g l cos θ   (zero at the pivot's height)

#include <optional>
#include <span>
#include <vector>

#include "plant/dynamics.hpp"
#include "plant/rigid_tree.hpp"

namespace lagrange {

struct CartPoleParams {
  double mc = 1.0;          // cart mass, kg
  double mp = 0.1;          // pole mass, kg
  double l = 0.5;           // pivot to pole centre of mass, m
  std::optional<double> I;  // pole inertia about its centre of mass, kg·m²; default: uniform rod of length 2l
  double g = kStandardGravity;

  double pole_inertia() const { return I.value_or(mp * (2.0 * l) * (2.0 * l) / 12.0); }
};

class CartPole {
 public:
  explicit CartPole(CartPoleParams p) : p_(p) {}
  const CartPoleParams& params() const { return p_; }
  std::vector<JointType> joint_types() const { return {JointType::kPrismatic, JointType::kRevolute}; }

  template <class S>
  S KineticEnergy(std::span<const S> q, std::span<const S> qd) const {
    using std::cos;
    using std::sin;
    const S xd = qd[0] + p_.l * cos(q[1]) * qd[1];
    const S yd = p_.l * sin(q[1]) * qd[1];
    return 0.5 * p_.mc * qd[0] * qd[0] + 0.5 * p_.mp * (xd * xd + yd * yd) + 0.5 * p_.pole_inertia() * qd[1] * qd[1];
  }
  template <class S>
  S PotentialEnergy(std::span<const S> q) const {
    using std::cos;
    return -(p_.mp * p_.g * p_.l) * cos(q[1]);
  }

 private:
  CartPoleParams p_;
};

// The cart-pole as a tree: joint "x" sliding along the world's x, the pole's
// joint "theta" at the cart's origin, its link pointing along −y at θ = 0.
// Frames (z out of the plane): "cart" at (x, 0, 0) with the world's axes,
// "pole" at the pivot with x along the pole, "pole_tip" at the end of a pole
// of length 2l (a uniform rod's), (x + 2l sin θ, −2l cos θ, 0).
RigidTree ToRigidTree(const CartPoleParams& p);

// M = [[mc + mp, mp l cos θ], [mp l cos θ, mp l² + I]], C = [[0, −mp l θ̇ sin θ], [0, 0]],
// G = [0, mp g l sin θ].
// Derivatives by hand from these (only θ and θ̇ enter); forward dynamics' with M⁻¹ written out (2 x 2).
class CartPoleClosedForm final : public Dynamics {
 public:
  explicit CartPoleClosedForm(CartPoleParams p);
  Method method() const override { return Method::kClosedForm; }
  void ComputeMassMatrix(DynamicsData& data, ConstVecRef q, MatRef M) const override;
  void ComputeCoriolisMatrix(DynamicsData& data, ConstVecRef q, ConstVecRef qd, MatRef C) const override;
  void ComputeCoriolisForce(DynamicsData& data, ConstVecRef q, ConstVecRef qd, VecRef c) const override;
  void ComputeGravityForce(DynamicsData& data, ConstVecRef q, VecRef G) const override;
  void ComputeKineticEnergyGradient(DynamicsData& data, ConstVecRef q, ConstVecRef qd, VecRef dTdq) const override;
  double ComputeKineticEnergy(DynamicsData& data, ConstVecRef q, ConstVecRef qd) const override;
  double ComputePotentialEnergy(DynamicsData& data, ConstVecRef q) const override;
  void ComputeInverseDynamics(DynamicsData& data, ConstVecRef q, ConstVecRef qd, ConstVecRef qdd, DynamicsTerms terms,
                              VecRef tau) const override;
  void ComputeForwardDynamics(DynamicsData& data, ConstVecRef q, ConstVecRef qd, ConstVecRef tau, DynamicsTerms terms,
                              VecRef qdd) const override;
  void ComputeInverseDynamicsDerivatives(DynamicsData& data, ConstVecRef q, ConstVecRef qd, ConstVecRef qdd,
                                         DynamicsTerms terms, MatRef dtau_dq, MatRef dtau_dqd,
                                         MatRef dtau_dqdd) const override;
  void ComputeGravityDerivatives(DynamicsData& data, ConstVecRef q, MatRef dG_dq) const override;
  void ComputeForwardDynamicsDerivatives(DynamicsData& data, ConstVecRef q, ConstVecRef qd, ConstVecRef tau,
                                         DynamicsTerms terms, VecRef qdd, MatRef dqdd_dq, MatRef dqdd_dqd,
                                         MatRef dqdd_dtau) const override;

 private:
  double mt_;   // mc + mp
  double ml_;   // mp l
  double Ip_;   // mp l² + I, about the pivot
  double mgl_;  // mp g l
};

}  // namespace lagrange
