#pragma once
// The dynamics contract every plant fulfils, whatever the method:
//
//   tau = M(q) qdd + C(q, qd) qd + G(q)
//
// with M = ∂²T/∂qd², C_ij = Σ_k ½(∂M_ij/∂q_k + ∂M_ik/∂q_j − ∂M_jk/∂q_i) qd_k and
// G = ∂V/∂q (see types.hpp for symbols, units and dimensions).
//
// Model and data apart, as Pinocchio's Model/Data and MuJoCo's
// mjModel/mjData: a Dynamics is the model, built once from the plant's
// parameters and immutable afterwards; everything a query writes (scratch,
// stage counts) lives in a DynamicsData made by that model for one user (a
// thread, a controller, a batch worker). Every query is const on the model
// and takes the caller's data:
//
//   std::shared_ptr<const Dynamics> model = MakeDynamics(spec, method);  // shared by every user
//   std::unique_ptr<DynamicsData> data = model->MakeData();               // one per user
//   model->ComputeMassMatrix(*data, q, M);
//
// So one model serves any number of threads at once, each with its own data
// (tests/plant/model_data_test.cpp runs that under ThreadSanitizer). Every
// buffer a query needs is in the data, sized by MakeData: no query allocates.
//
// The boundary: every Compute* checks at its top that `data` was made by this
// model and that its arguments are sized for it, vectors (n) and matrices
// (n x n) (eigen_assert: on in debug and sanitizer builds, compiled out under
// NDEBUG).
//
// Derivatives. Every model also gives the exact first derivatives of its
// inverse dynamics, forward dynamics and gravity (below, after the calls they
// differentiate); each method derives them its own way (recursive: analytic
// sweeps, plant/spatial_dynamics.hpp; lagrangian: nested duals of the
// energies, plant/lagrangian.hpp; closed form: by hand), and forward dynamics
// follows from inverse dynamics by the identity ID(q, qd, FD(q, qd, tau)) = tau:
//   ∂qdd/∂q = −M⁻¹ ∂tau/∂q,  ∂qdd/∂qd = −M⁻¹ ∂tau/∂qd,  ∂qdd/∂tau = M⁻¹
// with ∂tau/∂(q, qd) taken at (q, qd, qdd = FD(q, qd, tau)) (Carpentier and
// Mansard, RSS 2018). Matrices are (n x n): row i is output i, column j the
// input j (∂qdd_i/∂q_j). The effects and the integrator step are
// differentiated on top of these (PlantModel, StepDerivatives).

#include <Eigen/Cholesky>
#include <memory>
#include <vector>

#include "plant/types.hpp"

namespace lagrange {

class Dynamics;

// What one user of a Dynamics writes: the scratch of its queries and how
// often they evaluated the gated terms. Made only by Dynamics::MakeData,
// sized for that model, and passed back to that model alone. Not shared
// between threads (each thread makes its own).
class DynamicsData {
 public:
  virtual ~DynamicsData() = default;
  DynamicsData(const DynamicsData&) = delete;
  DynamicsData& operator=(const DynamicsData&) = delete;

  // The model this data belongs to.
  const Dynamics& model() const { return *model_; }
  // How often the gravity and Coriolis terms were evaluated by inverse and
  // forward dynamics through this data (the other counts stay zero).
  const StageCounts& counts() const { return counts_; }

 protected:
  // A model's own data type derives from this; only the model constructs it.
  explicit DynamicsData(const Dynamics& model);

 private:
  friend class Dynamics;
  const Dynamics* model_;
  StageCounts counts_;
  // Scratch of the generic inverse and forward dynamics (n x n, n).
  MatrixXd M_;
  VectorXd term_;
  Eigen::LLT<MatrixXd> llt_;
  // Scratch of the generic derivatives: two (n x n) results a caller did not
  // ask for, zeros (n), and the solve's right-hand sides, one row of the
  // system per column (3n x n: M⁻¹ [I, −∂tau/∂q, −∂tau/∂qd] row by row).
  MatrixXd unused_a_, unused_b_;
  VectorXd zeros_;
  MatrixXd rows_;
};

class Dynamics {
 public:
  explicit Dynamics(std::vector<JointType> joints);
  virtual ~Dynamics() = default;
  Dynamics(const Dynamics&) = delete;
  Dynamics& operator=(const Dynamics&) = delete;

  int num_dofs() const { return static_cast<int>(joints_.size()); }
  const std::vector<JointType>& joint_types() const { return joints_; }
  virtual Method method() const = 0;

  // A data object for one user of this model, every buffer sized.
  virtual std::unique_ptr<DynamicsData> MakeData() const;

  // q (n) => M (n x n).
  virtual void ComputeMassMatrix(DynamicsData& data, ConstVecRef q, MatRef M) const = 0;
  // (q, qd) (n, n) => C (n x n), the Christoffel factorisation: Ṁ − 2C is skew.
  virtual void ComputeCoriolisMatrix(DynamicsData& data, ConstVecRef q, ConstVecRef qd, MatRef C) const = 0;
  // (q, qd) => c = C(q, qd) qd (n).
  virtual void ComputeCoriolisForce(DynamicsData& data, ConstVecRef q, ConstVecRef qd, VecRef c) const = 0;
  // q => G = ∂V/∂q (n).
  virtual void ComputeGravityForce(DynamicsData& data, ConstVecRef q, VecRef G) const = 0;
  // (q, qd) => ∂T/∂q (n), which equals Cᵀ qd. Used by the variational integrator.
  virtual void ComputeKineticEnergyGradient(DynamicsData& data, ConstVecRef q, ConstVecRef qd, VecRef dTdq) const = 0;
  // (q, qd) => T = ½ qdᵀ M qd, J.
  virtual double ComputeKineticEnergy(DynamicsData& data, ConstVecRef q, ConstVecRef qd) const = 0;
  // q => V, J; zero with every centre of mass at the base's origin (the
  // planar plants: at the base's height, gravity along −y).
  virtual double ComputePotentialEnergy(DynamicsData& data, ConstVecRef q) const = 0;

