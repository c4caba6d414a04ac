// Loading robots from URDF: the shipped robots as cited, the tree's order and
// frames, fixed-joint merging, the properties, every refusal in one line, and
// a planar URDF equal to the planar `chain` plant.
#include "plant/urdf.hpp"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <random>
#include <regex>
#include <set>
#include <sstream>
#include <string_view>

#include <sys/stat.h>
#include <unistd.h>

#include "plant/eigenvalues.hpp"
#include "plant/floating_dynamics.hpp"
#include "plant/lagrangian.hpp"
#include "plant/plant_factory.hpp"
#include "plant/random_tree.hpp"
#include "plant/spatial_dynamics.hpp"
#include "tests/support/plant_cases.hpp"

namespace lagrange {
namespace {

namespace fs = std::filesystem;
using testing::PlanarChainOfTheFixture;
using testing::RandomStateFor;
using testing::RelativeDifference;

constexpr double kExact = 1e-15;     // numbers the loader copies or turns by a quarter turn
constexpr double kMergeTol = 1e-12;  // against a hand-merged robot, relative
constexpr double kAgreeTol = 1e-12;  // between dynamics derivations, relative
constexpr int kStates = 20;
constexpr double kPi = std::numbers::pi;

fs::path SourceDir() { return LAGRANGE_SOURCE_DIR; }
std::string Fixture(const std::string& name) { return (SourceDir() / "tests/fixtures/urdf" / name).string(); }
std::string Robot(const std::string& name) { return (SourceDir() / "config/robots" / name).string(); }

Eigen::Matrix3d Rpy(double roll, double pitch, double yaw) {
  using Eigen::AngleAxisd;
  return (AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) * AngleAxisd(pitch, Eigen::Vector3d::UnitY()) *
          AngleAxisd(roll, Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

// A property the file states, read as written.
void ExpectValue(const std::optional<double>& actual, double expected) {
  ASSERT_TRUE(actual.has_value());
  EXPECT_DOUBLE_EQ(*actual, expected);
}

struct Limits {
  double lower, upper, velocity, effort;
};

void ExpectLimits(const UrdfRobot& robot, const std::vector<Limits>& limits) {
  ASSERT_EQ(robot.properties.size(), limits.size());
  for (std::size_t i = 0; i < limits.size(); ++i) {
    const UrdfJointProperties& p = robot.properties[i];
    ASSERT_TRUE(p.lower && p.upper && p.velocity && p.effort) << i;
    EXPECT_DOUBLE_EQ(*p.lower, limits[i].lower) << i;
    EXPECT_DOUBLE_EQ(*p.upper, limits[i].upper) << i;
    EXPECT_DOUBLE_EQ(*p.velocity, limits[i].velocity) << i;
    EXPECT_DOUBLE_EQ(*p.effort, limits[i].effort) << i;
    EXPECT_FALSE(p.damping || p.friction) << i << ": no <dynamics> is published";
  }
}

// M symmetric positive definite, and the Lagrangian and recursive paths agree.
void ExpectPhysicalMassMatrix(const RigidTree& tree, std::mt19937& rng) {
  const LagrangianDynamics<RigidTree> lagrangian(tree);
  const std::unique_ptr<DynamicsData> lagrangian_data = lagrangian.MakeData();
  const SpatialDynamics spatial(tree);
  const std::unique_ptr<DynamicsData> spatial_data = spatial.MakeData();
  const int n = tree.num_dofs();
  MatrixXd Ml(n, n), Ms(n, n);
  VectorXd Gl(n), Gs(n);
  for (int k = 0; k < kStates; ++k) {
    const auto [q, qd] = RandomStateFor(tree.joint_types(), rng);
    lagrangian.ComputeMassMatrix(*lagrangian_data, q, Ml);
    spatial.ComputeMassMatrix(*spatial_data, q, Ms);
    lagrangian.ComputeGravityForce(*lagrangian_data, q, Gl);
    spatial.ComputeGravityForce(*spatial_data, q, Gs);
    EXPECT_LT(RelativeDifference(Ml, Ml.transpose()), kAgreeTol);
    EXPECT_GT(SymmetricEigenvalues(Ml).minCoeff(), 0.0);
    EXPECT_LT(RelativeDifference(Ml, Ms), kAgreeTol);
    EXPECT_LT(RelativeDifference(Gl, Gs), kAgreeTol);
  }
}

// ---------------------------------------------------------------------------
// The robots we ship.

TEST(ShippedRobots, PandaLoadsSevenJointsInFrankaOrderWithCitedLimitsAndMasses) {
  const UrdfRobot panda = LoadUrdf(Robot("panda.urdf"));
  EXPECT_EQ(panda.name, "panda");
  ASSERT_EQ(panda.tree.num_dofs(), 7);
  EXPECT_EQ(panda.tree.joint_names(),
            (std::vector<std::string>{"panda_joint1", "panda_joint2", "panda_joint3", "panda_joint4", "panda_joint5",
                                      "panda_joint6", "panda_joint7"}));
  for (int i = 0; i < 7; ++i) {
    EXPECT_EQ(panda.tree.joints[i].parent, i - 1);
    EXPECT_EQ(panda.tree.joints[i].type, JointType::kRevolute);
  }
  // Franka, "Limits for Panda": q_min, q_max (rad), dq_max (rad/s), tau_j_max (N·m).
  ExpectLimits(panda, {{-2.8973, 2.8973, 2.1750, 87},
                       {-1.7628, 1.7628, 2.1750, 87},
                       {-2.8973, 2.8973, 2.1750, 87},
                       {-3.0718, -0.0698, 2.1750, 87},
                       {-2.8973, 2.8973, 2.6100, 12},
                       {-0.0175, 3.7525, 2.6100, 12},
                       {-2.8973, 2.8973, 2.6100, 12}});
  // Gaz et al., RA-L 2019: link masses (kg); the flange adds none.
  const std::vector<double> masses{4.970684, 0.646926, 3.228604, 3.587895, 1.225946, 1.666555, 0.735522};
  for (int i = 0; i < 7; ++i) EXPECT_DOUBLE_EQ(panda.tree.bodies[i].mass, masses[i]) << i;
  // Franka's DH: joint 3 sits d3 = 0.316 m along link 2's −y; joint 5 at (−0.0825, 0.384, 0) in link 4.
  EXPECT_LT((panda.tree.joints[2].position - Eigen::Vector3d(0, -0.316, 0)).norm(), kExact);
  EXPECT_LT((panda.tree.joints[4].position - Eigen::Vector3d(-0.0825, 0.384, 0)).norm(), kExact);
  EXPECT_LT((panda.tree.joints[1].rotation - Rpy(-kPi / 2, 0, 0)).norm(), kExact);
}

TEST(ShippedRobots, Ur5LoadsSixJointsInOrderWithCitedLimitsAndMasses) {
  const UrdfRobot ur5 = LoadUrdf(Robot("ur5.urdf"));
  EXPECT_EQ(ur5.name, "ur5");
  ASSERT_EQ(ur5.tree.num_dofs(), 6);
  EXPECT_EQ(ur5.tree.joint_names(),
            (std::vector<std::string>{"shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint",
                                      "wrist_2_joint", "wrist_3_joint"}));
  for (int i = 0; i < 6; ++i) EXPECT_EQ(ur5.tree.joints[i].parent, i - 1);
  // UR5 manual and UR's "Max. joint torques": ±360°, 180°/s, 150 / 28 N·m.
  const double t = 2.0 * kPi;
  ExpectLimits(
      ur5,
      {{-t, t, kPi, 150}, {-t, t, kPi, 150}, {-t, t, kPi, 150}, {-t, t, kPi, 28}, {-t, t, kPi, 28}, {-t, t, kPi, 28}});
  // UR's DH page: link masses (kg); the flange adds none.
  const std::vector<double> masses{3.7, 8.393, 2.33, 1.219, 1.219, 0.1879};
  for (int i = 0; i < 6; ++i) EXPECT_DOUBLE_EQ(ur5.tree.bodies[i].mass, masses[i]) << i;
  // Centre of mass of the upper arm: UR's (0.2125, 0, 0.11336) in DH frame 2, a2 = −0.425 from link 2's frame.
  EXPECT_LT((ur5.tree.bodies[1].com - Eigen::Vector3d(-0.2125, 0, 0.11336)).norm(), kExact);
}

TEST(ShippedRobots, MassMatricesArePositiveDefiniteAndBothDerivationsAgree) {
  std::mt19937 rng{42};
  for (const char* name : {"panda.urdf", "ur5.urdf"}) {
    SCOPED_TRACE(name);
    ExpectPhysicalMassMatrix(LoadUrdf(Robot(name)).tree, rng);
  }
}

// At UR's DH zero the arm lies along −x at shoulder height, so the gravity
// torque on the shoulder-lift joint (axis −y) is g Σ m_i x_i over links 2..6
// and on the elbow g Σ m_i (x_i + 0.425) over links 3..6, with x_i from UR's
// DH table and centres of mass: a check of the DH-to-URDF conversion.
TEST(ShippedRobots, Ur5GravityAtZeroMatchesUrsTables) {
  const UrdfRobot ur5 = LoadUrdf(Robot("ur5.urdf"));
  const double a2 = -0.425, a3 = -0.39225, g = 9.81;
  const double wrist_mass = 1.219 + 1.219 + 0.1879;  // links 4–6, all on the wrist line x = a2 + a3
  const double shoulder = g * (8.393 * (a2 + 0.2125) + 2.33 * (a2 + a3 + 0.15) + wrist_mass * (a2 + a3));
  const double elbow = g * (2.33 * (a3 + 0.15) + wrist_mass * a3);
  std::vector<std::unique_ptr<Dynamics>> derivations;
  derivations.push_back(std::make_unique<LagrangianDynamics<RigidTree>>(ur5.tree));
  derivations.push_back(std::make_unique<SpatialDynamics>(ur5.tree));
  for (const auto& d : derivations) {
    SCOPED_TRACE(ToString(d->method()));
    VectorXd G(6);
    d->ComputeGravityForce(*d->MakeData(), VectorXd::Zero(6), G);
    EXPECT_NEAR(G[0], 0.0, 1e-12);
    EXPECT_NEAR(G[1], shoulder, 1e-12 * std::abs(shoulder));
    EXPECT_NEAR(G[2], elbow, 1e-12 * std::abs(elbow));
  }
}

// ---------------------------------------------------------------------------
// Order, frames, inertias, properties.

TEST(UrdfOrder, DepthFirstFromTheRootWithChildrenInFileOrder) {
  const UrdfRobot robot = LoadUrdf(Fixture("branching.urdf"));
  EXPECT_EQ(robot.tree.joint_names(), (std::vector<std::string>{"zeta", "alpha", "beta", "gamma", "delta"}));
  const std::vector<int> parents{-1, 0, 0, 2, -1};
  for (int i = 0; i < 5; ++i) EXPECT_EQ(robot.tree.joints[i].parent, parents[i]) << i;
  EXPECT_EQ(robot.tree.joints[1].type, JointType::kPrismatic);
  EXPECT_EQ(robot.tree.joints[3].type, JointType::kRevolute);  // continuous
}

TEST(UrdfOrder, AJointBehindAFixedJointIsRebasedOntoTheBodyFrame) {
  const UrdfRobot robot = LoadUrdf(Fixture("branching.urdf"));
  // alpha hangs from mount, fixed to arm at (0, 0.1, 0) turned π/2 about z; alpha's own origin is (0.05, 0, 0).
  const TreeJoint& alpha = robot.tree.joints[1];
  EXPECT_LT((alpha.position - Eigen::Vector3d(0.0, 0.15, 0.0)).norm(), kExact);
  EXPECT_LT((alpha.rotation - Rpy(0, 0, kPi / 2)).norm(), kExact);
  // arm's body carries mount's 0.1 kg at (0, 0.1, 0): 1.1 kg, centre of mass (0, 0.1 · 0.1/1.1, 0).
  const RigidBody& arm = robot.tree.bodies[0];
  EXPECT_NEAR(arm.mass, 1.1, kExact);
  EXPECT_LT((arm.com - Eigen::Vector3d(0.0, 0.01 / 1.1, 0.0)).norm(), kExact);
  // Parallel axis: Σ I_i + m_i d_i², the offsets d_i along y, so nothing is added about y.
  const double d_arm = 0.01 / 1.1, d_mount = 0.1 - d_arm;
  const double shift = 1.0 * d_arm * d_arm + 0.1 * d_mount * d_mount;
  EXPECT_NEAR(arm.inertia(0, 0), 0.011 + shift, kExact);
  EXPECT_NEAR(arm.inertia(1, 1), 0.011, kExact);
  EXPECT_NEAR(arm.inertia(2, 2), 0.011 + shift, kExact);
}

TEST(UrdfOrder, LinksFixedToTheRootAreIgnoredAndTheirJointsStartAtTheWorld) {
  const std::string xml = R"(<robot name="r">
    <link name="world"><inertial><mass value="50"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial></link>
    <link name="pedestal"><inertial><mass value="20"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial></link>
    <link name="arm"><inertial><mass value="2"/><origin xyz="0.3 0 0"/><inertia ixx="0.01" ixy="0" ixz="0" iyy="0.02" iyz="0" izz="0.02"/></inertial></link>
    <joint name="weld" type="fixed"><parent link="world"/><child link="pedestal"/><origin xyz="0 0 1" rpy="0 0 1"/></joint>
    <joint name="j" type="continuous"><parent link="pedestal"/><child link="arm"/><origin xyz="0.5 0 0"/></joint>
  </robot>)";
  const UrdfRobot robot = ParseUrdf(xml, "inline.urdf");
  ASSERT_EQ(robot.tree.num_dofs(), 1);
  EXPECT_EQ(robot.tree.joints[0].parent, -1);
  EXPECT_LT((robot.tree.joints[0].position - Eigen::Vector3d(0.5 * std::cos(1.0), 0.5 * std::sin(1.0), 1.0)).norm(),
            kExact);
  EXPECT_LT((robot.tree.joints[0].rotation - Rpy(0, 0, 1.0)).norm(), kExact);
  EXPECT_DOUBLE_EQ(robot.tree.bodies[0].mass, 2.0);
  // No <axis>: URDF's default, x.
  EXPECT_LT((robot.tree.joints[0].axis - Eigen::Vector3d::UnitX()).norm(), kExact);
}

TEST(UrdfFrames, OriginRpyIsFixedAxisRollPitchYawAndAxesAreNormalised) {
  const UrdfRobot robot = LoadUrdf(Fixture("rpy_inertia.urdf"));
  const TreeJoint& j = robot.tree.joints[0];
  EXPECT_LT((j.rotation - Rpy(0.1, 0.2, 0.3)).norm(), kExact);
  EXPECT_LT((j.position - Eigen::Vector3d(0.1, -0.2, 0.3)).norm(), kExact);
  EXPECT_LT((j.axis - Eigen::Vector3d(0.0, 0.6, 0.8)).norm(), kExact);
  EXPECT_LT((robot.tree.gravity - Eigen::Vector3d(0, 0, -9.81)).norm(), kExact);
}

TEST(UrdfInertia, FullTensorIsTurnedFromTheInertialOriginIntoTheLinkFrame) {
  const UrdfRobot robot = LoadUrdf(Fixture("rpy_inertia.urdf"));
  const RigidBody& body = robot.tree.bodies[0];
  Eigen::Matrix3d expected;  // hand-computed in the fixture's comment
  expected << 0.2, -0.01, -0.03, -0.01, 0.3, 0.02, -0.03, 0.02, 0.25;
  EXPECT_LT((body.inertia - expected).norm(), kExact);
  EXPECT_LT((body.com - Eigen::Vector3d(0.1, 0.2, 0.3)).norm(), kExact);
  EXPECT_DOUBLE_EQ(body.mass, 1.5);
}

TEST(UrdfFixedJoints, AChainOfFixedJointsMergesLikeTheHandMergedRobot) {
  const RigidTree loaded = LoadUrdf(Fixture("fixed_chain.urdf")).tree;
  const RigidTree merged = LoadUrdf(Fixture("fixed_chain_merged.urdf")).tree;
  ASSERT_EQ(loaded.num_dofs(), 2);
  ASSERT_EQ(merged.num_dofs(), 2);
  for (int i = 0; i < 2; ++i) {
    SCOPED_TRACE(i);
    EXPECT_EQ(loaded.joints[i].parent, merged.joints[i].parent);
    EXPECT_LT((loaded.joints[i].position - merged.joints[i].position).norm(), kMergeTol);
    EXPECT_LT((loaded.joints[i].rotation - merged.joints[i].rotation).norm(), kMergeTol);
    EXPECT_LT((loaded.joints[i].axis - merged.joints[i].axis).norm(), kMergeTol);
    EXPECT_NEAR(loaded.bodies[i].mass, merged.bodies[i].mass, kMergeTol * merged.bodies[i].mass);
    EXPECT_LT((loaded.bodies[i].com - merged.bodies[i].com).norm(), kMergeTol);
    EXPECT_LT(RelativeDifference(loaded.bodies[i].inertia, merged.bodies[i].inertia, 0.0), kMergeTol);
  }
}

TEST(UrdfFixedJoints, MergedRobotHasTheSameMassMatrixAndGravity) {
  const RigidTree loaded = LoadUrdf(Fixture("fixed_chain.urdf")).tree;
  const RigidTree merged = LoadUrdf(Fixture("fixed_chain_merged.urdf")).tree;
  std::mt19937 rng{42};
  const LagrangianDynamics<RigidTree> lagrangian(loaded), lagrangian_merged(merged);
  const SpatialDynamics spatial(loaded), spatial_merged(merged);
  MatrixXd M(2, 2), Mm(2, 2);
  VectorXd G(2), Gm(2);
  for (int k = 0; k < kStates; ++k) {
    const VectorXd q = RandomStateFor(loaded.joint_types(), rng).q;
    for (const auto& [d, dm] :
         {std::pair<const Dynamics*, const Dynamics*>{&lagrangian, &lagrangian_merged}, {&spatial, &spatial_merged}}) {
      const std::unique_ptr<DynamicsData> d_data = d->MakeData(), dm_data = dm->MakeData();
      d->ComputeMassMatrix(*d_data, q, M);
      dm->ComputeMassMatrix(*dm_data, q, Mm);
      d->ComputeGravityForce(*d_data, q, G);
      dm->ComputeGravityForce(*dm_data, q, Gm);
      EXPECT_LT(RelativeDifference(M, Mm, 0.0), kMergeTol);
      EXPECT_LT(RelativeDifference(G, Gm, 0.0), kMergeTol);
    }
  }
}

TEST(UrdfProperties, AbsentAttributesStayAbsentAndContinuousJointsHaveNoPositionLimits) {
  const UrdfRobot robot = LoadUrdf(Fixture("properties.urdf"));
  ASSERT_EQ(robot.tree.joint_names(), (std::vector<std::string>{"bounded", "unbounded", "spinner", "free", "slide"}));
  const auto& p = robot.properties;
  ExpectValue(p[0].lower, -1.5);
  ExpectValue(p[0].upper, 2.5);
  ExpectValue(p[0].effort, 40.0);
  ExpectValue(p[0].velocity, 3.0);
  ExpectValue(p[0].damping, 0.7);
  ExpectValue(p[0].friction, 0.2);
  // An absent lower/upper is absent, not 0: the file did not say 0.
  EXPECT_FALSE(p[1].lower || p[1].upper);
  ExpectValue(p[1].effort, 0.0);  // said, and zero
  ExpectValue(p[1].damping, 0.5);
  EXPECT_FALSE(p[1].friction);
  // Continuous: the <limit>'s lower/upper are ignored, effort and velocity kept.
  EXPECT_FALSE(p[2].lower || p[2].upper);
  ExpectValue(p[2].effort, 12.0);
  ExpectValue(p[2].velocity, 6.0);
  EXPECT_EQ(robot.tree.joints[2].type, JointType::kRevolute);
  EXPECT_FALSE(p[3].lower || p[3].upper || p[3].effort || p[3].velocity || p[3].damping || p[3].friction);
  EXPECT_EQ(robot.tree.joints[4].type, JointType::kPrismatic);
  ExpectValue(p[4].lower, 0.0);
  ExpectValue(p[4].upper, 0.3);
  EXPECT_FALSE(p[4].damping);
  ExpectValue(p[4].friction, 1.5);
}

// ---------------------------------------------------------------------------
// Refusals: one line, "FILE: ELEMENT: reason".

void ExpectOneLineNamingFile(const std::string& what, const std::string& file) {
  EXPECT_EQ(what.find('\n'), std::string::npos) << what;
  EXPECT_EQ(what.rfind(file + ": ", 0), 0u) << what;
}

// Each fixture's first line is "<!-- expect: ELEMENT: reason -->".
TEST(UrdfRefusals, EveryInvalidFixtureIsRefusedInOneLineNamingFileElementAndReason) {
  const fs::path dir = SourceDir() / "tests/fixtures/urdf/invalid";
  std::set<std::string> seen;
  for (const auto& entry : fs::directory_iterator(dir)) {
    if (entry.path().extension() != ".urdf") continue;
    const std::string file = entry.path().string();
    seen.insert(entry.path().stem().string());
    std::ifstream in(file);
    std::string first;
    std::getline(in, first);
    const std::string open = "<!-- expect: ", close = " -->";
    ASSERT_EQ(first.rfind(open, 0), 0u) << file << " has no '<!-- expect:' line";
    const std::string expected = first.substr(open.size(), first.size() - open.size() - close.size());
    try {
      LoadUrdf(file);
      ADD_FAILURE() << file << " was accepted";
    } catch (const UrdfError& e) {
      ExpectOneLineNamingFile(e.what(), file);
      EXPECT_EQ(std::string(e.what()).find(file + ": " + expected), 0u)
          << "got: " << e.what() << "\nexpected: " << expected;
    }
  }
  for (const char* required :
       {"floating", "planar", "unknown_type", "zero_axis", "negative_mass", "not_psd", "triangle_inequality",
        "massless_leaf", "mass_on_axis", "malformed", "non_finite", "overflow", "two_roots", "loop", "no_moving_joint",
        // what urdfdom refused for us before the loader read the DOM itself
        "revolute_without_limit", "prismatic_without_limit", "limit_without_effort", "limit_without_velocity",
        "inertial_without_mass", "mass_without_value", "inertial_without_inertia", "inertia_without_a_moment",
        "unsupported_version", "empty_dynamics", "axis_without_xyz",
        // mimics that name no degree of freedom
        "mimic_of_itself", "mimic_of_a_missing_joint", "mimic_of_a_fixed_joint", "mimic_chain", "mimic_cycle",
        "mimic_on_a_fixed_joint", "mimic_without_a_joint", "two_mimics", "mimic_multiplier_not_finite",
        // found by the URDF fuzzer: a tree the reduction runs but the recursive path, on the free tree, cannot
        "mimicked_joint_moves_no_mass_alone"}) {
    EXPECT_TRUE(seen.contains(required)) << required << ".urdf is missing";
  }
}

TEST(UrdfRefusals, MissingFileIsNamedWithTheSystemsReason) {
  const std::string path = Fixture("no_such_robot.urdf");
  try {
    LoadUrdf(path);
    ADD_FAILURE() << "accepted";
  } catch (const UrdfError& e) {
    ExpectOneLineNamingFile(e.what(), path);
    EXPECT_EQ(std::string(e.what()), path + ": file: cannot be opened (No such file or directory)");
  }
}

TEST(UrdfRefusals, EmptyTextIsMalformedXml) {
  try {
    ParseUrdf("", "empty.urdf");
    ADD_FAILURE() << "accepted";
  } catch (const UrdfError& e) {
    ExpectOneLineNamingFile(e.what(), "empty.urdf");
    EXPECT_NE(std::string(e.what()).find("malformed XML"), std::string::npos) << e.what();
  }
}

TEST(UrdfRefusals, MoreThanMaxDofsMovingJointsIsRefused) {
  std::ostringstream xml;
  xml << "<robot name=\"long\"><link name=\"l0\"/>";
  for (int i = 1; i <= kMaxDofs + 1; ++i) {
    xml << "<link name=\"l" << i << "\"><inertial><origin xyz=\"0.1 0 0\"/><mass value=\"1\"/>"
        << "<inertia ixx=\"0.01\" ixy=\"0\" ixz=\"0\" iyy=\"0.01\" iyz=\"0\" izz=\"0.01\"/></inertial></link>"
        << "<joint name=\"j" << i << "\" type=\"continuous\"><parent link=\"l" << i - 1 << "\"/><child link=\"l" << i
        << "\"/><axis xyz=\"0 0 1\"/></joint>";
  }
  xml << "</robot>";
  try {
    ParseUrdf(xml.str(), "long.urdf");
    ADD_FAILURE() << "accepted";
  } catch (const UrdfError& e) {
    EXPECT_EQ(std::string(e.what()),
              "long.urdf: robot 'long': more than " + std::to_string(kMaxDofs) + " moving joints");
  }
}

// Two joints on one axis line with nothing between them: each moves inertia,
// but M(0) is singular. The loader leaves that to ValidateRigidTree and names the file.
TEST(UrdfRefusals, ASingularMassMatrixFoundByValidateRigidTreeNamesTheFile) {
  const std::string xml = R"(<robot name="r"><link name="base"/><link name="hub"/>
    <link name="arm"><inertial><origin xyz="0.3 0 0"/><mass value="1"/>
      <inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial></link>
    <joint name="j1" type="continuous"><parent link="base"/><child link="hub"/><axis xyz="0 0 1"/></joint>
    <joint name="j2" type="continuous"><parent link="hub"/><child link="arm"/><axis xyz="0 0 1"/></joint>
  </robot>)";
  try {
    ParseUrdf(xml, "coaxial.urdf");
    ADD_FAILURE() << "accepted";
  } catch (const UrdfError& e) {
    ExpectOneLineNamingFile(e.what(), "coaxial.urdf");
    EXPECT_NE(std::string(e.what()).find("M(0) positive definite"), std::string::npos) << e.what();
  }
}

TEST(UrdfRefusals, NamesAreEscapedSoTheMessageStaysOneLine) {
  const std::string xml =
      "<robot name=\"r\"><link name=\"base\"/><link name=\"a\"/>"
      "<joint name=\"bad&#10;name\\&#27;[31m\" type=\"ball\"><parent link=\"base\"/><child link=\"a\"/>"
      "</joint></robot>";
  try {
    ParseUrdf(xml, "escape.urdf");
    ADD_FAILURE() << "accepted";
  } catch (const UrdfError& e) {
    ExpectOneLineNamingFile(e.what(), "escape.urdf");
    // As base/escape.hpp writes them, so callers print the message as it is.
    EXPECT_NE(std::string(e.what()).find("joint 'bad\\nname\\\\\\x1b[31m'"), std::string::npos) << e.what();
  }
}

// The message is the caller's to print: loading logs nothing, refused or not.
TEST(UrdfRefusals, LoadingPrintsNothing) {
  std::vector<std::string> files{Robot("panda.urdf")};
  for (const auto& entry : fs::directory_iterator(SourceDir() / "tests/fixtures/urdf/invalid")) {
    files.push_back(entry.path().string());
  }
  ::testing::internal::CaptureStdout();
  ::testing::internal::CaptureStderr();
  for (const std::string& file : files) {
    try {
      LoadUrdf(file);
    } catch (const UrdfError&) {
    }
  }
  EXPECT_EQ(::testing::internal::GetCapturedStderr(), "");
  EXPECT_EQ(::testing::internal::GetCapturedStdout(), "");
}

// A robot of one continuous joint: `joint` inside its <joint>, `attributes` in
// its <robot> tag and `more` (links, joints) after them.
std::string OneJointRobot(const std::string& joint, const std::string& attributes = "", const std::string& more = "") {
  return "<robot name=\"r\"" + attributes +
         "><link name=\"base\"/><link name=\"l1\"><inertial><origin xyz=\"0.1 0 0\"/><mass value=\"1\"/>"
         "<inertia ixx=\"0.01\" ixy=\"0\" ixz=\"0\" iyy=\"0.01\" iyz=\"0\" izz=\"0.01\"/></inertial></link>"
         "<joint name=\"j1\" type=\"continuous\"><parent link=\"base\"/><child link=\"l1\"/>" +
         joint + "<axis xyz=\"0 0 1\"/></joint>" + more + "</robot>";
}

// A fixed joint hanging link "tool" from l1, `joint` inside it.
std::string FixedTool(const std::string& joint) {
  return "<link name=\"tool\"/><joint name=\"weld\" type=\"fixed\"><parent link=\"l1\"/><child link=\"tool\"/>" +
         joint + "</joint>";
}

// The message of ParseUrdf's refusal, or "accepted".
std::string RefusalOf(const std::string& xml) {
  try {
    ParseUrdf(xml, "inline.urdf");
  } catch (const UrdfError& e) {
    return e.what();
  }
  return "accepted";
}

// URDF 1.0 is the only version: "major.minor" in decimal digits, equal to 1.0.
TEST(UrdfRefusals, OnlyVersionOnePointZeroIsRead) {
  for (const char* accepted : {"", " version=\"1.0\"", " version=\"1.00\"", " version=\"01.0\""}) {
    EXPECT_EQ(RefusalOf(OneJointRobot("", accepted)), "accepted") << accepted;
  }
  for (const char* refused : {"1.1", "2", "2.0", "1.0.0", "", "1", "1.", ".0", "x.y", "1.0 ", "-1.0"}) {
    EXPECT_EQ(RefusalOf(OneJointRobot("", std::string(" version=\"") + refused + "\"")),
              std::string("inline.urdf: robot 'r': version '") + refused + "' is not supported (URDF 1.0)");
  }
}

// URDF's <limit> needs effort and velocity on every joint type, a fixed one's too.
TEST(UrdfRefusals, EveryLimitNeedsEffortAndVelocityWhateverTheJointType) {
  EXPECT_EQ(RefusalOf(OneJointRobot("", "", FixedTool("<limit velocity=\"1\"/>"))),
            "inline.urdf: joint 'weld' <limit>: no effort attribute");
  EXPECT_EQ(RefusalOf(OneJointRobot("<limit effort=\"1\"/>")),
            "inline.urdf: joint 'j1' <limit>: no velocity attribute");
  EXPECT_EQ(RefusalOf(OneJointRobot("<limit effort=\"1\" velocity=\"1\"/>")), "accepted");
}

// <axis> is read on moving joints only: a fixed joint's <axis/> is ignored, as urdfdom ignored it.
TEST(UrdfRefusals, AnAxisWithoutXyzIsRefusedOnlyOnAMovingJoint) {
  EXPECT_EQ(RefusalOf(OneJointRobot("", "", FixedTool("<axis/>"))), "accepted");
  EXPECT_EQ(RefusalOf(OneJointRobot("<axis/>")), "inline.urdf: joint 'j1' <axis>: no xyz attribute");
}

// The loader reads links, joints, origins, axes, inertials, limits and dynamics
// (urdf.hpp); a broken <visual>, <collision>, <material>, <safety_controller> or
// <calibration>, which urdfdom refused, does not stop a robot's dynamics.
TEST(UrdfUnreadElements, AreNotCheckedSoABrokenVisualDoesNotStopTheDynamics) {
  const std::string broken_link =
      "<link name=\"shell\"><visual><geometry><box/></geometry><material/></visual>"
      "<collision><geometry><cone/></geometry></collision></link>"
      "<joint name=\"glue\" type=\"fixed\"><parent link=\"l1\"/><child link=\"shell\"/></joint>";
  const std::string xml = OneJointRobot("<safety_controller k_position=\"1\"/><calibration rising=\"abc\"/>", "",
                                        broken_link + "<material name=\"m\"/><material name=\"m\"/><transmission/>");
  EXPECT_EQ(RefusalOf(xml), "accepted");
}

// <visual>s are read from the same parse as the rest, for viewers: the origin's rpy as a joint's
// (the same rotation to the last bit), the mesh's filename as written, a colour inline or named at the
// robot's level; a visual that does not read is a note naming it, and the robot still loads.
TEST(UrdfLooks, VisualsAreReadWithTheJointsNumbersAndABadOneIsANote) {
  const std::string visuals =
      "<material name=\"steel\"><color rgba=\"0.6 0.62 0.68 1\"/></material>"
      "<link name=\"shell\"><visual><origin xyz=\"0.1 0 0\" rpy=\"0.3 -0.2 1.1\"/>"
      "<geometry><mesh filename=\"package://pkg/shell.stl\" scale=\"0.001 0.001 0.001\"/></geometry>"
      "<material name=\"steel\"/></visual>"
      "<visual><geometry><box size=\"0.2 nan 0.1\"/></geometry></visual></link>"
      "<joint name=\"glue\" type=\"fixed\"><parent link=\"l1\"/><child link=\"shell\"/></joint>";
  const UrdfRobot robot = ParseUrdf(OneJointRobot("<origin rpy=\"0.3 -0.2 1.1\"/>", "", visuals), "inline.urdf");
  ASSERT_EQ(robot.looks.visuals.size(), 1u);
  const UrdfVisual& v = robot.looks.visuals[0];
  EXPECT_EQ(v.link, "shell");
  EXPECT_EQ(v.geometry, UrdfVisual::Geometry::kMesh);
  EXPECT_EQ(v.mesh, "package://pkg/shell.stl");
  EXPECT_EQ(v.scale, Eigen::Vector3d(0.001, 0.001, 0.001));
  EXPECT_EQ(v.p, Eigen::Vector3d(0.1, 0.0, 0.0));
  EXPECT_EQ(v.R, robot.tree.joints[0].rotation);  // the joint's <origin rpy> is the same text
  EXPECT_EQ(v.rgba, (std::array<double, 4>{0.6, 0.62, 0.68, 1.0}));
  EXPECT_EQ(robot.looks.notes, std::vector<std::string>{"link 'shell' <visual> 2: <box size> is not 3 finite numbers"});
  ASSERT_EQ(robot.looks.links.size(), 2u);
  EXPECT_EQ(robot.looks.links[1], (std::array<std::string, 2>{"l1", "shell"}));
}

// A list of numbers may be separated by any white space (tab, newline), as in
// an XML attribute value; each is the double nearest to what is written, so
// the loader's copy equals the literal exactly.
TEST(UrdfNumbers, ListsAreSeparatedByAnyWhiteSpaceAndReadAsTheNearestDouble) {
  const UrdfRobot robot = ParseUrdf(OneJointRobot("<origin xyz=\"0.1\t-2e-1\n+0.3\"/>"), "inline.urdf");
  EXPECT_EQ(robot.tree.joints[0].position, Eigen::Vector3d(0.1, -0.2, 0.3));
}

// ---------------------------------------------------------------------------
// Hostile input: what the nesting guard, the size and count caps and the file
// checks refuse before TinyXML can overflow the stack or the heap.

std::string Repeated(std::string_view piece, int times) {
  std::string out;
  out.reserve(piece.size() * times);
  for (int i = 0; i < times; ++i) out += piece;
  return out;
}

// One line naming the file, and `reason` in it.
void ExpectRefusedWith(const std::string& xml, const std::string& file, const std::string& reason) {
  try {
    ParseUrdf(xml, file);
    ADD_FAILURE() << "accepted";
  } catch (const UrdfError& e) {
    ExpectOneLineNamingFile(e.what(), file);
    EXPECT_NE(std::string(e.what()).find(reason), std::string::npos) << e.what();
  }
}

constexpr int kDeep = 400'000;  // a few times what overflows an 8 MiB stack in tinyxml, under the 2 MiB cap

// tinyxml ends "<?x" (no "xml") at the first '>' and parses what follows.
TEST(ParseUrdf, ElementsAfterAProcessingInstructionWithoutItsEndAreCountedAsTinyxmlSeesThem) {
  ExpectRefusedWith("<?x>" + Repeated("<a>", kDeep), "pi.urdf", "line 1: elements nested deeper than 64");
}

// At the top level tinyxml reads "</a>" as an unknown node: depth stays 0.
TEST(ParseUrdf, EndTagsAtTheTopLevelDoNotLowerTheDepth) {
  ExpectRefusedWith(Repeated("</a>", kDeep / 2) + Repeated("<a>", kDeep / 2), "close.urdf",
                    "line 1: elements nested deeper than 64");
}

// "<!-->" does not end the comment it opens (tinyxml looks for "-->" after "<!--"):
// the end tags inside it must not lower the depth.
TEST(ParseUrdf, EndTagsInsideACommentDoNotLowerTheDepth) {
  const std::string round = Repeated("<a>", 60) + "<!-->" + Repeated("</a>", 60) + "-->";
  ExpectRefusedWith("<robot name=\"r\">" + Repeated(round, 4), "comment.urdf", "elements nested deeper than 64");
}

// In an <?xml ...?> declaration tinyxml skips quoted attribute values, '>' and end tags included.
TEST(ParseUrdf, EndTagsInsideADeclarationsQuotedValueDoNotLowerTheDepth) {
  const std::string round = Repeated("<a>", 60) + "<?xml version=\"" + Repeated("</a>", 60) + "\"?>";
  ExpectRefusedWith("<robot name=\"r\">" + Repeated(round, 4), "decl.urdf", "elements nested deeper than 64");
}

// "<1 \"" is an unknown node to tinyxml, ended by its first '>', not an open quote.
TEST(ParseUrdf, AQuoteInAnUnknownNodeDoesNotHideTheElementsAfterIt) {
  ExpectRefusedWith("<1 \">" + Repeated("<a>", 100), "unknown.urdf", "elements nested deeper than 64");
}

// In UTF-8 text tinyxml skips a lead byte's whole sequence, '<' included: refused as not UTF-8.
TEST(ParseUrdf, TextThatIsNotUtf8IsRefused) {
  ExpectRefusedWith("<?xml version=\"1.0\"?><robot name=\"r\">\xE0</robot>", "latin.urdf", "not UTF-8");
}

TEST(ParseUrdf, MoreThanTheMaximumNumberOfLinksIsRefusedNamingCountAndLimit) {
  std::string xml = "<robot name=\"chain\"><link name=\"l0\"/>";
  for (int i = 1; i < 5000; ++i) {
    const std::string n = std::to_string(i), p = std::to_string(i - 1);
    xml += "<link name=\"l" + n + "\"/><joint name=\"j" + n + "\" type=\"fixed\"><parent link=\"l" + p +
           "\"/><child link=\"l" + n + "\"/></joint>";
  }
  xml += "</robot>";
  try {
    ParseUrdf(xml, "chain.urdf");
    ADD_FAILURE() << "accepted";
  } catch (const UrdfError& e) {
    EXPECT_EQ(std::string(e.what()), "chain.urdf: robot 'chain': 5000 links, more than 4096");
  }
}

TEST(ParseUrdf, MoreThanTheMaximumNumberOfElementsIsRefused) {
  ExpectRefusedWith("<robot name=\"r\">" + Repeated("<gazebo/>", 70'000) + "</robot>", "many.urdf",
                    "file: 70001 XML elements, more than 65536");
}

TEST(ParseUrdf, TextOverTwoMebibytesIsRefused) {
  ExpectRefusedWith("<robot name=\"r\">" + std::string(2u << 20, ' ') + "</robot>", "big.urdf",
                    "file: larger than 2 MiB");
}

// <visual>s have no reader of their own (lagrangectl view draws what ParseUrdf
// read, UrdfLooks): a visual past the size bound, nested past the depth bound or
// not well-formed XML refuses the whole file, with the very message the same
// fault gets anywhere else in it (here in the joint, on the same line; for
// malformed XML tinyxml names the column too, which differs).
TEST(ParseUrdf, AnOversizeOrMalformedVisualIsRefusedAsTheSameFaultAnywhereElse) {
  const auto without_column = [](const std::string& message) {
    return std::regex_replace(message, std::regex(", column [0-9]+"), "");
  };
  const auto in_visual = [](const std::string& fault) {
    return OneJointRobot("", "",
                         "<link name=\"shell\"><visual>" + fault +
                             "</visual></link><joint name=\"glue\" type=\"fixed\"><parent link=\"l1\"/>"
                             "<child link=\"shell\"/></joint>");
  };
  const auto in_joint = [](const std::string& fault) { return OneJointRobot(fault); };
  ASSERT_EQ(RefusalOf(in_visual("<geometry><sphere radius=\"0.1\"/></geometry>")), "accepted");
  const std::string oversize = "<geometry><mesh filename=\"" + std::string(2u << 20, 'm') + ".stl\"/></geometry>";
  const std::string too_deep = Repeated("<a>", 70) + Repeated("</a>", 70);
  const std::string unclosed = "<geometry><box size=\"0.1 0.1 0.1\"></geometry>";
  for (const auto& [fault, reason] : {std::pair<std::string, std::string>{oversize, "file: larger than 2 MiB"},
                                      {too_deep, "elements nested deeper than 64"},
                                      {unclosed, "line 1, column "}}) {
    const std::string refusal = RefusalOf(in_visual(fault));
    EXPECT_NE(refusal, "accepted") << reason;
    EXPECT_NE(refusal.find(reason), std::string::npos) << refusal;
    EXPECT_EQ(without_column(refusal), without_column(RefusalOf(in_joint(fault))));
  }
}

TEST(LoadUrdf, AFifoIsRefusedWithoutBlocking) {
  const fs::path dir = fs::temp_directory_path() / ("urdf_test_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const std::string fifo = (dir / "robot.urdf").string();
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  try {
    LoadUrdf(fifo);
    ADD_FAILURE() << "accepted";
  } catch (const UrdfError& e) {
    EXPECT_EQ(std::string(e.what()), fifo + ": file: not a regular file (a FIFO)");
  }
  fs::remove_all(dir);
}

TEST(LoadUrdf, ADeviceOrADirectoryIsRefused) {
  for (const auto& [path, kind] :
       {std::pair<std::string, std::string>{"/dev/null", "a character device"}, {Fixture(""), "a directory"}}) {
    try {
      LoadUrdf(path);
      ADD_FAILURE() << path << " accepted";
    } catch (const UrdfError& e) {
      EXPECT_EQ(std::string(e.what()), path + ": file: not a regular file (" + kind + ")");
    }
  }
}

// ---------------------------------------------------------------------------
// A planar URDF is the planar chain plant.


struct Evaluated {
  MatrixXd M, C;
  VectorXd G, qdd;
};

Evaluated Evaluate(const Dynamics& d, const VectorXd& q, const VectorXd& qd, const VectorXd& tau) {
  const std::unique_ptr<DynamicsData> d_data = d.MakeData();
  const int n = d.num_dofs();
  Evaluated e{MatrixXd(n, n), MatrixXd(n, n), VectorXd(n), VectorXd(n)};
  d.ComputeMassMatrix(*d_data, q, e.M);
  d.ComputeCoriolisMatrix(*d_data, q, qd, e.C);
  d.ComputeGravityForce(*d_data, q, e.G);
  d.ComputeForwardDynamics(*d_data, q, qd, tau, DynamicsTerms{}, e.qdd);
  return e;
}

TEST(UrdfPlanar, PlanarUrdfEqualsTheChainPlantByEveryDerivation) {
  RigidTree tree = LoadUrdf(Fixture("planar_chain.urdf")).tree;
  tree.gravity = Eigen::Vector3d(0.0, -kStandardGravity, 0.0);
  const PlantSpec spec{PlanarChainOfTheFixture()};
  ASSERT_EQ(tree.joint_types(), JointTypesOf(spec));
  const std::vector<std::shared_ptr<const Dynamics>> chains{MakeDynamics(spec, Method::kRecursive),
                                                            MakeDynamics(spec, Method::kLagrangian)};
  const std::vector<std::shared_ptr<const Dynamics>> urdfs{std::make_shared<LagrangianDynamics<RigidTree>>(tree),
                                                           std::make_shared<SpatialDynamics>(tree)};
  std::mt19937 rng{42};
  for (int k = 0; k < kStates; ++k) {
    const auto [q, qd] = RandomStateFor(tree.joint_types(), rng);
    const VectorXd tau = testing::RandomVector(tree.num_dofs(), -5.0, 5.0, rng);
    for (const auto& chain : chains) {
      const Evaluated c = Evaluate(*chain, q, qd, tau);
      for (const auto& urdf : urdfs) {
        SCOPED_TRACE(std::string(ToString(chain->method())) + " chain vs " + std::string(ToString(urdf->method())) +
                     " urdf");
        const Evaluated u = Evaluate(*urdf, q, qd, tau);
        EXPECT_LT(RelativeDifference(u.M, c.M, 0.0), kAgreeTol);
        EXPECT_LT(RelativeDifference(u.C, c.C), kAgreeTol);
        EXPECT_LT(RelativeDifference(u.G, c.G, 0.0), kAgreeTol);
        EXPECT_LT(RelativeDifference(u.qdd, c.qdd, 0.0), kAgreeTol);
      }
    }
  }
}

// ---------------------------------------------------------------------------
// Floating base: the root link as the base, or a floating joint's child.

// A torso (its inertial off its origin and turned) with a leg (revolute hip,
// prismatic knee) and an arm (continuous shoulder).
constexpr std::string_view kWalkerLinks = R"(
  <link name="torso"><inertial><origin xyz="0.01 0.02 0.05" rpy="0.1 0.2 0.3"/><mass value="8"/>
    <inertia ixx="0.2" ixy="0.01" ixz="0" iyy="0.3" iyz="0.02" izz="0.25"/></inertial></link>
  <link name="thigh"><inertial><origin xyz="0 0 -0.2"/><mass value="1.5"/>
    <inertia ixx="0.02" ixy="0" ixz="0" iyy="0.02" iyz="0" izz="0.005"/></inertial></link>
  <link name="shin"><inertial><origin xyz="0 0 -0.15"/><mass value="0.8"/>
    <inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.002"/></inertial></link>
  <link name="arm"><inertial><origin xyz="0.1 0 0"/><mass value="0.5"/>
    <inertia ixx="0.001" ixy="0" ixz="0" iyy="0.004" iyz="0" izz="0.004"/></inertial></link>
  <joint name="hip" type="revolute"><parent link="torso"/><child link="thigh"/><origin xyz="0 0.1 -0.1"/>
    <axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="50" velocity="5"/></joint>
  <joint name="knee" type="prismatic"><parent link="thigh"/><child link="shin"/><origin xyz="0 0 -0.4"/>
    <axis xyz="0 0 1"/><limit lower="-0.1" upper="0.1" effort="50" velocity="1"/></joint>
  <joint name="shoulder" type="continuous"><parent link="torso"/><child link="arm"/>
    <origin xyz="0 -0.15 0.2" rpy="0.3 0 0"/><axis xyz="1 0 0"/></joint>)";
constexpr double kWalkerMass = 8.0 + 1.5 + 0.8 + 0.5;

std::string Walker(std::string_view before = "") {
  return "<robot name=\"walker\">" + std::string(before) + std::string(kWalkerLinks) + "</robot>";
}
UrdfRobot FloatingWalker(const std::string& xml = Walker()) {
  return ParseUrdf(xml, "walker.urdf", UrdfOptions{.floating_base = true});
}

// (p, a random unit quaternion x y z w, joints): a random floating state's q.
VectorXd RandomFloatingQ(const RigidTree& tree, std::mt19937& rng) {
  VectorXd q(tree.num_q());
  q.head<3>() = testing::RandomVector(3, -1.0, 1.0, rng);
  q.segment<4>(3) = Eigen::Quaterniond(RandomRotation(rng)).coeffs();
  q.tail(tree.num_dofs()) = RandomStateFor(tree.joint_types(), rng).q;
  return q;
}

MatrixXd FloatingMassMatrix(const RigidTree& tree, const VectorXd& q) {
  const FloatingDynamics dynamics(tree);
  MatrixXd M(tree.num_v(), tree.num_v());
  dynamics.ComputeMassMatrix(*dynamics.MakeData(), q, M);
  return M;
}

void ExpectFloatingRefusal(const std::string& xml, const std::string& reason) {
  try {
    FloatingWalker(xml);
    ADD_FAILURE() << "accepted";
  } catch (const UrdfError& e) {
    ExpectOneLineNamingFile(e.what(), "walker.urdf");
    EXPECT_EQ(std::string(e.what()).find("walker.urdf: " + reason), 0u) << "got: " << e.what();
  }
}

TEST(UrdfFloatingBase, TheRootLinkIsTheBaseWithItsInertialAndQHasSevenMoreEntries) {
  const UrdfRobot robot = FloatingWalker();
  const RigidTree& tree = robot.tree;
  ASSERT_TRUE(tree.floating_base);
  EXPECT_EQ(tree.num_dofs(), 3);
  EXPECT_EQ(tree.num_q(), 3 + 7);
  EXPECT_EQ(tree.num_v(), 3 + 6);
  EXPECT_EQ(tree.joint_names(), (std::vector<std::string>{"hip", "knee", "shoulder"}));
  EXPECT_EQ(tree.joints[0].parent, -1);  // rides on the base
  EXPECT_EQ(tree.joints[2].parent, -1);
  EXPECT_DOUBLE_EQ(tree.base.mass, 8.0);
  EXPECT_LT((tree.base.com - Eigen::Vector3d(0.01, 0.02, 0.05)).norm(), kExact);
  Eigen::Matrix3d I;
  I << 0.2, 0.01, 0.0, 0.01, 0.3, 0.02, 0.0, 0.02, 0.25;
  const Eigen::Matrix3d R = Rpy(0.1, 0.2, 0.3);
  EXPECT_LT((tree.base.inertia - R * I * R.transpose()).norm(), kExact);
  EXPECT_EQ(tree.frames[0].name, "torso");
  EXPECT_EQ(tree.frames[0].body, -1);  // the base's frame
  EXPECT_EQ(FloatingDynamics(tree).num_q(), 10);
  // The same file read as a fixed-base robot ignores the torso's inertia.
  const UrdfRobot fixed = ParseUrdf(Walker(), "walker.urdf");
  EXPECT_FALSE(fixed.tree.floating_base);
  EXPECT_EQ(fixed.tree.num_q(), 3);
}

// With the base locked (v_b = ω_b = 0) the kinetic energy is the fixed
// robot's, whatever the base's pose: M's joint block is the fixed M. The
// base block's linear part is the whole robot's mass.
TEST(UrdfFloatingBase, WithTheBaseLockedTheJointBlockOfMIsTheFixedRobotsM) {
  const RigidTree floating = FloatingWalker().tree;
  const SpatialDynamics fixed(ParseUrdf(Walker(), "walker.urdf").tree);
  const std::unique_ptr<DynamicsData> data = fixed.MakeData();
  std::mt19937 rng{42};
  for (int k = 0; k < kStates; ++k) {
    const VectorXd q = RandomFloatingQ(floating, rng);
    const MatrixXd M = FloatingMassMatrix(floating, q);
    MatrixXd M_fixed(3, 3);
    fixed.ComputeMassMatrix(*data, q.tail(3), M_fixed);
    EXPECT_LT(RelativeDifference(M.bottomRightCorner(3, 3), M_fixed, 0.0), kAgreeTol);
    EXPECT_LT((M.topLeftCorner<3, 3>() - kWalkerMass * Eigen::Matrix3d::Identity()).norm(), kAgreeTol * kWalkerMass);
  }
}

TEST(UrdfFloatingBase, AFloatingJointFromTheRootLinkMakesItsChildTheBase) {
  const UrdfRobot robot = FloatingWalker(Walker(R"(<link name="world"/>
    <joint name="free" type="floating"><parent link="world"/><child link="torso"/></joint>)"));
  const UrdfRobot same = FloatingWalker();
  ASSERT_TRUE(robot.tree.floating_base);
  EXPECT_DOUBLE_EQ(robot.tree.base.mass, same.tree.base.mass);
  EXPECT_EQ(robot.tree.joint_names(), same.tree.joint_names());
  EXPECT_EQ(robot.tree.frame_names(), (std::vector<std::string>{"torso", "thigh", "shin", "arm"}));  // no world
  std::mt19937 rng{7};
  const VectorXd q = RandomFloatingQ(robot.tree, rng);
  EXPECT_LT(RelativeDifference(FloatingMassMatrix(robot.tree, q), FloatingMassMatrix(same.tree, q), 0.0), kExact);
}

TEST(UrdfFloatingBase, ASingleLinkIsAFreeBody) {
  const UrdfRobot body = FloatingWalker(R"(<robot name="brick"><link name="brick"><inertial><mass value="2"/>
    <inertia ixx="0.1" ixy="0" ixz="0" iyy="0.2" iyz="0" izz="0.25"/></inertial></link></robot>)");
  EXPECT_EQ(body.tree.num_q(), 7);
  EXPECT_EQ(body.tree.num_v(), 6);
  VectorXd q = VectorXd::Zero(7);
  q[6] = 1.0;  // w: the identity
  const MatrixXd M = FloatingMassMatrix(body.tree, q);
  const VectorXd diagonal = (VectorXd(6) << 2.0, 2.0, 2.0, 0.1, 0.2, 0.25).finished();
  EXPECT_LT((M - MatrixXd(diagonal.asDiagonal())).norm(), kExact);
}

TEST(UrdfFloatingBase, AFloatingJointAnywhereButAtTheRootIsRefusedNamingIt) {
  std::string middle = Walker();
  middle.replace(middle.find(R"(type="prismatic")"), 16, R"(type="floating")");
  ExpectFloatingRefusal(middle,
                        "joint 'knee': a floating joint is read only from the root link (its parent here is link "
                        "'thigh'): a tree has one floating base, at its root");
  ExpectFloatingRefusal(Walker(R"(<link name="world"/><link name="post"/>
    <joint name="free" type="floating"><parent link="world"/><child link="torso"/></joint>
    <joint name="weld" type="fixed"><parent link="world"/><child link="post"/></joint>)"),
                        "joint 'free': a floating joint must be the root link 'world''s only joint (the root link is "
                        "the world; joint 'weld' would fix a second tree to it)");
  ExpectFloatingRefusal(Walker(R"(<link name="world"/>
    <joint name="free" type="floating"><parent link="world"/><child link="torso"/><origin xyz="0 0 1"/></joint>)"),
                        "joint 'free' <origin>: a floating joint's <origin> must be the identity (q places the base "
                        "'torso' in the world)");
}

TEST(UrdfFloatingBase, AMasslessBaseIsRefusedNamingItsLink) {
  std::string massless = Walker();
  const std::size_t from = massless.find("<inertial>"), to = massless.find("</inertial>") + 11;
  massless.erase(from, to - from);
  ExpectFloatingRefusal(massless,
                        "link 'torso': a floating base needs mass > 0 kg (its <inertial> and those of links fixed to "
                        "it), got 0");
}

}  // namespace
}  // namespace lagrange
