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
// at construction and every query is const; the scratch it writes is the
// object's own (mutable), so one object serves one thread; controllers hold
// their own.
//
// Every Compute* checks its arguments' sizes at its top in debug builds
// (assert; compiled out under NDEBUG): vectors (n), matrices (n x n).

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
  virtual void ComputeMassMatrix(ConstVecRef q, MatRef M) const = 0;
  // (q, qd) (n, n) => C (n x n), the Christoffel factorisation: Ṁ − 2C is skew.
  virtual void ComputeCoriolisMatrix(ConstVecRef q, ConstVecRef qd, MatRef C) const = 0;
  // (q, qd) => c = C(q, qd) qd (n).
  virtual void ComputeCoriolisForce(ConstVecRef q, ConstVecRef qd, VecRef c) const = 0;
  // q => G = ∂V/∂q (n).
  virtual void ComputeGravityForce(ConstVecRef q, VecRef G) const = 0;
  // (q, qd) => ∂T/∂q (n), which equals Cᵀ qd. Used by the variational integrator.
  virtual void ComputeKineticEnergyGradient(ConstVecRef q, ConstVecRef qd, VecRef dTdq) const = 0;
  // (q, qd) => T = ½ qdᵀ M qd, J.
  virtual double ComputeKineticEnergy(ConstVecRef q, ConstVecRef qd) const = 0;
  // q => V, J; zero at the base's height, gravity along −y.
  virtual double ComputePotentialEnergy(ConstVecRef q) const = 0;

  // (q, qd, qdd) => tau = M qdd + [C qd] + [G]; bracketed terms only when on in `terms`.
  virtual void ComputeInverseDynamics(ConstVecRef q, ConstVecRef qd, ConstVecRef qdd, DynamicsTerms terms,
                                      VecRef tau) const;
  // (q, qd, tau) => qdd = M⁻¹ (tau − [C qd] − [G]).
  virtual void ComputeForwardDynamics(ConstVecRef q, ConstVecRef qd, ConstVecRef tau, DynamicsTerms terms,
                                      VecRef qdd) const;

  // How often gravity and Coriolis terms were evaluated by the two calls above.
  const StageCounts& counts() const { return counts_; }

 protected:
  void CountGravity() const { ++counts_.gravity; }
  void CountCoriolis() const { ++counts_.coriolis; }

  // Debug-build check that every argument is sized for this plant: a vector
  // (n), a matrix (n x n). Call at the top of each Compute*.
  template <class... Xs>
  void AssertSizes([[maybe_unused]] const Xs&... xs) const {
    eigen_assert((HasDofSize(xs) && ...));
  }

 private:
  template <class X>
  bool HasDofSize(const X& x) const {
    return x.rows() == num_dofs() && x.cols() == (X::ColsAtCompileTime == 1 ? 1 : num_dofs());
  }

  std::vector<JointType> joints_;
  // Mutable: the const queries count their gated stages and write scratch
  // owned by this object, which is not shared between threads.
  mutable StageCounts counts_;
  // Scratch for the generic inverse and forward dynamics.
  mutable MatrixXd M_;
  mutable VectorXd term_;
  mutable Eigen::LLT<MatrixXd> llt_;
};

// Power delivered by generalized forces: qdᵀ tau, W.
double Power(ConstVecRef qd, ConstVecRef tau);

}  // namespace lagrange
