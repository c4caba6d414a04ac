#pragma once
// The 2-DOF planar arm: q1 from the +x axis, q2 relative to link 1, both
// counter-clockwise; gravity along −y; uniform rods (centre of mass at L/2,
// inertia mL²/12 about it).
//   p_c1 = L1/2 (cos q1, sin q1),  p_c2 = L1 (cos q1, sin q1) + L2/2 (cos q12, sin q12)
//   T = ½ m1|ṗ_c1|² + ½ (m1 L1²/12) q̇1² + ½ m2|ṗ_c2|² + ½ (m2 L2²/12)(q̇1 + q̇2)²
//   V = m1 g y_c1 + m2 g y_c2   (zero at the shoulder's height)

#include <span>
#include <vector>

#include "plant/dynamics.hpp"
#include "plant/rigid_tree.hpp"

namespace lagrange {

struct Arm2Params {
  double m1 = 1.0;  // kg
  double m2 = 0.8;  // kg
  double L1 = 0.6;  // m
  double L2 = 0.5;  // m
  double g = kStandardGravity;
};

class Arm2 {
 public:
  explicit Arm2(Arm2Params p) : p_(p) {}
  const Arm2Params& params() const { return p_; }
  std::vector<JointType> joint_types() const { return {JointType::kRevolute, JointType::kRevolute}; }

  template <class S>
  S KineticEnergy(std::span<const S> q, std::span<const S> qd) const {
    using std::cos;
    using std::sin;
    const S q12 = q[0] + q[1];
    const S w12 = qd[0] + qd[1];
    const double h1 = 0.5 * p_.L1, h2 = 0.5 * p_.L2;
    const S x1d = -h1 * sin(q[0]) * qd[0];
    const S y1d = h1 * cos(q[0]) * qd[0];
    const S x2d = -p_.L1 * sin(q[0]) * qd[0] - h2 * sin(q12) * w12;
    const S y2d = p_.L1 * cos(q[0]) * qd[0] + h2 * cos(q12) * w12;
    return 0.5 * p_.m1 * (x1d * x1d + y1d * y1d) + 0.5 * (p_.m1 * p_.L1 * p_.L1 / 12.0) * qd[0] * qd[0] +
           0.5 * p_.m2 * (x2d * x2d + y2d * y2d) + 0.5 * (p_.m2 * p_.L2 * p_.L2 / 12.0) * w12 * w12;
  }
  template <class S>
  S PotentialEnergy(std::span<const S> q) const {
    using std::sin;
    const S y1 = 0.5 * p_.L1 * sin(q[0]);
    const S y2 = p_.L1 * sin(q[0]) + 0.5 * p_.L2 * sin(q[0] + q[1]);
    return p_.m1 * p_.g * y1 + p_.m2 * p_.g * y2;
  }

 private:
  Arm2Params p_;
};

// The arm as a tree: joints "q1" at the origin and "q2" at (L1, 0) in link 1's frame.
// Frames (x along the link, z out of the plane): "link1" at the shoulder,
// "link2" at the elbow, "tip" at link 2's end, (L1 c1 + L2 c12, L1 s1 + L2 s12, 0).
RigidTree ToRigidTree(const Arm2Params& p);

// M = [[a + 2b cos q2, d + b cos q2], [d + b cos q2, d]],  a = m1L1²/3 + m2L1² + m2L2²/3,
// b = m2 L1 L2 / 2, d = m2 L2²/3;  C = h [[q̇2, q̇1 + q̇2], [−q̇1, 0]], h = −b sin q2;
// G = [g1 cos q1 + g2 cos q12, g2 cos q12], g1 = (m1 L1/2 + m2 L1) g, g2 = m2 L2 g / 2.
// Derivatives by hand from these: ∂M/∂q2 = −b sin q2 [[2, 1], [1, 0]], ∂h/∂q2 = −b cos q2,
// ∂G/∂q from the cosines; forward dynamics' with M⁻¹ written out (2 x 2).
class Arm2ClosedForm final : public Dynamics {
 public:
  explicit Arm2ClosedForm(Arm2Params p);
  Method method() const override { return Method::kClosedForm; }
  void ComputeMassMatrix(DynamicsData& data, ConstVecRef q, MatRef M) const override;
  void ComputeCoriolisMatrix(DynamicsData& data, ConstVecRef q, ConstVecRef qd, MatRef C) const override;
  void ComputeCoriolisForce(DynamicsData& data, ConstVecRef q, ConstVecRef qd, VecRef c) const override;
  void ComputeGravityForce(DynamicsData& data, ConstVecRef q, VecRef G) const override;
  void ComputeKineticEnergyGradient(DynamicsData& data, ConstVecRef q, ConstVecRef qd, VecRef dTdq) const override;
  double ComputeKineticEnergy(DynamicsData& data, ConstVecRef q, ConstVecRef qd) const override;
  double ComputePotentialEnergy(DynamicsData& data, ConstVecRef q) const override;
  void ComputeInverseDynamics(DynamicsData& data, ConstVecRef q, ConstVecRef qd, ConstVecRef qdd, DynamicsTerms terms,
                              VecRef tau) const override;
  void ComputeForwardDynamics(DynamicsData& data, ConstVecRef q, ConstVecRef qd, ConstVecRef tau, DynamicsTerms terms,
                              VecRef qdd) const override;
  void ComputeInverseDynamicsDerivatives(DynamicsData& data, ConstVecRef q, ConstVecRef qd, ConstVecRef qdd,
                                         DynamicsTerms terms, MatRef dtau_dq, MatRef dtau_dqd,
                                         MatRef dtau_dqdd) const override;
  void ComputeGravityDerivatives(DynamicsData& data, ConstVecRef q, MatRef dG_dq) const override;
  void ComputeForwardDynamicsDerivatives(DynamicsData& data, ConstVecRef q, ConstVecRef qd, ConstVecRef tau,
                                         DynamicsTerms terms, VecRef qdd, MatRef dqdd_dq, MatRef dqdd_dqd,
                                         MatRef dqdd_dtau) const override;

 private:
  Arm2Params p_;
  double a_, b_, d_, g1_, g2_;
};

}  // namespace lagrange
