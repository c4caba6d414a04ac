// A MuJoCo model as a plant (plant/mujoco_plant.hpp): with the exact-inertia
// fix, MuJoCo's M, bias forces, forward and inverse dynamics, T and V agree
// with lagrange's recursive path on the shipped URDF robots to round-off;
// what is refused at load is refused with one line; a step allocates nothing;
// a diverging simulation fails the step with MuJoCo's warning.

#include <gtest/gtest.h>
#include <mujoco/mujoco.h>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <Eigen/Geometry>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <future>
#include <random>
#include <stdexcept>
#include <string>

#include "plant/floating_dynamics.hpp"
#include "plant/mujoco_free_joint.hpp"
#include "plant/mujoco_plant.hpp"
#include "plant/plant_factory.hpp"
#include "plant/urdf.hpp"
#include "tests/support/alloc_counter.hpp"

namespace lagrange {
namespace {

const std::string kRobots = std::string(LAGRANGE_SOURCE_DIR) + "/config/robots/";

// Relative agreement to round-off: the largest difference over the largest entry.
constexpr double kRoundOff = 1e-12;

double RelativeDifference(const MatrixXd& a, const MatrixXd& b) {
  return (a - b).cwiseAbs().maxCoeff() / std::max(1.0, b.cwiseAbs().maxCoeff());
}

struct Loaded {
  UrdfRobot robot;
  std::shared_ptr<const MujocoPlantModel> mujoco;
};

Loaded Load(const std::string& name, bool exact) {
  Loaded l{LoadUrdf(kRobots + name), nullptr};
  MujocoOptions o;
  o.exact_inertia = exact ? &l.robot.tree : nullptr;
  l.mujoco = LoadMujocoPlant(kRobots + name, o);
  return l;
}

// Every term, at seeded random states inside the joints' ranges (no limit active, no contact).
struct Agreement {
  double M = 0, bias = 0, fd = 0, id = 0, T = 0, V = 0;
};

Agreement Compare(const Loaded& l) {
  const mjModel* m = l.mujoco->mj_model();
  mjData* d = mj_makeData(m);
  const auto dynamics = MakeDynamics(UrdfPlantSpec(std::make_shared<UrdfRobot>(l.robot)), Method::kRecursive);
  auto data = dynamics->MakeData();
  const int n = dynamics->num_dofs();
  std::mt19937 rng{42};
  std::uniform_real_distribution<double> u(0.05, 0.95), v(-1.5, 1.5);
  Agreement worst;
  for (int trial = 0; trial < 20; ++trial) {
    VectorXd q(n), qd(n), tau(n), qdd(n);
    for (int i = 0; i < n; ++i) {
      const double lo = m->jnt_limited[i] ? m->jnt_range[2 * i] : -M_PI;
      const double hi = m->jnt_limited[i] ? m->jnt_range[2 * i + 1] : M_PI;
      q[i] = lo + u(rng) * (hi - lo);
      qd[i] = v(rng);
      tau[i] = 10.0 * v(rng);
      qdd[i] = v(rng);
    }
    mju_copy(d->qpos, q.data(), n);
    mju_copy(d->qvel, qd.data(), n);
    mju_copy(d->qfrc_applied, tau.data(), n);
    mj_forward(m, d);
    MatrixXd Mj(n, n), Ml(n, n);
    mj_fullM(m, Mj.data(), d->qM);  // symmetric: row-major or column-major alike
    dynamics->ComputeMassMatrix(*data, q, Ml);
    VectorXd c(n), g(n), qdd_l(n), tau_l(n);
    dynamics->ComputeCoriolisForce(*data, q, qd, c);
    dynamics->ComputeGravityForce(*data, q, g);
    dynamics->ComputeForwardDynamics(*data, q, qd, tau, DynamicsTerms{}, qdd_l);
    worst.M = std::max(worst.M, RelativeDifference(Mj, Ml));
    worst.bias = std::max(worst.bias, RelativeDifference(Eigen::Map<VectorXd>(d->qfrc_bias, n), c + g));
    worst.fd = std::max(worst.fd, RelativeDifference(Eigen::Map<VectorXd>(d->qacc, n), qdd_l));
    const double T = dynamics->ComputeKineticEnergy(*data, q, qd), V = dynamics->ComputePotentialEnergy(*data, q);
    worst.T = std::max(worst.T, std::abs(d->energy[1] - T) / std::max(1.0, std::abs(T)));
    worst.V = std::max(worst.V, std::abs(d->energy[0] - V) / std::max(1.0, std::abs(V)));
    mju_copy(d->qacc, qdd.data(), n);
    mj_inverse(m, d);
    dynamics->ComputeInverseDynamics(*data, q, qd, qdd, DynamicsTerms{}, tau_l);
    worst.id = std::max(worst.id, RelativeDifference(Eigen::Map<VectorXd>(d->qfrc_inverse, n), tau_l));
  }
  mj_deleteData(d);
  return worst;
}

class ShippedRobot : public ::testing::TestWithParam<std::string> {};

TEST_P(ShippedRobot, AgreesWithLagrangeToRoundOffAfterTheInertiaFix) {
  const Agreement a = Compare(Load(GetParam(), /*exact=*/true));
  EXPECT_LT(a.M, kRoundOff);
  EXPECT_LT(a.bias, kRoundOff);
  EXPECT_LT(a.fd, kRoundOff);
  EXPECT_LT(a.id, kRoundOff);
  EXPECT_LT(a.T, kRoundOff);
  EXPECT_LT(a.V, kRoundOff);
  std::printf("%s: M %.2g, bias %.2g, FD %.2g, ID %.2g, T %.2g, V %.2g (relative)\n", GetParam().c_str(), a.M, a.bias,
              a.fd, a.id, a.T, a.V);
}

// The fix is what makes the difference: MuJoCo's own mju_eig3 leaves the
// Panda's stored tensors off by more than round-off.
TEST(MujocoPlant, OwnInertiasOfThePandaDifferBeyondRoundOff) {
  const Agreement a = Compare(Load("panda.urdf", /*exact=*/false));
  EXPECT_GT(std::max(a.M, a.fd), 100 * kRoundOff);
  std::printf("panda.urdf, MuJoCo's own inertias: M %.2g, bias %.2g, FD %.2g, ID %.2g, T %.2g, V %.2g (relative)\n",
              a.M, a.bias, a.fd, a.id, a.T, a.V);
}

INSTANTIATE_TEST_SUITE_P(MujocoPlant, ShippedRobot, ::testing::Values("panda.urdf", "ur5.urdf"),
                         [](const auto& p) { return p.param.substr(0, p.param.find('.')); });

TEST(MujocoPlant, DegreesOfFreedomAreTheModelsJointsInItsOrder) {
  const Loaded l = Load("ur5.urdf", true);
  EXPECT_EQ(l.mujoco->joint_names(), l.robot.tree.joint_names());
  EXPECT_EQ(l.mujoco->num_dofs(), 6);
}

std::string WriteTemp(const std::string& name, const std::string& text) {
  const std::string path = ::testing::TempDir() + name;
  std::ofstream(path) << text;
  return path;
}

std::string LoadError(const std::string& path) {
  try {
    LoadMujocoPlant(path, MujocoOptions{});
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

// A free joint is a free body lagrange does not model unless it is asked
// for as the floating base: alone, it leaves no degree of freedom.
TEST(MujocoPlant, AFreeBodyAloneIsNoRobotAndAFloatingBaseIsAskedFor) {
  const std::string path = WriteTemp("free.xml", R"(<mujoco><worldbody><body name="b"><freejoint name="float"/>
      <geom size="0.1"/></body></worldbody></mujoco>)");
  const std::string e = LoadError(path);
  EXPECT_NE(e.find("expected at least one hinge or slide joint, got none"), std::string::npos) << e;
  EXPECT_EQ(e.find('\n'), std::string::npos);
  MujocoOptions o;
  o.floating_base = true;
  const auto model = LoadMujocoPlant(path, o);
  EXPECT_TRUE(model->floating_base());
  EXPECT_EQ(model->num_positions(), 7);
  EXPECT_EQ(model->num_dofs(), 6);
  const std::string pendulum = WriteTemp("pendulum_alone.xml", R"(<mujoco><worldbody><body name="b">
      <joint name="theta" axis="0 1 0"/><geom size="0.1" pos="0 0 -1"/></body></worldbody></mujoco>)");
  try {
    LoadMujocoPlant(pendulum, o);
    ADD_FAILURE() << "a floating base without a free joint loaded";
  } catch (const std::invalid_argument& error) {
    EXPECT_NE(std::string(error.what()).find("expected a free joint for lagrange's floating base"), std::string::npos);
  }
}

TEST(MujocoPlant, RefusesABallJointWithOneLine) {
  const std::string path = WriteTemp("ball.xml", R"(<mujoco><worldbody><body name="b"><joint name="shoulder" type="ball"/>
      <geom size="0.1" pos="0 0 -0.5"/></body></worldbody></mujoco>)");
  const std::string e = LoadError(path);
  EXPECT_NE(e.find("joint 'shoulder' is a ball joint"), std::string::npos) << e;
}

TEST(MujocoPlant, RefusesABrokenMjcfWithMujocosMessageOnOneLine) {
  const std::string path = WriteTemp("broken.xml", "<mujoco><worldbody><body name=\"b\">\n<joint type=\"hinge\"/>\n"
                                                   "<geom size=\"0.1\"/></worldbody></mujoco>");
  const std::string e = LoadError(path);
  EXPECT_EQ(e.rfind(path + ": MuJoCo: ", 0), 0u) << e;
  EXPECT_EQ(e.find('\n'), std::string::npos) << e;
  EXPECT_GT(e.size(), path.size() + 20) << "MuJoCo's own message follows: " << e;
}

TEST(MujocoPlant, RefusesAMissingFile) {
  const std::string path = ::testing::TempDir() + "no_such_model.xml";
  EXPECT_EQ(LoadError(path), path + ": cannot be opened (No such file or directory)");
}

TEST(MujocoPlant, RefusesAnEmptyFile) {
  const std::string path = WriteTemp("empty.xml", "");
  EXPECT_EQ(LoadError(path), path + ": empty: expected an MJCF or URDF model");
}

// What MuJoCo's compiler refuses as written and lagrange takes: a point mass
// (l1), a massless link between two joints (virt), a mesh collision MuJoCo
// cannot find (package://). Loaded with the edits of mujoco_plant.hpp, the
// dynamics agree with lagrange's to round-off.
constexpr char kAwkwardUrdf[] = R"(<?xml version="1.0"?>
<robot name="awkward">
  <link name="base"/>
  <joint name="j1" type="revolute">
    <parent link="base"/><child link="l1"/><axis xyz="0 1 0"/>
    <limit lower="-3" upper="3" effort="20" velocity="2"/>
  </joint>
  <link name="l1">
    <inertial><origin xyz="0.3 0 0"/><mass value="1.0"/><inertia ixx="0" ixy="0" ixz="0" iyy="0" iyz="0" izz="0"/></inertial>
  </link>
  <joint name="j2" type="continuous">
    <parent link="l1"/><child link="virt"/><origin xyz="0.5 0 0" rpy="0.3 0 0"/><axis xyz="0 1 0"/>
  </joint>
  <link name="virt"/>
  <joint name="j3" type="prismatic">
    <parent link="virt"/><child link="l3"/><axis xyz="1 0 0"/>
    <limit lower="-0.2" upper="0.2" effort="20" velocity="2"/>
  </joint>
  <link name="l3">
    <inertial><origin xyz="0.2 0.01 0"/><mass value="0.5"/>
      <inertia ixx="0.001" ixy="0.0001" ixz="0" iyy="0.002" iyz="0" izz="0.002"/></inertial>
    <collision><geometry><mesh filename="package://awkward/meshes/l3.stl"/></geometry></collision>
  </link>
</robot>
)";

TEST(MujocoPlant, AUrdfWithAPointMassAMasslessLinkAndAMeshCollisionLoadsAndAgrees) {
  const std::string path = ::testing::TempDir() + "awkward.urdf";
  std::ofstream(path) << kAwkwardUrdf;
  Loaded l{LoadUrdf(path), nullptr};
  MujocoOptions o;
  o.exact_inertia = &l.robot.tree;
  l.mujoco = LoadMujocoPlant(path, o);
  EXPECT_EQ(l.mujoco->info().num_geoms, 0);  // the mesh collision dropped
  const Agreement a = Compare(l);
  EXPECT_LT(a.M, kRoundOff);
  EXPECT_LT(a.bias, kRoundOff);
  EXPECT_LT(a.fd, kRoundOff);
  EXPECT_LT(a.id, kRoundOff);
  EXPECT_LT(a.T, kRoundOff);
  EXPECT_LT(a.V, kRoundOff);
}

// A pendulum: one hinge, 1 kg at 1 m below the pivot.
constexpr char kPendulum[] = R"(<mujoco><worldbody><body name="bob"><joint name="theta" axis="0 1 0"/>
    <geom type="sphere" size="0.05" pos="0 0 -1" mass="1" contype="0" conaffinity="0"/></body></worldbody></mujoco>)";

// MuJoCo's order here is (theta, x); asked for lagrange's (x, theta), q follows the names.
TEST(MujocoPlant, QFollowsTheGivenJointOrderByName) {
  const std::string path = WriteTemp("two_order.xml", R"(<mujoco><worldbody>
      <body name="pole"><joint name="theta" axis="0 1 0"/><geom size="0.05" pos="0 0 -1" mass="1"/></body>
      <body name="cart" pos="0 1 0"><joint name="x" type="slide" axis="1 0 0"/><geom size="0.05" mass="1"/></body>
      </worldbody></mujoco>)");
  MujocoOptions o;
  o.joint_order = {"x", "theta"};
  const auto model = LoadMujocoPlant(path, o);
  EXPECT_EQ(model->joint_names(), (std::vector<std::string>{"x", "theta"}));
  auto data = model->MakeData();
  VectorXd q(2), qd = VectorXd::Zero(2), qdd(2), tau = VectorXd::Zero(2);
  q << 0.1, 0.5;
  data->SetState(q, qd);
  ASSERT_EQ(data->Step(tau, q, qd, qdd), nullptr);
  EXPECT_DOUBLE_EQ(qdd[0], 0.0);  // the cart, level, under no force
  EXPECT_LT(qdd[1], -1.0);        // the pendulum at 0.5 rad falls back
  EXPECT_NEAR(q[0], 0.1, 1e-15);
  o.joint_order = {"x", "phi"};
  EXPECT_THROW(LoadMujocoPlant(path, o), std::invalid_argument);
}

TEST(MujocoPlant, SteppingAllocatesNothing) {
  for (MujocoIntegrator integrator : {MujocoIntegrator::kEuler, MujocoIntegrator::kRk4, MujocoIntegrator::kImplicit}) {
    const Loaded l = [&] {
      Loaded x{LoadUrdf(kRobots + "panda.urdf"), nullptr};
      MujocoOptions o;
      o.exact_inertia = &x.robot.tree;
      o.substeps = 2;
      o.integrator = integrator;
      x.mujoco = LoadMujocoPlant(kRobots + "panda.urdf", o);
      return x;
    }();
    auto data = l.mujoco->MakeData();
    const int n = l.mujoco->num_dofs();
    VectorXd q = VectorXd::Constant(n, 0.1), qd = VectorXd::Zero(n), qdd(n), tau = VectorXd::Constant(n, 1.0);
    data->SetState(q, qd);
    testing::AllocationCounter counter;
    for (int k = 0; k < 50; ++k) ASSERT_EQ(data->Step(tau, q, qd, qdd), nullptr);
    data->SetState(q, qd);
    EXPECT_EQ(counter.count(), 0) << ToString(integrator);
  }
}

// A free pendulum under RK4 keeps its energy: T + V from MuJoCo, the other
// forces' work zero.
TEST(MujocoPlant, FreePendulumKeepsItsEnergyUnderRk4) {
  const auto model = LoadMujocoPlant(WriteTemp("pendulum.xml", kPendulum), MujocoOptions{});
  auto data = model->MakeData();
  VectorXd q(1), qd(1), qdd(1), tau = VectorXd::Zero(1);
  q << 1.0;
  qd << 0.0;
  data->SetState(q, qd);
  const double e0 = data->kinetic_energy() + data->potential_energy();
  EXPECT_NEAR(data->potential_energy(), -9.81 * std::cos(1.0), 1e-12);
  for (int k = 0; k < 2000; ++k) ASSERT_EQ(data->Step(tau, q, qd, qdd), nullptr);
  EXPECT_NEAR(data->kinetic_energy() + data->potential_energy(), e0, 1e-9);
  EXPECT_DOUBLE_EQ(data->other_work(), 0.0);
}

// A MuJoCo error in a step (here "Stack overflow": the block's contacts with
// the floor outgrow the file's nstack) faults that step with MuJoCo's words;
// by MuJoCo's default it printed "Press Enter to exit ...", read stdin and
// ended the process. The data is usable again after SetState.
TEST(MujocoPlant, AnErrorInAStepFaultsTheStepInsteadOfEndingTheProcess) {
  const auto model = LoadMujocoPlant(WriteTemp("small_stack.xml", R"(<mujoco><size nstack="300"/><worldbody>
    <geom type="plane" size="1 1 0.1"/>
    <body pos="0 0 0.3"><joint name="z" type="slide" axis="0 0 1"/><geom type="box" size="0.1 0.1 0.1"/>
      <geom type="box" pos="0.2 0 0" size="0.1 0.1 0.1"/><geom type="box" pos="0.4 0 0" size="0.1 0.1 0.1"/></body>
    </worldbody></mujoco>)"),
                                     MujocoOptions{});
  auto data = model->MakeData();
  VectorXd q = VectorXd::Zero(1), qd = VectorXd::Zero(1), qdd(1), tau = VectorXd::Zero(1);
  data->SetState(q, qd);  // falling, 0.2 m above the floor
  const char* reason = nullptr;
  int steps = 0;
  for (; steps < 2000 && reason == nullptr; ++steps) reason = data->Step(tau, q, qd, qdd);
  ASSERT_NE(reason, nullptr) << "the block never touched the floor";
  EXPECT_NE(std::string(reason).find("MuJoCo: Stack overflow"), std::string::npos) << reason;
  EXPECT_GT(steps, 100);  // not at once: when it reached the floor
  q << 0.0;
  qd << 0.0;
  data->SetState(q, qd);  // in the air again: its steps run until the floor
  EXPECT_EQ(data->Step(tau, q, qd, qdd), nullptr);
  EXPECT_LT(q[0], 0.0);
}

// Damping's work is counted: E(t) − E(0) = W to the trapezoid rule's error.
TEST(MujocoPlant, DampingsWorkIsTheEnergyLost) {
  std::string xml = kPendulum;
  xml.replace(xml.find("axis=\"0 1 0\""), 12, "axis=\"0 1 0\" damping=\"0.3\"");
  MujocoOptions o;
  o.substeps = 4;
  const auto model = LoadMujocoPlant(WriteTemp("damped.xml", xml), o);
  auto data = model->MakeData();
  VectorXd q(1), qd(1), qdd(1), tau = VectorXd::Zero(1);
  q << 1.0;
  qd << 0.0;
  data->SetState(q, qd);
  const double e0 = data->kinetic_energy() + data->potential_energy();
  double work = 0.0;
  for (int k = 0; k < 2000; ++k) {
    ASSERT_EQ(data->Step(tau, q, qd, qdd), nullptr);
    work += data->other_work();
  }
  const double change = data->kinetic_energy() + data->potential_energy() - e0;
  EXPECT_LT(change, -0.1);  // it lost energy
  EXPECT_NEAR(change, work, 1e-6 * std::abs(change));
}

// ------------------------------------------------------------------ files

// A fresh directory of the test's own under the temporary directory.
std::filesystem::path FreshDirectory(const std::string& name) {
  const std::filesystem::path dir = std::filesystem::path(::testing::TempDir()) / name;
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

void WriteFile(const std::filesystem::path& path, const std::string& bytes) {
  std::filesystem::create_directories(path.parent_path());
  std::ofstream(path, std::ios::binary) << bytes;
}

// kPendulum's elements after <mujoco>, for models that add their own first.
std::string PendulumBody() { return std::string(kPendulum).substr(std::string("<mujoco>").size()); }

// Within a 2 MiB bound, as a URDF: a 50 MB MJCF (a valid model behind a 50 MB
// comment) is refused with one line naming it and the bound, unparsed.
TEST(MujocoPlant, AnMjcfLargerThanTheUrdfBoundIsRefusedNamingTheFileAndTheBound) {
  const std::filesystem::path dir = FreshDirectory("mujoco_big");
  const std::string path = (dir / "big.xml").string();
  WriteFile(path, "<mujoco><!--" + std::string(50'000'000, ' ') + "-->" + PendulumBody());
  EXPECT_EQ(LoadError(path), path + ": larger than 2 MiB");
  std::filesystem::remove_all(dir);
}

// LoadError(path) where the model names the FIFO `fifo`: were the load to
// block on it, after 30 s the FIFO is opened for writing (the blocked reader
// gets end of file) and "blocked on the FIFO" is returned, so a test never hangs.
std::string LoadErrorUnlessBlocked(const std::string& path, const std::string& fifo) {
  auto refusal = std::async(std::launch::async, [&] { return LoadError(path); });
  if (refusal.wait_for(std::chrono::seconds(30)) == std::future_status::timeout) {
    ::close(::open(fifo.c_str(), O_WRONLY | O_NONBLOCK));
    refusal.wait();
    return "blocked on the FIFO";
  }
  return refusal.get();
}

// MuJoCo would open an included FIFO and wait for a writer forever: lagrange
// reads every file first, non-blocking, and refuses it at once.
TEST(MujocoPlant, AnIncludedFifoIsRefusedAtOnceNamingIt) {
  const std::filesystem::path dir = FreshDirectory("mujoco_fifo");
  const std::string fifo = (dir / "parts.xml").string(), path = (dir / "world.xml").string();
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  WriteFile(path, "<mujoco><include file=\"parts.xml\"/>" + PendulumBody());
  EXPECT_EQ(LoadErrorUnlessBlocked(path, fifo),
            path + ": <include file=\"parts.xml\">: " + fifo + ": not a regular file (a FIFO)");
  std::filesystem::remove_all(dir);
}

// A binary STL: a tetrahedron of 0.1 m.
std::string Tetrahedron() {
  const float v[4][3] = {{0, 0, 0}, {0.1f, 0, 0}, {0, 0.1f, 0}, {0, 0, 0.1f}};
  const int faces[4][3] = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
  std::string stl(80, '\0');
  const std::uint32_t count = 4;
  stl.append(reinterpret_cast<const char*>(&count), 4);
  for (const auto& face : faces) {
    stl.append(12, '\0');  // the normal: MuJoCo computes its own
    for (int k : face) stl.append(reinterpret_cast<const char*>(v[k]), 12);
    stl.append(2, '\0');
  }
  return stl;
}

// A 1 x 1 grey PNG.
std::string Png() {
  const unsigned char bytes[] = {0x89, 0x50, 0x4e, 0x47, 0x0d, 0x0a, 0x1a, 0x0a, 0x00, 0x00, 0x00, 0x0d, 0x49, 0x48,
                                 0x44, 0x52, 0x00, 0x00, 0x00, 0x01, 0x00, 0x00, 0x00, 0x01, 0x08, 0x02, 0x00, 0x00,
                                 0x00, 0x90, 0x77, 0x53, 0xde, 0x00, 0x00, 0x00, 0x0c, 0x49, 0x44, 0x41, 0x54, 0x78,
                                 0x9c, 0x63, 0x68, 0x68, 0x68, 0x00, 0x00, 0x03, 0x04, 0x01, 0x81, 0x4b, 0xd3, 0xd2,
                                 0x10, 0x00, 0x00, 0x00, 0x00, 0x49, 0x45, 0x4e, 0x44, 0xae, 0x42, 0x60, 0x82};
  return std::string(reinterpret_cast<const char*>(bytes), sizeof bytes);
}

// Includes (nested ones too) relative to the model's directory, meshes under
// meshdir, textures under texturedir, as MuJoCo 2.2.2 finds them: lagrange
// reads the same files and the model loads; one missing, or a FIFO, or a
// second file of the same name elsewhere, is refused naming it.
TEST(MujocoPlant, IncludesMeshesAndTexturesAreReadWhereMujocoFindsThem) {
  const std::filesystem::path dir = FreshDirectory("mujoco_files");
  const std::string path = (dir / "world.xml").string();
  WriteFile(path, R"(<mujoco>
      <compiler meshdir="assets" texturedir="assets/textures/"/>
      <include file="parts/assets.xml"/>
      <worldbody><body name="bob"><joint name="theta" axis="0 1 0"/>
        <geom type="sphere" size="0.05" pos="0 0 -1" mass="1" contype="0" conaffinity="0"/>
        <geom type="mesh" mesh="tet" contype="0" conaffinity="0"/></body></worldbody></mujoco>)");
  WriteFile(dir / "parts" / "assets.xml", R"(<mujoco><include file="parts/textures.xml"/>
      <asset><mesh name="tet" file="tet.stl"/></asset></mujoco>)");
  WriteFile(dir / "parts" / "textures.xml",
            R"(<mujoco><asset><texture name="grey" type="2d" file="grey.png"/></asset></mujoco>)");
  WriteFile(dir / "assets" / "tet.stl", Tetrahedron());
  WriteFile(dir / "assets" / "textures" / "grey.png", Png());
  const auto model = LoadMujocoPlant(path, MujocoOptions{});
  EXPECT_EQ(model->info().num_geoms, 2);
  EXPECT_EQ(model->mj_model()->nmesh, 1);
  EXPECT_EQ(model->mj_model()->ntex, 1);

  const std::string mesh = (dir / "assets" / "tet.stl").string();
  std::filesystem::remove(mesh);
  EXPECT_EQ(LoadError(path),
            path + ": <mesh file=\"tet.stl\">: " + mesh + ": cannot be opened (No such file or directory)");
  ASSERT_EQ(::mkfifo(mesh.c_str(), 0600), 0);
  EXPECT_EQ(LoadErrorUnlessBlocked(path, mesh),
            path + ": <mesh file=\"tet.stl\">: " + mesh + ": not a regular file (a FIFO)");
  std::filesystem::remove(mesh);
  WriteFile(mesh, "");  // MuJoCo 2.2.2's VFS would end the process for it
  EXPECT_EQ(LoadError(path), path + ": <mesh file=\"tet.stl\">: " + mesh + ": empty");
  WriteFile(mesh, Tetrahedron());

  WriteFile(dir / "parts" / "textures.xml", R"(<mujoco><include file="other/assets.xml"/>
      <asset><texture name="grey" type="2d" file="grey.png"/></asset></mujoco>)");
  WriteFile(dir / "other" / "assets.xml", "<mujoco/>");
  EXPECT_NE(LoadError(path).find("share the name 'assets.xml'"), std::string::npos) << LoadError(path);
  std::filesystem::remove_all(dir);
}

// ------------------------------------------------------------------ forces

// A slider on a floor (a contact) with damping, a spring, friction loss; an
// arm pushed into its stop (a limit), with a second hinge held to it by a
// joint equality. Every kind of MuJoCo force at once.
constexpr char kEveryForce[] = R"(<mujoco model="every_force">
  <compiler angle="radian" autolimits="true"/>
  <option timestep="0.001"/>
  <worldbody>
    <geom name="floor" type="plane" size="1 1 0.1"/>
    <body name="slider" pos="0 0 0.1">
      <joint name="z" type="slide" axis="0 0 1" damping="0.5" frictionloss="0.3" stiffness="20" springref="0.05"/>
      <geom name="ball" type="sphere" size="0.1" mass="1"/>
      <body name="arm" pos="0 0 0.3">
        <joint name="a" type="hinge" axis="0 1 0" range="-0.5 0.5" damping="0.1" frictionloss="0.05"/>
        <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.02" mass="0.2" contype="0" conaffinity="0"/>
        <body pos="0.3 0 0">
          <joint name="b" type="hinge" axis="0 1 0"/>
          <geom type="capsule" fromto="0 0 0 0.2 0 0" size="0.02" mass="0.1" contype="0" conaffinity="0"/>
        </body>
      </body>
    </body>
  </worldbody>
  <equality><joint joint1="b" joint2="a" polycoef="0 0.5 0 0 0"/></equality>
</mujoco>)";

// The rows are MuJoCo's own terms at the published state: they add up to its
// M(q) q̈ (mj_fullM at that q) to round-off; damping is −b q̇ − k (q − q_ref)
// (qfrc_passive); the stop's force is in limits, the friction loss in
// friction (bounded by the loss), the floor's and the equality's in constraint.
TEST(MujocoPlant, ForcesAreMujocosOwnTermsAndAddUpToItsMTimesQdd) {
  const auto model = LoadMujocoPlant(WriteTemp("every_force.xml", kEveryForce), MujocoOptions{});
  auto data = model->MakeData();
  const int n = model->num_dofs();
  ASSERT_EQ(n, 3);
  VectorXd q = VectorXd::Zero(n), qd = VectorXd::Zero(n), qdd(n), tau(n);
  tau << 0.0, 2.0, 0.0;  // N·m on a: into its stop at 0.5 rad
  data->SetState(q, qd);
  for (int k = 0; k < 500; ++k) ASSERT_EQ(data->Step(tau, q, qd, qdd), nullptr);
  EffectForces f(n);
  data->ComputeForces(f);
  f.tau_cmd = f.tau_applied = tau;
  EXPECT_TRUE(f.active.gravity && f.active.coriolis && f.active.damping && f.active.friction && f.active.limits &&
              f.constraint_on);
  // MuJoCo's M at q, from data of its own.
  const mjModel* m = model->mj_model();
  mjData* d = mj_makeData(m);
  mju_copy(d->qpos, q.data(), n);
  mju_copy(d->qvel, qd.data(), n);
  mj_forward(m, d);
  MatrixXd M(n, n);
  mj_fullM(m, M.data(), d->qM);
  VectorXd net(n);
  f.NetForce(net);
  const double scale = std::max(f.gravity.cwiseAbs().maxCoeff(), f.constraint.cwiseAbs().maxCoeff());
  std::printf(
      "every force: |sum - M qdd| = %.2g (terms up to %.3g); limits %.4g, friction %.4g N, constraint %.4g %.4g %.4g\n",
      (net - M * qdd).cwiseAbs().maxCoeff(), scale, f.limits[1], f.friction[0], f.constraint[0], f.constraint[1],
      f.constraint[2]);
  EXPECT_LT((net - M * qdd).cwiseAbs().maxCoeff(), 1e-12 * scale);
  // G + C q̇ is MuJoCo's bias force at (q, q̇).
  EXPECT_LT((f.gravity + f.coriolis - Eigen::Map<VectorXd>(d->qfrc_bias, n)).cwiseAbs().maxCoeff(), 1e-12 * scale);
  EXPECT_NEAR(f.gravity[0], (1.0 + 0.2 + 0.1) * 9.81, 1e-12 * scale);  // the slider carries every mass
  EXPECT_NEAR(f.damping[0], -0.5 * qd[0] - 20.0 * (q[0] - 0.05), 1e-12);
  EXPECT_NEAR(f.damping[1], -0.1 * qd[1], 1e-12);
  EXPECT_NEAR(q[1], 0.5, 0.01);  // at the stop ...
  EXPECT_LT(f.limits[1], -0.5);  // ... which pushes back
  EXPECT_EQ(f.limits[0], 0.0);   // z has no range
  EXPECT_LE(std::abs(f.friction[0]), 0.3 + 1e-12);
  EXPECT_LE(std::abs(f.friction[1]), 0.05 + 1e-12);
  EXPECT_GT(f.constraint[0], 5.0);  // the floor carries the weight (N)
  // The one contact: the ball on the floor, pushed up.
  ASSERT_EQ(f.num_contacts, 1);
  EXPECT_EQ(f.contacts_total, 1);
  const ContactWrench& c = f.contacts[0];
  EXPECT_EQ(c.geom1, mj_name2id(m, mjOBJ_GEOM, "floor"));
  EXPECT_EQ(c.geom2, mj_name2id(m, mjOBJ_GEOM, "ball"));
  EXPECT_NEAR(c.normal.z(), 1.0, 1e-12);
  EXPECT_NEAR(c.force.z(), f.constraint[0], 1e-9 * scale);  // the slider's row is the contact's normal force
  EXPECT_NEAR(c.position.z(), 0.0, 1e-3);
  mj_deleteData(d);
}

// The gravity row (Σ −J_comᵀ m g over MuJoCo's bodies) and the Coriolis row
// (MuJoCo's bias less it) are lagrange's G(q) and C(q, q̇) q̇ on the Panda
// with the inertia fix, to round-off: two independent implementations.
TEST(MujocoPlant, GravityAndCoriolisRowsAreLagrangesToRoundOff) {
  const Loaded l = Load("panda.urdf", /*exact=*/true);
  const auto dynamics = MakeDynamics(UrdfPlantSpec(std::make_shared<UrdfRobot>(l.robot)), Method::kRecursive);
  auto ours = dynamics->MakeData();
  auto data = l.mujoco->MakeData();
  const int n = l.mujoco->num_dofs();
  std::mt19937 rng{42};
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  EffectForces f(n);
  double worst = 0.0;
  for (int trial = 0; trial < 10; ++trial) {
    VectorXd q(n), qd(n), g(n), c(n);
    for (int i = 0; i < n; ++i) {
      q[i] = 0.5 * u(rng) + (i == 3 ? -1.5 : 0.0) + (i == 5 ? 1.5 : 0.0);  // inside every range
      qd[i] = 1.5 * u(rng);
    }
    data->SetState(q, qd);
    data->ComputeForces(f);
    dynamics->ComputeGravityForce(*ours, q, g);
    dynamics->ComputeCoriolisForce(*ours, q, qd, c);
    worst = std::max({worst, RelativeDifference(f.gravity, g), RelativeDifference(f.coriolis, c)});
    EXPECT_EQ(f.constraint.cwiseAbs().maxCoeff(), 0.0);  // panda.urdf has no collision geometry
    EXPECT_EQ(f.num_contacts, 0);
  }
  EXPECT_LT(worst, kRoundOff);
  EXPECT_FALSE(f.constraint_on);
  std::printf("Panda: MuJoCo's gravity and Coriolis rows against lagrange's: %.2g relative\n", worst);
}

TEST(MujocoPlant, ComputingForcesAllocatesNothing) {
  const auto model = LoadMujocoPlant(WriteTemp("every_force_alloc.xml", kEveryForce), MujocoOptions{});
  auto data = model->MakeData();
  VectorXd q = VectorXd::Zero(3), qd = VectorXd::Zero(3), qdd(3), tau = VectorXd::Constant(3, 1.0);
  data->SetState(q, qd);
  EffectForces f(3);
  ASSERT_EQ(data->Step(tau, q, qd, qdd), nullptr);
  testing::AllocationCounter counter;
  for (int k = 0; k < 20; ++k) {
    ASSERT_EQ(data->Step(tau, q, qd, qdd), nullptr);
    data->ComputeForces(f);
  }
  EXPECT_EQ(counter.count(), 0);
  EXPECT_EQ(f.num_contacts, 1);
}

// ------------------------------------------------------------------ mimic joints

// panda_hand.urdf as a scene loads it: lagrange's degrees of freedom in its
// order, its mimic (the right finger) coupled by the equality lagrange adds.
Loaded LoadPandaHand(MujocoIntegrator integrator = MujocoIntegrator::kRk4) {
  Loaded l{LoadUrdf(kRobots + "panda_hand.urdf"), nullptr};
  MujocoOptions o;
  o.exact_inertia = &l.robot.tree;
  o.joint_order = l.robot.tree.joint_names();
  o.mimics = MimicsOf(l.robot.tree);
  o.integrator = integrator;
  l.mujoco = LoadMujocoPlant(kRobots + "panda_hand.urdf", o);
  return l;
}

// MuJoCo's 9 joints, lagrange's 8 degrees of freedom: with the mimic placed
// on its leader (q_joints = S q + o), Sᵀ M S, Sᵀ (bias), T and V of MuJoCo's
// model are lagrange's to round-off, so the URDF written back as MJCF (17
// digits) kept every number.
TEST(MujocoPlant, PandaWithItsHandReducedToItsDegreesOfFreedomAgreesToRoundOff) {
  const Loaded l = LoadPandaHand();
  const mjModel* m = l.mujoco->mj_model();
  const RigidTree& tree = l.robot.tree;
  ASSERT_EQ(m->nv, 9);
  ASSERT_EQ(m->neq, 1);
  EXPECT_EQ(l.mujoco->num_dofs(), 8);
  EXPECT_EQ(l.mujoco->joint_names(), tree.joint_names());
  MatrixXd S = MatrixXd::Zero(9, 8);  // MuJoCo's joint order
  VectorXd o = VectorXd::Zero(9);
  for (int j = 0; j < tree.num_joints(); ++j) {
    const int k = mj_name2id(m, mjOBJ_JOINT, tree.joints[static_cast<std::size_t>(j)].name.c_str());
    ASSERT_GE(k, 0);
    const RigidTree::JointMap map = tree.MapOf(j);
    S(k, map.dof) = map.scale;
    o[k] = map.offset;
  }
  const auto dynamics = MakeDynamics(UrdfPlantSpec(std::make_shared<UrdfRobot>(l.robot)), Method::kRecursive);
  auto data = dynamics->MakeData();
  mjData* d = mj_makeData(m);
  std::mt19937 rng{42};
  std::uniform_real_distribution<double> u(0.05, 0.95), v(-1.5, 1.5);
  Agreement worst;
  for (int trial = 0; trial < 20; ++trial) {
    VectorXd q(8), qd(8);
    for (int i = 0; i < 8; ++i) {
      const double lo = l.mujoco->info().lower[static_cast<std::size_t>(i)];
      const double hi = l.mujoco->info().upper[static_cast<std::size_t>(i)];
      q[i] = lo + u(rng) * (hi - lo);
      qd[i] = v(rng) * (i == 7 ? 0.1 : 1.0);  // m/s for the finger
    }
    const VectorXd qpos = S * q + o, qvel = S * qd;
    mju_copy(d->qpos, qpos.data(), 9);
    mju_copy(d->qvel, qvel.data(), 9);
    mju_zero(d->qfrc_applied, 9);
    mj_forward(m, d);
    MatrixXd Mj(9, 9), Ml(8, 8);
    mj_fullM(m, Mj.data(), d->qM);
    dynamics->ComputeMassMatrix(*data, q, Ml);
    VectorXd c(8), g(8);
    dynamics->ComputeCoriolisForce(*data, q, qd, c);
    dynamics->ComputeGravityForce(*data, q, g);
    worst.M = std::max(worst.M, RelativeDifference(S.transpose() * Mj * S, Ml));
    const double T = dynamics->ComputeKineticEnergy(*data, q, qd), V = dynamics->ComputePotentialEnergy(*data, q);
    worst.T = std::max(worst.T, std::abs(d->energy[1] - T) / std::max(1.0, std::abs(T)));
    worst.V = std::max(worst.V, std::abs(d->energy[0] - V) / std::max(1.0, std::abs(V)));
  }
  mj_deleteData(d);
  EXPECT_LT(worst.M, kRoundOff);
  EXPECT_LT(worst.bias, kRoundOff);
  EXPECT_LT(worst.T, kRoundOff);
  EXPECT_LT(worst.V, kRoundOff);
  std::printf("panda_hand.urdf reduced (S^T M S, S^T bias): M %.2g, bias %.2g, T %.2g, V %.2g (relative)\n", worst.M,
              worst.bias, worst.T, worst.V);
}

// MuJoCo's equality is soft: the right finger follows the left to its
// violation. The arm falls under gravity from the ready pose for 0.5 s, the
// fingers opening from 0.2 m/s (Franka's limit), every force on the fingers
// inertial, the left one's damping or the constraint's. The largest
// |q_right − q_left| allowed, m, per integrator (measured: 1.4e-7, 1.4e-8,
// 6.0e-6; MuJoCo's implicit integrator keeps the coupling the least well).
TEST(MujocoPlant, TheMimicFingerFollowsItsLeaderToTheEqualitysSoftness) {
  for (const auto& [integrator, tolerance] :
       {std::pair{MujocoIntegrator::kEuler, 1e-6}, std::pair{MujocoIntegrator::kRk4, 1e-7},
        std::pair{MujocoIntegrator::kImplicit, 1e-5}}) {
    const Loaded l = LoadPandaHand(integrator);
    auto data = l.mujoco->MakeData();
    VectorXd q(8), qd = VectorXd::Zero(8), qdd(8), tau = VectorXd::Zero(8);
    q << 0, -0.785, 0, -2.356, 0, 1.571, 0.785, 0.01;
    qd[7] = 0.2;
    data->SetState(q, qd);
    EXPECT_DOUBLE_EQ(*MujocoJointPosition(*data, "panda_finger_joint2"), 0.01);  // placed on its leader
    double gap = 0.0;
    for (int k = 0; k < 500; ++k) {
      ASSERT_EQ(data->Step(tau, q, qd, qdd), nullptr);
      gap = std::max(gap, std::abs(*MujocoJointPosition(*data, "panda_finger_joint2") - q[7]));
    }
    EXPECT_GT(q[7], 0.015);  // the fingers did open
    EXPECT_LT(gap, tolerance) << ToString(integrator);
    std::printf("panda_hand free fall 0.5 s, %s: max |q_finger2 - q_finger1| = %.2g m\n",
                std::string(ToString(integrator)).c_str(), gap);
    testing::AllocationCounter counter;
    for (int k = 0; k < 20; ++k) ASSERT_EQ(data->Step(tau, q, qd, qdd), nullptr);
    data->SetState(q, qd);
    EXPECT_EQ(counter.count(), 0);
  }
}

// Two sliders a and b in an MJCF; lagrange's model says b mimics a.
std::string Sliders(const std::string& equality) {
  return R"(<mujoco><worldbody>
      <body name="ba"><joint name="a" type="slide" axis="1 0 0"/><geom size="0.05" mass="1"/></body>
      <body name="bb" pos="0 1 0"><joint name="b" type="slide" axis="1 0 0"/><geom size="0.05" mass="1"/></body>
      </worldbody>)" +
         equality + "</mujoco>";
}

std::string MimicLoadError(const std::string& path, const std::vector<MujocoMimic>& mimics) {
  MujocoOptions o;
  o.mimics = mimics;
  try {
    LoadMujocoPlant(path, o);
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

TEST(MujocoPlant, AnMjcfWithoutTheMimicsEqualityIsRefusedNamingTheElementToAdd) {
  const std::string path = WriteTemp("uncoupled.xml", Sliders(""));
  const std::string e = MimicLoadError(path, {{"b", "a", 1.0, 0.0}});
  EXPECT_NE(
      e.find("joint 'b' mimics 'a' in lagrange's model (q = 1 q_leader + 0): expected "
             "<equality><joint joint1=\"b\" joint2=\"a\" polycoef=\"0 1 0 0 0\"/></equality> in the MJCF, got none"),
      std::string::npos)
      << e;
  EXPECT_EQ(e.find('\n'), std::string::npos);
}

TEST(MujocoPlant, AnMjcfWhoseEqualityIsNotTheMimicsIsRefusedWithWhatItHolds) {
  const std::string path = WriteTemp(
      "miscoupled.xml", Sliders(R"(<equality><joint joint1="b" joint2="a" polycoef="0 2 0 0 0"/></equality>)"));
  const std::string e = MimicLoadError(path, {{"b", "a", 1.0, 0.0}});
  EXPECT_NE(e.find("got polycoef 0 2 0 0 0"), std::string::npos) << e;
}

TEST(MujocoPlant, AMimicThatIsNotMujocosJointIsRefused) {
  const std::string path = WriteTemp("no_mimic.xml", Sliders(""));
  const std::string e = MimicLoadError(path, {{"c", "a", 1.0, 0.0}});
  EXPECT_NE(e.find("MuJoCo's joints (a, b) are not those of lagrange's model (a, b; mimics c)"), std::string::npos)
      << e;
}

// A coupled MJCF: q is (a) alone; b is placed at 2 a + 0.1 and follows it.
TEST(MujocoPlant, ACoupledMjcfsMimicIsNoDegreeOfFreedomAndFollowsItsLeader) {
  const std::string path = WriteTemp(
      "coupled.xml", Sliders(R"(<equality><joint joint1="b" joint2="a" polycoef="0.1 2 0 0 0"/></equality>)"));
  MujocoOptions o;
  o.mimics = {{"b", "a", 2.0, 0.1}};
  const auto model = LoadMujocoPlant(path, o);
  EXPECT_EQ(model->joint_names(), std::vector<std::string>{"a"});
  auto data = model->MakeData();
  VectorXd q(1), qd(1), qdd(1), tau(1);
  q << 0.2;
  qd << 0.0;
  tau << 3.0;  // N on a: 1 kg of a plus 2² × 1 kg of b through the coupling, q̈ = 3 / 5 m/s²
  data->SetState(q, qd);
  EXPECT_NEAR(*MujocoJointPosition(*data, "b"), 0.5, 1e-15);
  for (int k = 0; k < 1000; ++k) ASSERT_EQ(data->Step(tau, q, qd, qdd), nullptr);
  EXPECT_NEAR(qdd[0], 3.0 / 5.0, 0.05 * 3.0 / 5.0);  // MuJoCo's default solref, soft: to 5 %
  EXPECT_NEAR(*MujocoJointPosition(*data, "b"), 2.0 * q[0] + 0.1, 1e-2);
  std::printf("coupled sliders (default solref): qdd %.6g m/s² against 0.6; |b - (2a + 0.1)| = %.2g m\n", qdd[0],
              std::abs(*MujocoJointPosition(*data, "b") - 2.0 * q[0] - 0.1));
}

// A mimic's forces act on its leader times its multiplier (Sᵀ, as lagrange's
// reduction): the equality's share cancels there exactly, and the rows add
// up to Sᵀ M S q̈ = (1 + 2²) kg q̈ to the equality's softness.
TEST(MujocoPlant, AMimicsForcesActOnItsLeaderWhereTheEqualitysShareCancels) {
  const std::string path = WriteTemp(
      "coupled_forces.xml", Sliders(R"(<equality><joint joint1="b" joint2="a" polycoef="0.1 2 0 0 0"/></equality>)"));
  MujocoOptions o;
  o.mimics = {{"b", "a", 2.0, 0.1}};
  const auto model = LoadMujocoPlant(path, o);
  auto data = model->MakeData();
  VectorXd q(1), qd(1), qdd(1), tau(1);
  q << 0.2;
  qd << 0.0;
  tau << 3.0;
  data->SetState(q, qd);
  for (int k = 0; k < 1000; ++k) ASSERT_EQ(data->Step(tau, q, qd, qdd), nullptr);
  EffectForces f(1);
  data->ComputeForces(f);
  f.tau_cmd = f.tau_applied = tau;
  EXPECT_TRUE(f.constraint_on);                 // the equality
  EXPECT_LT(std::abs(f.constraint[0]), 1e-12);  // −2 λ on a, λ on b: Sᵀ adds 2 λ back
  VectorXd net(1);
  f.NetForce(net);
  EXPECT_NEAR(net[0], 5.0 * qdd[0], 0.05 * 3.0);  // MuJoCo's default solref, soft: to 5 %
}

TEST(MujocoPlant, ADivergingSimulationFailsTheStepWithMujocosWarning) {
  const auto model = LoadMujocoPlant(WriteTemp("diverge.xml", kPendulum), MujocoOptions{});
  auto data = model->MakeData();
  VectorXd q = VectorXd::Zero(1), qd = VectorXd::Zero(1), qdd = VectorXd::Zero(1), tau(1);
  tau << 1e300;
  const char* why = data->Step(tau, q, qd, qdd);
  ASSERT_NE(why, nullptr);
  EXPECT_NE(std::string(why).find("mjWARN_BAD"), std::string::npos) << why;
  EXPECT_EQ(q[0], 0.0);  // outputs untouched
}

// ---- Free joints: MuJoCo's conventions beside lagrange's (plant/mujoco_free_joint.hpp) ----

// A conversion and its inverse, relative to the vector's norm: the round-off
// of turning by R and back (Rᵀ (R x) = x to 1.2e-15 relative at worst over
// these 100 states, with Eigen's quaternion-to-matrix, without any conversion of ours).
constexpr double kExact = 2e-15;

// A unit quaternion (x, y, z, w), seeded.
Eigen::Vector4d RandomQuaternion(std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  Eigen::Vector4d x(n(rng), n(rng), n(rng), n(rng));
  return x.normalized();
}

TEST(MujocoFreeJoint, TheConversionsRoundTripBothWaysExactly) {
  std::mt19937 rng{42};
  std::uniform_real_distribution<double> u(-2.0, 2.0);
  double worst = 0.0;
  for (int trial = 0; trial < 100; ++trial) {
    Eigen::Matrix<double, 7, 1> q, qpos, q_back, qpos_back;
    Eigen::Matrix<double, 6, 1> v, qvel, v_back, qvel_back, a, qacc, a_back, f, qfrc, f_back;
    q << u(rng), u(rng), u(rng), RandomQuaternion(rng);
    for (int k = 0; k < 6; ++k) v[k] = u(rng), a[k] = u(rng), f[k] = u(rng);
    // lagrange => MuJoCo => lagrange
    FreeJointToMujoco(q.data(), v.data(), qpos.data(), qvel.data());
    FreeJointFromMujoco(qpos.data(), qvel.data(), q_back.data(), v_back.data());
    FreeJointAccelerationToMujoco(q.data(), v.data(), a.data(), qacc.data());
    FreeJointAccelerationFromMujoco(q.data(), v.data(), qacc.data(), a_back.data());
    FreeJointForceToMujoco(q.data(), f.data(), qfrc.data());
    FreeJointForceFromMujoco(q.data(), qfrc.data(), f_back.data());
    EXPECT_EQ(q_back, q);  // positions: a permutation, bit for bit
    EXPECT_DOUBLE_EQ(qpos[3], q[6]);  // w first in MuJoCo, last in lagrange
    const auto rel = [](const auto& x, const auto& y) { return (x - y).norm() / y.norm(); };
    worst = std::max({worst, rel(v_back, v), rel(a_back, a), rel(f_back, f)});
    // MuJoCo => lagrange => MuJoCo
    FreeJointFromMujoco(qpos.data(), qvel.data(), q_back.data(), v_back.data());
    FreeJointToMujoco(q_back.data(), v_back.data(), qpos_back.data(), qvel_back.data());
    EXPECT_EQ(qpos_back, qpos);
    worst = std::max(worst, rel(qvel_back, qvel));
    // power is the same on both sides: qvelᵀ qfrc = vᵀ f
    worst = std::max(worst, std::abs(qvel.dot(qfrc) - v.dot(f)) / (v.norm() * f.norm()));
  }
  EXPECT_LT(worst, kExact);
  std::printf("free joint conversions, 100 random states: worst relative round trip %.2g\n", worst);
}

// The physical fact behind the velocity's conversion: a point r of the body
// (a site) moves at R (v_b + ω_b × r) and the body turns at R ω_b, by
// MuJoCo's own mj_objectVelocity at the qvel the plant sets for lagrange's v.
constexpr char kFreeBodyWithASite[] = R"(<mujoco><option gravity="0 0 0"/><worldbody>
    <body name="box" pos="0 0 1"><freejoint name="root"/>
      <geom type="box" size="0.1 0.2 0.3" mass="2" contype="0" conaffinity="0"/>
      <site name="corner" pos="0.1 -0.2 0.3"/></body>
    <body name="pole"><joint name="theta" axis="0 1 0"/><geom size="0.05" pos="0 0 -1" mass="1"/></body>
  </worldbody></mujoco>)";

TEST(MujocoFreeJoint, APointOfTheBaseMovesAsLagrangesVelocitySaysByMujocosObjectVelocity) {
  MujocoOptions o;
  o.floating_base = true;
  const auto model = LoadMujocoPlant(WriteTemp("free_site.xml", kFreeBodyWithASite), o);
  ASSERT_EQ(model->num_positions(), 8);
  ASSERT_EQ(model->num_dofs(), 7);
  const mjModel* m = model->mj_model();
  auto plant = model->MakeData();
  mjData* d = mj_makeData(m);
  const int site = mj_name2id(m, mjOBJ_SITE, "corner");
  const Eigen::Vector3d r(0.1, -0.2, 0.3);
  std::mt19937 rng{7};
  std::uniform_real_distribution<double> u(-2.0, 2.0);
  double worst = 0.0;
  for (int trial = 0; trial < 20; ++trial) {
    VectorXd q(8), v(7);
    q << u(rng), u(rng), u(rng), RandomQuaternion(rng), u(rng);
    for (int k = 0; k < 7; ++k) v[k] = u(rng);
    plant->SetState(q, v);
    const std::optional<MujocoFreeBody> body = MujocoFreeJointState(*plant, "root");  // read back from MuJoCo
    ASSERT_TRUE(body);
    worst = std::max({worst, (body->q - q.head<7>()).cwiseAbs().maxCoeff(), (body->v - v.head<6>()).cwiseAbs().maxCoeff()});
    FreeJointToMujoco(q.data(), v.data(), d->qpos, d->qvel);  // the free joint is MuJoCo's first: qpos 0..6, qvel 0..5
    d->qpos[7] = q[7];
    d->qvel[6] = v[6];
    mj_forward(m, d);
    mjtNum res[6];  // (angular, linear) in the world at the site
    mj_objectVelocity(m, d, mjOBJ_SITE, site, res, 0);
    const Eigen::Matrix3d R = FreeJointRotation(q.data());
    const Eigen::Vector3d vb = v.head<3>(), wb = v.segment<3>(3);
    worst = std::max({worst, (Eigen::Map<Eigen::Vector3d>(res + 3) - R * (vb + wb.cross(r))).cwiseAbs().maxCoeff(),
                      (Eigen::Map<Eigen::Vector3d>(res) - R * wb).cwiseAbs().maxCoeff()});
  }
  mj_deleteData(d);
  EXPECT_LT(worst, 1e-14);
  std::printf("a point of the free body: |MuJoCo's velocity - R (v_b + w_b x r)| <= %.2g\n", worst);
}

// A free box beside the robot is a free body: no entry of q, MuJoCo moves it.
TEST(MujocoFreeJoint, AFreeBodyIsNoDegreeOfFreedomAndFallsUnderGravity) {
  const auto model = LoadMujocoPlant(WriteTemp("free_beside.xml", R"(<mujoco><worldbody>
      <body name="box" pos="0 0 1"><freejoint name="root"/><geom type="box" size="0.1 0.2 0.3" mass="2"/></body>
      <body name="pole"><joint name="theta" axis="0 1 0"/><geom size="0.05" pos="0 0 -1" mass="1"/></body>
      </worldbody></mujoco>)"), MujocoOptions{});
  EXPECT_EQ(model->num_dofs(), 1);
  EXPECT_EQ(model->num_positions(), 1);
  EXPECT_EQ(model->joint_names(), std::vector<std::string>{"theta"});
  auto data = model->MakeData();
  VectorXd q = VectorXd::Zero(1), qd = VectorXd::Zero(1), qdd(1), tau = VectorXd::Zero(1);
  data->SetState(q, qd);
  for (int k = 0; k < 100; ++k) ASSERT_EQ(data->Step(tau, q, qd, qdd), nullptr);
  const std::optional<MujocoFreeBody> box = MujocoFreeJointState(*data, "root");
  ASSERT_TRUE(box);
  const double t = 0.1;  // s: 100 steps of 1 ms, RK4: exact for constant acceleration
  EXPECT_NEAR(box->q[2], 1.0 - 0.5 * 9.81 * t * t, 1e-12);
  EXPECT_NEAR(box->v[2], -9.81 * t, 1e-12);  // its axes are the world's: v_b = ṗ
  EXPECT_NEAR(box->q.segment<4>(3).norm(), 1.0, 1e-15);
  EXPECT_FALSE(MujocoFreeJointState(*data, "theta"));  // not a free joint
}

// ---- A floating model on MuJoCo (free joint, no contact) against FloatingDynamics ----

// A floating base with a two-joint leg (a revolute about x, then one about y
// turned 0.4 rad about z) and a prismatic one: the URDF lagrange reads with
// UrdfOptions{.floating_base = true}, and its MJCF twin (a free joint on the
// base; the same frames; inertias anything: the exact-inertia fix sets them).
constexpr char kFloatingUrdf[] = R"(<?xml version="1.0"?>
<robot name="floater">
  <link name="base"><inertial><origin xyz="0.01 -0.02 0.03"/><mass value="3.0"/>
    <inertia ixx="0.05" ixy="0.002" ixz="-0.001" iyy="0.08" iyz="0.003" izz="0.1"/></inertial></link>
  <joint name="hip" type="revolute"><parent link="base"/><child link="thigh"/>
    <origin xyz="0.2 0.1 -0.05"/><axis xyz="1 0 0"/><limit lower="-1" upper="1" effort="30" velocity="10"/></joint>
  <link name="thigh"><inertial><origin xyz="0.0 0.01 -0.1"/><mass value="0.8"/>
    <inertia ixx="0.004" ixy="0.0001" ixz="0.0002" iyy="0.005" iyz="-0.0003" izz="0.0015"/></inertial></link>
  <joint name="knee" type="revolute"><parent link="thigh"/><child link="shank"/>
    <origin xyz="0 0 -0.2" rpy="0 0 0.4"/><axis xyz="0 1 0"/><limit lower="-2.5" upper="-0.2" effort="30" velocity="10"/></joint>
  <link name="shank"><inertial><origin xyz="0.01 0 -0.1"/><mass value="0.3"/>
    <inertia ixx="0.002" ixy="0" ixz="0.0001" iyy="0.002" iyz="0" izz="0.0003"/></inertial></link>
  <joint name="slider" type="prismatic"><parent link="base"/><child link="block"/>
    <origin xyz="-0.2 0 0"/><axis xyz="0 0 1"/><limit lower="-0.1" upper="0.1" effort="30" velocity="1"/></joint>
  <link name="block"><inertial><origin xyz="0 0.02 0"/><mass value="0.5"/>
    <inertia ixx="0.001" ixy="0" ixz="0" iyy="0.001" iyz="0" izz="0.001"/></inertial></link>
</robot>
)";
constexpr char kFloatingMjcf[] = R"(<mujoco model="floater"><compiler angle="radian" autolimits="true"/><worldbody>
  <body name="base" pos="0 0 1"><freejoint name="root"/><inertial pos="0 0 0" mass="3" diaginertia="0.05 0.08 0.1"/>
    <body name="thigh" pos="0.2 0.1 -0.05"><joint name="hip" axis="1 0 0" range="-1 1"/>
      <inertial pos="0 0 -0.1" mass="0.8" diaginertia="0.004 0.005 0.0015"/>
      <body name="shank" pos="0 0 -0.2" euler="0 0 0.4"><joint name="knee" axis="0 1 0" range="-2.5 -0.2"/>
        <inertial pos="0 0 -0.1" mass="0.3" diaginertia="0.002 0.002 0.0003"/></body></body>
    <body name="block" pos="-0.2 0 0"><joint name="slider" type="slide" axis="0 0 1" range="-0.1 0.1"/>
      <inertial pos="0 0 0" mass="0.5" diaginertia="0.001 0.001 0.001"/></body>
  </body></worldbody></mujoco>)";

struct FloatingTwin {
  UrdfRobot robot;
  std::shared_ptr<const MujocoPlantModel> mujoco;
};

// The URDF read floating by lagrange, the MJCF by MuJoCo with its base and bodies' inertias lagrange's.
FloatingTwin LoadFloatingTwin(const std::string& urdf, const std::string& mjcf) {
  FloatingTwin t{LoadUrdf(urdf, UrdfOptions{.floating_base = true}), nullptr};
  MujocoOptions o;
  o.floating_base = true;
  o.exact_inertia = &t.robot.tree;
  o.joint_order = t.robot.tree.joint_names();
  t.mujoco = LoadMujocoPlant(mjcf, o);
  return t;
}

// S (MuJoCo's nv x lagrange's nv): qvel = S v at q; the free joint's block T = diag(R, 1), the joints' by name.
MatrixXd VelocityMap(const mjModel* m, const RigidTree& tree, const VectorXd& q, int base_dof) {
  MatrixXd S = MatrixXd::Zero(m->nv, tree.num_v());
  S.block<3, 3>(base_dof, 0) = FreeJointRotation(q.data());
  S.block<3, 3>(base_dof + 3, 3).setIdentity();
  for (int i = 0; i < tree.num_dofs(); ++i)
    S(m->jnt_dofadr[mj_name2id(m, mjOBJ_JOINT, tree.joints[static_cast<std::size_t>(i)].name.c_str())], 6 + i) = 1.0;
  return S;
}

struct FloatingAgreement {
  double M = 0, bias = 0, fd = 0, plant_bias = 0, step = 0;
};

// At seeded random states (joints inside their ranges, the base anywhere and
// turned any way, a wrench on it too): M = Sᵀ M_MuJoCo S, the bias
// Sᵀ (qfrc_bias + M_MuJoCo Ṡ v) and the plant's gravity + Coriolis rows, and
// FD (MuJoCo's qacc turned into v̇) against FloatingDynamics; then a plant
// Step's q̈ against FloatingDynamics' FD at the state it returns.
// `height`: m added to the base's random height (the ground far away).
FloatingAgreement CompareFloating(const FloatingTwin& t, double height = 0.0) {
  const mjModel* m = t.mujoco->mj_model();
  const RigidTree& tree = t.robot.tree;
  const FloatingDynamics dynamics(tree);
  auto fdata = dynamics.MakeData();
  auto plant = t.mujoco->MakeData();
  mjData* d = mj_makeData(m);
  int base = 0;
  while (m->jnt_type[base] != mjJNT_FREE) ++base;
  const int bq = m->jnt_qposadr[base], bv = m->jnt_dofadr[base];
  const int nq = tree.num_q(), nv = tree.num_v(), n = tree.num_dofs();
  const MujocoModelInfo& info = t.mujoco->info();
  std::mt19937 rng{42};
  std::uniform_real_distribution<double> u(0.05, 0.95), w(-1.5, 1.5);
  FloatingAgreement worst;
  EffectForces forces(nv);
  for (int trial = 0; trial < 20; ++trial) {
    VectorXd q(nq), v(nv), tau(nv), a(nv), a_l(nv), zero = VectorXd::Zero(nv), bias_l(nv);
    q << w(rng), w(rng), height + w(rng), RandomQuaternion(rng), VectorXd::Zero(n);
    for (int i = 0; i < n; ++i) {
      const double lo = info.limited[6 + i] ? info.lower[6 + i] : -M_PI, hi = info.limited[6 + i] ? info.upper[6 + i] : M_PI;
      q[7 + i] = lo + u(rng) * (hi - lo);
    }
    for (int i = 0; i < nv; ++i) v[i] = w(rng), tau[i] = 10.0 * w(rng);
    mju_zero(d->qfrc_applied, m->nv);
    FreeJointToMujoco(q.data(), v.data(), d->qpos + bq, d->qvel + bv);
    FreeJointForceToMujoco(q.data(), tau.data(), d->qfrc_applied + bv);
    for (int i = 0; i < n; ++i) {
      const int j = mj_name2id(m, mjOBJ_JOINT, tree.joints[static_cast<std::size_t>(i)].name.c_str());
      d->qpos[m->jnt_qposadr[j]] = q[7 + i];
      d->qvel[m->jnt_dofadr[j]] = v[6 + i];
      d->qfrc_applied[m->jnt_dofadr[j]] = tau[6 + i];
    }
    mj_forward(m, d);
    const MatrixXd S = VelocityMap(m, tree, q, bv);
    MatrixXd Mj(m->nv, m->nv), Ml(nv, nv);
    mj_fullM(m, Mj.data(), d->qM);
    dynamics.ComputeMassMatrix(*fdata, q, Ml);
    worst.M = std::max(worst.M, RelativeDifference(S.transpose() * Mj * S, Ml));
    VectorXd sdot_v = VectorXd::Zero(m->nv);  // Ṡ v: the free joint's R (ω_b × v_b)
    sdot_v.segment<3>(bv) = FreeJointRotation(q.data()) * v.segment<3>(3).cross(v.head<3>());
    dynamics.ComputeInverseDynamics(*fdata, q, v, zero, DynamicsTerms{}, bias_l);
    const VectorXd bias_j = S.transpose() * (Eigen::Map<VectorXd>(d->qfrc_bias, m->nv) + Mj * sdot_v);
    worst.bias = std::max(worst.bias, RelativeDifference(bias_j, bias_l));
    FreeJointAccelerationFromMujoco(q.data(), v.data(), d->qacc + bv, a.data());
    for (int i = 0; i < n; ++i) a[6 + i] = (S.col(6 + i).transpose() * Eigen::Map<VectorXd>(d->qacc, m->nv))(0);
    dynamics.ComputeForwardDynamics(*fdata, q, v, tau, DynamicsTerms{}, a_l);
    worst.fd = std::max(worst.fd, RelativeDifference(a, a_l));
    plant->SetState(q, v);
    plant->ComputeForces(forces);
    worst.plant_bias = std::max(worst.plant_bias, RelativeDifference(forces.gravity + forces.coriolis, bias_l));
    VectorXd q1 = q, v1 = v, a1(nv), joints_only = tau;
    joints_only.head<6>().setZero();  // a base wrench is held in the world over the step, not in base axes
    EXPECT_EQ(plant->Step(joints_only, q1, v1, a1), nullptr);
    dynamics.ComputeForwardDynamics(*fdata, q1, v1, joints_only, DynamicsTerms{}, a_l);
    worst.step = std::max(worst.step, RelativeDifference(a1, a_l));
  }
  mj_deleteData(d);
  return worst;
}

constexpr double kFloatingAgreement = 1e-10;  // the issue's bound (relative to the largest entry)

void ExpectFloatingAgreement(const FloatingAgreement& a, const std::string& name) {
  EXPECT_LT(a.M, kFloatingAgreement);
  EXPECT_LT(a.bias, kFloatingAgreement);
  EXPECT_LT(a.fd, kFloatingAgreement);
  EXPECT_LT(a.plant_bias, kFloatingAgreement);
  EXPECT_LT(a.step, kFloatingAgreement);
  std::printf("%s floating on MuJoCo (free joint): M %.2g, bias %.2g, FD %.2g, the plant's bias rows %.2g, "
              "a step's qdd %.2g (relative)\n", name.c_str(), a.M, a.bias, a.fd, a.plant_bias, a.step);
}

TEST(MujocoFloating, MBiasAndForwardDynamicsAgreeWithFloatingDynamicsAfterTheInertiaFix) {
  const FloatingTwin t = LoadFloatingTwin(WriteTemp("floater.urdf", kFloatingUrdf), WriteTemp("floater.xml", kFloatingMjcf));
  EXPECT_EQ(t.mujoco->num_positions(), 10);
  EXPECT_EQ(t.mujoco->num_dofs(), 9);
  EXPECT_EQ(t.mujoco->joint_names(), (std::vector<std::string>{"hip", "knee", "slider"}));
  ExpectFloatingAgreement(CompareFloating(t), "floater");
}

// The shipped quadruped (config/robots/a1.urdf) and its MJCF twin (a1.xml):
// 12 joints, the ground 10 m below, so that no foot touches it.
TEST(MujocoFloating, TheA1AndItsMjcfTwinAgreeWithTheGroundFarAway) {
  const FloatingTwin t = LoadFloatingTwin(kRobots + "a1.urdf", kRobots + "a1.xml");
  EXPECT_EQ(t.mujoco->num_positions(), 19);
  EXPECT_EQ(t.mujoco->num_dofs(), 18);
  EXPECT_EQ(t.mujoco->joint_names(), t.robot.tree.joint_names());
  EXPECT_EQ(t.mujoco->info().num_actuators, 12);
  EXPECT_EQ(t.mujoco->info().num_geoms, 6);  // the ground, the trunk, four feet
  double mass = t.robot.tree.base.mass;
  for (const RigidBody& b : t.robot.tree.bodies) mass += b.mass;
  EXPECT_NEAR(mass, 13.74, 1e-12);  // the file's sum: 6.0 + 4 (0.696 + 1.013 + 0.166 + 0.06) kg
  EXPECT_NEAR(mj_getTotalmass(t.mujoco->mj_model()), mass, 1e-12);
  ExpectFloatingAgreement(CompareFloating(t, 10.0), "a1");
}

// The floating base's conversions in SetState, Step and ComputeForces allocate nothing.
TEST(MujocoFloating, SteppingAndComputingForcesAllocateNothing) {
  const FloatingTwin t = LoadFloatingTwin(WriteTemp("floater_alloc.urdf", kFloatingUrdf),
                                          WriteTemp("floater_alloc.xml", kFloatingMjcf));
  auto data = t.mujoco->MakeData();
  const int nq = t.mujoco->num_positions(), nv = t.mujoco->num_dofs();
  VectorXd q = VectorXd::Zero(nq), v = VectorXd::Constant(nv, 0.1), a(nv), tau = VectorXd::Constant(nv, 0.5);
  q[2] = 1.0;
  q[6] = 1.0;  // w: the identity
  EffectForces forces(nv);
  data->SetState(q, v);
  testing::AllocationCounter counter;
  for (int k = 0; k < 50; ++k) ASSERT_EQ(data->Step(tau, q, v, a), nullptr);
  data->ComputeForces(forces);
  data->SetState(q, v);
  EXPECT_EQ(counter.count(), 0);
  EXPECT_NEAR(q.segment<4>(3).norm(), 1.0, 1e-12);
}

}  // namespace
}  // namespace lagrange
