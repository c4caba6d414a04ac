#include "plant/arm2.hpp"

#include <cmath>

namespace lagrange {

RigidTree ToRigidTree(const Arm2Params& p) {
  RigidTree tree;
  tree.gravity = PlanarGravity(p.g);
  tree.joints.push_back(PlanarTreeJoint("q1", JointType::kRevolute, -1, 0.0, 0.0, 0.0));
  tree.joints.push_back(PlanarTreeJoint("q2", JointType::kRevolute, 0, p.L1, 0.0, 0.0));
  tree.bodies.push_back(PlanarTreeBody(p.m1, 0.5 * p.L1, 0.0, p.m1 * p.L1 * p.L1 / 12.0));
  tree.bodies.push_back(PlanarTreeBody(p.m2, 0.5 * p.L2, 0.0, p.m2 * p.L2 * p.L2 / 12.0));
  tree.frames.push_back(PlanarTreeFrame("link1", 0, 0.0, 0.0, 0.0));
  tree.frames.push_back(PlanarTreeFrame("link2", 1, 0.0, 0.0, 0.0));
  tree.frames.push_back(PlanarTreeFrame("tip", 1, p.L2, 0.0, 0.0));
  return tree;
}

Arm2ClosedForm::Arm2ClosedForm(Arm2Params p)
    : Dynamics({JointType::kRevolute, JointType::kRevolute}),
      p_(p),
      a_(p.m1 * p.L1 * p.L1 / 3.0 + p.m2 * p.L1 * p.L1 + p.m2 * p.L2 * p.L2 / 3.0),
      b_(0.5 * p.m2 * p.L1 * p.L2),
      d_(p.m2 * p.L2 * p.L2 / 3.0),
      g1_((0.5 * p.m1 * p.L1 + p.m2 * p.L1) * p.g),
      g2_(0.5 * p.m2 * p.L2 * p.g) {}

void Arm2ClosedForm::ComputeMassMatrix(DynamicsData& data, ConstVecRef q, MatRef M) const {
  Checked(data, q, M);
  const double bc = b_ * std::cos(q[1]);
  M(0, 0) = a_ + 2.0 * bc;
  M(0, 1) = d_ + bc;
  M(1, 0) = d_ + bc;
  M(1, 1) = d_;
}

void Arm2ClosedForm::ComputeCoriolisMatrix(DynamicsData& data, ConstVecRef q, ConstVecRef qd, MatRef C) const {
  Checked(data, q, qd, C);
  const double h = -b_ * std::sin(q[1]);
  C(0, 0) = h * qd[1];
  C(0, 1) = h * (qd[0] + qd[1]);
  C(1, 0) = -h * qd[0];
  C(1, 1) = 0.0;
}

void Arm2ClosedForm::ComputeCoriolisForce(DynamicsData& data, ConstVecRef q, ConstVecRef qd, VecRef c) const {
  Checked(data, q, qd, c);
  const double h = -b_ * std::sin(q[1]);
  c[0] = h * (2.0 * qd[0] + qd[1]) * qd[1];
  c[1] = -h * qd[0] * qd[0];
}

void Arm2ClosedForm::ComputeGravityForce(DynamicsData& data, ConstVecRef q, VecRef G) const {
  Checked(data, q, G);
  const double c12 = std::cos(q[0] + q[1]);
  G[0] = g1_ * std::cos(q[0]) + g2_ * c12;
  G[1] = g2_ * c12;
}

void Arm2ClosedForm::ComputeKineticEnergyGradient(DynamicsData& data, ConstVecRef q, ConstVecRef qd,
                                                  VecRef dTdq) const {
  Checked(data, q, qd, dTdq);
  dTdq[0] = 0.0;
  dTdq[1] = -b_ * std::sin(q[1]) * (qd[0] * qd[0] + qd[0] * qd[1]);
}

double Arm2ClosedForm::ComputeKineticEnergy(DynamicsData& data, ConstVecRef q, ConstVecRef qd) const {
  Checked(data, q, qd);
  const double bc = b_ * std::cos(q[1]);
  return 0.5 * (a_ + 2.0 * bc) * qd[0] * qd[0] + (d_ + bc) * qd[0] * qd[1] + 0.5 * d_ * qd[1] * qd[1];
}

double Arm2ClosedForm::ComputePotentialEnergy(DynamicsData& data, ConstVecRef q) const {
  Checked(data, q);
  const double s1 = std::sin(q[0]);
  return p_.g * (0.5 * p_.m1 * p_.L1 * s1 + p_.m2 * (p_.L1 * s1 + 0.5 * p_.L2 * std::sin(q[0] + q[1])));
}

void Arm2ClosedForm::ComputeInverseDynamics(DynamicsData& data, ConstVecRef q, ConstVecRef qd, ConstVecRef qdd,
                                            DynamicsTerms terms, VecRef tau) const {
  Checked(data, q, qd, qdd, tau);
  const double s2 = std::sin(q[1]), c2 = std::cos(q[1]);
  const double bc = b_ * c2;
  tau[0] = (a_ + 2.0 * bc) * qdd[0] + (d_ + bc) * qdd[1];
  tau[1] = (d_ + bc) * qdd[0] + d_ * qdd[1];
  if (terms.coriolis) {
    CountCoriolis(data);
    const double h = -b_ * s2;
    tau[0] += h * (2.0 * qd[0] + qd[1]) * qd[1];
    tau[1] -= h * qd[0] * qd[0];
  }
  if (terms.gravity) {
    CountGravity(data);
    const double c12 = std::cos(q[0] + q[1]);
    tau[0] += g1_ * std::cos(q[0]) + g2_ * c12;
    tau[1] += g2_ * c12;
  }
}

void Arm2ClosedForm::ComputeForwardDynamics(DynamicsData& data, ConstVecRef q, ConstVecRef qd, ConstVecRef tau,
                                            DynamicsTerms terms, VecRef qdd) const {
  Checked(data, q, qd, tau, qdd);
  const double s2 = std::sin(q[1]), c2 = std::cos(q[1]);
  double r0 = tau[0], r1 = tau[1];
  if (terms.coriolis) {
    CountCoriolis(data);
    const double h = -b_ * s2;
    r0 -= h * (2.0 * qd[0] + qd[1]) * qd[1];
    r1 += h * qd[0] * qd[0];
  }
  if (terms.gravity) {
    CountGravity(data);
    const double c12 = std::cos(q[0] + q[1]);
    r0 -= g1_ * std::cos(q[0]) + g2_ * c12;
    r1 -= g2_ * c12;
  }
  // 2x2 solve by the explicit inverse; det = (a + 2b c2) d − (d + b c2)² > 0.
  const double bc = b_ * c2;
  const double m00 = a_ + 2.0 * bc, m01 = d_ + bc;
  const double inv_det = 1.0 / (m00 * d_ - m01 * m01);
  qdd[0] = (d_ * r0 - m01 * r1) * inv_det;
  qdd[1] = (m00 * r1 - m01 * r0) * inv_det;
}

// tau0 = (a + 2b c2) qdd0 + (d + b c2) qdd1 + h (2 qd0 + qd1) qd1 + g1 c1 + g2 c12,
// tau1 = (d + b c2) qdd0 + d qdd1 − h qd0² + g2 c12, h = −b s2.
void Arm2ClosedForm::ComputeInverseDynamicsDerivatives(DynamicsData& data, ConstVecRef q, ConstVecRef qd,
                                                       ConstVecRef qdd, DynamicsTerms terms, MatRef dtau_dq,
                                                       MatRef dtau_dqd, MatRef dtau_dqdd) const {
  Checked(data, q, qd, qdd, dtau_dq, dtau_dqd, dtau_dqdd);
  CountTerms(data, terms);
  const double s2 = std::sin(q[1]), c2 = std::cos(q[1]);
  const double bc = b_ * c2, bs = b_ * s2;
  dtau_dqdd(0, 0) = a_ + 2.0 * bc;
  dtau_dqdd(0, 1) = d_ + bc;
  dtau_dqdd(1, 0) = d_ + bc;
  dtau_dqdd(1, 1) = d_;
  dtau_dq(0, 0) = 0.0;
  dtau_dq(1, 0) = 0.0;
  dtau_dq(0, 1) = -bs * (2.0 * qdd[0] + qdd[1]);
  dtau_dq(1, 1) = -bs * qdd[0];
  dtau_dqd.setZero();
  if (terms.coriolis) {
    const double h = -bs;
    dtau_dq(0, 1) -= bc * (2.0 * qd[0] + qd[1]) * qd[1];
    dtau_dq(1, 1) += bc * qd[0] * qd[0];
    dtau_dqd(0, 0) = 2.0 * h * qd[1];
    dtau_dqd(0, 1) = 2.0 * h * (qd[0] + qd[1]);
    dtau_dqd(1, 0) = -2.0 * h * qd[0];
  }
  if (terms.gravity) {
    const double gs12 = g2_ * std::sin(q[0] + q[1]);
    dtau_dq(0, 0) -= g1_ * std::sin(q[0]) + gs12;
    dtau_dq(0, 1) -= gs12;
    dtau_dq(1, 0) -= gs12;
    dtau_dq(1, 1) -= gs12;
  }
}

void Arm2ClosedForm::ComputeGravityDerivatives(DynamicsData& data, ConstVecRef q, MatRef dG_dq) const {
  Checked(data, q, dG_dq);
  const double gs12 = g2_ * std::sin(q[0] + q[1]);
  dG_dq(0, 0) = -g1_ * std::sin(q[0]) - gs12;
  dG_dq(0, 1) = -gs12;
  dG_dq(1, 0) = -gs12;
  dG_dq(1, 1) = -gs12;
}

void Arm2ClosedForm::ComputeForwardDynamicsDerivatives(DynamicsData& data, ConstVecRef q, ConstVecRef qd,
                                                       ConstVecRef tau, DynamicsTerms terms, VecRef qdd,
                                                       MatRef dqdd_dq, MatRef dqdd_dqd, MatRef dqdd_dtau) const {
  TwoJointForwardDynamicsDerivatives(data, q, qd, tau, terms, qdd, dqdd_dq, dqdd_dqd, dqdd_dtau);
}

}  // namespace lagrange
