#pragma once
// Recursive dynamics of a floating-base RigidTree (floating_base true,
// plant/rigid_tree.hpp): the free-flyer root is a 6-DoF joint between the
// world and the base body, and every algorithm is Featherstone's with that
// root (Rigid Body Dynamics Algorithms, §9.5; Pinocchio's free-flyer), O(n)
// but the mass matrix (O(Σ d)). n degrees of freedom, nq = n + 7,
// nv = n + 6 (RigidTree::num_q, num_v); conventions of q, v and the base's
// generalized force in plant/rigid_tree.hpp; a = v̇ (nv): the base's entries
// are the time derivatives of its body-axes velocity (v_b, ω_b).
//
// Frames are folded as SpatialDynamics' (plant/spatial_dynamics.hpp): at
// construction each joint's body frame is turned about its origin so that its
// axis is z (inertias, children's placements and frames re-expressed), so a
// joint's motion is S = (z, 0) or (0, z) and its transform a rotation about z;
// the sines and cosines of every joint angle come from one vectorised loop
// (plant/spatial_sincos.hpp).
//
//   inverse dynamics  RNEA in body coordinates, each body's net force by
//                     Newton–Euler at its centre of mass, gravity entering
//                     as the base's acceleration: tau = M a + [C v] + [G]
//                     (nv); the base's six entries are the wrench on the
//                     base in base axes (force, then moment about the base
//                     origin) that produces a; zero for a free-flying robot  O(n)
//   mass matrix       CRBA: M (nv x nv), symmetric positive definite    O(Σ d)
//   forward dynamics  ABA: a = M⁻¹ (tau − [C v] − [G]) in world axes at the
//                     base's origin, where a subtree's articulated inertia
//                     is a plain sum (no transforms) and every length is
//                     the robot's (not its distance from the world origin);
//                     the base's 6 x 6 articulated inertia solved at the
//                     root by Cholesky                                   O(n)
//   T, V              ½ vᵀ M v; −gravity · (first moment in the world)   O(n)
//   momentum          the tree's spatial momentum in world axes about the
//                     world origin (angular N·m·s, then linear N·s);
//                     constant when no external force acts (no gravity,
//                     a zero base wrench; joint torques are internal)     O(n)
//
// Kinematics (world frame; rows of every Jacobian linear then angular, as
// plant/kinematics.hpp's kWorldAligned):
//   frames            every named frame's pose R_k, p_k (frames with body −1
//                     ride on the base)                                    O(n + frames)
//   frame Jacobian    J_k (6 x nv): (ṗ_k, ω_k) = J_k v; base columns
//                     (R e_j, 0) and (R e_j × (p_k − p), R e_j), joint columns
//                     as for a fixed base, on the frame's support          O(depth)
//   centre of mass    c (m, world) and J_c (3 x nv), ċ = J_c v               O(n)
//   centroidal        A_G (6 x nv), Orin et al.'s centroidal momentum matrix
//                     (Pinocchio's ccrba): (linear N·s, angular about the
//                     centre of mass N·m·s) = A_G v; each column a composite
//                     inertia times its joint's motion, carried to c        O(n)
//   J̇v                frame k's classical acceleration at a = 0 (6: m/s², then
//                     rad/s², world axes): d/dt (J_k v) = J_k a + J̇_k v; the
//                     drift accelerations a_b = X_b a_λ(b) + v_b × S_b qd_b from
//                     a_base = 0, then (a_v + a_w × r + ω × (v + ω × r), a_w) at
//                     the frame's point r, turned to the world                O(n)
//   Ȧ_G v             the centroidal momentum's rate at a = 0 (N, then N·m about
//                     c, world axes): ḣ_G = A_G a + Ȧ_G v; the RNEA's base
//                     wrench at a = 0 without gravity (the sum of every body's
//                     momentum rate, joint forces being internal), carried to c  O(n)
//
// Model and data: a FloatingDynamics is built once and is const; every
// buffer a query writes is in the FloatingData it makes (MakeData), so no
// query allocates. Every Compute* checks (eigen_assert, off under NDEBUG)
// that q has nq entries and v, a, tau nv, M nv x nv, naming which.
//
// The Lagrangian (Euler–Poincaré) path is plant/floating_lagrangian.hpp.
// Mimic joints (RigidTree: q_j = s q_dof + o, qd_j = s qd_dof) compose with the
// root: each sweep reads a joint's q, qd, qdd through its map and lands its
// generalized force, Jacobian or A_G column on its degree of freedom scaled by
// s (Sᵀ, as plant/mimic_dynamics.hpp's reduction; M = Sᵀ M_j S entry by entry).
// Forward dynamics with mimics solves the reduced M (Cholesky written out:
// the ABA would give the unconstrained joints' accelerations).
// Not here yet: derivatives.

