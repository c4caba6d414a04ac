#pragma once
// The generic Lagrangian path: M, C, G and ∂T/∂q derived from a plant's
// energies by forward-mode automatic differentiation (plant/dual.hpp).
//
// A plant is added by writing its two energy functions as templates over the
// scalar type S (double or any Dual):
//
//   struct MyPlant {
//     std::vector<JointType> joint_types() const;
//     template <class S> S KineticEnergy(std::span<const S> q, std::span<const S> qd) const;
//     template <class S> S PotentialEnergy(std::span<const S> q) const;
//   };
//   LagrangianDynamics<MyPlant> dynamics(MyPlant{...});
//
// What is differentiated, with P_ij = ∂²T/∂q_j∂qd_i and Ṁ = Σ_k ∂M/∂q_k qd_k:
//   M_ij   = ∂²T/∂qd_i∂qd_j                       (ε1 on qd_i, ε2 on qd_j)
//   C      = ½ (Ṁ + P − Pᵀ)                        (the Christoffel sum, regrouped:
//            Σ_k ∂M_ik/∂q_j qd_k = P_ij and Σ_k ∂M_jk/∂q_i qd_k = P_ji)
//   C qd   = Ṁ qd − ∂T/∂q                          (Euler–Lagrange, T quadratic in qd)
//   G      = ∂V/∂q
// Costs grow as O(n²) energy evaluations for M and C: this is the reference
// path, not the fast one.

#include <span>
#include <utility>
#include <vector>

#include "plant/dual.hpp"
#include "plant/dynamics.hpp"

namespace lagrange {

template <class Plant>
class LagrangianDynamics final : public Dynamics {
 public:
  explicit LagrangianDynamics(Plant plant) : Dynamics(plant.joint_types()), plant_(std::move(plant)) {
    const auto n = static_cast<std::size_t>(num_dofs());
    q1_.resize(n);
    qd1_.resize(n);
    q2_.resize(n);
    qd2_.resize(n);
    q3_.resize(n);
    qd3_.resize(n);
    dTdq_.resize(num_dofs());
  }

  const Plant& plant() const { return plant_; }
  Method method() const override { return Method::kLagrangian; }

  void ComputeMassMatrix(ConstVecRef q, MatRef M) const override {
    AssertSizes(q, M);
    const int n = num_dofs();
    for (int k = 0; k < n; ++k) {
      q2_[k] = Dual2(q[k]);
      qd2_[k] = Dual2(0.0);
    }
    for (int i = 0; i < n; ++i) {
      for (int j = 0; j <= i; ++j) {
        qd2_[i].v.d = 1.0;  // ε1 on qd_i
        qd2_[j].d.v = 1.0;  // ε2 on qd_j
        const double m = T2().d.d;
        M(i, j) = m;
        M(j, i) = m;
        qd2_[i] = Dual2(0.0);
        qd2_[j] = Dual2(0.0);
      }
    }
  }

  void ComputeCoriolisMatrix(ConstVecRef q, ConstVecRef qd, MatRef C) const override {
    AssertSizes(q, qd, C);
    const int n = num_dofs();
    // Ṁ_ij: ε3 moves q along qd, ε1 and ε2 pick qd_i and qd_j.
    for (int k = 0; k < n; ++k) {
      q3_[k] = Dual3(Dual2(q[k]), Dual2(qd[k]));
      qd3_[k] = Dual3(0.0);
    }
    for (int i = 0; i < n; ++i) {
      for (int j = 0; j <= i; ++j) {
        qd3_[i].v.v.d = 1.0;  // ε1
        qd3_[j].v.d.v = 1.0;  // ε2
        const double mdot = T3().d.d.d;
        C(i, j) = 0.5 * mdot;
        C(j, i) = 0.5 * mdot;
        qd3_[i] = Dual3(0.0);
        qd3_[j] = Dual3(0.0);
      }
    }
    // P_ij = ∂²T/∂q_j∂qd_i enters as ½ (P − Pᵀ).
    ResetSeeds2(q, qd);
    for (int i = 0; i < n; ++i) {
      qd2_[i].v.d = 1.0;  // ε1 on qd_i
      for (int j = 0; j < n; ++j) {
        if (j == i) continue;
        q2_[j].d.v = 1.0;  // ε2 on q_j
        const double p_ij = T2().d.d;
        q2_[j].d.v = 0.0;
        C(i, j) += 0.5 * p_ij;
        C(j, i) -= 0.5 * p_ij;
      }
      qd2_[i].v.d = 0.0;
    }
  }

  void ComputeCoriolisForce(ConstVecRef q, ConstVecRef qd, VecRef c) const override {
    AssertSizes(q, qd, c);
    const int n = num_dofs();
    // (Ṁ qd)_i: ε2 moves q along qd, ε1 picks ∂/∂qd_i.
    for (int k = 0; k < n; ++k) {
      q2_[k] = Dual2(Dual1(q[k]), Dual1(qd[k]));
      qd2_[k] = Dual2(qd[k]);
    }
    for (int i = 0; i < n; ++i) {
      qd2_[i].v.d = 1.0;
      c[i] = T2().d.d;
      qd2_[i].v.d = 0.0;
    }
    ComputeKineticEnergyGradient(q, qd, dTdq_);
    c -= dTdq_;
  }

  void ComputeGravityForce(ConstVecRef q, VecRef G) const override {
    AssertSizes(q, G);
    const int n = num_dofs();
    for (int k = 0; k < n; ++k) q1_[k] = Dual1(q[k]);
    for (int i = 0; i < n; ++i) {
      q1_[i].d = 1.0;
      G[i] = plant_.template PotentialEnergy<Dual1>(q1_).d;
      q1_[i].d = 0.0;
    }
  }

  void ComputeKineticEnergyGradient(ConstVecRef q, ConstVecRef qd, VecRef dTdq) const override {
    AssertSizes(q, qd, dTdq);
    const int n = num_dofs();
    for (int k = 0; k < n; ++k) {
      q1_[k] = Dual1(q[k]);
      qd1_[k] = Dual1(qd[k]);
    }
    for (int i = 0; i < n; ++i) {
      q1_[i].d = 1.0;
      dTdq[i] = plant_.template KineticEnergy<Dual1>(q1_, qd1_).d;
      q1_[i].d = 0.0;
    }
  }

  double ComputeKineticEnergy(ConstVecRef q, ConstVecRef qd) const override {
    AssertSizes(q, qd);
    return plant_.template KineticEnergy<double>(std::span<const double>(q.data(), q.size()),
                                                 std::span<const double>(qd.data(), qd.size()));
  }

  double ComputePotentialEnergy(ConstVecRef q) const override {
    AssertSizes(q);
    return plant_.template PotentialEnergy<double>(std::span<const double>(q.data(), q.size()));
  }

 private:
  Dual2 T2() const { return plant_.template KineticEnergy<Dual2>(q2_, qd2_); }
  Dual3 T3() const { return plant_.template KineticEnergy<Dual3>(q3_, qd3_); }

  void ResetSeeds2(ConstVecRef q, ConstVecRef qd) const {
    for (int k = 0; k < num_dofs(); ++k) {
      q2_[k] = Dual2(q[k]);
      qd2_[k] = Dual2(qd[k]);
    }
  }

  Plant plant_;
  // Seeds and scratch, mutable: the const queries write them, and they are
  // this object's own (Dynamics objects are not shared between threads).
  mutable std::vector<Dual1> q1_, qd1_;
  mutable std::vector<Dual2> q2_, qd2_;
  mutable std::vector<Dual3> q3_, qd3_;
  mutable VectorXd dTdq_;
};

}  // namespace lagrange
