// Mimic joints (plant/rigid_tree.hpp, plant/mimic_dynamics.hpp): a joint that
// follows another, q_j = S q + o, is no degree of freedom. Two derivations
// that share nothing but the tree are checked against each other and against
// the reduction written out here from the free tree's closed form:
//   the Lagrangian path   automatic differentiation of T(q, qd) and V(q),
//                         which place each mimic from q directly;
//   MimicDynamics         the recursive spatial algorithms on the free tree,
//                         reduced as Sᵀ(·)S.
// Forward dynamics is checked against the reduction (M_red⁻¹(τ − Sᵀ b)), not
// against an articulated-body pass over the free tree, which would ignore the
// coupling.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <string>

#include "plant/arm2.hpp"
#include "plant/kinematics.hpp"
#include "plant/lagrangian.hpp"
#include "plant/mimic_dynamics.hpp"
#include "plant/plant_factory.hpp"
#include "plant/random_tree.hpp"
#include "plant/spatial_dynamics.hpp"
#include "plant/urdf.hpp"
#include "tests/support/plant_cases.hpp"

namespace lagrange {
namespace {

using testing::RandomVector;
using testing::RelativeDifference;

constexpr double kAgreeTol = 1e-12;    // between derivations, relative
constexpr double kInverseTol = 1e-10;  // ID(FD(tau)) − tau, relative
constexpr int kStates = 10;

// Every reduced term of one dynamics at (q, qd).
struct Terms {
  MatrixXd M, C;
  VectorXd c, G, dTdq;
  double T = 0.0, V = 0.0;
};
Terms TermsOf(const Dynamics& dynamics, const VectorXd& q, const VectorXd& qd) {
  const int n = dynamics.num_dofs();
  auto data = dynamics.MakeData();
  Terms t{MatrixXd(n, n), MatrixXd(n, n), VectorXd(n), VectorXd(n), VectorXd(n)};
  dynamics.ComputeMassMatrix(*data, q, t.M);
  dynamics.ComputeCoriolisMatrix(*data, q, qd, t.C);
  dynamics.ComputeCoriolisForce(*data, q, qd, t.c);
  dynamics.ComputeGravityForce(*data, q, t.G);
  dynamics.ComputeKineticEnergyGradient(*data, q, qd, t.dTdq);
  t.T = dynamics.ComputeKineticEnergy(*data, q, qd);
  t.V = dynamics.ComputePotentialEnergy(*data, q);
  return t;
}

void ExpectAgree(const Terms& a, const Terms& b, double tol) {
  EXPECT_LT(RelativeDifference(a.M, b.M), tol);
  EXPECT_LT(RelativeDifference(a.C, b.C), tol);
  EXPECT_LT(RelativeDifference(a.c, b.c), tol);
  EXPECT_LT(RelativeDifference(a.G, b.G), tol);
  EXPECT_LT(RelativeDifference(a.dTdq, b.dTdq), tol);
  EXPECT_NEAR(a.T, b.T, tol * (1.0 + std::abs(a.T)));
  EXPECT_NEAR(a.V, b.V, tol * (1.0 + std::abs(a.V)));
}

// The selection S (num_joints x n) and offsets o of a tree, written out.
struct Reduction {
  MatrixXd S;
  VectorXd o;
};
Reduction ReductionOf(const RigidTree& tree) {
  Reduction r{MatrixXd::Zero(tree.num_joints(), tree.num_dofs()), VectorXd::Zero(tree.num_joints())};
  int dof = 0;
  for (int i = 0; i < tree.num_joints(); ++i) {
    if (tree.joints[i].mimic < 0) r.S(i, dof++) = 1.0;
  }
  for (int i = 0; i < tree.num_joints(); ++i) {
    const TreeJoint& j = tree.joints[i];
    if (j.mimic < 0) continue;
    r.S.row(i) = j.multiplier * r.S.row(j.mimic);
    r.o[i] = j.offset;
  }
  return r;
}

// The free tree's terms at (S q + o, S qd), reduced by S.
Terms Reduced(const Dynamics& free, const Reduction& r, const VectorXd& q, const VectorXd& qd) {
  const Terms f = TermsOf(free, r.S * q + r.o, r.S * qd);
  return {r.S.transpose() * f.M * r.S, r.S.transpose() * f.C * r.S, r.S.transpose() * f.c, r.S.transpose() * f.G,
          r.S.transpose() * f.dTdq, f.T, f.V};
}

// The default arm with its elbow following its shoulder, q2 = m q1 + o.
RigidTree ArmWithMimicElbow(double multiplier, double offset) {
  RigidTree tree = ToRigidTree(Arm2Params{});
  tree.joints[1].mimic = 0;
  tree.joints[1].multiplier = multiplier;
  tree.joints[1].offset = offset;
  return tree;
}

TEST(MimicJoint, AnArmWhoseElbowFollowsItsShoulderIsTheClosedFormArmReduced) {
  const RigidTree tree = ArmWithMimicElbow(-0.6, 0.4);
  ASSERT_EQ(tree.num_dofs(), 1);
  ASSERT_EQ(tree.joint_names(), std::vector<std::string>{"q1"});
  const Arm2ClosedForm closed(Arm2Params{});
  const LagrangianDynamics<RigidTree> lagrangian(tree);
  const MimicDynamics recursive(tree, std::make_shared<const SpatialDynamics>(tree.WithEveryJointFree()));
  const Reduction r = ReductionOf(tree);
  std::mt19937 rng(42);
  for (int k = 0; k < kStates; ++k) {
    const VectorXd q = RandomVector(1, -3.0, 3.0, rng), qd = RandomVector(1, -3.0, 3.0, rng);
    const Terms expected = Reduced(closed, r, q, qd);
    ExpectAgree(TermsOf(lagrangian, q, qd), expected, kAgreeTol);
    ExpectAgree(TermsOf(recursive, q, qd), expected, kAgreeTol);
  }
}

// A random tree with some joints made mimics of others that stay degrees of freedom.
RigidTree RandomTreeWithMimics(int k, std::mt19937& rng) {
  RandomTreeOptions options;
  options.bodies = 3 + k % 8;
  options.chain = k % 2 == 0;
  RigidTree tree = RandomRigidTree(options, rng);
  AddRandomMimics(tree, rng);  // every other joint, each following an even one
  return tree;
}

TEST(MimicJoint, OnRandomTreesTheEnergiesAndTheReducedRecursiveAlgorithmsAgree) {
  std::mt19937 rng(42);
  for (int k = 0; k < 16; ++k) {
    const RigidTree tree = RandomTreeWithMimics(k, rng);
    ASSERT_EQ(ValidateRigidTree(tree), std::nullopt);
    ASSERT_LT(tree.num_dofs(), tree.num_joints());
    const LagrangianDynamics<RigidTree> lagrangian(tree);
    const SpatialDynamics free(tree.WithEveryJointFree());
    const MimicDynamics recursive(tree, std::make_shared<const SpatialDynamics>(tree.WithEveryJointFree()));
    const Reduction r = ReductionOf(tree);
    for (int s = 0; s < 3; ++s) {
      const int n = tree.num_dofs();
      const VectorXd q = RandomVector(n, -2.0, 2.0, rng), qd = RandomVector(n, -2.0, 2.0, rng);
      const Terms expected = Reduced(free, r, q, qd);
      ExpectAgree(TermsOf(lagrangian, q, qd), expected, kAgreeTol);
      ExpectAgree(TermsOf(recursive, q, qd), expected, kAgreeTol);
    }
  }
}

TEST(MimicJoint, ForwardAndInverseDynamicsInvertEachOtherOverTheDegreesOfFreedom) {
  std::mt19937 rng(7);
  for (int k = 0; k < 8; ++k) {
    const RigidTree tree = RandomTreeWithMimics(k, rng);
    const MimicDynamics dynamics(tree, std::make_shared<const SpatialDynamics>(tree.WithEveryJointFree()));
    auto data = dynamics.MakeData();
    const int n = tree.num_dofs();
    const VectorXd q = RandomVector(n, -2.0, 2.0, rng), qd = RandomVector(n, -2.0, 2.0, rng);
    const VectorXd tau = RandomVector(n, -5.0, 5.0, rng);
    VectorXd qdd(n), back(n);
    dynamics.ComputeForwardDynamics(*data, q, qd, tau, DynamicsTerms{}, qdd);
    dynamics.ComputeInverseDynamics(*data, q, qd, qdd, DynamicsTerms{}, back);
    EXPECT_LT(RelativeDifference(back, tau), kInverseTol);
    // M qdd = tau − C qd − G, with the reduced terms written out.
    const Terms t = Reduced(SpatialDynamics(tree.WithEveryJointFree()), ReductionOf(tree), q, qd);
    EXPECT_LT(RelativeDifference(t.M * qdd, tau - t.c - t.G), kInverseTol);
  }
}

TEST(MimicJoint, ARecursiveAlgorithmRefusesATreeWithMimicsAndTheReductionATreeWithout) {
  const RigidTree tree = ArmWithMimicElbow(1.0, 0.0);
  EXPECT_THROW(SpatialDynamics{tree}, std::invalid_argument);
  const RigidTree plain = ToRigidTree(Arm2Params{});
  EXPECT_THROW(MimicDynamics(plain, std::make_shared<const SpatialDynamics>(plain)), std::invalid_argument);
}

TEST(MimicJoint, ValidationRefusesChainsCyclesAndMissingJointsByKey) {
  RigidTree tree = ToRigidTree(Arm2Params{});
  tree.joints[1].mimic = 1;
  EXPECT_NE(ValidateRigidTree(tree).value_or("").find("joints[1].mimic: expected -1 (a degree of freedom)"),
            std::string::npos);
  tree.joints[1].mimic = 5;
  EXPECT_NE(ValidateRigidTree(tree).value_or("").find("joints[1].mimic"), std::string::npos);
  tree.joints[0].mimic = 1;
  tree.joints[1].mimic = 0;
  EXPECT_NE(ValidateRigidTree(tree).value_or("").find("joints[0].mimic: expected a joint that is a degree of freedom"),
            std::string::npos);
  tree.joints[0].mimic = -1;
  tree.joints[1].multiplier = std::nan("");
  EXPECT_NE(ValidateRigidTree(tree).value_or("").find("joints[1].multiplier: expected a finite number"),
            std::string::npos);
}

// The Panda with the Franka Hand: the right finger mimics the left.
UrdfRobot PandaHand() { return LoadUrdf(std::string(LAGRANGE_SOURCE_DIR) + "/config/robots/panda_hand.urdf"); }

TEST(MimicJoint, ThePandaHandHasEightDegreesOfFreedomAndEveryLinkAsAFrame) {
  const UrdfRobot robot = PandaHand();
  EXPECT_EQ(robot.tree.num_joints(), 9);
  EXPECT_EQ(robot.tree.num_dofs(), 8);
  EXPECT_EQ(robot.properties.size(), 8u);
  EXPECT_EQ(robot.tree.joint_names().back(), "panda_finger_joint1");
  const std::vector<std::string> frames = robot.tree.frame_names();
  for (const char* name : {"panda_link8", "panda_hand", "panda_hand_tcp", "panda_leftfinger", "panda_rightfinger"}) {
    EXPECT_NE(std::find(frames.begin(), frames.end(), name), frames.end()) << name;
  }
  const PlantSpec spec = UrdfPlantSpec(std::make_shared<const UrdfRobot>(robot));
  EXPECT_EQ(spec.num_dofs(), 8);
  EXPECT_EQ(JointNamesOf(spec), robot.tree.joint_names());
}

TEST(MimicJoint, ThePandaHandsFingersMoveTwiceAFingersMassAndGravityCancelsBetweenThem) {
  const UrdfRobot robot = PandaHand();
  constexpr double kFingerMass = 0.015;  // kg, config/robots/panda_hand.urdf
  std::mt19937 rng(3);
  const LagrangianDynamics<RigidTree> lagrangian(robot.tree);
  const MimicDynamics recursive(robot.tree,
                                std::make_shared<const SpatialDynamics>(robot.tree.WithEveryJointFree()));
  for (int k = 0; k < kStates; ++k) {
    VectorXd q = RandomVector(8, -2.0, 2.0, rng);
    q[7] = RandomVector(1, 0.0, 0.04, rng)[0];
    const VectorXd qd = RandomVector(8, -1.0, 1.0, rng);
    const Terms a = TermsOf(lagrangian, q, qd), b = TermsOf(recursive, q, qd);
    ExpectAgree(a, b, kAgreeTol);
    // Both fingers slide at the finger joint's speed, opposite ways along the
    // hand's y: the joint carries both masses, and their weights cancel.
    EXPECT_NEAR(b.M(7, 7), 2.0 * kFingerMass, 1e-14);
    EXPECT_NEAR(b.G[7], 0.0, 1e-14);
  }
}

TEST(MimicJoint, FramesFollowTheFreeTreeAtTheExpandedStateWithJacobianColumnsSummed) {
  std::mt19937 rng(11);
  UrdfRobot panda = PandaHand();
  for (int k = 0; k < 9; ++k) {
    const RigidTree tree = k == 8 ? panda.tree : RandomTreeWithMimics(k, rng);
    const RigidTree free_tree = tree.WithEveryJointFree();
    // Every body a frame, so every joint's motion shows somewhere.
    RigidTree framed = tree;
    for (int b = 0; b < tree.num_joints(); ++b) framed.frames.push_back({"body" + std::to_string(b), b});
    RigidTree free_framed = framed.WithEveryJointFree();
    const Kinematics kin(framed), free_kin(free_framed);
    ASSERT_EQ(kin.num_dofs(), tree.num_dofs());
    auto data = kin.MakeData();
    auto free_data = free_kin.MakeData();
    const Reduction r = ReductionOf(tree);
    const int n = tree.num_dofs();
    const VectorXd q = RandomVector(n, -2.0, 2.0, rng), qd = RandomVector(n, -2.0, 2.0, rng);
    kin.ComputeFrameKinematics(*data, q, qd);
    free_kin.ComputeFrameKinematics(*free_data, r.S * q + r.o, r.S * qd);
    for (int f = 0; f < kin.num_frames(); ++f) {
      EXPECT_LT(RelativeDifference(data->position(f), free_data->position(f)), kAgreeTol);
      EXPECT_LT(RelativeDifference(data->rotation(f), free_data->rotation(f)), kAgreeTol);
      for (const FrameAxes axes : {FrameAxes::kWorldAligned, FrameAxes::kLocal}) {
        const MatrixXd expected = free_data->jacobian(f, axes) * r.S;
        EXPECT_LT(RelativeDifference(data->jacobian(f, axes), expected), kAgreeTol) << kin.frame_names()[f];
        EXPECT_LT(RelativeDifference(data->bias_acceleration(f, axes), free_data->bias_acceleration(f, axes)),
                  kAgreeTol);
      }
    }
  }
}

}  // namespace
}  // namespace lagrange
