#include "plant/pendulum.hpp"

#include <cmath>

namespace lagrange {

PlanarChain Pendulum::ToChain() const {
  PlanarChain chain;
  chain.g = p_.g;
  chain.joints.push_back({JointType::kRevolute, {0.0, 0.0}, -std::numbers::pi / 2});
  chain.bodies.push_back({p_.m, {p_.com(), 0.0}, p_.com_inertia()});
  return chain;
}

PendulumClosedForm::PendulumClosedForm(PendulumParams p)
    : Dynamics({JointType::kRevolute}), inertia_(p.pivot_inertia()), mgl_(p.m * p.g * p.com()) {}

void PendulumClosedForm::ComputeMassMatrix(ConstVecRef q, MatRef M) const {
  AssertSizes(q, M);
  M(0, 0) = inertia_;
}

void PendulumClosedForm::ComputeCoriolisMatrix(ConstVecRef q, ConstVecRef qd, MatRef C) const {
  AssertSizes(q, qd, C);
  C(0, 0) = 0.0;
}

void PendulumClosedForm::ComputeCoriolisForce(ConstVecRef q, ConstVecRef qd, VecRef c) const {
  AssertSizes(q, qd, c);
  c[0] = 0.0;
}

void PendulumClosedForm::ComputeGravityForce(ConstVecRef q, VecRef G) const {
  AssertSizes(q, G);
  G[0] = mgl_ * std::sin(q[0]);
}

void PendulumClosedForm::ComputeKineticEnergyGradient(ConstVecRef q, ConstVecRef qd, VecRef dTdq) const {
  AssertSizes(q, qd, dTdq);
  dTdq[0] = 0.0;
}

double PendulumClosedForm::ComputeKineticEnergy(ConstVecRef q, ConstVecRef qd) const {
  AssertSizes(q, qd);
  return 0.5 * inertia_ * qd[0] * qd[0];
}

double PendulumClosedForm::ComputePotentialEnergy(ConstVecRef q) const {
  AssertSizes(q);
  return -mgl_ * std::cos(q[0]);
}

void PendulumClosedForm::ComputeForwardDynamics(ConstVecRef q, ConstVecRef qd, ConstVecRef tau, DynamicsTerms terms,
                                                VecRef qdd) const {
  AssertSizes(q, qd, tau, qdd);
  double rhs = tau[0];
  if (terms.coriolis) CountCoriolis();  // C = 0 for one joint: nothing to add
  if (terms.gravity) {
    CountGravity();
    rhs -= mgl_ * std::sin(q[0]);
  }
  qdd[0] = rhs / inertia_;
}

}  // namespace lagrange
