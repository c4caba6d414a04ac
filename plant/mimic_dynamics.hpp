#pragma once
// The dynamics of a tree with mimic joints (plant/rigid_tree.hpp) over its
// degrees of freedom, from the dynamics of the same tree with every joint
// free (RigidTree::WithEveryJointFree), by the constant reduction
//
//   q_j = S q + o,  qd_j = S qd,  qdd_j = S qdd        (S: num_joints x n)
//
//   M(q)      = Sᵀ M_j(q_j) S
//   C(q, qd)  = Sᵀ C_j(q_j, qd_j) S       (Ṁ − 2C = Sᵀ(Ṁ_j − 2C_j)S stays skew)
//   C qd      = Sᵀ (C_j qd_j)
//   G(q)      = Sᵀ G_j(q_j)
//   ∂T/∂q     = Sᵀ ∂T_j/∂q_j,  T and V unchanged
//   ∂tau/∂x   = Sᵀ ∂tau_j/∂x_j S  for x = q, qd, qdd (tau = Sᵀ tau_j(S q + o, S qd, S qdd))
//   ∂G/∂q     = Sᵀ ∂G_j/∂q_j S
//
// since T(q, qd) = T_j(S q + o, S qd) and V(q) = V_j(S q + o). A mimic's
// generalized force lands on the joint it follows, scaled by its multiplier
// (Sᵀ). Inverse and forward dynamics are the generic ones of Dynamics over
// the reduced M, C qd and G: forward dynamics solves the reduced M by
// Cholesky (an articulated-body pass over the free tree would give the free
// tree's accelerations, not the constrained ones). The Lagrangian path needs
// none of this: its energies are over the degrees of freedom already.
//
// Model and data apart: the free tree's dynamics is this model's, shared and
// immutable; MimicDynamics' data holds the free tree's data and the joint-
// space buffers, so no query allocates.

#include <memory>
#include <vector>

#include "plant/dynamics.hpp"
#include "plant/rigid_tree.hpp"

namespace lagrange {

class MimicDynamics final : public Dynamics {
 public:
  // `free` the dynamics of tree.WithEveryJointFree(), by any method. Throws
  // std::invalid_argument when `tree` is not valid (ValidateRigidTree), has
  // no mimic, or `free` is null or of another size.
  MimicDynamics(const RigidTree& tree, std::shared_ptr<const Dynamics> free);

  Method method() const override { return free_->method(); }
  std::unique_ptr<DynamicsData> MakeData() const override;
  const Dynamics& free_dynamics() const { return *free_; }

  void ComputeMassMatrix(DynamicsData& data, ConstVecRef q, MatRef M) const override;
  void ComputeCoriolisMatrix(DynamicsData& data, ConstVecRef q, ConstVecRef qd, MatRef C) const override;
  void ComputeCoriolisForce(DynamicsData& data, ConstVecRef q, ConstVecRef qd, VecRef c) const override;
  void ComputeGravityForce(DynamicsData& data, ConstVecRef q, VecRef G) const override;
  void ComputeKineticEnergyGradient(DynamicsData& data, ConstVecRef q, ConstVecRef qd, VecRef dTdq) const override;
  double ComputeKineticEnergy(DynamicsData& data, ConstVecRef q, ConstVecRef qd) const override;
  double ComputePotentialEnergy(DynamicsData& data, ConstVecRef q) const override;
  void ComputeInverseDynamicsDerivatives(DynamicsData& data, ConstVecRef q, ConstVecRef qd, ConstVecRef qdd,
                                         DynamicsTerms terms, MatRef dtau_dq, MatRef dtau_dqd,
                                         MatRef dtau_dqdd) const override;
  void ComputeGravityDerivatives(DynamicsData& data, ConstVecRef q, MatRef dG_dq) const override;

 private:
  struct Data;

  // (q, qd) => the joints' q_j = S q + o and qd_j = S qd, into the data.
  void Expand(Data& d, ConstVecRef q, ConstVecRef qd) const;
  void ExpandPosition(Data& d, ConstVecRef q) const;
  // x_j (num_joints) => Sᵀ x_j (n).
  void Reduce(ConstVecRef x_joints, VecRef out) const;
  // A_j (num_joints²) => Sᵀ A_j S (n x n).
  void Reduce(const MatrixXd& A_joints, MatRef out) const;

  std::shared_ptr<const Dynamics> free_;
  std::vector<RigidTree::JointMap> maps_;  // (num_joints) each joint's row of S and entry of o
};

}  // namespace lagrange