#include <memory>
#include <vector>

#include "plant/rigid_tree.hpp"
#include "plant/spatial_algebra.hpp"
#include "plant/types.hpp"

namespace lagrange {

class FloatingDynamics;

// One user's scratch (one per thread), sized by FloatingDynamics::MakeData.
class FloatingData {
 public:
  explicit FloatingData(const FloatingDynamics& model);
  ~FloatingData();
  FloatingData(const FloatingData&) = delete;
  FloatingData& operator=(const FloatingData&) = delete;
  const FloatingDynamics& model() const { return *model_; }
  // After ComputeFramePlacements: frame k's axes in the world (3 x 3) and origin (m).
  const Eigen::Matrix3d& frame_rotation(int k) const { return frame_R[static_cast<std::size_t>(k)]; }
  const Eigen::Vector3d& frame_position(int k) const { return frame_p[static_cast<std::size_t>(k)]; }
  // How often inverse and forward dynamics evaluated the gravity and Coriolis
  // terms through this data (the other counts stay zero), as DynamicsData's.
  const StageCounts& counts() const { return counts_; }

 private:
  friend class FloatingDynamics;
  struct Scratch;  // the sweeps' buffers, defined in the .cpp
  const FloatingDynamics* model_;
  StageCounts counts_;
  std::unique_ptr<Scratch> s;
  std::vector<Eigen::Matrix3d> frame_R;
  std::vector<Eigen::Vector3d> frame_p;
};

class FloatingDynamics {
 public:
  // Throws std::invalid_argument with ValidateFloatingTree's reason.
  explicit FloatingDynamics(RigidTree tree);

  const RigidTree& tree() const { return tree_; }
  int num_joints() const { return n_; }
  int num_dofs() const { return tree_.num_dofs(); }
  int num_q() const { return num_dofs() + kFreeFlyerNq; }
  int num_v() const { return num_dofs() + kFreeFlyerNv; }
  std::unique_ptr<FloatingData> MakeData() const;

  // (q, v, a) (nq, nv, nv) => tau (nv) = M a + [C v] + [G], bracketed terms
  // only when on in `terms`, each counted in data.counts() (forward dynamics too).
  void ComputeInverseDynamics(FloatingData& data, ConstVecRef q, ConstVecRef v, ConstVecRef a, DynamicsTerms terms,
                              VecRef tau) const;
  // q (nq) => M (nv x nv).
  void ComputeMassMatrix(FloatingData& data, ConstVecRef q, MatRef M) const;
  // (q, v, tau) (nq, nv, nv) => a (nv) = M⁻¹ (tau − [C v] − [G]).
  void ComputeForwardDynamics(FloatingData& data, ConstVecRef q, ConstVecRef v, ConstVecRef tau, DynamicsTerms terms,
                              VecRef a) const;
  // (q, v) => T, J.
  double ComputeKineticEnergy(FloatingData& data, ConstVecRef q, ConstVecRef v) const;
  // q => V, J; zero with every centre of mass at the world origin.
  double ComputePotentialEnergy(FloatingData& data, ConstVecRef q) const;
  // (q, v) => the spatial momentum (angular about the world origin, N·m·s;
  // linear, N·s), world axes.
  spatial::Force ComputeMomentum(FloatingData& data, ConstVecRef q, ConstVecRef v) const;

