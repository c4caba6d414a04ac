#pragma once
// Recursive dynamics of a planar serial chain: O(n) algorithms (recursive
// Newton–Euler, composite rigid bodies, articulated bodies) in 2-D spatial
// (Plücker) algebra. The built-in plants (pendulum, arm2, cartpole, chain)
// are described, like every plant, by a RigidTree (plant/rigid_tree.hpp);
// theirs are planar chains, and PlanarChainOf folds such a tree into the
// PlanarChain these algorithms and the planar Lagrangian path run on. They
// are kept beside the spatial algorithms because they are faster where the
// tick spends its time: forward dynamics of long chains (about 10 % at 20
// to 64 links) and the C matrix (2 to 3 ×) (bench/spatial_bench.cpp,
// planar/...); the spatial ones win on inverse dynamics and G.
//
// Frames. Body i's frame is placed in body i−1's frame (the world for i = 0)
// by the joint: translate by `position`, rotate by `angle`, then the joint
// motion: a revolute joint rotates by q_i about z, a prismatic joint
// translates by q_i along its own x axis. Gravity is g along −y of the world.
//
// Spatial vectors are 3-vectors in body coordinates: motion (ω, vx, vy),
// force (n_z, fx, fy). The motion subspace is S = (1, 0, 0) for a revolute
// joint and (0, 1, 0) for a prismatic joint.

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <vector>

#include "plant/dynamics.hpp"
#include "plant/rigid_tree.hpp"

namespace lagrange {

class SpatialDynamics;  // plant/spatial_dynamics.hpp

struct PlanarJoint {
  JointType type = JointType::kRevolute;
  Eigen::Vector2d position = Eigen::Vector2d::Zero();  // in the parent frame, m
  double angle = 0.0;                                  // fixed rotation before the motion, rad
};

struct PlanarBody {
  double mass = 1.0;                              // kg, > 0
  Eigen::Vector2d com = Eigen::Vector2d::Zero();  // centre of mass in the body frame, m
  double inertia = 0.0;                           // about the centre of mass, kg·m², >= 0
};

struct PlanarChain {
  std::vector<PlanarJoint> joints;  // joint i carries body i
  std::vector<PlanarBody> bodies;
  double g = kStandardGravity;  // m/s², along −y

  int num_dofs() const { return static_cast<int>(joints.size()); }
  std::vector<JointType> joint_types() const;

  // Energies by forward kinematics, templated for the Lagrangian path.
  template <class S>
  S KineticEnergy(std::span<const S> q, std::span<const S> qd) const;
  template <class S>
  S PotentialEnergy(std::span<const S> q) const;
};

// `tree` as a planar serial chain, when it is one: joint i's parent is joint
// i − 1, every joint frame lies in the xy plane turned about z only, every
// revolute axis is +z and every prismatic axis +x, gravity is along y.
// A body keeps its mass, its centre of mass's (x, y) and its inertia about z
// (the rest of its tensor is never excited by planar motion). nullopt for any
// other tree. The built-in plants' trees always are planar chains.
std::optional<PlanarChain> PlanarChainOf(const RigidTree& tree);

// O(n) recursive dynamics of a PlanarChain.
//   inverse dynamics: recursive Newton–Euler (RNEA)
//   forward dynamics: articulated-body algorithm (ABA)
//   mass matrix: composite rigid bodies in base coordinates (four scalars
//     per subtree), each entry an independent 3-D dot product, O(n²) to fill M
//   Coriolis matrix: one forward and one backward pass over base-frame
//     composite inertias, their rates and momenta (Pinocchio's
//     computeCoriolisMatrix); O(n) passes, O(n²) to fill C
//   ∂T/∂q: ∂T/∂q_j = −S_jᵀ (v_{j−1} ×* Σ_{i≥j} I_i v_i), O(n)
//   derivatives of inverse dynamics and of G: the spatial sweeps
//     (SpatialDynamics) on the chain's tree, the same bodies in the xy plane
//     (built once here); forward dynamics' by the planar ABA and those
class RecursiveDynamics final : public Dynamics {
 public:
  // Throws std::invalid_argument when the chain's tree is not a valid model
  // (ValidateRigidTree: M(0) not positive definite, a massless link, ...).
  explicit RecursiveDynamics(PlanarChain chain);
  ~RecursiveDynamics() override;

  const PlanarChain& chain() const { return chain_; }
  Method method() const override { return Method::kRecursive; }
  std::unique_ptr<DynamicsData> MakeData() const override;

