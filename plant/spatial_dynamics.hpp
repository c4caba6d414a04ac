#pragma once
// Recursive dynamics of a RigidTree (plant/rigid_tree.hpp) in 3-D spatial
// (Plücker) algebra (plant/spatial_algebra.hpp), no heap after construction.
// Symbols, units and dimensions as in plant/types.hpp; n joints, d(i) the
// number of ancestors of joint i.
//
//   inverse dynamics  RNEA: body frames, each body's net force by Newton–Euler
//                     at its centre of mass; a term that is off is not
//                     computed (gravity enters as the base acceleration −g)  O(n)
//   C qd              RNEA with only the velocity terms                       O(n)
//   gravity G         subtree masses and first moments carried tip to base,
//                     G_i = −S_iᵀ (subtree's gravity wrench about joint i)   O(n)
//   ∂T/∂q             (v_i × S_i) · (subtree momentum), one forward and one
//                     backward sweep; equals Cᵀ qd                            O(n)
//   T, V              ½ Σ vᵀ I v; −gravity · (first moment carried to the world)  O(n)
//   mass matrix M     CRBA, the faster of two exact kernels for the tree's
//                     shape, chosen at construction (MassMatrixKernel below):
//                     on chains and deep trees in world coordinates (each
//                     body's inertia taken to the world once, composites as
//                     plain sums, M_ij = J_i · F_j, independent 6-D dot
//                     products), on shallow branching trees in body frames   O(Σ d)
//   Coriolis matrix C the Christoffel factorisation (Ṁ − 2C skew, C qd the
//                     Coriolis force, Cᵀ qd = ∂T/∂q) in one forward and one
//                     backward sweep in world coordinates, no per-column sweeps  O(Σ d)
//   forward dynamics  the faster of two exact algorithms for the tree's shape,
//                     chosen at construction (ForwardAlgorithm below)
//
// Folding. At construction each joint's frame is turned about its origin so
// that its axis is z: the rotation is folded into the joint's origin rotation,
// and its body's inertia and its children's origins are re-expressed in the
// turned frame. Every sweep then sees one motion subspace per joint type,
// S = (z, 0) for a revolute joint and (0, z) for a prismatic one, and a
// parent-to-body transform X_i = (Rz(q_i)ᵀ E0_i, r_i) (revolute) or
// (E0_i, r_i + q_i E0_iᵀ z) (prismatic) with E0_i, r_i constant; fixed-size
// types, no virtual dispatch, one branch on the joint type.
//
// Accuracy. Sines and cosines of all joint angles come from one vectorised
// loop (plant/spatial_sincos.hpp, within 2 ulp of the C library); every result agrees with the
// Lagrangian path (LagrangianDynamics<RigidTree>) to 1e-12 relative
// (tests/plant/rigid_tree_test.cpp).
//
// Cost (bench/spatial_bench.cpp, a 7-joint arm with the Franka Panda's
// geometry), in multiples of one sin + cos of the C library measured in the
// same run: inverse dynamics 25, forward dynamics 46, M 27, C 57, G 9.
//
// Invalid trees (ValidateRigidTree) are refused by the constructor with
// std::invalid_argument, and so are trees with mimic joints: those run as
// their WithEveryJointFree() tree under MimicDynamics (plant/mimic_dynamics.hpp).

#include <cstdint>
#include <memory>

#include "plant/dynamics.hpp"
#include "plant/rigid_tree.hpp"

namespace lagrange {

struct SpatialModel;  // the folded tree (defined in the .cpp)

class SpatialDynamics final : public Dynamics {
 public:
  explicit SpatialDynamics(RigidTree tree);
  ~SpatialDynamics() override;

  const RigidTree& tree() const { return tree_; }
  Method method() const override { return Method::kRecursive; }
  std::unique_ptr<DynamicsData> MakeData() const override;