  // q => every frame's R_k, p_k (read them from `data`).
  void ComputeFramePlacements(FloatingData& data, ConstVecRef q) const;
  // q => frame k's pose (in `data`) and J_k (6 x nv), world axes at its origin.
  void ComputeFrameJacobian(FloatingData& data, ConstVecRef q, int frame, MatRef J) const;
  // q => c (m, world), returned, and J_c (3 x nv).
  Eigen::Vector3d ComputeCenterOfMass(FloatingData& data, ConstVecRef q, MatRef Jc) const;
  // q => A_G (6 x nv); returns c (m, world).
  Eigen::Vector3d ComputeCentroidalMomentumMatrix(FloatingData& data, ConstVecRef q, MatRef A) const;
  // (q, v) => J̇_k v (6: linear, then angular; world axes) of frame k.
  void ComputeFrameAccelerationBias(FloatingData& data, ConstVecRef q, ConstVecRef v, int frame,
                                    Eigen::Ref<Eigen::Matrix<double, 6, 1>> Jdv) const;
  // (q, v) => Ȧ_G v (6: linear, then angular about c; world axes); returns c (m, world).
  Eigen::Vector3d ComputeCentroidalMomentumBias(FloatingData& data, ConstVecRef q, ConstVecRef v,
                                                Eigen::Ref<Eigen::Matrix<double, 6, 1>> Adv) const;

 private:
  void CheckSizes(const FloatingData& data, ConstVecRef q) const;
  static void CountTerms(FloatingData& data, DynamicsTerms terms) {
    if (terms.gravity) ++data.counts_.gravity;
    if (terms.coriolis) ++data.counts_.coriolis;
  }
  // q => X (and the base's R, o); WorldPlacements: X => every body's R, o.
  void Transforms(FloatingData& data, ConstVecRef q) const;
  void WorldPlacements(FloatingData& data) const;
  void Placements(FloatingData& data, ConstVecRef q) const {
    Transforms(data, q);
    WorldPlacements(data);
  }
  void Velocities(FloatingData& data, ConstVecRef v, bool products) const;
  template <bool kVelocity>
  void RneaForward(FloatingData& data, ConstVecRef v, ConstVecRef a) const;
  void Aba(FloatingData& data, ConstVecRef v, ConstVecRef tau, DynamicsTerms terms, VecRef a) const;
  void CompositeInertias(FloatingData& data) const;
  int parent(int body) const { return parent_[static_cast<std::size_t>(body)]; }
  // Body b's joint: its entry of v (and tau), q through its mimic map, qd and qdd.
  int Vi(int b) const { return kFreeFlyerNv + dof_[b]; }
  double JointQ(ConstVecRef q, int b) const { return q[kFreeFlyerNq + dof_[b]] * scale_[b] + offset_[b]; }
  double JointRate(ConstVecRef x, int b) const { return x[Vi(b)] * scale_[b]; }
  // Body b's joint motion S_b: (z, 0) revolute, (0, z) prismatic, folded body axes.
  spatial::Motion Subspace(int b) const {
    return revolute_[b] ? spatial::Motion{Eigen::Vector3d::UnitZ(), Eigen::Vector3d::Zero()}
                        : spatial::Motion{Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitZ()};
  }
  // S_bᵀ f: one component.
  double SubspaceDot(int b, const spatial::Force& f) const { return revolute_[b] ? f.n.z() : f.f.z(); }

  RigidTree tree_;
  int n_ = 0;
  std::vector<int> parent_;     // body → parent body (−1 for the base)
  std::vector<char> revolute_;  // per body (the base: unused)
  // Joint b's fixed placement in its parent's folded frame: the joint frame's
  // coordinates are E0 (x − r); the joint moves the body frame by Rz(q) or q z.
  std::vector<Eigen::Matrix3d> E0_;
  std::vector<Eigen::Vector3d> r_;
  std::vector<spatial::Inertia> inertia_;        // about the body origin, folded body axes
  std::vector<Eigen::Vector3d> com_;             // centre of mass, folded body axes, m
  std::vector<Eigen::Matrix3d> inertia_com_;     // rotational inertia about the centre of mass, folded body axes
  std::vector<Eigen::Matrix3d> frame_rotation_;  // per frame: its axes in its body's folded frame
  std::vector<Eigen::Vector3d> frame_position_;  // per frame: its origin in its body's folded frame, m
  std::vector<int> dof_;                   // per body: its joint's degree of freedom (the base: unused)
  std::vector<double> scale_, offset_;     // per body: its joint's mimic map (1, 0 for a degree of freedom)
};

// x ← A⁻¹ x for a symmetric positive definite A, which is overwritten by its
// Cholesky factor; written out (Eigen's LLT is compiled in plant/dynamics.cpp alone).
void CholeskySolveInPlace(MatrixXd& A, VecRef x);

}  // namespace lagrange