  void ComputeMassMatrix(DynamicsData& data, ConstVecRef q, MatRef M) const override;
  // The mass matrix's exact kernels:
  //   kCarried    CRBA in body frames: each row's force Ic_i S_i carried
  //               down the chain (Xᵀ F), a serial chain of transforms per row
  //   kBaseFrame  composite inertias in base coordinates (four scalars per
  //               subtree), F_j = Ic_j J_j, M_ij = J_i · F_j: independent dot
  //               products, each column of M written contiguously (the default)
  // kCarried stays for the tests and bench/dynamics_bench.cpp's baseline.
  enum class MassMatrixKernel : std::uint8_t { kCarried, kBaseFrame };
  void ComputeMassMatrix(DynamicsData& data, MassMatrixKernel kernel, ConstVecRef q, MatRef M) const;
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

  // Parent-to-child motion transform of one joint: the child frame sits at r
  // (parent coordinates) rotated by θ; (c, s) = (cos θ, sin θ).
  struct Xform {
    double c = 1.0, s = 0.0;
    Eigen::Vector2d r = Eigen::Vector2d::Zero();
  };

 private:
  struct Data;  // the workspace, defined in the .cpp
  // q => X_i for every joint.
  void ComputeTransforms(Data& d, ConstVecRef q) const;
  // (X, qd) => v_i, body velocities.
  void ComputeVelocities(Data& d, ConstVecRef qd) const;
  // (X, qd) => axes, ov, com: joint axes, body velocities and centres of
  // mass in base coordinates, for the Coriolis and mass matrices; qd null:
  // axes and com only.
  void ComputeBaseFrameMotion(Data& d, const double* qd) const;
  // (X) => M by the kBaseFrame kernel.
  void MassMatrixBaseFrame(Data& d, MatRef M) const;
  // (X, v, qdd, terms) => tau by the backward RNEA pass.
  void Rnea(Data& d, ConstVecRef qd, ConstVecRef qdd, DynamicsTerms terms, VecRef tau) const;

  PlanarChain chain_;
  std::vector<Eigen::Matrix3d> inertia_;            // spatial inertia of each body about its frame origin
  VectorXd angle_offset_, angle_gain_;  // (n) joint i's angle to its parent is offset + gain q_i (gain 1 revolute, 0 prismatic)
  std::unique_ptr<const SpatialDynamics> spatial_;  // the chain's tree, for the derivatives
};

// The chain as the RigidTree it came from (PlanarChainOf's inverse): joints
// "q1" .. "qn", each body a lamina in the xy plane (PlanarTreeBody).
RigidTree PlanarChainTree(const PlanarChain& chain);

// ---- templated energies -------------------------------------------------

template <class S>
S PlanarChain::KineticEnergy(std::span<const S> q, std::span<const S> qd) const {
  using std::cos;
  using std::sin;
  S phi(0.0), phid(0.0);                   // world angle of the current body and its rate
  S ox(0.0), oy(0.0), oxd(0.0), oyd(0.0);  // world origin of the current body and its velocity
  S T(0.0);
  for (int i = 0; i < num_dofs(); ++i) {
    const PlanarJoint& j = joints[i];
    // Joint location: o + R(phi) p, moving with the parent.
    const S cp = cos(phi), sp = sin(phi);
    const S px = cp * j.position.x() - sp * j.position.y();
    const S py = sp * j.position.x() + cp * j.position.y();
    ox = ox + px;
    oy = oy + py;
    oxd = oxd - phid * py;
    oyd = oyd + phid * px;
    phi = phi + j.angle;
    if (j.type == JointType::kRevolute) {
      phi = phi + q[i];
      phid = phid + qd[i];
    } else {
      const S ca = cos(phi), sa = sin(phi);
      ox = ox + ca * q[i];
      oy = oy + sa * q[i];
      oxd = oxd + ca * qd[i] - phid * sa * q[i];
      oyd = oyd + sa * qd[i] + phid * ca * q[i];
    }
    const PlanarBody& b = bodies[i];
    const S c = cos(phi), s = sin(phi);
    const S rx = c * b.com.x() - s * b.com.y();
    const S ry = s * b.com.x() + c * b.com.y();
    const S vx = oxd - phid * ry;
    const S vy = oyd + phid * rx;
    T = T + 0.5 * b.mass * (vx * vx + vy * vy) + 0.5 * b.inertia * phid * phid;
  }
  return T;
}

template <class S>
S PlanarChain::PotentialEnergy(std::span<const S> q) const {
  using std::cos;
  using std::sin;
  S phi(0.0), oy(0.0);
  S V(0.0);
  for (int i = 0; i < num_dofs(); ++i) {
    const PlanarJoint& j = joints[i];
    oy = oy + sin(phi) * j.position.x() + cos(phi) * j.position.y();
    phi = phi + j.angle;
    if (j.type == JointType::kRevolute) {
      phi = phi + q[i];
    } else {
      oy = oy + sin(phi) * q[i];
    }
    const PlanarBody& b = bodies[i];
    const S y = oy + sin(phi) * b.com.x() + cos(phi) * b.com.y();
    V = V + b.mass * g * y;
  }
  return V;
}

}  // namespace lagrange
