#pragma once
// The dynamics contract every plant fulfils, whatever the method:
//
//   tau = M(q) qdd + C(q, qd) qd + G(q)
//
// with M = ∂²T/∂qd², C_ij = Σ_k ½(∂M_ij/∂q_k + ∂M_ik/∂q_j − ∂M_jk/∂q_i) qd_k and
// G = ∂V/∂q (see types.hpp for symbols, units and dimensions).
//
// A Dynamics object owns the scratch memory its algorithms need: every buffer
// is sized in the constructor, so no call below allocates. Parameters are fixed
// at construction. One object serves one thread; controllers hold their own.

#include <Eigen/Cholesky>
#include <vector>

#include "plant/types.hpp"

namespace lagrange {

class Dynamics {
 public:
  explicit Dynamics(std::vector<JointType> joints);
  virtual ~Dynamics() = default;
  Dynamics(const Dynamics&) = delete;
  Dynamics& operator=(const Dynamics&) = delete;

  int num_dofs() const { return static_cast<int>(joints_.size()); }
  const std::vector<JointType>& joint_types() const { return joints_; }
  virtual Method method() const = 0;

  // q (n) => M (n x n).
  virtual void ComputeMassMatrix(ConstVecRef q, MatRef M) = 0;
  // (q, qd) (n, n) => C (n x n), the Christoffel factorisation: Ṁ − 2C is skew.
  virtual void ComputeCoriolisMatrix(ConstVecRef q, ConstVecRef qd, MatRef C) = 0;
  // (q, qd) => c = C(q, qd) qd (n).
  virtual void ComputeCoriolisForce(ConstVecRef q, ConstVecRef qd, VecRef c) = 0;
  // q => G = ∂V/∂q (n).
  virtual void ComputeGravityForce(ConstVecRef q, VecRef G) = 0;
  // (q, qd) => ∂T/∂q (n), which equals Cᵀ qd. Used by the variational integrator.
  virtual void ComputeKineticEnergyGradient(ConstVecRef q, ConstVecRef qd, VecRef dTdq) = 0;
  // (q, qd) => T = ½ qdᵀ M qd, J.
  virtual double ComputeKineticEnergy(ConstVecRef q, ConstVecRef qd) = 0;
  // q => V, J; zero at the base's height, gravity along −y.
  virtual double ComputePotentialEnergy(ConstVecRef q) = 0;

  // (q, qd, qdd) => tau = M qdd + [C qd] + [G]; bracketed terms only when on in `terms`.
  virtual void ComputeInverseDynamics(ConstVecRef q, ConstVecRef qd, ConstVecRef qdd,
                                      DynamicsTerms terms, VecRef tau);
  // (q, qd, tau) => qdd = M⁻¹ (tau − [C qd] − [G]).
  virtual void ComputeForwardDynamics(ConstVecRef q, ConstVecRef qd, ConstVecRef tau,
                                      DynamicsTerms terms, VecRef qdd);

  // How often gravity and Coriolis terms were evaluated by the two calls above.
  const StageCounts& counts() const { return counts_; }

 protected:
  void CountGravity() { ++counts_.gravity; }
  void CountCoriolis() { ++counts_.coriolis; }

 private:
  std::vector<JointType> joints_;
  StageCounts counts_;
  // Scratch for the generic inverse and forward dynamics.
  MatrixXd M_;
  VectorXd term_;
  Eigen::LLT<MatrixXd> llt_;
};

// Power delivered by generalized forces: qdᵀ tau, W.
double Power(ConstVecRef qd, ConstVecRef tau);

}  // namespace lagrange
