// The floating base's Lagrangian path (FloatingLagrangian: Euler–Poincaré on
// the base twist, dual numbers on the energies) against the recursive one
// (FloatingDynamics: RNEA, CRBA, ABA): two derivations that share no code but
// the tree, on random floating trees.

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <numbers>
#include <random>
#include <string>

#include "plant/floating_dynamics.hpp"
#include "plant/floating_lagrangian.hpp"
#include "plant/random_tree.hpp"
#include "tests/support/plant_cases.hpp"

namespace lagrange {
namespace {

using testing::RandomVector;
using testing::RelativeDifference;

constexpr double kPathsAgreeTol = 1e-10;  // recursive − Lagrangian, relative
constexpr int kLagrangianTrees = 16;

// q: p within ±1 m, a random unit quaternion, joints within ±π (±1 m prismatic); v within ±2.
void RandomFloatingState(const RigidTree& tree, std::mt19937& rng, VectorXd& q, VectorXd& v) {
  q = RandomVector(tree.num_q(), -1.0, 1.0, rng);
  v = RandomVector(tree.num_v(), -2.0, 2.0, rng);
  q.segment<4>(3) = Eigen::Quaterniond(RandomRotation(rng)).coeffs();
  for (int i = 0; i < tree.num_dofs(); ++i) q[kFreeFlyerNq + i] *= std::numbers::pi;
}

RigidTree LagrangianCase(int k, std::mt19937& rng) {
  RandomTreeOptions options;
  options.bodies = k % 8;  // 0: a lone free body
  options.chain = k % 2 == 0;
  return RandomFloatingTree(options, rng);
}

TEST(FloatingLagrangian, MassMatrixBiasAndForwardDynamicsAgreeWithTheRecursivePath) {
  std::mt19937 rng{7};
  for (int k = 0; k < kLagrangianTrees; ++k) {
    const RigidTree tree = LagrangianCase(k, rng);
    const FloatingDynamics recursive(tree);
    const FloatingLagrangian lagrangian(tree);
    auto rd = recursive.MakeData();
    auto ld = lagrangian.MakeData();
    VectorXd q, v;
    RandomFloatingState(tree, rng, q, v);
    const int nv = tree.num_v();
    MatrixXd M_r(nv, nv), M_l(nv, nv);
    recursive.ComputeMassMatrix(*rd, q, M_r);
    lagrangian.ComputeMassMatrix(*ld, q, M_l);
    EXPECT_LT(RelativeDifference(M_r, M_l), kPathsAgreeTol) << "tree " << k;
    for (const DynamicsTerms terms : {DynamicsTerms{}, DynamicsTerms{.gravity = false, .coriolis = true},
                                      DynamicsTerms{.gravity = true, .coriolis = false}}) {
      VectorXd b_r(nv), b_l(nv);
      recursive.ComputeInverseDynamics(*rd, q, v, VectorXd::Zero(nv), terms, b_r);
      lagrangian.ComputeBias(*ld, q, v, terms, b_l);
      EXPECT_LT(RelativeDifference(b_r, b_l), kPathsAgreeTol)
          << "tree " << k << " gravity " << terms.gravity << " coriolis " << terms.coriolis;
    }
    const VectorXd tau = RandomVector(nv, -3.0, 3.0, rng);
    VectorXd a_r(nv), a_l(nv), tau_l(nv);
    recursive.ComputeForwardDynamics(*rd, q, v, tau, {}, a_r);
    lagrangian.ComputeForwardDynamics(*ld, q, v, tau, {}, a_l);
    EXPECT_LT(RelativeDifference(a_r, a_l), kPathsAgreeTol) << "tree " << k;
    lagrangian.ComputeInverseDynamics(*ld, q, v, a_r, {}, tau_l);
    EXPECT_LT(RelativeDifference(tau_l, tau), kPathsAgreeTol) << "tree " << k;
    EXPECT_NEAR(lagrangian.ComputeKineticEnergy(*ld, q, v), recursive.ComputeKineticEnergy(*rd, q, v),
                kPathsAgreeTol * (1.0 + recursive.ComputeKineticEnergy(*rd, q, v)));
    EXPECT_NEAR(lagrangian.ComputePotentialEnergy(*ld, q), recursive.ComputePotentialEnergy(*rd, q),
                kPathsAgreeTol * (1.0 + std::abs(recursive.ComputePotentialEnergy(*rd, q))));
  }
}

TEST(FloatingLagrangian, TheCoadjointTermIsWhatSpinsAFreeBody) {
  // A lone body in no gravity: the bias is ξ ×* μ alone (T has no r to move
  // along), Euler's ω × I ω among it; dropping −ad* would leave it zero.
  std::mt19937 rng{3};
  RandomTreeOptions options;
  options.bodies = 0;
  RigidTree tree = RandomFloatingTree(options, rng);
  tree.gravity.setZero();
  const FloatingLagrangian lagrangian(tree);
  auto ld = lagrangian.MakeData();
  VectorXd q, v;
  RandomFloatingState(tree, rng, q, v);
  VectorXd bias(6);
  lagrangian.ComputeBias(*ld, q, v, {}, bias);
  EXPECT_GT(bias.norm(), 1e-3);
  MatrixXd M(6, 6);
  lagrangian.ComputeMassMatrix(*ld, q, M);
  const VectorXd mu = M * v;
  Eigen::Matrix<double, 6, 1> expected;
  const Eigen::Vector3d vb = v.head<3>(), w = v.tail<3>();
  expected << w.cross(mu.head<3>()), w.cross(mu.tail<3>()) + vb.cross(mu.head<3>());
  EXPECT_LT(RelativeDifference(bias, expected), kPathsAgreeTol);
}

// A random floating tree with every other joint a mimic of an even one
// (multiplier within ±2, offset within ±0.5), prismatic joints among them.
RigidTree FloatingTreeWithMimics(int k, std::mt19937& rng) {
  RandomTreeOptions options;
  options.bodies = 3 + k % 6;
  options.chain = k % 2 == 0;
  options.prismatic_fraction = 0.4;
  RigidTree tree = RandomFloatingTree(options, rng);
  AddRandomMimics(tree, rng);
  for (int b = -1; b < tree.num_joints(); ++b) {  // a frame on every body, the base's included
    tree.frames.push_back({"f" + std::to_string(b + 1), b, RandomUnitVector(rng) * 0.3, RandomRotation(rng)});
  }
  return tree;
}

TEST(FloatingMimic, MimicAndPrismaticJointsComposeWithTheFreeFlyer) {
  // The recursive path reduces the joints onto the degrees of freedom (Sᵀ);
  // the Lagrangian path's energies are over the degrees of freedom already:
  // M, the bias, FD and T agree. The free tree's M projected, Gᵀ M_free G with
  // G = (1₆ ⊕ S), is M again, and J v = J_free (G v).
  std::mt19937 rng{11};
  for (int k = 0; k < 8; ++k) {
    const RigidTree tree = FloatingTreeWithMimics(k, rng);
    ASSERT_TRUE(tree.has_mimics());
    const FloatingDynamics recursive(tree), free(tree.WithEveryJointFree());
    const FloatingLagrangian lagrangian(tree);
    auto rd = recursive.MakeData();
    auto fd = free.MakeData();
    auto ld = lagrangian.MakeData();
    VectorXd q, v;
    RandomFloatingState(tree, rng, q, v);
    const int nv = tree.num_v(), nf = free.num_v();
    MatrixXd M_r(nv, nv), M_l(nv, nv), M_f(nf, nf), G = MatrixXd::Zero(nf, nv);
    recursive.ComputeMassMatrix(*rd, q, M_r);
    lagrangian.ComputeMassMatrix(*ld, q, M_l);
    EXPECT_LT(RelativeDifference(M_r, M_l), kPathsAgreeTol) << "tree " << k;
    G.topLeftCorner<6, 6>().setIdentity();
    VectorXd q_f(free.num_q());
    q_f.head<kFreeFlyerNq>() = q.head<kFreeFlyerNq>();
    for (int i = 0; i < tree.num_joints(); ++i) {
      const RigidTree::JointMap m = tree.MapOf(i);
      G(kFreeFlyerNv + i, kFreeFlyerNv + m.dof) = m.scale;
      q_f[kFreeFlyerNq + i] = m.scale * q[kFreeFlyerNq + m.dof] + m.offset;
    }
    free.ComputeMassMatrix(*fd, q_f, M_f);
    EXPECT_LT(RelativeDifference(G.transpose() * M_f * G, M_r), kPathsAgreeTol) << "tree " << k;
    VectorXd b_r(nv), b_l(nv), a_r(nv), a_l(nv), back(nv);
    recursive.ComputeInverseDynamics(*rd, q, v, VectorXd::Zero(nv), {}, b_r);
    lagrangian.ComputeBias(*ld, q, v, {}, b_l);
    EXPECT_LT(RelativeDifference(b_r, b_l), kPathsAgreeTol) << "tree " << k;
    const VectorXd tau = RandomVector(nv, -3.0, 3.0, rng);
    recursive.ComputeForwardDynamics(*rd, q, v, tau, {}, a_r);
    lagrangian.ComputeForwardDynamics(*ld, q, v, tau, {}, a_l);
    EXPECT_LT(RelativeDifference(a_r, a_l), kPathsAgreeTol) << "tree " << k;
    recursive.ComputeInverseDynamics(*rd, q, v, a_r, {}, back);
    EXPECT_LT(RelativeDifference(back, tau), kPathsAgreeTol) << "tree " << k;
    EXPECT_NEAR(recursive.ComputeKineticEnergy(*rd, q, v), lagrangian.ComputeKineticEnergy(*ld, q, v),
                kPathsAgreeTol * (1.0 + recursive.ComputeKineticEnergy(*rd, q, v)));
    MatrixXd J(6, nv), J_f(6, nf), A(6, nv), A_f(6, nf);
    const VectorXd v_f = G * v;
    for (int f = 0; f < static_cast<int>(tree.frames.size()); ++f) {
      recursive.ComputeFrameJacobian(*rd, q, f, J);
      free.ComputeFrameJacobian(*fd, q_f, f, J_f);
      EXPECT_LT(RelativeDifference(J * v, J_f * v_f), kPathsAgreeTol) << "tree " << k << " frame " << f;
      Eigen::Matrix<double, 6, 1> drift, drift_f;
      recursive.ComputeFrameAccelerationBias(*rd, q, v, f, drift);
      free.ComputeFrameAccelerationBias(*fd, q_f, v_f, f, drift_f);
      EXPECT_LT(RelativeDifference(drift, drift_f), kPathsAgreeTol) << "tree " << k << " frame " << f;
    }
    recursive.ComputeCentroidalMomentumMatrix(*rd, q, A);
    free.ComputeCentroidalMomentumMatrix(*fd, q_f, A_f);
    EXPECT_LT(RelativeDifference(A, A_f * G), kPathsAgreeTol) << "tree " << k;
  }
}

}  // namespace
}  // namespace lagrange
