#pragma once
// The Lagrangian path's derivatives (declared, and their equations given, in
// plant/lagrangian.hpp): nested duals of the plant's two energies. Included
// only by plant/lagrangian_instances.cpp, which compiles them once per plant
// type.

#include "plant/lagrangian.hpp"

namespace lagrange {

template <class Plant>
void LagrangianDynamics<Plant>::ComputeInverseDynamicsDerivatives(DynamicsData& data, ConstVecRef q, ConstVecRef qd,
                                                                  ConstVecRef qdd, DynamicsTerms terms,
                                                                  MatRef dtau_dq, MatRef dtau_dqd,
                                                                  MatRef dtau_dqdd) const {
  Data& d = Checked<Data>(data, q, qd, qdd, dtau_dq, dtau_dqd, dtau_dqdd);
  CountTerms(d, terms);
  const int n = num_dofs();
  ComputeMassMatrix(d, q, dtau_dqdd);
  if (terms.coriolis) {
    // ∂/∂x_k (d/dt ∂T/∂qd_i): q = q + ε2 qd (+ ε2ε3 e_k for x = qd), qd = qd + ε1 e_i + ε2 qdd + ε3 e_k (x = qd)
    // or q + ε3 e_k (x = q).
    for (int m = 0; m < n; ++m) {
      d.q3[m] = Dual3(Dual2(Dual1(q[m]), Dual1(qd[m])), Dual2(0.0));
      d.qd3[m] = Dual3(Dual2(Dual1(qd[m]), Dual1(qdd[m])), Dual2(0.0));
    }
    for (int i = 0; i < n; ++i) {
      d.qd3[i].v.v.d = 1.0;  // ε1
      for (int k = 0; k < n; ++k) {
        d.q3[k].d.v.v = 1.0;  // ε3 on q_k
        dtau_dq(i, k) = T3(d).d.d.d;
        d.q3[k].d.v.v = 0.0;
        d.q3[k].d.d.v = 1.0;  // ε3 on qd_k: in q's ε2 part and in qd
        d.qd3[k].d.v.v = 1.0;
        dtau_dqd(i, k) = T3(d).d.d.d;
        d.q3[k].d.d.v = 0.0;
        d.qd3[k].d.v.v = 0.0;
      }
      d.qd3[i].v.v.d = 0.0;
    }
    // − ∂²T/∂q_i∂qd_k: ε1 on q_i, ε2 on qd_k.
    ResetSeeds2(d, q, qd);
    for (int i = 0; i < n; ++i) {
      d.q2[i].v.d = 1.0;
      for (int k = 0; k < n; ++k) {
        d.qd2[k].d.v = 1.0;
        dtau_dqd(i, k) -= T2(d).d.d;
        d.qd2[k].d.v = 0.0;
      }
      d.q2[i].v.d = 0.0;
    }
    // − ∂²(T − V)/∂q_i∂q_k, symmetric: ε1 on q_i, ε2 on q_k.
    for (int i = 0; i < n; ++i) {
      for (int k = 0; k <= i; ++k) {
        d.q2[i].v.d = 1.0;
        d.q2[k].d.v = 1.0;
        const double h = terms.gravity ? V2(d).d.d - T2(d).d.d : -T2(d).d.d;
        dtau_dq(i, k) += h;
        if (k != i) dtau_dq(k, i) += h;
        d.q2[i].v.d = 0.0;
        d.q2[k].d.v = 0.0;
      }
    }
    return;
  }
  // tau = M(q) qdd + [G]: (M qdd)_i = ∂T/∂qd_i at qd = qdd; ∂/∂q_k with ε1 on qd_i, ε2 on q_k.
  dtau_dqd.setZero();
  ResetSeeds2(d, q, qdd);
  for (int i = 0; i < n; ++i) {
    d.qd2[i].v.d = 1.0;
    for (int k = 0; k < n; ++k) {
      d.q2[k].d.v = 1.0;
      dtau_dq(i, k) = T2(d).d.d;
      d.q2[k].d.v = 0.0;
    }
    d.qd2[i].v.d = 0.0;
  }
  if (!terms.gravity) return;
  for (int i = 0; i < n; ++i) {
    for (int k = 0; k <= i; ++k) {
      d.q2[i].v.d = 1.0;
      d.q2[k].d.v = 1.0;
      const double h = V2(d).d.d;
      dtau_dq(i, k) += h;
      if (k != i) dtau_dq(k, i) += h;
      d.q2[i].v.d = 0.0;
      d.q2[k].d.v = 0.0;
    }
  }
}

template <class Plant>
void LagrangianDynamics<Plant>::ComputeGravityDerivatives(DynamicsData& data, ConstVecRef q, MatRef dG_dq) const {
  Data& d = Checked<Data>(data, q, dG_dq);
  const int n = num_dofs();
  for (int m = 0; m < n; ++m) d.q2[m] = Dual2(q[m]);
  for (int i = 0; i < n; ++i) {
    for (int k = 0; k <= i; ++k) {
      d.q2[i].v.d = 1.0;  // ε1
      d.q2[k].d.v = 1.0;  // ε2
      const double h = V2(d).d.d;
      dG_dq(i, k) = h;
      dG_dq(k, i) = h;
      d.q2[i].v.d = 0.0;
      d.q2[k].d.v = 0.0;
    }
  }
}

}  // namespace lagrange