  // (q, qd, qdd) => tau = M qdd + [C qd] + [G]; bracketed terms only when on in
  // `terms`, each counted in data.counts() when evaluated.
  virtual void ComputeInverseDynamics(DynamicsData& data, ConstVecRef q, ConstVecRef qd, ConstVecRef qdd,
                                      DynamicsTerms terms, VecRef tau) const;
  // (q, qd, tau) => qdd = M⁻¹ (tau − [C qd] − [G]), counted as above.
  virtual void ComputeForwardDynamics(DynamicsData& data, ConstVecRef q, ConstVecRef qd, ConstVecRef tau,
                                      DynamicsTerms terms, VecRef qdd) const;

  // (q, qd, qdd) => ∂tau/∂q, ∂tau/∂qd and ∂tau/∂qdd = M (n x n each) of
  // tau = M qdd + [C qd] + [G], `terms` as in ComputeInverseDynamics (without
  // the Coriolis term ∂tau/∂qd is zero). Units: ∂tau/∂q in N·m/rad (N/m, ...),
  // ∂tau/∂qd in N·m·s/rad, M in kg·m². The gated terms count once per call.
  // Cost: recursive O(Σ d) (one forward and one backward sweep), lagrangian
  // O(n²) energy evaluations in nested duals, closed forms a few products
  // (bench/derivatives_bench.cpp).
  virtual void ComputeInverseDynamicsDerivatives(DynamicsData& data, ConstVecRef q, ConstVecRef qd,
                                                 ConstVecRef qdd, DynamicsTerms terms, MatRef dtau_dq,
                                                 MatRef dtau_dqd, MatRef dtau_dqdd) const = 0;
  // (q, qd, tau) => qdd = FD(q, qd, tau) (n) and its derivatives ∂qdd/∂q,
  // ∂qdd/∂qd, ∂qdd/∂tau = M⁻¹ (n x n each), by the identity above: the
  // model's forward dynamics, its inverse-dynamics derivatives at that qdd,
  // and one Cholesky factorisation of M (O(n³), n² solves). The gated terms
  // count once per call (bench/derivatives_bench.cpp).
  virtual void ComputeForwardDynamicsDerivatives(DynamicsData& data, ConstVecRef q, ConstVecRef qd, ConstVecRef tau,
                                                 DynamicsTerms terms, VecRef qdd, MatRef dqdd_dq, MatRef dqdd_dqd,
                                                 MatRef dqdd_dtau) const;
  // q => ∂G/∂q (n x n), the Hessian of V: symmetric. Generic: the
  // inverse-dynamics derivatives at qd = qdd = 0 with gravity alone; a method
  // may do it cheaper (recursive: one sweep without the velocity terms).
  virtual void ComputeGravityDerivatives(DynamicsData& data, ConstVecRef q, MatRef dG_dq) const;

 protected:
  static void CountGravity(DynamicsData& data) { ++data.counts_.gravity; }
  static void CountCoriolis(DynamicsData& data) { ++data.counts_.coriolis; }
  // Each term that is on in `terms`, counted once.
  static void CountTerms(DynamicsData& data, DynamicsTerms terms) {
    if (terms.gravity) CountGravity(data);
    if (terms.coriolis) CountCoriolis(data);
  }
  // The counts of `data`, to restore after calls whose own counting a caller
  // replaces with its own (a derivative call counts once).
  static StageCounts SavedCounts(const DynamicsData& data) { return data.counts_; }
  static void RestoreCounts(DynamicsData& data, const StageCounts& counts) { data.counts_ = counts; }

  // ComputeForwardDynamicsDerivatives of a two-joint model (the closed forms):
  // its forward dynamics, its inverse-dynamics derivatives at that qdd, and
  // M⁻¹ as the explicit 2 x 2 inverse (cheaper than the generic Cholesky).
  void TwoJointForwardDynamicsDerivatives(DynamicsData& data, ConstVecRef q, ConstVecRef qd, ConstVecRef tau,
                                          DynamicsTerms terms, VecRef qdd, MatRef dqdd_dq, MatRef dqdd_dqd,
                                          MatRef dqdd_dtau) const;

  // The boundary check at the top of each Compute*: `data` is this model's
  // and every argument is sized for this plant, a vector (n), a matrix
  // (n x n). Returns the data as the model's own type.
  template <class Data = DynamicsData, class... Xs>
  Data& Checked(DynamicsData& data, [[maybe_unused]] const Xs&... xs) const {
    eigen_assert(&data.model() == this && "DynamicsData made by another model");
    eigen_assert((HasDofSize(xs) && ...));
    return static_cast<Data&>(data);
  }

 private:
  template <class X>
  bool HasDofSize(const X& x) const {
    return x.rows() == num_dofs() && x.cols() == (X::ColsAtCompileTime == 1 ? 1 : num_dofs());
  }

  std::vector<JointType> joints_;
};

// Power delivered by generalized forces: qdᵀ tau, W.
double Power(ConstVecRef qd, ConstVecRef tau);

}  // namespace lagrange
