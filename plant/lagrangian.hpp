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
//
// Derivatives, from the same two energies and nothing else (they share no
// code with the recursive path), with tau_i = d/dt ∂T/∂qd_i − ∂T/∂q_i + ∂V/∂q_i
// and d/dt taken along (qd, qdd):
//   ∂tau_i/∂q_k  = ∂/∂q_k (d/dt ∂T/∂qd_i) − ∂²(T − V)/∂q_i∂q_k
//   ∂tau_i/∂qd_k = ∂/∂qd_k (d/dt ∂T/∂qd_i) − ∂²T/∂q_i∂qd_k
// each first term the ε1ε2ε3 part of T in Dual3: ε1 on qd_i, ε2 moving
// (q, qd) along (qd, qdd), ε3 on q_k (or on qd_k, in qd and in q's ε2 part);
// the second terms in Dual2. 2n² + n(n+1)/2 + n² energy evaluations. Without
// the Coriolis term tau = M qdd + [G] with (M qdd)_i = ∂T/∂qd_i at qd = qdd.
// ∂G/∂q = ∂²V/∂q², n(n+1)/2 evaluations of V in Dual2. Forward dynamics'
// from these by the identity in plant/dynamics.hpp.
//
// The derivatives' definitions are in plant/lagrangian_derivatives.hpp,
// compiled once per plant type in plant/lagrangian_instances.cpp (nested duals
// over a URDF tree cost compile minutes): a new plant type adds its line
// there and its extern declaration at the end of this file. The built-in
// plants' and RigidTree's paths are declared extern below, so no other
// translation unit compiles them again (g++ 12 -O3, CPU seconds:
// tests/plant/mimic_test.cpp 13.9 → 10.6, rigid_tree_test.cpp 28.4 → 22.2).

#include <span>
#include <utility>
#include <vector>

#include "plant/arm2.hpp"
#include "plant/cartpole.hpp"
#include "plant/dual.hpp"
#include "plant/dynamics.hpp"
#include "plant/pendulum.hpp"
#include "plant/recursive_dynamics.hpp"
#include "plant/rigid_tree.hpp"

namespace lagrange {

template <class Plant>
class LagrangianDynamics final : public Dynamics {
 public:
  explicit LagrangianDynamics(Plant plant) : Dynamics(plant.joint_types()), plant_(std::move(plant)) {}

  const Plant& plant() const { return plant_; }
  Method method() const override { return Method::kLagrangian; }
  std::unique_ptr<DynamicsData> MakeData() const override { return std::make_unique<Data>(*this); }

  void ComputeMassMatrix(DynamicsData& data, ConstVecRef q, MatRef M) const override {
    Data& d = Checked<Data>(data, q, M);
    const int n = num_dofs();
    for (int k = 0; k < n; ++k) {
      d.q2[k] = Dual2(q[k]);
      d.qd2[k] = Dual2(0.0);
    }
    for (int i = 0; i < n; ++i) {
      for (int j = 0; j <= i; ++j) {
        d.qd2[i].v.d = 1.0;  // ε1 on qd_i
        d.qd2[j].d.v = 1.0;  // ε2 on qd_j
        const double m = T2(d).d.d;
        M(i, j) = m;
        M(j, i) = m;
        d.qd2[i] = Dual2(0.0);
        d.qd2[j] = Dual2(0.0);
      }
    }
  }

  void ComputeCoriolisMatrix(DynamicsData& data, ConstVecRef q, ConstVecRef qd, MatRef C) const override {
    Data& d = Checked<Data>(data, q, qd, C);
    const int n = num_dofs();
    // Ṁ_ij: ε3 moves q along qd, ε1 and ε2 pick qd_i and qd_j.
    for (int k = 0; k < n; ++k) {
      d.q3[k] = Dual3(Dual2(q[k]), Dual2(qd[k]));
      d.qd3[k] = Dual3(0.0);
    }
    for (int i = 0; i < n; ++i) {
      for (int j = 0; j <= i; ++j) {
        d.qd3[i].v.v.d = 1.0;  // ε1
        d.qd3[j].v.d.v = 1.0;  // ε2
        const double mdot = T3(d).d.d.d;
        C(i, j) = 0.5 * mdot;
        C(j, i) = 0.5 * mdot;
        d.qd3[i] = Dual3(0.0);
        d.qd3[j] = Dual3(0.0);
      }
    }
    // P_ij = ∂²T/∂q_j∂qd_i enters as ½ (P − Pᵀ).
    ResetSeeds2(d, q, qd);
    for (int i = 0; i < n; ++i) {
      d.qd2[i].v.d = 1.0;  // ε1 on qd_i
      for (int j = 0; j < n; ++j) {
        if (j == i) continue;
        d.q2[j].d.v = 1.0;  // ε2 on q_j
        const double p_ij = T2(d).d.d;
        d.q2[j].d.v = 0.0;
        C(i, j) += 0.5 * p_ij;
        C(j, i) -= 0.5 * p_ij;
      }
      d.qd2[i].v.d = 0.0;
    }
  }

