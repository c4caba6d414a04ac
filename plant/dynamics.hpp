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

 protected:
  static void CountGravity(DynamicsData& data) { ++data.counts_.gravity; }
  static void CountCoriolis(DynamicsData& data) { ++data.counts_.coriolis; }

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
