// Spatial dynamics of rigid trees: the three derivations checked against each
// other. On seeded random trees (branching and chains, revolute and prismatic
// joints, random axes, origin rotations, full inertias and gravity direction)
// the recursive spatial algorithms (SpatialDynamics) agree with automatic
// differentiation of the templated energies (LagrangianDynamics<RigidTree>)
// and, on planar chains, with the planar recursive algorithms; and they obey
// the physics every Lagrangian system obeys.

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <numbers>

#include "plant/eigenvalues.hpp"
#include "plant/lagrangian.hpp"
#include "plant/mimic_dynamics.hpp"
#include "plant/random_tree.hpp"
#include "plant/recursive_dynamics.hpp"
#include "plant/rigid_tree.hpp"
#include "plant/spatial_dynamics.hpp"
#include "plant/spatial_sincos.hpp"
#include "plant/urdf.hpp"
#include "tests/support/alloc_counter.hpp"
#include "tests/support/plant_cases.hpp"

namespace lagrange {
namespace {

using testing::RandomVector;
using testing::RelativeDifference;
using ForwardAlgorithm = SpatialDynamics::ForwardAlgorithm;

constexpr double kAgreeTol = 1e-12;            // between derivations, relative
constexpr double kSymmetryTol = 1e-14;         // M − Mᵀ, relative to ‖M‖
constexpr double kFiniteDifferenceTol = 1e-7;  // central differences with ε = kEps, relative
constexpr double kEps = 1e-6;
constexpr double kInverseTol = 1e-10;     // ID(FD(tau)) − tau, relative to the terms' scale
constexpr int kMaxLagrangianBodies = 12;  // the O(n²)-energy path stays cheap up to here

// A random tree of 1..kMaxLagrangianBodies bodies, chain or branching by turns.
RigidTree RandomTree(int k, std::mt19937& rng, int max_bodies = kMaxLagrangianBodies) {
  RandomTreeOptions options;
  options.bodies = 1 + k % max_bodies;
  options.chain = k % 2 == 0;
  return RandomRigidTree(options, rng);
}

// q within ±π (revolute) or ±1 m (prismatic), qd within ±2.
struct State {
  VectorXd q, qd;
};
State RandomState(const RigidTree& tree, std::mt19937& rng) {
  const int n = tree.num_dofs();
  State s{RandomVector(n, -std::numbers::pi, std::numbers::pi, rng), RandomVector(n, -2.0, 2.0, rng)};
  for (int i = 0; i < n; ++i) {
    if (tree.joints[i].type == JointType::kPrismatic) s.q[i] /= std::numbers::pi;
  }
  return s;
}

struct Terms {
  MatrixXd M, C;
  VectorXd c, G, dTdq, qdd, tau;
  double T = 0.0, V = 0.0;
};

// Every query at (q, qd); forward dynamics of u and inverse dynamics of u as qdd.
Terms Evaluate(const Dynamics& d, const State& s, const VectorXd& u) {
  const std::unique_ptr<DynamicsData> d_data = d.MakeData();
  const int n = d.num_dofs();
  Terms t{MatrixXd(n, n), MatrixXd(n, n), VectorXd(n), VectorXd(n), VectorXd(n), VectorXd(n), VectorXd(n)};
  d.ComputeMassMatrix(*d_data, s.q, t.M);
  d.ComputeCoriolisMatrix(*d_data, s.q, s.qd, t.C);
  d.ComputeCoriolisForce(*d_data, s.q, s.qd, t.c);
  d.ComputeGravityForce(*d_data, s.q, t.G);
  d.ComputeKineticEnergyGradient(*d_data, s.q, s.qd, t.dTdq);
  d.ComputeForwardDynamics(*d_data, s.q, s.qd, u, DynamicsTerms{}, t.qdd);
  d.ComputeInverseDynamics(*d_data, s.q, s.qd, u, DynamicsTerms{}, t.tau);
  t.T = d.ComputeKineticEnergy(*d_data, s.q, s.qd);
  t.V = d.ComputePotentialEnergy(*d_data, s.q);
  return t;
}

// a and b agree on every term, relative to each term's scale.
void ExpectAgree(const Terms& a, const Terms& b, const State& s, const std::string& where) {
  const double m = a.M.norm();
  const double g = m * kStandardGravity;    // scale of gravity terms
  const double v = m * s.qd.squaredNorm();  // scale of velocity-product terms
  EXPECT_LE(RelativeDifference(a.M, b.M), kAgreeTol) << where << " M";
  EXPECT_LE(RelativeDifference(a.C, b.C, m * s.qd.norm()), kAgreeTol) << where << " C";
  EXPECT_LE(RelativeDifference(a.c, b.c, v), kAgreeTol) << where << " C qd";
  EXPECT_LE(RelativeDifference(a.G, b.G, g), kAgreeTol) << where << " G";
  EXPECT_LE(RelativeDifference(a.dTdq, b.dTdq, v), kAgreeTol) << where << " dT/dq";
  EXPECT_LE(RelativeDifference(a.tau, b.tau, g + v), kAgreeTol) << where << " inverse dynamics";
  // Accelerations through the residual, which does not grow with M's condition number.
  EXPECT_LE((a.M * (a.qdd - b.qdd)).norm(), kAgreeTol * (g + v + a.M.norm() * a.qdd.norm()))
      << where << " forward dynamics";
  EXPECT_NEAR(a.T, b.T, kAgreeTol * std::max(1.0, a.T)) << where << " T";
  EXPECT_NEAR(a.V, b.V, kAgreeTol * g) << where << " V";
}

// ---- physics ----------------------------------------------------------------

TEST(SpatialDynamics, MassMatrixIsSymmetricPositiveDefinite) {
  std::mt19937 rng{42};
  for (int k = 0; k < 40; ++k) {
    const RigidTree tree = RandomTree(k, rng, 30);
    const SpatialDynamics d(tree);
    const std::unique_ptr<DynamicsData> d_data = d.MakeData();
    const int n = d.num_dofs();
    MatrixXd M(n, n);
    for (int j = 0; j < 3; ++j) {
      d.ComputeMassMatrix(*d_data, RandomState(tree, rng).q, M);
      ASSERT_LE((M - M.transpose()).norm(), kSymmetryTol * M.norm()) << "tree " << k;
      ASSERT_GT(SymmetricEigenvalues(M).minCoeff(), 0.0) << "tree " << k;
    }
  }
}

TEST(SpatialDynamics, MassMatrixRateMinusTwoCoriolisIsSkewSymmetric) {
  std::mt19937 rng{7};
  for (int k = 0; k < 40; ++k) {
    const RigidTree tree = RandomTree(k, rng, 30);
    const SpatialDynamics d(tree);
    const std::unique_ptr<DynamicsData> d_data = d.MakeData();
    const int n = d.num_dofs();
    MatrixXd Mp(n, n), Mm(n, n), C(n, n);
    const State s = RandomState(tree, rng);
    d.ComputeMassMatrix(*d_data, s.q + kEps * s.qd, Mp);
    d.ComputeMassMatrix(*d_data, s.q - kEps * s.qd, Mm);
    const MatrixXd Mdot = (Mp - Mm) / (2.0 * kEps);  // Ṁ along qd
    d.ComputeCoriolisMatrix(*d_data, s.q, s.qd, C);
    const MatrixXd N = Mdot - 2.0 * C;
    ASSERT_LE((N + N.transpose()).norm(), kFiniteDifferenceTol * Mp.norm() * s.qd.norm()) << "tree " << k;
  }
}

TEST(SpatialDynamics, CoriolisForceAndEnergyGradientFollowFromTheCoriolisMatrix) {
  std::mt19937 rng{13};
  for (int k = 0; k < 40; ++k) {
    const RigidTree tree = RandomTree(k, rng, 40);
    const SpatialDynamics d(tree);
    const std::unique_ptr<DynamicsData> d_data = d.MakeData();
    const int n = d.num_dofs();
    MatrixXd C(n, n), M(n, n);
    VectorXd c(n), dTdq(n);
    const State s = RandomState(tree, rng);
    d.ComputeMassMatrix(*d_data, s.q, M);
    d.ComputeCoriolisMatrix(*d_data, s.q, s.qd, C);
    d.ComputeCoriolisForce(*d_data, s.q, s.qd, c);
    d.ComputeKineticEnergyGradient(*d_data, s.q, s.qd, dTdq);
    const double floor = M.norm() * s.qd.squaredNorm();
    ASSERT_LE(RelativeDifference(c, C * s.qd, floor), kAgreeTol) << "tree " << k;
    ASSERT_LE(RelativeDifference(dTdq, C.transpose() * s.qd, floor), kAgreeTol) << "tree " << k;
    ASSERT_NEAR(d.ComputeKineticEnergy(*d_data, s.q, s.qd), 0.5 * s.qd.dot(M * s.qd), kAgreeTol * floor)
        << "tree " << k;
  }
}

TEST(SpatialDynamics, ForwardDynamicsInvertsInverseDynamics) {
  std::mt19937 rng{17};
  for (int k = 0; k < 40; ++k) {
    const RigidTree tree = RandomTree(k, rng, 30);
    const SpatialDynamics d(tree);
    const std::unique_ptr<DynamicsData> d_data = d.MakeData();
    const int n = d.num_dofs();
    MatrixXd M(n, n);
    VectorXd qdd(n), back(n);
    const State s = RandomState(tree, rng);
    d.ComputeMassMatrix(*d_data, s.q, M);
    const VectorXd tau = RandomVector(n, -10.0, 10.0, rng);
    const double scale = tau.norm() + M.norm() * (kStandardGravity + s.qd.squaredNorm());
    for (const DynamicsTerms terms : {DynamicsTerms{true, true}, DynamicsTerms{false, true}, DynamicsTerms{true, false},
                                      DynamicsTerms{false, false}}) {
      for (ForwardAlgorithm algorithm : {ForwardAlgorithm::kArticulatedBody, ForwardAlgorithm::kCompositeRigidBody}) {
        d.ComputeForwardDynamics(*d_data, algorithm, s.q, s.qd, tau, terms, qdd);
        d.ComputeInverseDynamics(*d_data, s.q, s.qd, qdd, terms, back);
        ASSERT_LE((back - tau).norm(), kInverseTol * scale)
            << "tree " << k << " algorithm " << static_cast<int>(algorithm) << " gravity " << terms.gravity
            << " coriolis " << terms.coriolis;
      }
    }
  }
}

// d(T + V)/dt = qdᵀ tau along the vector field: the energy is differentiated
// along (q̇, q̈) = (qd, FD(q, qd, tau)) by central differences.
TEST(SpatialDynamics, EnergyChangesAtThePowerOfTheJointForces) {
  std::mt19937 rng{19};
  for (int k = 0; k < 40; ++k) {
    const RigidTree tree = RandomTree(k, rng, 30);
    const SpatialDynamics d(tree);
    const std::unique_ptr<DynamicsData> d_data = d.MakeData();
    const int n = d.num_dofs();
    const State s = RandomState(tree, rng);
    const VectorXd tau = RandomVector(n, -5.0, 5.0, rng);
    VectorXd qdd(n);
    d.ComputeForwardDynamics(*d_data, s.q, s.qd, tau, DynamicsTerms{}, qdd);
    auto energy = [&](double t) {
      const VectorXd q = s.q + t * s.qd, qd = s.qd + t * qdd;
      return d.ComputeKineticEnergy(*d_data, q, qd) + d.ComputePotentialEnergy(*d_data, q);
    };
    const double rate = (energy(kEps) - energy(-kEps)) / (2.0 * kEps);
    const double power = Power(s.qd, tau);
    MatrixXd M(n, n);
    d.ComputeMassMatrix(*d_data, s.q, M);
    const double scale = M.norm() * (s.qd.norm() + qdd.norm()) * (s.qd.norm() + kStandardGravity) + std::abs(power);
    ASSERT_NEAR(rate, power, kFiniteDifferenceTol * scale) << "tree " << k;
  }
}

TEST(SpatialDynamics, InverseDynamicsComputesAndCountsOnlyTheTermsThatAreOn) {
  std::mt19937 rng{23};
  const RigidTree tree = RandomRigidTree({.bodies = 6, .chain = false, .prismatic_fraction = 0.3}, rng);
  const SpatialDynamics d(tree);
  const std::unique_ptr<DynamicsData> d_data = d.MakeData();
  const int n = d.num_dofs();
  const State s = RandomState(tree, rng);
  const VectorXd qdd = RandomVector(n, -3.0, 3.0, rng);
  MatrixXd M(n, n);
  VectorXd c(n), G(n), tau(n);
  d.ComputeMassMatrix(*d_data, s.q, M);
  d.ComputeCoriolisForce(*d_data, s.q, s.qd, c);
  d.ComputeGravityForce(*d_data, s.q, G);
  const double scale = M.norm() * (qdd.norm() + s.qd.squaredNorm() + kStandardGravity);
  for (const DynamicsTerms terms : {DynamicsTerms{true, true}, DynamicsTerms{false, true}, DynamicsTerms{true, false},
                                    DynamicsTerms{false, false}}) {
    const StageCounts before = d_data->counts();
    d.ComputeInverseDynamics(*d_data, s.q, s.qd, qdd, terms, tau);
    VectorXd expected = M * qdd;
    if (terms.coriolis) expected += c;
    if (terms.gravity) expected += G;
    EXPECT_LE((tau - expected).norm(), kAgreeTol * scale);
    EXPECT_EQ(d_data->counts().gravity - before.gravity, terms.gravity ? 1 : 0);
    EXPECT_EQ(d_data->counts().coriolis - before.coriolis, terms.coriolis ? 1 : 0);
    const StageCounts middle = d_data->counts();
    VectorXd back(n);
    d.ComputeForwardDynamics(*d_data, s.q, s.qd, tau, terms, back);
    EXPECT_EQ(d_data->counts().gravity - middle.gravity, terms.gravity ? 1 : 0);
    EXPECT_EQ(d_data->counts().coriolis - middle.coriolis, terms.coriolis ? 1 : 0);
  }
}

TEST(SpatialDynamics, BothForwardAlgorithmsAgreeOnLargeTrees) {
  std::mt19937 rng{29};
  for (int bodies : {16, 40, 64}) {
    for (bool chain : {true, false}) {
      const RigidTree tree = RandomRigidTree({.bodies = bodies, .chain = chain, .prismatic_fraction = 0.3}, rng);
      const SpatialDynamics d(tree);
      const std::unique_ptr<DynamicsData> d_data = d.MakeData();
      const State s = RandomState(tree, rng);
      const VectorXd tau = RandomVector(bodies, -5.0, 5.0, rng);
      VectorXd a(bodies), b(bodies);
      MatrixXd M(bodies, bodies);
      d.ComputeMassMatrix(*d_data, s.q, M);
      d.ComputeForwardDynamics(*d_data, ForwardAlgorithm::kArticulatedBody, s.q, s.qd, tau, DynamicsTerms{}, a);
      d.ComputeForwardDynamics(*d_data, ForwardAlgorithm::kCompositeRigidBody, s.q, s.qd, tau, DynamicsTerms{}, b);
      EXPECT_LE((M * (a - b)).norm(), kInverseTol * (tau.norm() + M.norm() * (s.qd.squaredNorm() + kStandardGravity)))
          << bodies << " bodies, chain " << chain;
    }
  }
}

// ---- the three derivations ------------------------------------------------------

TEST(SpatialDynamics, AgreesWithTheLagrangianPathOnRandomTrees) {
  std::mt19937 rng{31};
  for (int k = 0; k < 2 * kMaxLagrangianBodies; ++k) {
    const RigidTree tree = RandomTree(k, rng);
    const SpatialDynamics recursive(tree);
    const LagrangianDynamics<RigidTree> lagrangian(tree);
    for (int j = 0; j < 2; ++j) {
      const State s = RandomState(tree, rng);
      const VectorXd u = RandomVector(tree.num_dofs(), -10.0, 10.0, rng);
      ExpectAgree(Evaluate(lagrangian, s, u), Evaluate(recursive, s, u), s,
                  "tree " + std::to_string(k) + " (" + std::to_string(tree.num_dofs()) + " bodies)");
    }
  }
}

// A random planar chain, described as every plant is, by a RigidTree in the
// xy plane (PlanarTreeJoint, PlanarTreeBody, PlanarGravity).
RigidTree RandomPlanarTree(int links, std::mt19937& rng) {
  std::uniform_real_distribution<double> mass(0.3, 2.0), coord(-0.6, 0.6), angle(-1.5, 1.5), inertia(0.01, 0.2),
      unit(0.0, 1.0);
  RigidTree tree;
  tree.gravity = PlanarGravity(kStandardGravity);
  for (int i = 0; i < links; ++i) {
    const JointType type = unit(rng) < 0.3 ? JointType::kPrismatic : JointType::kRevolute;
    tree.joints.push_back(PlanarTreeJoint(std::string(1, 'j').append(std::to_string(i)), type, i - 1, coord(rng),
                                          coord(rng), angle(rng)));
    tree.bodies.push_back(PlanarTreeBody(mass(rng), coord(rng), coord(rng), inertia(rng)));
  }
  return tree;
}

TEST(SpatialDynamics, PlanarTreeMatchesThePlanarRecursiveDynamicsOfItsFold) {
  std::mt19937 rng{37};
  for (int k = 0; k < 12; ++k) {
    const RigidTree tree = RandomPlanarTree(1 + k % 8, rng);
    const std::optional<PlanarChain> chain = PlanarChainOf(tree);
    ASSERT_TRUE(chain.has_value()) << "tree " << k;
    const RecursiveDynamics planar(*chain);
    const SpatialDynamics spatial(tree);
    for (int j = 0; j < 4; ++j) {
      const State s = RandomState(tree, rng);
      const VectorXd u = RandomVector(tree.num_dofs(), -10.0, 10.0, rng);
      ExpectAgree(Evaluate(planar, s, u), Evaluate(spatial, s, u), s, "chain " + std::to_string(k));
    }
  }
}

// The base-frame mass matrix (the default since issue 37) against the
// body-frame CRBA it replaced, on random planar chains of 1 to 64 links with
// prismatic joints; the Panda, the UR5, random and mimic trees never reach
// RecursiveDynamics (PlanarChainOf refuses them).
TEST(RecursiveDynamics, BaseFrameMassMatrixMatchesTheCarriedOne) {
  using Kernel = RecursiveDynamics::MassMatrixKernel;
  std::mt19937 rng{42};
  for (int links : {1, 2, 3, 5, 8, 13, 21, 34, 64}) {
    const RigidTree tree = RandomPlanarTree(links, rng);
    const RecursiveDynamics d(*PlanarChainOf(tree));
    const std::unique_ptr<DynamicsData> data = d.MakeData();
    MatrixXd carried(links, links), base(links, links), fallback(links, links);
    for (int k = 0; k < 4; ++k) {
      const State s = RandomState(tree, rng);
      d.ComputeMassMatrix(*data, Kernel::kCarried, s.q, carried);
      d.ComputeMassMatrix(*data, Kernel::kBaseFrame, s.q, base);
      d.ComputeMassMatrix(*data, s.q, fallback);
      EXPECT_LT(RelativeDifference(base, carried), kAgreeTol) << links << " links, state " << k;
      EXPECT_TRUE(fallback == base) << "ComputeMassMatrix runs kBaseFrame, the same code: the same bits";
    }
  }
}

// The world-frame mass matrix (the default on chains and deep trees since
// issue 37) against the body-frame CRBA: on random chains and branching trees of 1 to
// 64 bodies with prismatic joints (shallow and deep: the body-frame kernel
// carries rows up to 6.5 mean ancestors, then takes them to the world), the
// shipped Panda and UR5, and random trees with mimic joints (through
// MimicDynamics, against Sᵀ M(S q + o) S by the body-frame kernel).
TEST(SpatialDynamics, WorldFrameMassMatrixMatchesTheBodyFrameOne) {
  using Kernel = SpatialDynamics::MassMatrixKernel;
  std::mt19937 rng{61};
  std::vector<RigidTree> trees;
  for (int bodies : {1, 2, 3, 5, 7, 12, 20, 40, 64}) {
    for (bool chain : {true, false}) {
      trees.push_back(RandomRigidTree({bodies, chain, 0.3}, rng));
      // Random branching trees are shallow (about ln n ancestors a joint): the body frame's, unless a chain by chance.
      bool is_chain = true;
      for (int i = 0; i < bodies; ++i) is_chain = is_chain && trees.back().joints[i].parent == i - 1;
      EXPECT_EQ(SpatialDynamics(trees.back()).mass_matrix_kernel(), is_chain ? Kernel::kWorldFrame : Kernel::kBodyFrame)
          << bodies << " bodies, chain " << chain;
    }
  }
  for (const char* robot : {"panda", "ur5"}) {
    trees.push_back(LoadUrdf(std::string(LAGRANGE_SOURCE_DIR) + "/config/robots/" + robot + ".urdf").tree);
  }
  for (std::size_t t = 0; t < trees.size(); ++t) {
    const SpatialDynamics d(trees[t]);
    const std::unique_ptr<DynamicsData> data = d.MakeData();
    const int n = d.num_dofs();
    MatrixXd body(n, n), world(n, n), fallback(n, n);
    for (int k = 0; k < 3; ++k) {
      const State s = RandomState(trees[t], rng);
      d.ComputeMassMatrix(*data, Kernel::kBodyFrame, s.q, body);
      d.ComputeMassMatrix(*data, Kernel::kWorldFrame, s.q, world);
      d.ComputeMassMatrix(*data, s.q, fallback);
      EXPECT_LT(RelativeDifference(world, body), kAgreeTol) << "tree " << t << " (" << n << " bodies), state " << k;
      EXPECT_TRUE(fallback == (d.mass_matrix_kernel() == Kernel::kWorldFrame ? world : body))
          << "ComputeMassMatrix runs the kernel mass_matrix_kernel() names: the same bits";
    }
  }
  for (int k = 0; k < 6; ++k) {
    RigidTree tree = RandomRigidTree({4 + 2 * k, k % 2 == 0, 0.3}, rng);
    AddRandomMimics(tree, rng);
    const RigidTree free_tree = tree.WithEveryJointFree();
    const auto free = std::make_shared<const SpatialDynamics>(free_tree);
    const MimicDynamics mimic(tree, free);
    const std::unique_ptr<DynamicsData> mimic_data = mimic.MakeData();
    const std::unique_ptr<DynamicsData> free_data = free->MakeData();
    const int n = tree.num_dofs(), joints = tree.num_joints();
    MatrixXd S = MatrixXd::Zero(joints, n);
    VectorXd offset(joints);
    for (int j = 0; j < joints; ++j) {
      const RigidTree::JointMap map = tree.MapOf(j);
      S(j, map.dof) = map.scale;
      offset[j] = map.offset;
    }
    const VectorXd q = RandomVector(n, -2.0, 2.0, rng);
    MatrixXd reduced(n, n), body(joints, joints);
    mimic.ComputeMassMatrix(*mimic_data, q, reduced);
    free->ComputeMassMatrix(*free_data, Kernel::kBodyFrame, S * q + offset, body);
    EXPECT_LT(RelativeDifference(reduced, S.transpose() * body * S), kAgreeTol) << "mimic tree " << k;
  }
}

TEST(PlanarChainOf, FoldsOnlyPlanarSerialChains) {
  std::mt19937 rng{43};
  const RigidTree planar = RandomPlanarTree(4, rng);
  ASSERT_TRUE(PlanarChainOf(planar).has_value());
  const auto fails = [&planar](auto&& change) {
    RigidTree t = planar;
    change(t);
    return !PlanarChainOf(t).has_value();
  };
  EXPECT_TRUE(fails([](RigidTree& t) { t.gravity = Eigen::Vector3d(0.0, 0.0, -kStandardGravity); }));
  EXPECT_TRUE(fails([](RigidTree& t) { t.joints[2].parent = 0; }));  // a branch, not a chain
  EXPECT_TRUE(fails([](RigidTree& t) { t.joints[1].position.z() = 0.1; }));
  EXPECT_TRUE(fails([](RigidTree& t) { t.joints[3].axis = Eigen::Vector3d::UnitY(); }));
  EXPECT_TRUE(fails([](RigidTree& t) {
    t.joints[1].rotation = Eigen::AngleAxisd(0.2, Eigen::Vector3d::UnitX()).toRotationMatrix();
  }));
}

TEST(SpatialDynamics, ForwardAlgorithmFollowsTheTreeDepth) {
  std::mt19937 rng{41};
  const auto algorithm = [&rng](int bodies, bool chain) {
    return SpatialDynamics(RandomRigidTree({.bodies = bodies, .chain = chain, .prismatic_fraction = 0.3}, rng))
        .forward_algorithm();
  };
  EXPECT_EQ(algorithm(7, true), ForwardAlgorithm::kCompositeRigidBody);
  EXPECT_EQ(algorithm(30, true), ForwardAlgorithm::kArticulatedBody);
  EXPECT_EQ(algorithm(30, false), ForwardAlgorithm::kCompositeRigidBody);  // shallow: few ancestors each
}

// The sweeps' sine and cosine agree with the C library's within 2 ulp of the
// result, near the zeros too, and fall back to it beyond their range.
TEST(SpatialSinCos, MatchesTheCLibraryWithinTwoUlps) {
  constexpr double kUlp = std::numeric_limits<double>::epsilon();
  std::mt19937 rng{59};
  std::uniform_real_distribution<double> angle(-60.0, 60.0), tiny(-1e-7, 1e-7);
  std::vector<double> x;
  for (int k = 0; k < 20000; ++k) x.push_back(angle(rng));
  for (int k = -40; k <= 40; ++k) x.push_back(k * std::numbers::pi / 2 + tiny(rng));  // near the zeros
  for (double big : {2e5, -3.7e7, 1e300}) x.push_back(big);
  std::vector<double> c(x.size()), s(x.size());
  spatial::SinCos(x.data(), c.data(), s.data(), static_cast<int>(x.size()));
  for (std::size_t k = 0; k < x.size(); ++k) {
    ASSERT_LE(std::abs(s[k] - std::sin(x[k])), 2.0 * kUlp * std::abs(std::sin(x[k]))) << "sin " << x[k];
    ASSERT_LE(std::abs(c[k] - std::cos(x[k])), 2.0 * kUlp * std::abs(std::cos(x[k]))) << "cos " << x[k];
  }
  const double bad[2] = {std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity()};
  double cb[2], sb[2];
  spatial::SinCos(bad, cb, sb, 2);
  EXPECT_TRUE(std::isnan(cb[0]) && std::isnan(sb[0]) && std::isnan(cb[1]) && std::isnan(sb[1]));
}

// ---- validation -------------------------------------------------------------

RigidTree ValidTree() {
  std::mt19937 rng{43};
  return RandomRigidTree({.bodies = 5, .chain = false, .prismatic_fraction = 0.3}, rng);
}

// The message names `key` first, in the "KEY: expected ..., got ..." form.
void ExpectRefused(const RigidTree& tree, const std::string& key) {
  const std::optional<std::string> error = ValidateRigidTree(tree);
  ASSERT_TRUE(error.has_value()) << key;
  EXPECT_EQ(error->rfind(key + ": expected ", 0), 0u) << *error;
  EXPECT_NE(error->find(", got "), std::string::npos) << *error;
  EXPECT_THROW(SpatialDynamics{tree}, std::invalid_argument) << key;
}

TEST(ValidateRigidTree, AcceptsRandomTrees) {
  std::mt19937 rng{47};
  for (int k = 0; k < 50; ++k) {
    const RigidTree tree = RandomTree(k, rng, 40);
    EXPECT_EQ(ValidateRigidTree(tree), std::nullopt) << *ValidateRigidTree(tree);
  }
}

TEST(ValidateRigidTree, RefusesANonUnitAxis) {
  RigidTree tree = ValidTree();
  tree.joints[3].axis *= 1.2;
  ExpectRefused(tree, "joints[3].axis");
}

TEST(ValidateRigidTree, RefusesAParentAfterItsChild) {
  RigidTree tree = ValidTree();
  tree.joints[2].parent = 4;
  ExpectRefused(tree, "joints[2].parent");
  tree.joints[2].parent = 2;
  ExpectRefused(tree, "joints[2].parent");
}

TEST(ValidateRigidTree, RefusesAnImproperRotation) {
  RigidTree tree = ValidTree();
  tree.joints[1].rotation.col(0) *= -1.0;  // a reflection
  ExpectRefused(tree, "joints[1].rotation");
}

TEST(ValidateRigidTree, RefusesAnInertiaThatIsNotPositiveSemiDefinite) {
  RigidTree tree = ValidTree();
  tree.bodies[2].inertia = Eigen::Vector3d(0.1, 0.1, -0.01).asDiagonal();
  ExpectRefused(tree, "bodies[2].inertia");
}

TEST(ValidateRigidTree, RefusesAnInertiaViolatingTheTriangleInequality) {
  RigidTree tree = ValidTree();
  const Eigen::Matrix3d R = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  tree.bodies[4].inertia = R * Eigen::Vector3d(0.1, 0.2, 0.35).asDiagonal() * R.transpose();  // 0.35 > 0.1 + 0.2
  ExpectRefused(tree, "bodies[4].inertia");
}

TEST(ValidateRigidTree, RefusesAnAsymmetricInertia) {
  RigidTree tree = ValidTree();
  tree.bodies[0].inertia(0, 1) += 0.01;
  ExpectRefused(tree, "bodies[0].inertia");
}

// One tolerance, kInertiaTolerance of the largest principal moment, at any
// scale: rounding just inside it is accepted, just outside refused, for a
// gram-millimetre body as for a tonne-metre one.
TEST(CheckRotationalInertia, ToleranceIsRelativeToTheLargestPrincipalMomentAtAnyScale) {
  const Eigen::Matrix3d R = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  for (const double scale : {1e-9, 1.0, 1e6}) {
    SCOPED_TRACE(scale);
    const auto turned = [&](double a, double b, double c) {
      return Eigen::Matrix3d(scale * R * Eigen::Vector3d(a, b, c).asDiagonal() * R.transpose());
    };
    EXPECT_EQ(CheckRotationalInertia(turned(0.5, 0.5, 1.0)), std::nullopt);  // a thin disc: the triangle's edge
    EXPECT_EQ(CheckRotationalInertia(turned(0.0, 1.0, 1.0)), std::nullopt);  // a thin rod
    EXPECT_EQ(CheckRotationalInertia(turned(-0.5 * kInertiaTolerance, 1.0, 1.0)), std::nullopt);
    EXPECT_EQ(CheckRotationalInertia(turned(0.5, 0.5, 1.0 + 0.5 * kInertiaTolerance)), std::nullopt);
    const auto negative = CheckRotationalInertia(turned(-2.0 * kInertiaTolerance, 1.0, 1.0));
    ASSERT_TRUE(negative.has_value());
    EXPECT_NE(negative->find("not positive semi-definite"), std::string::npos) << *negative;
    const auto triangle = CheckRotationalInertia(turned(0.5, 0.5, 1.0 + 2.0 * kInertiaTolerance));
    ASSERT_TRUE(triangle.has_value());
    EXPECT_NE(triangle->find("triangle inequality"), std::string::npos) << *triangle;
    Eigen::Matrix3d asymmetric = turned(1.0, 1.0, 1.0);
    asymmetric(0, 1) += 2.0 * kInertiaTolerance * scale;
    EXPECT_NE(CheckRotationalInertia(asymmetric), std::nullopt);
  }
  EXPECT_NE(CheckRotationalInertia(Eigen::Matrix3d::Constant(std::nan(""))), std::nullopt);
}

TEST(ValidateRigidTree, RefusesAMasslessLeaf) {
  RigidTree tree = ValidTree();
  tree.joints.push_back(TreeJoint{.name = "tip", .type = JointType::kRevolute, .parent = 4});
  tree.bodies.push_back(RigidBody{});
  ExpectRefused(tree, "bodies[5].mass");
}

TEST(ValidateRigidTree, RefusesAJointThatMovesNothing) {
  // Two coincident revolute axes, the second carrying everything: M(0) singular at the second.
  RigidTree tree;
  tree.joints.push_back(TreeJoint{.name = "a", .type = JointType::kRevolute, .parent = -1});
  tree.joints.push_back(TreeJoint{.name = "b", .type = JointType::kRevolute, .parent = 0});
  tree.bodies.push_back(RigidBody{});
  tree.bodies.push_back(
      RigidBody{.mass = 1.0, .com = Eigen::Vector3d(0.3, 0.0, 0.0), .inertia = Eigen::Matrix3d::Identity() * 0.01});
  ExpectRefused(tree, "joints[1]");
}

TEST(ValidateRigidTree, RefusesNaN) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  {
    RigidTree tree = ValidTree();
    tree.joints[1].position.y() = nan;
    ExpectRefused(tree, "joints[1].position");
  }
  {
    RigidTree tree = ValidTree();
    tree.bodies[3].mass = nan;
    ExpectRefused(tree, "bodies[3].mass");
  }
  {
    RigidTree tree = ValidTree();
    tree.bodies[2].inertia(1, 1) = nan;
    ExpectRefused(tree, "bodies[2].inertia");
  }
  {
    RigidTree tree = ValidTree();
    tree.gravity.x() = std::numeric_limits<double>::infinity();
    ExpectRefused(tree, "gravity");
  }
}

TEST(ValidateRigidTree, RefusesMismatchedSizesAndEmptyTrees) {
  RigidTree tree = ValidTree();
  tree.bodies.pop_back();
  ExpectRefused(tree, "bodies");
  ExpectRefused(RigidTree{}, "joints");
}

// ---- real time ----------------------------------------------------------------

TEST(NoAllocation, SpatialAndLagrangianTreeDynamicsAllocateNothing) {
  std::mt19937 rng{53};
  const RigidTree tree = RandomRigidTree({.bodies = 9, .chain = false, .prismatic_fraction = 0.3}, rng);
  const SpatialDynamics spatial(tree);
  const std::unique_ptr<DynamicsData> spatial_data = spatial.MakeData();
  const LagrangianDynamics<RigidTree> lagrangian(tree);
  const int n = tree.num_dofs();
  const State s = RandomState(tree, rng);
  const VectorXd u = RandomVector(n, -1.0, 1.0, rng);
  MatrixXd M(n, n);
  VectorXd out(n);
  for (const Dynamics* d : {static_cast<const Dynamics*>(&spatial), static_cast<const Dynamics*>(&lagrangian)}) {
    const std::unique_ptr<DynamicsData> d_data = d->MakeData();
    std::int64_t allocations = 0;
    double sink = 0.0;
    {
      testing::AllocationCounter counter;
      d->ComputeMassMatrix(*d_data, s.q, M);
      d->ComputeCoriolisMatrix(*d_data, s.q, s.qd, M);
      d->ComputeCoriolisForce(*d_data, s.q, s.qd, out);
      d->ComputeGravityForce(*d_data, s.q, out);
      d->ComputeKineticEnergyGradient(*d_data, s.q, s.qd, out);
      sink += d->ComputeKineticEnergy(*d_data, s.q, s.qd) + d->ComputePotentialEnergy(*d_data, s.q);
      for (const DynamicsTerms terms : {DynamicsTerms{true, true}, DynamicsTerms{false, false}}) {
        d->ComputeInverseDynamics(*d_data, s.q, s.qd, u, terms, out);
        d->ComputeForwardDynamics(*d_data, s.q, s.qd, u, terms, out);
      }
      if (d == &spatial) {
        for (ForwardAlgorithm a : {ForwardAlgorithm::kArticulatedBody, ForwardAlgorithm::kCompositeRigidBody}) {
          spatial.ComputeForwardDynamics(*spatial_data, a, s.q, s.qd, u, DynamicsTerms{}, out);
        }
      }
      allocations = counter.count();
    }
    EXPECT_EQ(allocations, 0) << ToString(d->method());
    EXPECT_TRUE(std::isfinite(sink));
  }
}

}  // namespace
}  // namespace lagrange
