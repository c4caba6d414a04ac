#include "plant/cartpole.hpp"

#include <cmath>
#include <numbers>

namespace lagrange {

PlanarChain CartPole::ToChain() const {
  PlanarChain chain;
  chain.g = p_.g;
  chain.joints.push_back({JointType::kPrismatic, {0.0, 0.0}, 0.0});
  chain.joints.push_back({JointType::kRevolute, {0.0, 0.0}, -std::numbers::pi / 2});
  chain.bodies.push_back({p_.mc, {0.0, 0.0}, 0.0});
  chain.bodies.push_back({p_.mp, {p_.l, 0.0}, p_.pole_inertia()});
  return chain;
}

CartPoleClosedForm::CartPoleClosedForm(CartPoleParams p)
    : Dynamics({JointType::kPrismatic, JointType::kRevolute}),
      mt_(p.mc + p.mp),
      ml_(p.mp * p.l),
      Ip_(p.mp * p.l * p.l + p.pole_inertia()),
      mgl_(p.mp * p.g * p.l) {}

void CartPoleClosedForm::ComputeMassMatrix(ConstVecRef q, MatRef M) const {
  AssertSizes(q, M);
  const double m01 = ml_ * std::cos(q[1]);
  M(0, 0) = mt_;
  M(0, 1) = m01;
  M(1, 0) = m01;
  M(1, 1) = Ip_;
}

void CartPoleClosedForm::ComputeCoriolisMatrix(ConstVecRef q, ConstVecRef qd, MatRef C) const {
  AssertSizes(q, qd, C);
  C.setZero();
  C(0, 1) = -ml_ * std::sin(q[1]) * qd[1];
}

void CartPoleClosedForm::ComputeCoriolisForce(ConstVecRef q, ConstVecRef qd, VecRef c) const {
  AssertSizes(q, qd, c);
  c[0] = -ml_ * std::sin(q[1]) * qd[1] * qd[1];
  c[1] = 0.0;
}

void CartPoleClosedForm::ComputeGravityForce(ConstVecRef q, VecRef G) const {
  AssertSizes(q, G);
  G[0] = 0.0;
  G[1] = mgl_ * std::sin(q[1]);
}

void CartPoleClosedForm::ComputeKineticEnergyGradient(ConstVecRef q, ConstVecRef qd, VecRef dTdq) const {
  AssertSizes(q, qd, dTdq);
  dTdq[0] = 0.0;
  dTdq[1] = -ml_ * std::sin(q[1]) * qd[0] * qd[1];
}

double CartPoleClosedForm::ComputeKineticEnergy(ConstVecRef q, ConstVecRef qd) const {
  AssertSizes(q, qd);
  return 0.5 * mt_ * qd[0] * qd[0] + ml_ * std::cos(q[1]) * qd[0] * qd[1] + 0.5 * Ip_ * qd[1] * qd[1];
}

double CartPoleClosedForm::ComputePotentialEnergy(ConstVecRef q) const {
  AssertSizes(q);
  return -mgl_ * std::cos(q[1]);
}

void CartPoleClosedForm::ComputeInverseDynamics(ConstVecRef q, ConstVecRef qd, ConstVecRef qdd, DynamicsTerms terms,
                                                VecRef tau) const {
  AssertSizes(q, qd, qdd, tau);
  const double s = std::sin(q[1]), c = std::cos(q[1]);
  tau[0] = mt_ * qdd[0] + ml_ * c * qdd[1];
  tau[1] = ml_ * c * qdd[0] + Ip_ * qdd[1];
  if (terms.coriolis) {
    CountCoriolis();
    tau[0] -= ml_ * s * qd[1] * qd[1];
  }
  if (terms.gravity) {
    CountGravity();
    tau[1] += mgl_ * s;
  }
}

void CartPoleClosedForm::ComputeForwardDynamics(ConstVecRef q, ConstVecRef qd, ConstVecRef tau, DynamicsTerms terms,
                                                VecRef qdd) const {
  AssertSizes(q, qd, tau, qdd);
  const double s = std::sin(q[1]), c = std::cos(q[1]);
  double r0 = tau[0], r1 = tau[1];
  if (terms.coriolis) {
    CountCoriolis();
    r0 += ml_ * s * qd[1] * qd[1];
  }
  if (terms.gravity) {
    CountGravity();
    r1 -= mgl_ * s;
  }
  const double m01 = ml_ * c;
  const double inv_det = 1.0 / (mt_ * Ip_ - m01 * m01);
  qdd[0] = (Ip_ * r0 - m01 * r1) * inv_det;
  qdd[1] = (mt_ * r1 - m01 * r0) * inv_det;
}

}  // namespace lagrange