  void ComputeCoriolisForce(DynamicsData& data, ConstVecRef q, ConstVecRef qd, VecRef c) const override {
    Data& d = Checked<Data>(data, q, qd, c);
    const int n = num_dofs();
    // (Ṁ qd)_i: ε2 moves q along qd, ε1 picks ∂/∂qd_i.
    for (int k = 0; k < n; ++k) {
      d.q2[k] = Dual2(Dual1(q[k]), Dual1(qd[k]));
      d.qd2[k] = Dual2(qd[k]);
    }
    for (int i = 0; i < n; ++i) {
      d.qd2[i].v.d = 1.0;
      c[i] = T2(d).d.d;
      d.qd2[i].v.d = 0.0;
    }
    ComputeKineticEnergyGradient(d, q, qd, d.dTdq);
    c -= d.dTdq;
  }

  void ComputeGravityForce(DynamicsData& data, ConstVecRef q, VecRef G) const override {
    Data& d = Checked<Data>(data, q, G);
    const int n = num_dofs();
    for (int k = 0; k < n; ++k) d.q1[k] = Dual1(q[k]);
    for (int i = 0; i < n; ++i) {
      d.q1[i].d = 1.0;
      G[i] = plant_.template PotentialEnergy<Dual1>(d.q1).d;
      d.q1[i].d = 0.0;
    }
  }

  void ComputeKineticEnergyGradient(DynamicsData& data, ConstVecRef q, ConstVecRef qd, VecRef dTdq) const override {
    Data& d = Checked<Data>(data, q, qd, dTdq);
    const int n = num_dofs();
    for (int k = 0; k < n; ++k) {
      d.q1[k] = Dual1(q[k]);
      d.qd1[k] = Dual1(qd[k]);
    }
    for (int i = 0; i < n; ++i) {
      d.q1[i].d = 1.0;
      dTdq[i] = plant_.template KineticEnergy<Dual1>(d.q1, d.qd1).d;
      d.q1[i].d = 0.0;
    }
  }

  double ComputeKineticEnergy(DynamicsData& data, ConstVecRef q, ConstVecRef qd) const override {
    Checked(data, q, qd);
    return plant_.template KineticEnergy<double>(std::span<const double>(q.data(), q.size()),
                                                 std::span<const double>(qd.data(), qd.size()));
  }

  double ComputePotentialEnergy(DynamicsData& data, ConstVecRef q) const override {
    Checked(data, q);
    return plant_.template PotentialEnergy<double>(std::span<const double>(q.data(), q.size()));
  }

  // Defined in plant/lagrangian_derivatives.hpp (see above).
  void ComputeInverseDynamicsDerivatives(DynamicsData& data, ConstVecRef q, ConstVecRef qd, ConstVecRef qdd,
                                         DynamicsTerms terms, MatRef dtau_dq, MatRef dtau_dqd,
                                         MatRef dtau_dqdd) const override;
  void ComputeGravityDerivatives(DynamicsData& data, ConstVecRef q, MatRef dG_dq) const override;

 private:
  // One user's seeds and scratch (n each).
  struct Data final : DynamicsData {
    explicit Data(const LagrangianDynamics& model)
        : DynamicsData(model),
          q1(static_cast<std::size_t>(model.num_dofs())),
          qd1(q1.size()),
          q2(q1.size()),
          qd2(q1.size()),
          q3(q1.size()),
          qd3(q1.size()),
          dTdq(model.num_dofs()) {}
    std::vector<Dual1> q1, qd1;
    std::vector<Dual2> q2, qd2;
    std::vector<Dual3> q3, qd3;
    VectorXd dTdq;
  };

  Dual2 T2(const Data& d) const { return plant_.template KineticEnergy<Dual2>(d.q2, d.qd2); }
  Dual2 V2(const Data& d) const { return plant_.template PotentialEnergy<Dual2>(d.q2); }
  Dual3 T3(const Data& d) const { return plant_.template KineticEnergy<Dual3>(d.q3, d.qd3); }

  void ResetSeeds2(Data& d, ConstVecRef q, ConstVecRef qd) const {
    for (int k = 0; k < num_dofs(); ++k) {
      d.q2[k] = Dual2(q[k]);
      d.qd2[k] = Dual2(qd[k]);
    }
  }

  Plant plant_;
};

// Compiled once, in plant/lagrangian_instances.cpp.
extern template class LagrangianDynamics<Pendulum>;
extern template class LagrangianDynamics<Arm2>;
extern template class LagrangianDynamics<CartPole>;
extern template class LagrangianDynamics<PlanarChain>;
extern template class LagrangianDynamics<RigidTree>;

}  // namespace lagrange
