#include "plant/cartpole.hpp"

#include <cmath>
#include <numbers>

namespace lagrange {

RigidTree ToRigidTree(const CartPoleParams& p) {
  RigidTree tree;
  tree.gravity = PlanarGravity(p.g);
  tree.joints.push_back(PlanarTreeJoint("x", JointType::kPrismatic, -1, 0.0, 0.0, 0.0));
  tree.joints.push_back(PlanarTreeJoint("theta", JointType::kRevolute, 0, 0.0, 0.0, -std::numbers::pi / 2));
  tree.bodies.push_back(PlanarTreeBody(p.mc, 0.0, 0.0, 0.0));
  tree.bodies.push_back(PlanarTreeBody(p.mp, p.l, 0.0, p.pole_inertia()));
  tree.frames.push_back(PlanarTreeFrame("cart", 0, 0.0, 0.0, 0.0));
  tree.frames.push_back(PlanarTreeFrame("pole", 1, 0.0, 0.0, 0.0));
  tree.frames.push_back(PlanarTreeFrame("pole_tip", 1, 2.0 * p.l, 0.0, 0.0));
  return tree;
}

CartPoleClosedForm::CartPoleClosedForm(CartPoleParams p)
    : Dynamics({JointType::kPrismatic, JointType::kRevolute}),
      mt_(p.mc + p.mp),
      ml_(p.mp * p.l),
      Ip_(p.mp * p.l * p.l + p.pole_inertia()),
      mgl_(p.mp * p.g * p.l) {}

void CartPoleClosedForm::ComputeMassMatrix(DynamicsData& data, ConstVecRef q, MatRef M) const {
  Checked(data, q, M);
  const double m01 = ml_ * std::cos(q[1]);
  M(0, 0) = mt_;
  M(0, 1) = m01;
  M(1, 0) = m01;
  M(1, 1) = Ip_;
}

void CartPoleClosedForm::ComputeCoriolisMatrix(DynamicsData& data, ConstVecRef q, ConstVecRef qd, MatRef C) const {
  Checked(data, q, qd, C);
  C.setZero();
  C(0, 1) = -ml_ * std::sin(q[1]) * qd[1];
}

void CartPoleClosedForm::ComputeCoriolisForce(DynamicsData& data, ConstVecRef q, ConstVecRef qd, VecRef c) const {
  Checked(data, q, qd, c);
  c[0] = -ml_ * std::sin(q[1]) * qd[1] * qd[1];
  c[1] = 0.0;
}

void CartPoleClosedForm::ComputeGravityForce(DynamicsData& data, ConstVecRef q, VecRef G) const {
  Checked(data, q, G);
  G[0] = 0.0;
  G[1] = mgl_ * std::sin(q[1]);
}

void CartPoleClosedForm::ComputeKineticEnergyGradient(DynamicsData& data, ConstVecRef q, ConstVecRef qd,
                                                      VecRef dTdq) const {
  Checked(data, q, qd, dTdq);
  dTdq[0] = 0.0;
  dTdq[1] = -ml_ * std::sin(q[1]) * qd[0] * qd[1];
}

double CartPoleClosedForm::ComputeKineticEnergy(DynamicsData& data, ConstVecRef q, ConstVecRef qd) const {
  Checked(data, q, qd);
  return 0.5 * mt_ * qd[0] * qd[0] + ml_ * std::cos(q[1]) * qd[0] * qd[1] + 0.5 * Ip_ * qd[1] * qd[1];
}

double CartPoleClosedForm::ComputePotentialEnergy(DynamicsData& data, ConstVecRef q) const {
  Checked(data, q);
  return -mgl_ * std::cos(q[1]);
}

void CartPoleClosedForm::ComputeInverseDynamics(DynamicsData& data, ConstVecRef q, ConstVecRef qd, ConstVecRef qdd,
                                                DynamicsTerms terms, VecRef tau) const {
  Checked(data, q, qd, qdd, tau);
  const double s = std::sin(q[1]), c = std::cos(q[1]);
  tau[0] = mt_ * qdd[0] + ml_ * c * qdd[1];
  tau[1] = ml_ * c * qdd[0] + Ip_ * qdd[1];
  if (terms.coriolis) {
    CountCoriolis(data);
    tau[0] -= ml_ * s * qd[1] * qd[1];
  }
  if (terms.gravity) {
    CountGravity(data);
    tau[1] += mgl_ * s;
  }
}

void CartPoleClosedForm::ComputeForwardDynamics(DynamicsData& data, ConstVecRef q, ConstVecRef qd, ConstVecRef tau,
                                                DynamicsTerms terms, VecRef qdd) const {
  Checked(data, q, qd, tau, qdd);
  const double s = std::sin(q[1]), c = std::cos(q[1]);
  double r0 = tau[0], r1 = tau[1];
  if (terms.coriolis) {
    CountCoriolis(data);
    r0 += ml_ * s * qd[1] * qd[1];
  }
  if (terms.gravity) {
    CountGravity(data);
    r1 -= mgl_ * s;
  }
  const double m01 = ml_ * c;
  const double inv_det = 1.0 / (mt_ * Ip_ - m01 * m01);
  qdd[0] = (Ip_ * r0 - m01 * r1) * inv_det;
  qdd[1] = (mt_ * r1 - m01 * r0) * inv_det;
}

// tau0 = mt ẍ + ml c θ̈ − ml s θ̇², tau1 = ml c ẍ + Ip θ̈ + mgl s: only θ and θ̇ enter.
void CartPoleClosedForm::ComputeInverseDynamicsDerivatives(DynamicsData& data, ConstVecRef q, ConstVecRef qd,
                                                           ConstVecRef qdd, DynamicsTerms terms, MatRef dtau_dq,
                                                           MatRef dtau_dqd, MatRef dtau_dqdd) const {
  Checked(data, q, qd, qdd, dtau_dq, dtau_dqd, dtau_dqdd);
  CountTerms(data, terms);
  const double s = std::sin(q[1]), c = std::cos(q[1]);
  dtau_dqdd(0, 0) = mt_;
  dtau_dqdd(0, 1) = ml_ * c;
  dtau_dqdd(1, 0) = ml_ * c;
  dtau_dqdd(1, 1) = Ip_;
  dtau_dq.setZero();
  dtau_dqd.setZero();
  dtau_dq(0, 1) = -ml_ * s * qdd[1];
  dtau_dq(1, 1) = -ml_ * s * qdd[0];
  if (terms.coriolis) {
    dtau_dq(0, 1) -= ml_ * c * qd[1] * qd[1];
    dtau_dqd(0, 1) = -2.0 * ml_ * s * qd[1];
  }
  if (terms.gravity) dtau_dq(1, 1) += mgl_ * c;
}

void CartPoleClosedForm::ComputeGravityDerivatives(DynamicsData& data, ConstVecRef q, MatRef dG_dq) const {
  Checked(data, q, dG_dq);
  dG_dq.setZero();
  dG_dq(1, 1) = mgl_ * std::cos(q[1]);
}

void CartPoleClosedForm::ComputeForwardDynamicsDerivatives(DynamicsData& data, ConstVecRef q, ConstVecRef qd,
                                                           ConstVecRef tau, DynamicsTerms terms, VecRef qdd,
                                                           MatRef dqdd_dq, MatRef dqdd_dqd,
                                                           MatRef dqdd_dtau) const {
  TwoJointForwardDynamicsDerivatives(data, q, qd, tau, terms, qdd, dqdd_dq, dqdd_dqd, dqdd_dtau);
}

}  // namespace lagrange
