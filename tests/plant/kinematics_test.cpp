// Frame kinematics (plant/kinematics.hpp): poses, Jacobians and J̇ qd of
// every named frame, against finite differences, closed forms, the planar
// chain plant, Franka's published kinematics, and the allocation counter.

#include "plant/kinematics.hpp"
#include "plant/lagrangian.hpp"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <numbers>
#include <random>
#include <string>
#include <vector>

#include "plant/plant_factory.hpp"
#include "plant/random_tree.hpp"
#include "plant/spatial_dynamics.hpp"
#include "plant/urdf.hpp"
#include "tests/support/alloc_counter.hpp"
#include "tests/support/plant_cases.hpp"

namespace lagrange {
namespace {

using testing::PlanarChainOfTheFixture;
using testing::RandomStateFor;

constexpr double kPi = std::numbers::pi;
constexpr double kExactTol = 1e-12;  // closed forms and other exact derivations, m or rad (per unit)
constexpr double kStep = 1e-6;       // central-difference step, rad or m (or s along a motion)
constexpr double kFdTol = 1e-7;      // central differences at kStep, absolute
constexpr int kStates = 10;

std::string Source(const std::string& relative) { return std::string(LAGRANGE_SOURCE_DIR) + "/" + relative; }

RigidTree UrdfTree(const std::string& relative) { return LoadUrdf(Source(relative)).tree; }

struct NamedTree {
  std::string name;
  RigidTree tree;
};

// A branching random tree (random joint axes, so every joint is folded;
// prismatic joints) with a frame at each body's origin, one at a random
// placement on each body, and one on the world away from its origin.
RigidTree RandomTreeWithFrames() {
  std::mt19937 rng{7};
  RandomTreeOptions options;
  options.bodies = 9;
  RigidTree tree = RandomRigidTree(options, rng);
  std::uniform_real_distribution<double> offset(-0.3, 0.3);
  tree.frames.push_back({"stand", -1, Eigen::Vector3d(offset(rng), offset(rng), offset(rng)), RandomRotation(rng)});
  for (int i = 0; i < tree.num_dofs(); ++i) {
    tree.frames.push_back({"body" + std::to_string(i), i, Eigen::Vector3d::Zero(), Eigen::Matrix3d::Identity()});
    tree.frames.push_back(
        {"tool" + std::to_string(i), i, Eigen::Vector3d(offset(rng), offset(rng), offset(rng)), RandomRotation(rng)});
  }
  return tree;
}

// Every built-in plant, a chain with a prismatic link, the URDF robots and fixtures, and a random tree.
std::vector<NamedTree> AllTrees() {
  std::vector<NamedTree> trees;
  for (const testing::PlantCase& c : testing::AllPlantCases()) trees.push_back({c.name, MakeRigidTree(c.spec)});
  trees.push_back({"prismatic chain", MakeRigidTree(PlantSpec{PlanarChainOfTheFixture()})});
  trees.push_back({"panda", UrdfTree("config/robots/panda.urdf")});
  trees.push_back({"ur5", UrdfTree("config/robots/ur5.urdf")});
  trees.push_back({"panda with hand (a mimic finger)", UrdfTree("config/robots/panda_hand.urdf")});
  trees.push_back({"fixed_chain", UrdfTree("tests/fixtures/urdf/fixed_chain.urdf")});
  trees.push_back({"branching", UrdfTree("tests/fixtures/urdf/branching.urdf")});
  trees.push_back({"random tree", RandomTreeWithFrames()});
  return trees;
}

// vee(log(A Bᵀ)): the rotation vector taking B to A, world axes.
Eigen::Vector3d RotationVector(const Eigen::Matrix3d& A, const Eigen::Matrix3d& B) {
  const Eigen::AngleAxisd aa(Eigen::Matrix3d(A * B.transpose()));
  return aa.angle() * aa.axis();
}

Eigen::Matrix<double, 6, 6> LocalOfWorld(const Eigen::Matrix3d& R) {
  Eigen::Matrix<double, 6, 6> T = Eigen::Matrix<double, 6, 6>::Zero();
  T.topLeftCorner<3, 3>() = R.transpose();
  T.bottomRightCorner<3, 3>() = R.transpose();
  return T;
}

TEST(FrameKinematics, JacobianIsTheDerivativeOfThePose) {
  std::mt19937 rng{42};
  for (const NamedTree& t : AllTrees()) {
    SCOPED_TRACE(t.name);
    const Kinematics model(t.tree);
    const int n = model.num_dofs();
    auto data = model.MakeData(), plus = model.MakeData(), minus = model.MakeData();
    for (int s = 0; s < kStates; ++s) {
      const auto [q, qd] = RandomStateFor(t.tree.joint_types(), rng);
      model.ComputeFrameKinematics(*data, q, qd);
      for (int j = 0; j < n; ++j) {
        const VectorXd dq = kStep * VectorXd::Unit(n, j);
        model.ComputeFrameKinematics(*plus, q + dq, qd);
        model.ComputeFrameKinematics(*minus, q - dq, qd);
        for (int k = 0; k < model.num_frames(); ++k) {
          SCOPED_TRACE(model.frame_names()[k]);
          const Eigen::Vector3d linear = (plus->position(k) - minus->position(k)) / (2.0 * kStep);
          const Eigen::Vector3d angular = RotationVector(plus->rotation(k), minus->rotation(k)) / (2.0 * kStep);
          const Matrix6Xd& J = data->jacobian(k, FrameAxes::kWorldAligned);
          EXPECT_LT((J.col(j).head<3>() - linear).norm(), kFdTol) << "joint " << j;
          EXPECT_LT((J.col(j).tail<3>() - angular).norm(), kFdTol) << "joint " << j;
        }
      }
      for (int k = 0; k < model.num_frames(); ++k) {
        const Matrix6Xd expected = LocalOfWorld(data->rotation(k)) * data->jacobian(k, FrameAxes::kWorldAligned);
        EXPECT_LT((data->jacobian(k, FrameAxes::kLocal) - expected).norm(), kExactTol);
      }
    }
  }
}

TEST(FrameKinematics, BiasIsTheDerivativeOfJacobianTimesVelocityAlongTheMotion) {
  std::mt19937 rng{42};
  for (const NamedTree& t : AllTrees()) {
    SCOPED_TRACE(t.name);
    const Kinematics model(t.tree);
    auto data = model.MakeData(), plus = model.MakeData(), minus = model.MakeData();
    for (int s = 0; s < kStates; ++s) {
      const auto [q, qd] = RandomStateFor(t.tree.joint_types(), rng);
      // q(t) = q + t qd: qdd = 0, so d/dt (J qd) = J̇ qd.
      model.ComputeFrameKinematics(*data, q, qd);
      model.ComputeFrameKinematics(*plus, q + kStep * qd, qd);
      model.ComputeFrameKinematics(*minus, q - kStep * qd, qd);
      for (int k = 0; k < model.num_frames(); ++k) {
        SCOPED_TRACE(model.frame_names()[k]);
        const FrameAxes world = FrameAxes::kWorldAligned;
        const Vector6d derivative = (plus->jacobian(k, world) * qd - minus->jacobian(k, world) * qd) / (2.0 * kStep);
        EXPECT_LT((data->bias_acceleration(k, world) - derivative).norm(), 10.0 * kFdTol);
        const Vector6d local = LocalOfWorld(data->rotation(k)) * data->bias_acceleration(k, world);
        EXPECT_LT((data->bias_acceleration(k, FrameAxes::kLocal) - local).norm(), kExactTol);
      }
    }
  }
}

TEST(FrameKinematics, ArmFramesAreTheClosedForm) {
  const Arm2Params p;
  const Kinematics model(ToRigidTree(p));
  auto data = model.MakeData();
  const int tip = *model.FrameIndex("tip"), elbow = *model.FrameIndex("link2");
  std::mt19937 rng{42};
  for (int s = 0; s < kStates; ++s) {
    const auto [q, qd] = RandomStateFor({JointType::kRevolute, JointType::kRevolute}, rng);
    model.ComputeFrameKinematics(*data, q, qd);
    const double c1 = std::cos(q[0]), s1 = std::sin(q[0]);
    const double c12 = std::cos(q[0] + q[1]), s12 = std::sin(q[0] + q[1]);
    const double w1 = qd[0], w12 = qd[0] + qd[1];
    EXPECT_LT((data->position(elbow) - Eigen::Vector3d(p.L1 * c1, p.L1 * s1, 0.0)).norm(), kExactTol);
    EXPECT_LT((data->position(tip) - Eigen::Vector3d(p.L1 * c1 + p.L2 * c12, p.L1 * s1 + p.L2 * s12, 0.0)).norm(),
              kExactTol);
    // The tip's x axis points along link 2, at q1 + q2 from +x.
    EXPECT_LT((data->rotation(tip) - Eigen::Matrix3d(Eigen::AngleAxisd(q[0] + q[1], Eigen::Vector3d::UnitZ()))).norm(),
              kExactTol);
    Matrix6Xd J = Matrix6Xd::Zero(6, 2);
    J.col(0) << -p.L1 * s1 - p.L2 * s12, p.L1 * c1 + p.L2 * c12, 0.0, 0.0, 0.0, 1.0;
    J.col(1) << -p.L2 * s12, p.L2 * c12, 0.0, 0.0, 0.0, 1.0;
    EXPECT_LT((data->jacobian(tip, FrameAxes::kWorldAligned) - J).norm(), kExactTol);
    Vector6d bias;
    bias << -p.L1 * c1 * w1 * w1 - p.L2 * c12 * w12 * w12, -p.L1 * s1 * w1 * w1 - p.L2 * s12 * w12 * w12, 0.0, 0.0, 0.0,
        0.0;
    EXPECT_LT((data->bias_acceleration(tip, FrameAxes::kWorldAligned) - bias).norm(), kExactTol * 10.0);
  }
}

TEST(FrameKinematics, PendulumHangsDownAndThePoleHangsFromTheCart) {
  const PendulumParams pendulum;
  const Kinematics pm(ToRigidTree(pendulum));
  auto pd = pm.MakeData();
  const CartPoleParams cp;
  const Kinematics cm(ToRigidTree(cp));
  auto cd = cm.MakeData();
  std::mt19937 rng{42};
  for (int s = 0; s < kStates; ++s) {
    const auto [q, qd] = RandomStateFor({JointType::kPrismatic, JointType::kRevolute}, rng);
    const double x = q[0], th = q[1];
    pm.ComputeFrameKinematics(*pd, q.tail(1), qd.tail(1));
    const Eigen::Vector3d bob(pendulum.L * std::sin(th), -pendulum.L * std::cos(th), 0.0);
    EXPECT_LT((pd->position(*pm.FrameIndex("bob")) - bob).norm(), kExactTol);
    cm.ComputeFrameKinematics(*cd, q, qd);
    EXPECT_LT((cd->position(*cm.FrameIndex("cart")) - Eigen::Vector3d(x, 0.0, 0.0)).norm(), kExactTol);
    EXPECT_LT((cd->position(*cm.FrameIndex("pole")) - Eigen::Vector3d(x, 0.0, 0.0)).norm(), kExactTol);
    const Eigen::Vector3d tip(x + 2.0 * cp.l * std::sin(th), -2.0 * cp.l * std::cos(th), 0.0);
    EXPECT_LT((cd->position(*cm.FrameIndex("pole_tip")) - tip).norm(), kExactTol);
  }
  // θ = 0: straight down.
  pm.ComputeFrameKinematics(*pd, VectorXd::Zero(1), VectorXd::Zero(1));
  EXPECT_LT((pd->position(0) - Eigen::Vector3d(0.0, -pendulum.L, 0.0)).norm(), kExactTol);
}

TEST(FrameKinematics, BuiltInPlantsNameTheirLinksAndTips) {
  EXPECT_EQ(Kinematics(ToRigidTree(PendulumParams{})).frame_names(), std::vector<std::string>({"bob"}));
  EXPECT_EQ(Kinematics(ToRigidTree(Arm2Params{})).frame_names(), std::vector<std::string>({"link1", "link2", "tip"}));
  EXPECT_EQ(Kinematics(ToRigidTree(CartPoleParams{})).frame_names(),
            std::vector<std::string>({"cart", "pole", "pole_tip"}));
  EXPECT_EQ(Kinematics(ToRigidTree(ChainParams{})).frame_names(), std::vector<std::string>({"link1", "link2", "tip"}));
  EXPECT_FALSE(Kinematics(ToRigidTree(ChainParams{})).FrameIndex("link3").has_value());
}

TEST(FrameKinematics, PlanarUrdfFramesEqualTheChainPlants) {
  RigidTree urdf = UrdfTree("tests/fixtures/urdf/planar_chain.urdf");
  const Kinematics um(urdf);
  const Kinematics cm(ToRigidTree(PlanarChainOfTheFixture()));
  auto ud = um.MakeData(), cd = cm.MakeData();
  std::mt19937 rng{42};
  for (int s = 0; s < kStates; ++s) {
    const auto [q, qd] = RandomStateFor(urdf.joint_types(), rng);
    um.ComputeFrameKinematics(*ud, q, qd);
    cm.ComputeFrameKinematics(*cd, q, qd);
    for (const char* name : {"link1", "link2", "link3", "link4"}) {
      SCOPED_TRACE(name);
      const int u = *um.FrameIndex(name), c = *cm.FrameIndex(name);
      EXPECT_LT((ud->position(u) - cd->position(c)).norm(), kExactTol);
      EXPECT_LT((ud->rotation(u) - cd->rotation(c)).norm(), kExactTol);
      for (FrameAxes axes : {FrameAxes::kWorldAligned, FrameAxes::kLocal}) {
        EXPECT_LT((ud->jacobian(u, axes) - cd->jacobian(c, axes)).norm(), kExactTol);
        EXPECT_LT((ud->bias_acceleration(u, axes) - cd->bias_acceleration(c, axes)).norm(), 10.0 * kExactTol);
      }
    }
  }
}

// Franka's published kinematics (modified DH, Craig): link i's frame is
// link i−1's · Rx(α) Tx(a) Tz(d) Rz(q_i); the flange (panda_link8) is link 7's
// · Tz(0.107). Written here from the table, not read from the URDF.
TEST(FrameKinematics, PandaLinksFollowFrankasDhTable) {
  struct Dh {
    double a, d, alpha;
  };
  const Dh table[] = {{0.0, 0.333, 0.0},          {0.0, 0.0, -kPi / 2}, {0.0, 0.316, kPi / 2}, {0.0825, 0.0, kPi / 2},
                      {-0.0825, 0.384, -kPi / 2}, {0.0, 0.0, kPi / 2},  {0.088, 0.0, kPi / 2}};
  const Kinematics model(UrdfTree("config/robots/panda.urdf"));
  auto data = model.MakeData();
  std::mt19937 rng{42};
  for (int s = 0; s < kStates; ++s) {
    const auto [q, qd] = RandomStateFor(std::vector<JointType>(7, JointType::kRevolute), rng);
    model.ComputeFrameKinematics(*data, q, qd);
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    for (int i = 0; i < 7; ++i) {
      T = T * Eigen::AngleAxisd(table[i].alpha, Eigen::Vector3d::UnitX()) *
          Eigen::Translation3d(table[i].a, 0.0, table[i].d) * Eigen::AngleAxisd(q[i], Eigen::Vector3d::UnitZ());
      const int k = *model.FrameIndex("panda_link" + std::to_string(i + 1));
      EXPECT_LT((data->position(k) - T.translation()).norm(), kExactTol) << "panda_link" << i + 1;
      EXPECT_LT((data->rotation(k) - T.rotation()).norm(), kExactTol) << "panda_link" << i + 1;
    }
    T = T * Eigen::Translation3d(0.0, 0.0, 0.107);
    const int flange = *model.FrameIndex("panda_link8");
    EXPECT_LT((data->position(flange) - T.translation()).norm(), kExactTol);
    EXPECT_LT((data->rotation(flange) - T.rotation()).norm(), kExactTol);
  }
}

TEST(FrameKinematics, EveryUrdfLinkIsAFrameIncludingFixedOnes) {
  const Kinematics panda(UrdfTree("config/robots/panda.urdf"));
  std::vector<std::string> links{"panda_link0"};
  for (int i = 1; i <= 8; ++i) links.push_back("panda_link" + std::to_string(i));
  EXPECT_EQ(panda.frame_names(), links);
  const Kinematics ur5(UrdfTree("config/robots/ur5.urdf"));
  EXPECT_EQ(ur5.frame_names(), std::vector<std::string>({"base_link", "shoulder_link", "upper_arm_link", "forearm_link",
                                                         "wrist_1_link", "wrist_2_link", "wrist_3_link", "flange"}));
  // The root link is the world: still, whatever the state.
  auto data = ur5.MakeData();
  ur5.ComputeFrameKinematics(*data, VectorXd::Constant(6, 0.4), VectorXd::Constant(6, 1.0));
  EXPECT_EQ(data->position(0), Eigen::Vector3d::Zero());
  EXPECT_EQ(data->jacobian(0, FrameAxes::kWorldAligned).norm(), 0.0);
  EXPECT_EQ(data->bias_acceleration(0, FrameAxes::kWorldAligned).norm(), 0.0);
}

// tests/fixtures/urdf/fixed_chain.urdf merges bracket, sensor and tool into
// the bodies of upper and lower; their frames keep the file's placements.
TEST(FrameKinematics, LinksMergedByFixedJointsKeepTheirPlacement) {
  const Kinematics model(UrdfTree("tests/fixtures/urdf/fixed_chain.urdf"));
  ASSERT_EQ(model.num_dofs(), 2);
  auto data = model.MakeData();
  std::mt19937 rng{42};
  const auto pose = [&](const char* name) {
    const int k = *model.FrameIndex(name);
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = data->rotation(k);
    T.translation() = data->position(k);
    return T;
  };
  for (int s = 0; s < kStates; ++s) {
    const auto [q, qd] = RandomStateFor(std::vector<JointType>(2, JointType::kRevolute), rng);
    model.ComputeFrameKinematics(*data, q, qd);
    const Eigen::Isometry3d bracket =
        pose("upper") * Eigen::Translation3d(0.4, 0.0, 0.0) * Eigen::AngleAxisd(kPi / 2, Eigen::Vector3d::UnitZ());
    const Eigen::Isometry3d sensor =
        bracket * Eigen::Translation3d(0.0, 0.0, 0.05) * Eigen::AngleAxisd(kPi / 2, Eigen::Vector3d::UnitX());
    const Eigen::Isometry3d tool = pose("lower") * Eigen::Translation3d(0.3, 0.0, 0.02);
    EXPECT_LT((pose("bracket").matrix() - bracket.matrix()).norm(), kExactTol);
    EXPECT_LT((pose("sensor").matrix() - sensor.matrix()).norm(), kExactTol);
    EXPECT_LT((pose("tool").matrix() - tool.matrix()).norm(), kExactTol);
    // The elbow sits 0.1 along the sensor's x.
    EXPECT_LT((pose("lower").translation() - (sensor * Eigen::Vector3d(0.1, 0.0, 0.0))).norm(), kExactTol);
  }
}

// A joint's folding (the rotation taking z to its axis) is the model's inner
// choice: a chain whose axes are z, −z, nearly −z and a general direction
// places every frame exactly as the same chain with each axis reversed and q
// negated (its Jacobian columns reversed), where −z folds to z by no rotation.
TEST(FrameKinematics, ReversingAJointsAxisAndItsAngleMovesNoFrameAntiparallelToZIncluded) {
  const std::vector<Eigen::Vector3d> axes = {Eigen::Vector3d::UnitZ(), -Eigen::Vector3d::UnitZ(),
                                             Eigen::Vector3d(1e-9, -2e-9, -1.0).normalized(),
                                             Eigen::Vector3d(0.3, -0.4, 0.5).normalized()};
  RigidTree tree;
  std::mt19937 rng{11};
  for (int i = 0; i < static_cast<int>(axes.size()); ++i) {
    TreeJoint j;
    j.name = "j" + std::to_string(i);
    j.parent = i - 1;
    j.position = Eigen::Vector3d(0.1, 0.2 * i, 0.3);
    j.rotation = RandomRotation(rng);
    j.axis = axes[i];
    tree.joints.push_back(j);
    tree.bodies.push_back(RigidBody{1.0, Eigen::Vector3d::Zero(), Eigen::Matrix3d::Identity()});
    tree.frames.push_back({"f" + std::to_string(i), i, Eigen::Vector3d(0.05, -0.1, 0.2), RandomRotation(rng)});
  }
  RigidTree reversed = tree;
  for (TreeJoint& j : reversed.joints) j.axis = -j.axis;
  const Kinematics model(tree), model_reversed(reversed);
  auto data = model.MakeData();
  auto data_reversed = model_reversed.MakeData();
  for (int s = 0; s < kStates; ++s) {
    const auto [q, qd] = RandomStateFor(std::vector<JointType>(axes.size(), JointType::kRevolute), rng);
    model.ComputeFrameKinematics(*data, q, qd);
    model_reversed.ComputeFrameKinematics(*data_reversed, -q, -qd);
    for (int k = 0; k < model.num_frames(); ++k) {
      EXPECT_LT((data->rotation(k) - data_reversed->rotation(k)).norm(), kExactTol) << "frame " << k;
      EXPECT_LT((data->position(k) - data_reversed->position(k)).norm(), kExactTol) << "frame " << k;
      for (const FrameAxes in : {FrameAxes::kWorldAligned, FrameAxes::kLocal}) {
        EXPECT_LT((data->jacobian(k, in) + data_reversed->jacobian(k, in)).norm(), kExactTol) << "frame " << k;
        EXPECT_LT((data->bias_acceleration(k, in) - data_reversed->bias_acceleration(k, in)).norm(), kExactTol)
            << "frame " << k;
      }
    }
  }
}

// Two derivations meet: with a frame at every body's centre of mass, the
// recursive dynamics' G = −Σ m J_vᵀ g and T = ½ Σ (m |J_v qd|² + ωᵀ I ω),
// ω = J_ω qd, I the body's inertia turned into world axes.
TEST(FrameKinematics, CentreOfMassJacobiansGiveTheDynamicsGravityAndKineticEnergy) {
  constexpr double kAgreeTol = 1e-12;  // relative
  std::mt19937 rng{42};
  for (const NamedTree& t : AllTrees()) {
    SCOPED_TRACE(t.name);
    RigidTree tree = t.tree;
    tree.frames.clear();
    for (int i = 0; i < tree.num_joints(); ++i) {
      tree.frames.push_back({"com" + std::to_string(i), i, tree.bodies[i].com, Eigen::Matrix3d::Identity()});
    }
    const Kinematics model(tree);
    // With mimic joints, the energies' derivation (the recursive one runs on the free tree).
    std::unique_ptr<Dynamics> derived;
    if (tree.has_mimics()) {
      derived = std::make_unique<LagrangianDynamics<RigidTree>>(tree);
    } else {
      derived = std::make_unique<SpatialDynamics>(tree);
    }
    const Dynamics& dynamics = *derived;
    auto data = model.MakeData();
    auto dynamics_data = dynamics.MakeData();
    const int n = model.num_dofs();
    for (int s = 0; s < kStates; ++s) {
      const auto [q, qd] = RandomStateFor(tree.joint_types(), rng);
      model.ComputeFrameKinematics(*data, q, qd);
      VectorXd G = VectorXd::Zero(n), G_rnea(n);
      double T = 0.0;
      for (int i = 0; i < tree.num_joints(); ++i) {
        const RigidBody& b = tree.bodies[i];
        const Matrix6Xd& J = data->jacobian(i, FrameAxes::kWorldAligned);
        G -= b.mass * J.topRows<3>().transpose() * tree.gravity;
        const Eigen::Vector3d v = J.topRows<3>() * qd, w = J.bottomRows<3>() * qd;
        const Eigen::Matrix3d& R = data->rotation(i);  // the body's axes (the frame has them)
        T += 0.5 * (b.mass * v.squaredNorm() + w.dot(R * b.inertia * R.transpose() * w));
      }
      dynamics.ComputeGravityForce(*dynamics_data, q, G_rnea);
      EXPECT_LT(testing::RelativeDifference(G, G_rnea), kAgreeTol);
      const double T_dynamics = dynamics.ComputeKineticEnergy(*dynamics_data, q, qd);
      EXPECT_LT(std::abs(T - T_dynamics), kAgreeTol * std::max(1.0, T_dynamics));
    }
  }
}

TEST(FrameKinematics, ComputingEveryFrameAllocatesNothing) {
  for (const NamedTree& t : AllTrees()) {
    const Kinematics model(t.tree);
    auto data = model.MakeData();
    const int n = model.num_dofs();
    const VectorXd q = VectorXd::Constant(n, 0.3), qd = VectorXd::Constant(n, -0.7);
    std::int64_t allocations = 0;
    {
      testing::AllocationCounter counter;
      for (int k = 0; k < 10; ++k) model.ComputeFrameKinematics(*data, q, qd);
      allocations = counter.count();
    }
    EXPECT_EQ(allocations, 0) << t.name;
  }
}

// Each entry point that computes a part, through a data that last computed
// everything at another state, gives what ComputeFrameKinematics gives for
// that part: every frame, both axes.
TEST(FrameKinematics, EachPartsEntryPointAgreesWithComputeFrameKinematics) {
  constexpr double kSameTol = 1e-14;  // the same arithmetic on the same state, m, rad or per unit velocity
  constexpr FrameAxes kBothAxes[] = {FrameAxes::kWorldAligned, FrameAxes::kLocal};
  std::mt19937 rng{42};
  for (const NamedTree& t : AllTrees()) {
    SCOPED_TRACE(t.name);
    const Kinematics model(t.tree);
    auto full = model.MakeData(), part = model.MakeData();
    for (int s = 0; s < kStates; ++s) {
      const auto [q, qd] = RandomStateFor(t.tree.joint_types(), rng);
      const auto [q_other, qd_other] = RandomStateFor(t.tree.joint_types(), rng);
      model.ComputeFrameKinematics(*full, q, qd);
      // part last saw another state: whatever an entry point does not refresh would show.
      const auto stale = [&] { model.ComputeFrameKinematics(*part, q_other, qd_other); };
      const auto expect_pose = [&](int k, const char* entry) {
        EXPECT_LT((part->rotation(k) - full->rotation(k)).cwiseAbs().maxCoeff(), kSameTol) << entry << " frame " << k;
        EXPECT_LT((part->position(k) - full->position(k)).cwiseAbs().maxCoeff(), kSameTol) << entry << " frame " << k;
      };
      const auto expect_jacobian = [&](int k, FrameAxes axes, const char* entry) {
        EXPECT_LT((part->jacobian(k, axes) - full->jacobian(k, axes)).cwiseAbs().maxCoeff(), kSameTol)
            << entry << " frame " << k << " axes " << static_cast<int>(axes);
      };
      const auto expect_bias = [&](int k, FrameAxes axes, const char* entry) {
        EXPECT_LT((part->bias_acceleration(k, axes) - full->bias_acceleration(k, axes)).cwiseAbs().maxCoeff(), kSameTol)
            << entry << " frame " << k << " axes " << static_cast<int>(axes);
      };
      stale();
      model.ComputeFramePlacements(*part, q);
      for (int k = 0; k < model.num_frames(); ++k) expect_pose(k, "ComputeFramePlacements");
      for (FrameAxes axes : kBothAxes) {
        stale();
        model.ComputeFrameJacobians(*part, q, axes);
        for (int k = 0; k < model.num_frames(); ++k) {
          expect_pose(k, "ComputeFrameJacobians");
          expect_jacobian(k, axes, "ComputeFrameJacobians");
        }
      }
      for (int k = 0; k < model.num_frames(); ++k) {
        stale();
        model.ComputeFramePlacement(*part, q, k);
        expect_pose(k, "ComputeFramePlacement");
        for (FrameAxes axes : kBothAxes) {
          stale();
          model.ComputeFrameJacobian(*part, q, k, axes);
          expect_pose(k, "ComputeFrameJacobian");
          expect_jacobian(k, axes, "ComputeFrameJacobian");
          stale();
          model.ComputeFrameBiasAcceleration(*part, q, qd, k, axes);
          expect_pose(k, "ComputeFrameBiasAcceleration");
          expect_bias(k, axes, "ComputeFrameBiasAcceleration");
          stale();
          model.ComputeFrameJacobianAndBias(*part, q, qd, k, axes);
          expect_pose(k, "ComputeFrameJacobianAndBias");
          expect_jacobian(k, axes, "ComputeFrameJacobianAndBias");
          expect_bias(k, axes, "ComputeFrameJacobianAndBias");
        }
      }
    }
  }
}

// The local-axes Jacobian formed from the tip (the default since issue 37)
// against the world-axes one rotated column by column (the old kernel): every
// frame of every tree (prismatic joints, a mimic finger, frames off their
// bodies and on the world), pose and Jacobian; each through a data that last
// saw another state.
TEST(FrameKinematics, LocalJacobianFromTheTipMatchesTheRotatedWorldOne) {
  using Kernel = Kinematics::LocalJacobianKernel;
  std::mt19937 rng{11};
  for (const NamedTree& t : AllTrees()) {
    SCOPED_TRACE(t.name);
    const Kinematics model(t.tree);
    auto rotated = model.MakeData(), from_tip = model.MakeData();
    for (int s = 0; s < 4; ++s) {
      const auto [q, qd] = RandomStateFor(t.tree.joint_types(), rng);
      const auto [q_other, qd_other] = RandomStateFor(t.tree.joint_types(), rng);
      for (int k = 0; k < model.num_frames(); ++k) {
        model.ComputeFrameKinematics(*from_tip, q_other, qd_other);
        model.ComputeFrameJacobian(*rotated, q, k, Kernel::kRotated);
        model.ComputeFrameJacobian(*from_tip, q, k, Kernel::kFromTip);
        const Matrix6Xd& J = rotated->jacobian(k, FrameAxes::kLocal);
        EXPECT_LT((from_tip->jacobian(k, FrameAxes::kLocal) - J).cwiseAbs().maxCoeff(), kExactTol) << "frame " << k;
        EXPECT_LT((from_tip->rotation(k) - rotated->rotation(k)).cwiseAbs().maxCoeff(), kExactTol) << "frame " << k;
        EXPECT_LT((from_tip->position(k) - rotated->position(k)).cwiseAbs().maxCoeff(), kExactTol) << "frame " << k;
        model.ComputeFrameJacobian(*rotated, q, k, FrameAxes::kLocal);
        EXPECT_TRUE(rotated->jacobian(k, FrameAxes::kLocal) == from_tip->jacobian(k, FrameAxes::kLocal))
            << "FrameAxes::kLocal runs kFromTip, the same code: the same bits; frame " << k;
      }
    }
  }
}

TEST(FrameKinematics, EachPartsEntryPointAllocatesNothing) {
  for (const NamedTree& t : AllTrees()) {
    const Kinematics model(t.tree);
    auto data = model.MakeData();
    const int n = model.num_dofs();
    const VectorXd q = VectorXd::Constant(n, 0.3), qd = VectorXd::Constant(n, -0.7);
    std::int64_t allocations = 0;
    {
      testing::AllocationCounter counter;
      for (FrameAxes axes : {FrameAxes::kWorldAligned, FrameAxes::kLocal}) {
        model.ComputeFramePlacements(*data, q);
        model.ComputeFrameJacobians(*data, q, axes);
        for (int k = 0; k < model.num_frames(); ++k) {
          model.ComputeFramePlacement(*data, q, k);
          model.ComputeFrameJacobian(*data, q, k, axes);
          model.ComputeFrameBiasAcceleration(*data, q, qd, k, axes);
          model.ComputeFrameJacobianAndBias(*data, q, qd, k, axes);
        }
      }
      allocations = counter.count();
    }
    EXPECT_EQ(allocations, 0) << t.name;
  }
}

#ifndef NDEBUG
// Debug builds check sizes, frame indices and the data's model at the top of
// every entry point; NDEBUG compiles the checks out.
TEST(SizeChecks, KinematicsRejectsMisSizedArgumentsBadFramesAndOtherModelsData) {
  const Kinematics model(ToRigidTree(Arm2Params{}));
  auto data = model.MakeData();
  const VectorXd q2 = VectorXd::Zero(2), q3 = VectorXd::Zero(3);
  const int frames = model.num_frames();
  constexpr FrameAxes kWorld = FrameAxes::kWorldAligned;
  EXPECT_DEATH(model.ComputeFrameKinematics(*data, q3, q2), "num_dofs");
  EXPECT_DEATH(model.ComputeFramePlacements(*data, q3), "num_dofs");
  EXPECT_DEATH(model.ComputeFrameJacobians(*data, q3, kWorld), "num_dofs");
  EXPECT_DEATH(model.ComputeFramePlacement(*data, q3, 0), "num_dofs");
  EXPECT_DEATH(model.ComputeFramePlacement(*data, q2, frames), "num_frames");
  EXPECT_DEATH(model.ComputeFrameJacobian(*data, q2, -1, kWorld), "frame >= 0");
  EXPECT_DEATH(model.ComputeFrameBiasAcceleration(*data, q2, q3, 0, kWorld), "num_dofs");
  EXPECT_DEATH(model.ComputeFrameJacobianAndBias(*data, q2, q2, frames, kWorld), "num_frames");
  const Kinematics other(ToRigidTree(Arm2Params{}));
  EXPECT_DEATH(other.ComputeFrameJacobian(*data, q2, 0, kWorld), "another model");
}
#endif

TEST(FrameKinematics, RefusesAFrameOnAMissingBodyOrARepeatedName) {
  RigidTree tree = ToRigidTree(Arm2Params{});
  tree.frames.push_back(PlanarTreeFrame("elsewhere", 2, 0.0, 0.0, 0.0));
  EXPECT_THROW(Kinematics{tree}, std::invalid_argument);
  tree.frames.back() = PlanarTreeFrame("tip", 1, 0.0, 0.0, 0.0);
  EXPECT_THROW(Kinematics{tree}, std::invalid_argument);
  EXPECT_EQ(ValidateRigidTree(tree), "frames[3].name: expected a name of one frame, got a repeated name");
}

}  // namespace
}  // namespace lagrange
