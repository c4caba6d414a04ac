#include "plant/pendulum.hpp"

#include <cmath>

namespace lagrange {

RigidTree ToRigidTree(const PendulumParams& p) {
  RigidTree tree;
  tree.gravity = PlanarGravity(p.g);
  tree.joints.push_back(PlanarTreeJoint("theta", JointType::kRevolute, -1, 0.0, 0.0, -std::numbers::pi / 2));
  tree.bodies.push_back(PlanarTreeBody(p.m, p.com(), 0.0, p.com_inertia()));
  tree.frames.push_back(PlanarTreeFrame("bob", 0, p.L, 0.0, 0.0));
  return tree;
}

PendulumClosedForm::PendulumClosedForm(PendulumParams p)
    : Dynamics({JointType::kRevolute}), inertia_(p.pivot_inertia()), mgl_(p.m * p.g * p.com()) {}

void PendulumClosedForm::ComputeMassMatrix(DynamicsData& data, ConstVecRef q, MatRef M) const {
  Checked(data, q, M);
  M(0, 0) = inertia_;
}

void PendulumClosedForm::ComputeCoriolisMatrix(DynamicsData& data, ConstVecRef q, ConstVecRef qd, MatRef C) const {
  Checked(data, q, qd, C);
  C(0, 0) = 0.0;
}

void PendulumClosedForm::ComputeCoriolisForce(DynamicsData& data, ConstVecRef q, ConstVecRef qd, VecRef c) const {
  Checked(data, q, qd, c);
  c[0] = 0.0;
}

void PendulumClosedForm::ComputeGravityForce(DynamicsData& data, ConstVecRef q, VecRef G) const {
  Checked(data, q, G);
  G[0] = mgl_ * std::sin(q[0]);
}

void PendulumClosedForm::ComputeKineticEnergyGradient(DynamicsData& data, ConstVecRef q, ConstVecRef qd,
                                                      VecRef dTdq) const {
  Checked(data, q, qd, dTdq);
  dTdq[0] = 0.0;
}

double PendulumClosedForm::ComputeKineticEnergy(DynamicsData& data, ConstVecRef q, ConstVecRef qd) const {
  Checked(data, q, qd);
  return 0.5 * inertia_ * qd[0] * qd[0];
}

double PendulumClosedForm::ComputePotentialEnergy(DynamicsData& data, ConstVecRef q) const {
  Checked(data, q);
  return -mgl_ * std::cos(q[0]);
}

void PendulumClosedForm::ComputeForwardDynamics(DynamicsData& data, ConstVecRef q, ConstVecRef qd, ConstVecRef tau,
                                                DynamicsTerms terms, VecRef qdd) const {
  Checked(data, q, qd, tau, qdd);
  double rhs = tau[0];
  if (terms.coriolis) CountCoriolis(data);  // C = 0 for one joint: nothing to add
  if (terms.gravity) {
    CountGravity(data);
    rhs -= mgl_ * std::sin(q[0]);
  }
  qdd[0] = rhs / inertia_;
}

// tau = I qdd + mgl sin θ: ∂tau/∂θ = mgl cos θ, ∂tau/∂θ̇ = 0, ∂tau/∂θ̈ = I.
void PendulumClosedForm::ComputeInverseDynamicsDerivatives(DynamicsData& data, ConstVecRef q, ConstVecRef qd,
                                                           ConstVecRef qdd, DynamicsTerms terms, MatRef dtau_dq,
                                                           MatRef dtau_dqd, MatRef dtau_dqdd) const {
  Checked(data, q, qd, qdd, dtau_dq, dtau_dqd, dtau_dqdd);
  CountTerms(data, terms);
  dtau_dq(0, 0) = terms.gravity ? mgl_ * std::cos(q[0]) : 0.0;
  dtau_dqd(0, 0) = 0.0;
  dtau_dqdd(0, 0) = inertia_;
}

void PendulumClosedForm::ComputeGravityDerivatives(DynamicsData& data, ConstVecRef q, MatRef dG_dq) const {
  Checked(data, q, dG_dq);
  dG_dq(0, 0) = mgl_ * std::cos(q[0]);
}

}  // namespace lagrange