  void ComputeMassMatrix(DynamicsData& data, ConstVecRef q, MatRef M) const override;
  // The mass matrix's exact kernels:
  //   kBodyFrame   CRBA in body frames: composite inertias carried tip to base
  //                (Xᵀ I X per body), then each row's force Ic_i S_i carried
  //                up its ancestors (Xᵀ F per step; on deep trees taken to
  //                world coordinates once, M_ij = J_j · F)
  //   kWorldFrame  CRBA in world coordinates (Pinocchio's crba since 2.x): each
  //                body's inertia about the world origin from its rotation R
  //                (R I_c Rᵀ as λ0 1 + (R a)(R a)ᵀ + (R b)(R b)ᵀ, factored at
  //                construction), composites Ic_j as plain sums of 10 numbers,
  //                F_j = Ic_j J_j, M_ij = J_i · F_j over the joints above j
  // ComputeMassMatrix runs kWorldFrame on a chain (every joint's parent the
  // joint before it) and on a deep tree (kDeepTreeMeanAncestors), kBodyFrame
  // on other trees: the world frame's placements (R_i, o_i) cost more than
  // the body frame's row products save when joints have few ancestors
  // (bench/dynamics_bench.cpp, mass/...: the Panda, the UR5 and random chains
  // faster in the world frame, a random branching tree of 12 bodies slower).
  enum class MassMatrixKernel : std::uint8_t { kBodyFrame, kWorldFrame };
  MassMatrixKernel mass_matrix_kernel() const { return mass_kernel_; }
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
  // Derivatives: RneaDerivatives in the .cpp, one forward and one backward
  // sweep in world coordinates, O(Σ d) with a few 6-D products per
  // (joint, ancestor) pair; ∂G/∂q by the same sweep without velocities.
  void ComputeInverseDynamicsDerivatives(DynamicsData& data, ConstVecRef q, ConstVecRef qd, ConstVecRef qdd,
                                         DynamicsTerms terms, MatRef dtau_dq, MatRef dtau_dqd,
                                         MatRef dtau_dqdd) const override;
  void ComputeGravityDerivatives(DynamicsData& data, ConstVecRef q, MatRef dG_dq) const override;

  // The exact forward-dynamics algorithms, qdd = M⁻¹ (tau − [C qd] − [G]):
  //   kArticulatedBody     ABA in world coordinates (a subtree's articulated
  //                        inertia is then a plain sum, no transforms)          O(n)
  //   kCompositeRigidBody  the bias forces by RNEA, then one backward sweep
  //                        that builds each row of M by CRBA and at once takes
  //                        the matching step of M's tree-sparse Lᵀ D L
  //                        factorisation and of the solve                     O(Σ d²)
  enum class ForwardAlgorithm : std::uint8_t { kArticulatedBody, kCompositeRigidBody };
  // A tree is deep when its joints have more ancestors than this on average
  // (a chain of more than 14 joints): ComputeForwardDynamics then uses
  // kArticulatedBody, and MassMatrixKernel::kBodyFrame forms each M_ij as a
  // product in world coordinates instead of carrying row i's force up its
  // ancestors (kCompositeRigidBody and the carried force win on shallow
  // trees; both measured in bench/spatial_bench.cpp).
  static constexpr double kDeepTreeMeanAncestors = 6.5;
  ForwardAlgorithm forward_algorithm() const { return forward_; }
  void ComputeForwardDynamics(DynamicsData& data, ForwardAlgorithm algorithm, ConstVecRef q, ConstVecRef qd,
                              ConstVecRef tau, DynamicsTerms terms, VecRef qdd) const;

 private:
  struct Data;  // one user's per-body scratch, defined in the .cpp
  RigidTree tree_;
  ForwardAlgorithm forward_ = ForwardAlgorithm::kArticulatedBody;
  MassMatrixKernel mass_kernel_ = MassMatrixKernel::kWorldFrame;
  std::unique_ptr<const SpatialModel> model_;  // the folded tree, built once in the constructor
};

}  // namespace lagrange
