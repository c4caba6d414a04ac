#pragma once
// The Lagrangian path of a floating-base tree, by the Euler–Poincaré form of
// the Euler–Lagrange equations (Marsden & Ratiu, Introduction to Mechanics and
// Symmetry, §13; Boltzmann–Hamel): independent of FloatingDynamics' recursive
// algorithms, from the same templated energies the fixed-base Lagrangian path
// differentiates (plant/rigid_tree_energy.hpp), by dual numbers.
//
// The Lagrangian ℓ(g, r, v) = T(r, v) − V(g, r) is written on the base twist
// in base axes ξ = (v_b, ω_b) and the joint rates ṙ, v = (ξ, ṙ) (nv), with g the
// base's pose (R, p) and r the joints' degrees of freedom. T is left-invariant
// (it does not depend on g), so for the base
//   d/dt (∂ℓ/∂ξ) − ad*_ξ (∂ℓ/∂ξ) = ∂ℓ/∂g (left-trivialised) + w_base
// with ad*_ξ μ = −ξ ×* μ (spatial force cross product; μ = (linear, angular
// momentum) in base axes) and ∂ℓ/∂g_k = d/dε ℓ(g exp(ε e_k)) at ε = 0, and for
// the joints the Euler–Lagrange equations d/dt (∂ℓ/∂ṙ) − ∂ℓ/∂r = τ. So:
//   M_ij    = ∂²T/∂v_i∂v_j                                (ε1 on v_i, ε2 on v_j)
//   C v     = d/dt(∂T/∂v)|_{v̇=0} + (ξ ×* μ_base, −∂T/∂r)  (ε1 on v_i, ε2 moving r along ṙ)
//   G       = (∂V/∂g left-trivialised, ∂V/∂r)            (ε on g exp(ε e_k) to first order, on r_j)
//   tau     = M a + [C v] + [G],  a = M⁻¹ (tau − [C v] − [G])  (Cholesky written out)
// with a, tau as FloatingDynamics' (the base's entries v̇_b, ω̇_b and the base
// wrench in base axes, force then moment). Mimic joints come for free: the
// energies are over the degrees of freedom. Costs: nv(nv+1)/2 energy
// evaluations for M, nv + n for C v, 6 + n for G, each O(n): a reference path,
// not the fast one.

#include <memory>
#include <vector>

#include "plant/dual.hpp"
#include "plant/rigid_tree.hpp"
#include "plant/types.hpp"

namespace lagrange {

class FloatingLagrangian;

// One user's seeds and scratch, sized by FloatingLagrangian::MakeData.
class FloatingLagrangianData {
 public:
  explicit FloatingLagrangianData(const FloatingLagrangian& model);
  const FloatingLagrangian& model() const { return *model_; }

 private:
  friend class FloatingLagrangian;
  const FloatingLagrangian* model_;
  std::vector<Dual1> r1, v1;   // (n), (nv)
  std::vector<Dual2> r2, v2;   // (n), (nv)
  MatrixXd M;                  // (nv x nv) forward dynamics' mass matrix, then its Cholesky factor
  VectorXd bias;               // (nv)
};

class FloatingLagrangian {
 public:
  // Throws std::invalid_argument with ValidateFloatingTree's reason.
  explicit FloatingLagrangian(RigidTree tree);

  const RigidTree& tree() const { return tree_; }
  int num_q() const { return tree_.num_q(); }
  int num_v() const { return tree_.num_v(); }
  std::unique_ptr<FloatingLagrangianData> MakeData() const;

  // q (nq) => M (nv x nv).
  void ComputeMassMatrix(FloatingLagrangianData& data, ConstVecRef q, MatRef M) const;
  // (q, v) (nq, nv) => [C v] + [G] (nv).
  void ComputeBias(FloatingLagrangianData& data, ConstVecRef q, ConstVecRef v, DynamicsTerms terms, VecRef bias) const;
  // (q, v, a) => tau = M a + [C v] + [G] (nv).
  void ComputeInverseDynamics(FloatingLagrangianData& data, ConstVecRef q, ConstVecRef v, ConstVecRef a,
                              DynamicsTerms terms, VecRef tau) const;
  // (q, v, tau) => a = M⁻¹ (tau − [C v] − [G]) (nv).
  void ComputeForwardDynamics(FloatingLagrangianData& data, ConstVecRef q, ConstVecRef v, ConstVecRef tau,
                              DynamicsTerms terms, VecRef a) const;
  // (q, v) (nq, nv) => ∂T/∂r (num_dofs()): the kinetic energy's gradient in the
  // joints' degrees of freedom at v held, N·m or N (exact, by dual numbers; the
  // variational floating integrator's joint force, plant/floating_integrator.hpp).
  void ComputeKineticEnergyGradient(FloatingLagrangianData& data, ConstVecRef q, ConstVecRef v, VecRef grad) const;
  // (q, v) => T, J; q => V, J (as FloatingDynamics').
  double ComputeKineticEnergy(FloatingLagrangianData& data, ConstVecRef q, ConstVecRef v) const;
  double ComputePotentialEnergy(FloatingLagrangianData& data, ConstVecRef q) const;

 private:
  void CheckSizes(const FloatingLagrangianData& data, ConstVecRef q) const;
  template <class S>
  S Kinetic(const std::vector<S>& r, const std::vector<S>& v) const;

  RigidTree tree_;
  int n_ = 0;  // degrees of freedom of the joints
};

}  // namespace lagrange
