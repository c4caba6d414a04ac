// Scenes with a mujoco plant (plant: {type: mujoco, file: F}): MuJoCo steps
// the plant, lagranged's controllers run on lagrange's model of it. The same
// Panda scene on lagrange's own plant and on MuJoCo runs the same trajectory
// to round-off; what MuJoCo owns (integrator, effects) is refused in the
// scene with one line; a diverging MuJoCo simulation faults the instance with
// MuJoCo's warning; a tick allocates nothing.

#include <gtest/gtest.h>
#include <lagrange/forces_t.hpp>
#include <lagrange/state_t.hpp>
#include <lagrange/status_t.hpp>
#include <lagrange/telemetry_t.hpp>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <future>
#include <iterator>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "daemon/loop.hpp"
#include "daemon/publisher.hpp"
#include "daemon/receiver.hpp"
#include "daemon/runtime.hpp"
#include "plant/kinematics.hpp"
#include "plant/mujoco_plant.hpp"
#include "plant/plant_factory.hpp"
#include "plant/urdf.hpp"
#include "protocol/bus.hpp"
#include "protocol/status.hpp"
#include "protocol/wire.hpp"
#include "sim/health.hpp"
#include "sim/instance.hpp"
#include "sim/offline.hpp"
#include "sim/scene.hpp"
#include "sim/yaml_reader.hpp"
#include "tests/support/alloc_counter.hpp"
#include "tests/support/fake_clock.hpp"

namespace lagrange {
namespace {

// Parsed as if it were a file in config/, so robots/panda.urdf resolves.
const std::string kLabel = std::string(LAGRANGE_SOURCE_DIR) + "/config/mujoco_test.yaml";

// The Panda of config/panda_minjerk.yaml: a 2 s min-jerk move under computed
// torque, RK4 at 1 ms, on plant `plant` (one YAML line, indented for it).
std::string PandaScene(const std::string& plant, const std::string& extra = "") {
  return R"(period: 0.001
instances:
  - name: panda
    plant: )" + plant + R"(
    initial: {q: [0, -0.785, 0, -2.356, 0, 1.571, 0.785]}
    integrator: {type: rk4}
    controller: {type: computed-torque, kp: 400, kd: 40}
    setpoint: {type: min-jerk, target: [0.6, -0.3, -0.4, -1.9, 0.5, 2.1, 0.3], duration: 2.0}
)" + extra;
}

constexpr char kLagrangePlant[] = "{type: urdf, file: robots/panda.urdf}";
constexpr char kMujocoPlant[] = "{type: mujoco, file: robots/panda.urdf}";

std::string SceneError(const std::string& text) {
  try {
    ParseScene(text, kLabel);
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "";
}

// The acceptance test of the issue: ≤ 1e-6 rad over 2 s; round-off is what is expected.
constexpr double kTrajectoryTolerance = 1e-6;  // rad

TEST(MujocoScene, PandaUnderComputedTorqueRunsLagrangesTrajectoryToRoundOff) {
  const Scene ours = ParseScene(PandaScene(kLagrangePlant), kLabel);
  const Scene theirs = ParseScene(PandaScene(kMujocoPlant), kLabel);
  ASSERT_TRUE(theirs.instances[0].mujoco.has_value());
  Instance a(ours.instances[0]), b(theirs.instances[0]);
  double worst = 0.0, moved = 0.0;
  for (int k = 0; k < 2000; ++k) {
    ASSERT_EQ(a.Step(ours.period), nullptr);
    ASSERT_EQ(b.Step(theirs.period), nullptr);
    worst = std::max(worst, (a.q() - b.q()).cwiseAbs().maxCoeff());
    moved = std::max(moved, (a.q() - ours.instances[0].q0).cwiseAbs().maxCoeff());
  }
  EXPECT_GT(moved, 0.5);  // it did move
  EXPECT_LT(worst, kTrajectoryTolerance);
  std::printf("Panda, computed torque, RK4 1 ms, 2 s: max |q_lagrange - q_mujoco| = %.2g rad\n", worst);
  // The energies are MuJoCo's, and agree with lagrange's to round-off too.
  EXPECT_NEAR(a.KineticEnergy() + a.PotentialEnergy(), b.KineticEnergy() + b.PotentialEnergy(), 1e-9);
}

// ε = E − E(0) − W with MuJoCo's energies, the command's work exact: the
// integrator's error only, as on lagrange's own plant.
TEST(MujocoScene, EnergyBalanceResidualOfThePandaMoveIsRk4s) {
  const Scene s = ParseScene(PandaScene(kMujocoPlant), kLabel);
  Instance inst(s.instances[0]);
  ASSERT_TRUE(inst.accounting());
  for (int k = 0; k < 2000; ++k) ASSERT_EQ(inst.Step(s.period), nullptr);
  EXPECT_GT(std::abs(inst.energy_balance().work()), 1.0);  // J: the move did work
  EXPECT_LT(std::abs(inst.energy_balance().residual()), 1e-8);
  std::printf("Panda move on MuJoCo: W %.6g J, eps %.2g J\n", inst.energy_balance().work(),
              inst.energy_balance().residual());
}

TEST(MujocoScene, ATickAllocatesNothing) {
  const Scene s = ParseScene(PandaScene(kMujocoPlant), kLabel);
  Instance inst(s.instances[0]);
  Instance::Saved saved = inst.MakeSaved();
  ASSERT_EQ(inst.Step(s.period), nullptr);
  testing::AllocationCounter counter;
  for (int k = 0; k < 100; ++k) ASSERT_EQ(inst.Step(s.period), nullptr);
  inst.Save(saved);
  inst.Restore(saved);
  inst.Reset();
  EXPECT_EQ(counter.count(), 0);
}

TEST(MujocoScene, DivergingSimulationFailsTheStepWithMujocosWarning) {
  const Scene s = ParseScene(PandaScene(kMujocoPlant), kLabel);
  Instance inst(s.instances[0]);
  ASSERT_EQ(inst.Step(s.period), nullptr);
  const Instance::Saved good = inst.MakeSaved();
  // 1e12 N·m on every joint: q̈ beyond MuJoCo's bound (1e10), which it answers by resetting its data.
  const char* why = inst.StepWithTorque(s.period, VectorXd::Constant(7, 1e12));
  ASSERT_NE(why, nullptr);
  EXPECT_NE(std::string(why).find("mjWARN_BADQACC"), std::string::npos) << why;
  EXPECT_TRUE(inst.q().allFinite() && inst.qd().allFinite());
  EXPECT_LT((inst.q() - good.q).cwiseAbs().maxCoeff(), 1e-15);  // not MuJoCo's reset state: the last good one
  // The health rule names it, as lagranged's tick and simulate report it.
  StepEnergies energies;
  EXPECT_EQ(CheckStepHealth(inst, why, 1e9, EnergyBalanceBound{}, energies), why);
  inst.Restore(good);
  EXPECT_EQ(inst.Step(s.period), nullptr);  // MuJoCo runs on from the restored state
}

TEST(MujocoScene, TheIntegratorAndEffectCommandsAreRefused) {
  const Scene s = ParseScene(PandaScene(kMujocoPlant), kLabel);
  Instance inst(s.instances[0]);
  EXPECT_STREQ(inst.SetIntegrator(IntegratorConfig{}), kMujocoIntegrated);
  EXPECT_STREQ(inst.SetEffect(EffectKind::kGravity, false), kMujocoEffects);
  EXPECT_EQ(inst.Step(s.period), nullptr);  // and it runs on
}

// A urdf scene's plant keys (gravity, method) mean the same with type mujoco:
// gravity along +x here, on MuJoCo and on lagrange's model alike.
TEST(MujocoScene, AUrdfScenesGravityAndMethodKeysCarryOver) {
  const std::string keys = "gravity: [9.81, 0, 0], method: lagrangian}";
  std::string ours_plant = kLagrangePlant, theirs_plant = kMujocoPlant;
  ours_plant.replace(ours_plant.size() - 1, 1, ", " + keys);
  theirs_plant.replace(theirs_plant.size() - 1, 1, ", " + keys);
  const Scene ours = ParseScene(PandaScene(ours_plant), kLabel);
  const Scene theirs = ParseScene(PandaScene(theirs_plant), kLabel);
  EXPECT_EQ(theirs.instances[0].method, Method::kLagrangian);
  Instance a(ours.instances[0]), b(theirs.instances[0]);
  for (int k = 0; k < 300; ++k) {
    ASSERT_EQ(a.Step(ours.period), nullptr);
    ASSERT_EQ(b.Step(theirs.period), nullptr);
  }
  EXPECT_LT((a.q() - b.q()).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_NEAR(a.PotentialEnergy(), b.PotentialEnergy(), 1e-9);
}

TEST(MujocoScene, RefusesLagrangesEffects) {
  const std::string e = SceneError(PandaScene(kMujocoPlant, "    effects: {damping: 0.1}\n"));
  EXPECT_NE(e.find("effects"), std::string::npos) << e;
  EXPECT_NE(e.find("a mujoco plant's effects are MuJoCo's"), std::string::npos) << e;
}

TEST(MujocoScene, RefusesAnIntegratorMujocoLacksListingItsOwn) {
  std::string text = PandaScene(kMujocoPlant);
  text.replace(text.find("{type: rk4}"), 11, "{type: dopri5}");
  const std::string e = SceneError(text);
  EXPECT_NE(e.find("expected one of euler (= semi-implicit-euler), rk4, implicit for a mujoco plant"),
            std::string::npos)
      << e;
  EXPECT_NE(e.find("'dopri5'"), std::string::npos) << e;
}

TEST(MujocoScene, AcceptsMujocosIntegrators) {
  for (const std::string type : {"euler", "semi-implicit-euler", "implicit"}) {
    std::string text = PandaScene(kMujocoPlant);
    text.replace(text.find("{type: rk4}"), 11, "{type: " + type + ", substeps: 2}");
    const Scene s = ParseScene(text, kLabel);
    Instance inst(s.instances[0]);
    for (int k = 0; k < 100; ++k) ASSERT_EQ(inst.Step(s.period), nullptr) << type;
  }
}

TEST(MujocoScene, RefusesAContinuousController) {
  std::string text = PandaScene(kMujocoPlant);
  text.replace(text.find("kd: 40}"), 7, "kd: 40, continuous: true}");
  EXPECT_NE(SceneError(text).find("a mujoco plant's controller runs once per tick"), std::string::npos);
}

std::string WriteTemp(const std::string& name, const std::string& text) {
  const std::string path = ::testing::TempDir() + name;
  std::ofstream(path) << text;
  return path;
}

TEST(MujocoScene, RefusesABrokenMjcfWithMujocosMessageOnOneLine) {
  const std::string path = WriteTemp("broken_scene.xml", "<mujoco><worldbody><body>\n</worldbody></mujoco>");
  const std::string e = SceneError(PandaScene("{type: mujoco, file: " + path + ", model: " + kLagrangePlant + "}"));
  EXPECT_NE(e.find("plant.file"), std::string::npos) << e;
  EXPECT_NE(e.find(": MuJoCo: "), std::string::npos) << e;
  EXPECT_EQ(e.find('\n'), std::string::npos) << e;
}

// A MuJoCo model's files are read as a URDF is, before MuJoCo sees them
// (plant/mujoco_files.hpp): a 50 MB MJCF is refused naming it and the 2 MiB
// bound; an <include> of a FIFO is refused at once (were it to block, the
// test releases it after 30 s by opening the FIFO for writing, and fails).
TEST(MujocoScene, AnOversizedMjcfOrAnIncludedFifoIsRefusedBeforeTheLoopWithOneLine) {
  const std::string big =
      WriteTemp("big_scene.xml", "<mujoco><!--" + std::string(50'000'000, ' ') + "-->" + "<worldbody/></mujoco>");
  std::string e = SceneError(PandaScene("{type: mujoco, file: " + big + ", model: " + kLagrangePlant + "}"));
  EXPECT_NE(e.find("plant.file: " + big + ": larger than 2 MiB"), std::string::npos) << e.substr(0, 300);
  EXPECT_EQ(e.find('\n'), std::string::npos);
  std::remove(big.c_str());

  const std::string fifo = ::testing::TempDir() + "scene_parts.xml";
  std::remove(fifo.c_str());
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  const std::string world = WriteTemp("scene_world.xml", "<mujoco><include file=\"scene_parts.xml\"/></mujoco>");
  auto refusal = std::async(std::launch::async, [&] {
    return SceneError(PandaScene("{type: mujoco, file: " + world + ", model: " + kLagrangePlant + "}"));
  });
  if (refusal.wait_for(std::chrono::seconds(30)) == std::future_status::timeout) {
    ::close(::open(fifo.c_str(), O_WRONLY | O_NONBLOCK));  // the blocked reader gets end of file
    FAIL() << "blocked on the FIFO for 30 s";
  }
  e = refusal.get();
  EXPECT_NE(e.find("plant.file: " + world + ": <include file=\"scene_parts.xml\">: " + fifo +
                   ": not a regular file (a FIFO)"),
            std::string::npos)
      << e;
  EXPECT_EQ(e.find('\n'), std::string::npos);
  std::remove(fifo.c_str());
}

// A free joint is a free body, no joint of lagrange's model: a free body alone is no robot.
TEST(MujocoScene, RefusesAFreeBodyAlone) {
  const std::string path = WriteTemp("free_scene.xml", R"(<mujoco><worldbody><body name="b"><freejoint name="float"/>
      <geom size="0.1"/></body></worldbody></mujoco>)");
  const std::string e = SceneError(PandaScene("{type: mujoco, file: " + path + ", model: " + kLagrangePlant + "}"));
  EXPECT_NE(e.find("expected at least one hinge or slide joint, got none"), std::string::npos) << e;
}

TEST(MujocoScene, RefusesAnMjcfWithoutLagrangesModel) {
  const std::string path = WriteTemp("pendulum_scene.xml", R"(<mujoco><worldbody><body name="b">
      <joint name="theta" axis="0 1 0"/><geom size="0.1" pos="0 0 -1"/></body></worldbody></mujoco>)");
  const std::string e = SceneError(PandaScene("{type: mujoco, file: " + path + "}"));
  EXPECT_NE(e.find("an MJCF file needs model: {type: urdf"), std::string::npos) << e;
}

TEST(MujocoScene, RefusesAModelWhoseJointsAreNotMujocos) {
  const std::string path = WriteTemp("other_joints.xml", R"(<mujoco><worldbody><body name="b">
      <joint name="theta" axis="0 1 0"/><geom size="0.1" pos="0 0 -1"/></body></worldbody></mujoco>)");
  const std::string e = SceneError(PandaScene("{type: mujoco, file: " + path + ", model: " + kLagrangePlant + "}"));
  EXPECT_NE(e.find("MuJoCo's joints (theta) are not those of lagrange's model (panda_joint1"), std::string::npos) << e;
}

// config/panda_mujoco_table.yaml: the flange's target 0.05 m below touching.
// At rest the table holds the impedance's force: F = K (commanded
// penetration − how far the fingertip sank into MuJoCo's soft table).
TEST(MujocoScene, PressingOnTheTableTheContactForceIsStiffnessTimesPenetration) {
  const Scene s = LoadScene(std::string(LAGRANGE_SOURCE_DIR) + "/config/panda_mujoco_table.yaml");
  Instance inst(s.instances[0]);
  const double K = 600.0, commanded = 0.05;  // N/m, m: the scene's
  const double touching = 0.3 + 0.02;         // m: the flange's height when the fingertip touches the table top
  for (int k = 0; k < 5000; ++k) ASSERT_EQ(inst.Step(s.period), nullptr) << "tick " << k;
  const TaskSpaceController& c = *inst.task_space_controller(0);
  const double z = c.pose().position.z();
  const std::optional<Eigen::Vector3d> f = MujocoContactForce(*inst.stepped_plant(), "fingertip");
  ASSERT_TRUE(f.has_value());
  const double sank = touching - z;
  std::printf("table: contact force (%.4g, %.4g, %.4g) N; K x commanded %.4g N; sank %.3g m; K (commanded - sank) %.5g N\n",
              f->x(), f->y(), f->z(), K * commanded, sank, K * (commanded - sank));
  EXPECT_GT(sank, 0.0);                    // soft contact: the fingertip is a little inside the table
  EXPECT_LT(sank, 1e-3 * commanded);       // by less than 0.1 % of the commanded penetration
  EXPECT_NEAR(f->z(), K * commanded, 2e-3 * K * commanded);  // stiffness × commanded penetration, to 0.2 %
  EXPECT_NEAR(f->z(), K * (commanded - sank), 1e-3 * K * commanded);  // and the impedance's own balance closer
  std::printf("table: W %.6g J, E - E(0) %.6g J, eps %.3g J\n", inst.energy_balance().work(),
              inst.energy_balance().energy_change(), inst.energy_balance().residual());
  // What lateral error the fingertip touched down with, friction holds: inside the cone (μ = 1, MuJoCo's default).
  EXPECT_LT(std::hypot(f->x(), f->y()), 1.0 * f->z());
}

// config/panda_mujoco_table.yaml at rest on the table: what <NAME>_FORCES
// carries adds up to M(q) q̈ (lagrange's M of panda.urdf; the MJCF holds its
// numbers, its inertias MuJoCo's diagonalisation, within 3e-8 relative) once
// MuJoCo's constraint force is a row of its own; that row is the contact's
// wrench through the Jacobian of the contact point (lagrange's kinematics of
// panda.urdf), and the contact listed carries the README's 30 N.
TEST(MujocoScene, OnTheTableTheForcesAddUpToMTimesQddAndTheContactCarriesThirtyNewtons) {
  const Scene s = LoadScene(std::string(LAGRANGE_SOURCE_DIR) + "/config/panda_mujoco_table.yaml");
  Instance inst(s.instances[0]);
  const int n = inst.num_dofs();
  const double K = 600.0, commanded = 0.05;  // N/m, m: the scene's
  for (int k = 0; k < 5000; ++k) ASSERT_EQ(inst.Step(s.period), nullptr) << "tick " << k;
  EffectForces f(n);
  inst.ComputeForces(f);
  // M q̈ = tau_applied + damping + friction + limits + constraint − C q̇ − G.
  MatrixXd M(n, n);
  inst.model().dynamics().ComputeMassMatrix(inst.model().data(), inst.q(), M);
  VectorXd net(n);
  f.NetForce(net);
  const VectorXd residual = net - M * inst.qdd();
  const double scale = f.gravity.cwiseAbs().maxCoeff();  // N·m: the largest term
  std::printf(
      "table forces: |sum - M qdd| = %.2g N·m (terms up to %.3g N·m, M qdd %.2g N·m, constraint up to %.3g N·m)\n",
      residual.cwiseAbs().maxCoeff(), scale, (M * inst.qdd()).cwiseAbs().maxCoeff(),
      f.constraint.cwiseAbs().maxCoeff());
  EXPECT_GT(scale, 1.0);
  EXPECT_LT(residual.cwiseAbs().maxCoeff(), 1e-6 * scale);
  // The contact: fingertip (geom 1) on the table (geom 0), 30 N up, as the README says.
  ASSERT_TRUE(f.constraint_on);
  ASSERT_EQ(f.contacts_total, 1);
  ASSERT_EQ(f.num_contacts, 1);
  const ContactWrench& c = f.contacts[0];
  EXPECT_EQ(std::minmax(c.geom1, c.geom2), std::minmax(0, 1));
  const Eigen::Vector3d up = c.geom2 == 1 ? c.force : Eigen::Vector3d(-c.force);  // on the fingertip
  std::printf(
      "table forces: contact of geoms %d and %d, force on the fingertip (%.4g, %.4g, %.6g) N, distance %.2g m\n",
      c.geom1, c.geom2, up.x(), up.y(), up.z(), c.distance);
  EXPECT_NEAR(up.z(), K * commanded, 2e-3 * K * commanded);
  EXPECT_LT((up - *MujocoContactForce(*inst.stepped_plant(), "fingertip")).norm(), 1e-12 * K * commanded);
  EXPECT_LT(c.distance, 0.0);  // soft contact: a little inside the table
  EXPECT_GT(c.distance, -1e-3 * commanded);
  EXPECT_NEAR(std::abs(c.normal.z()), 1.0, 1e-12);
  // Joint space: constraint = J_pᵀ F + J_ωᵀ τ on the fingertip at the contact point p.
  const UrdfRobot robot = LoadUrdf(std::string(LAGRANGE_SOURCE_DIR) + "/config/robots/panda.urdf");
  const Kinematics kinematics(robot.tree);
  const auto data = kinematics.MakeData();
  const int flange = *kinematics.FrameIndex("panda_link8");
  kinematics.ComputeFrameJacobian(*data, inst.q(), flange, FrameAxes::kWorldAligned);
  const Matrix6Xd& J = data->jacobian(flange, FrameAxes::kWorldAligned);
  const Eigen::Vector3d r = c.position - data->position(flange);
  Eigen::Matrix3d skew;
  skew << 0, -r.z(), r.y(), r.z(), 0, -r.x(), -r.y(), r.x(), 0;
  const MatrixXd Jp = J.topRows(3) - skew * J.bottomRows(3);  // the contact point's velocity: v + ω × r
  const Eigen::Vector3d torque = c.geom2 == 1 ? c.torque : Eigen::Vector3d(-c.torque);
  const VectorXd through_contact = Jp.transpose() * up + J.bottomRows(3).transpose() * torque;
  std::printf("table forces: |constraint - J_p^T F| = %.2g N·m\n",
              (f.constraint - through_contact).cwiseAbs().maxCoeff());
  EXPECT_LT((f.constraint - through_contact).cwiseAbs().maxCoeff(), 1e-9 * K * commanded);
  // What the model has: limits (its joint ranges; none reached at rest), no damping, no friction loss.
  EXPECT_TRUE(f.active.gravity && f.active.coriolis && f.active.limits);
  EXPECT_FALSE(f.active.damping || f.active.friction || f.active.saturation || f.active.disturbance);
  EXPECT_EQ(f.limits.cwiseAbs().maxCoeff(), 0.0);
  // Computing them allocates nothing, the contacts included.
  testing::AllocationCounter counter;
  for (int k = 0; k < 10; ++k) {
    ASSERT_EQ(inst.Step(s.period), nullptr);
    inst.ComputeForces(f);
  }
  EXPECT_EQ(counter.count(), 0);
}

// The Panda with its hand (panda_hand.urdf: 8 degrees of freedom, the right
// finger mimicking the left), on lagrange's plant and on MuJoCo, where the
// mimic is MuJoCo's soft joint equality: computed torque through a 2 s
// min-jerk move that opens the fingers too.
std::string PandaHandScene(const std::string& plant) {
  return R"(period: 0.001
instances:
  - name: panda
    plant: )" +
         plant + R"(
    initial: {q: [0, -0.785, 0, -2.356, 0, 1.571, 0.785, 0.01]}
    integrator: {type: rk4}
    controller: {type: computed-torque, kp: 400, kd: 40}
    setpoint: {type: min-jerk, target: [0.6, -0.3, -0.4, -1.9, 0.5, 2.1, 0.3, 0.035], duration: 2.0}
)";
}

// What MuJoCo's soft equality lets the two runs drift apart by (the mimic's
// violation, through the coupling, on the whole arm), and the mimic's own.
constexpr double kHandTrajectoryTolerance = 1e-6;  // rad or m
constexpr double kHandMimicTolerance = 1e-6;       // m

TEST(MujocoScene, PandaWithItsHandRunsLagrangesTrajectoryToTheMimicsSoftness) {
  const Scene ours = ParseScene(PandaHandScene("{type: urdf, file: robots/panda_hand.urdf}"), kLabel);
  const Scene theirs = ParseScene(PandaHandScene("{type: mujoco, file: robots/panda_hand.urdf}"), kLabel);
  Instance a(ours.instances[0]), b(theirs.instances[0]);
  ASSERT_EQ(b.num_dofs(), 8);
  double worst = 0.0, gap = 0.0;
  for (int k = 0; k < 2000; ++k) {
    ASSERT_EQ(a.Step(ours.period), nullptr);
    ASSERT_EQ(b.Step(theirs.period), nullptr);
    worst = std::max(worst, (a.q() - b.q()).cwiseAbs().maxCoeff());
    gap = std::max(gap, std::abs(*MujocoJointPosition(*b.stepped_plant(), "panda_finger_joint2") - b.q()[7]));
  }
  EXPECT_NEAR(b.q()[7], 0.035, 1e-3);  // the fingers opened
  EXPECT_LT(worst, kHandTrajectoryTolerance);
  EXPECT_LT(gap, kHandMimicTolerance);
  std::printf(
      "Panda with its hand, computed torque, RK4 1 ms, 2 s: max |q_lagrange - q_mujoco| = %.2g, "
      "max |q_finger2 - q_finger1| on MuJoCo = %.2g m\n",
      worst, gap);
}

// config/panda_hand_mujoco_table.yaml: the TCP's target 0.05 m below where
// the fingertips touch the table. At rest the table holds the impedance's
// force on the two fingers together: F = K (commanded penetration − how far
// the fingertips sank into MuJoCo's soft table).
TEST(MujocoScene, PandaWithItsHandPressingOnTheTableTheContactForceIsStiffnessTimesPenetration) {
  const Scene s = LoadScene(std::string(LAGRANGE_SOURCE_DIR) + "/config/panda_hand_mujoco_table.yaml");
  Instance inst(s.instances[0]);
  const double K = 600.0, commanded = 0.05;  // N/m, m: the scene's
  const double touching = 0.3 + 0.009;       // m: the TCP's height when the fingertips touch the table top
  double gap = 0.0;
  for (int k = 0; k < 5000; ++k) {
    ASSERT_EQ(inst.Step(s.period), nullptr) << "tick " << k;
    gap = std::max(gap, std::abs(*MujocoJointPosition(*inst.stepped_plant(), "panda_finger_joint2") - inst.q()[7]));
  }
  const double z = inst.task_space_controller(0)->pose().position.z();
  const std::optional<Eigen::Vector3d> left = MujocoContactForce(*inst.stepped_plant(), "leftfinger_pad");
  const std::optional<Eigen::Vector3d> right = MujocoContactForce(*inst.stepped_plant(), "rightfinger_pad");
  ASSERT_TRUE(left && right);
  const Eigen::Vector3d f = *left + *right;
  const double sank = touching - z;
  std::printf(
      "hand on table: contact force (%.4g, %.4g, %.6g) N (left %.4g N, right %.4g N); K x commanded %.4g N; "
      "sank %.3g m; K (commanded - sank) %.5g N; finger gap %.2g m, fingers at %.5g m\n",
      f.x(), f.y(), f.z(), left->z(), right->z(), K * commanded, sank, K * (commanded - sank), gap, inst.q()[7]);
  EXPECT_GT(left->z(), 0.25 * K * commanded);  // both fingers bear on the table
  EXPECT_GT(right->z(), 0.25 * K * commanded);
  EXPECT_GT(sank, 0.0);               // soft contact: the fingertips are a little inside the table
  EXPECT_LT(sank, 1e-3 * commanded);  // by less than 0.1 % of the commanded penetration
  EXPECT_NEAR(f.z(), K * commanded, 1e-3 * K * commanded);           // stiffness × commanded penetration, to 0.1 %
  EXPECT_NEAR(f.z(), K * (commanded - sank), 1e-3 * K * commanded);  // and the impedance's own balance closer
  EXPECT_LT(std::hypot(f.x(), f.y()), 1.0 * f.z());                  // inside the friction cone (μ = 1)
  EXPECT_LT(gap, kHandMimicTolerance);
  // forces_t: the rows, Sᵀ of MuJoCo's (the right finger's on the left), add up to lagrange's
  // Sᵀ M S q̈ to what the soft equality leaves of the mimic's acceleration; two contacts per finger pad or more.
  EffectForces forces(inst.num_dofs());
  inst.ComputeForces(forces);
  MatrixXd M(inst.num_dofs(), inst.num_dofs());
  inst.model().dynamics().ComputeMassMatrix(inst.model().data(), inst.q(), M);
  VectorXd net(inst.num_dofs());
  forces.NetForce(net);
  double listed = 0.0;
  for (int k = 0; k < forces.num_contacts; ++k)
    listed += std::abs(forces.contacts[static_cast<std::size_t>(k)].force.z());
  const double scale = forces.gravity.cwiseAbs().maxCoeff();
  std::printf("hand on table forces: |sum - M qdd| = %.2g (terms up to %.3g), %d contacts carrying %.6g N\n",
              (net - M * inst.qdd()).cwiseAbs().maxCoeff(), scale, forces.contacts_total, listed);
  EXPECT_LT((net - M * inst.qdd()).cwiseAbs().maxCoeff(), 1e-8 * scale);
  EXPECT_EQ(forces.num_contacts, forces.contacts_total);  // all listed (box on box: several per pad)
  // the pads' contacts, every one, and the loose box's on the table, which bear its weight (at rest beside the hand)
  const double box_weight = 0.2 * 9.81;  // N: panda_hand_table.xml's box
  EXPECT_NEAR(listed, f.z() + box_weight, 1e-6 * K * commanded);
}

// config/panda_hand_mujoco_table.yaml's instance `pusher`: the loose box (a
// free body only MuJoCo moves) starts at rest on the table; the hand's move
// forward pushes it along +x; it ends at rest further on, still flat on the
// table (its centre half its height above the top), its quaternion unit.
TEST(MujocoScene, TheHandPushesTheLooseBoxAlongTheTable) {
  const Scene s = LoadScene(std::string(LAGRANGE_SOURCE_DIR) + "/config/panda_hand_mujoco_table.yaml");
  ASSERT_EQ(s.instances.size(), 2u);
  ASSERT_EQ(s.instances[1].name, "pusher");
  Instance inst(s.instances[1]);
  const double half_height = 0.025, half_length = 0.04, top = 0.3, table_end = 0.7;  // m, the scene's
  const std::optional<MujocoFreeBody> start = MujocoFreeJointState(*inst.stepped_plant(), "box");
  ASSERT_TRUE(start);
  EXPECT_NEAR(start->q.z(), top + half_height, 1e-12);  // resting on the table
  EXPECT_LT(start->v.norm(), 1e-12);                      // at rest
  double lowest = start->q.z(), worst_norm = 0.0;
  for (int k = 0; k < 5000; ++k) {
    ASSERT_EQ(inst.Step(s.period), nullptr) << "tick " << k;
    const std::optional<MujocoFreeBody> box = MujocoFreeJointState(*inst.stepped_plant(), "box");
    lowest = std::min(lowest, box->q.z());
    worst_norm = std::max(worst_norm, std::abs(box->q.segment<4>(3).norm() - 1.0));
  }
  const MujocoFreeBody end = *MujocoFreeJointState(*inst.stepped_plant(), "box");
  const double pushed = end.q.x() - start->q.x();
  std::printf("loose box: pushed %.4g m along x (%.3g m along y), height %.6g m (lowest %.6g), |v| %.2g, "
              "tilt %.2g rad, max | |quat| - 1 | %.2g\n",
              pushed, end.q.y() - start->q.y(), end.q.z(), lowest, end.v.norm(),
              2.0 * std::asin(std::min(1.0, end.q.segment<2>(3).norm())), worst_norm);
  EXPECT_GT(pushed, 0.02);                                 // forward, by the fingers
  EXPECT_LT(std::abs(end.q.y() - start->q.y()), 0.25 * pushed);  // mostly straight ahead
  EXPECT_LT(end.q.x() + half_length, table_end);           // still on the table
  EXPECT_NEAR(end.q.z(), top + half_height, 1e-3);         // flat on it: not tipped, not sunk
  EXPECT_GT(lowest, top + half_height - 1e-3);             // never sank or tipped on the way
  EXPECT_LT(end.q.segment<2>(3).norm(), 0.05);             // tilted less than 0.1 rad (the quaternion's x, y)
  EXPECT_LT(worst_norm, 1e-12);                            // the quaternion unit throughout
  EXPECT_LT(end.v.norm(), 1e-2);                           // at rest again
}

// config/cartpole_mujoco_stops.yaml: driven towards x = 1 m, the cart stops
// at the rail's end, x = 0.5 m, to what MuJoCo's soft limit gives; lagrange's
// own cart-pole (no stops) goes on to 1 m.
TEST(MujocoScene, TheCartHitsItsEndStop) {
  const Scene s = LoadScene(std::string(LAGRANGE_SOURCE_DIR) + "/config/cartpole_mujoco_stops.yaml");
  Instance inst(s.instances[0]);
  double farthest = 0.0;
  for (int k = 0; k < 6000; ++k) {
    ASSERT_EQ(inst.Step(s.period), nullptr);
    farthest = std::max(farthest, inst.q()[0]);
  }
  EXPECT_GT(farthest, 0.5);          // it reached the stop
  EXPECT_LT(farthest, 0.5 + 5e-3);  // and did not pass it by more than 5 mm (the impact)
  EXPECT_NEAR(inst.q()[0], 0.5, 1e-4);  // at rest pressed on it, 10 N on a stiff soft limit
  std::printf("cart-pole: W %.6g J, E - E(0) %.6g J, eps %.3g J\n", inst.energy_balance().work(),
              inst.energy_balance().energy_change(), inst.energy_balance().residual());
  InstanceConfig free = s.instances[0];
  free.mujoco.reset();  // lagrange's own cart-pole, its model
  Instance ours(free);
  for (int k = 0; k < 6000; ++k) ASSERT_EQ(ours.Step(s.period), nullptr);
  EXPECT_NEAR(ours.q()[0], 1.0, 0.05);
}

// ε over the cart's impact on its stop: the stop's force, MuJoCo's
// constraint, switches on inside a step, so its work by the trapezoid rule
// per MuJoCo step is first order in the step: ε is the impact's resolution
// (0.30 J at 1 ms, 0.020 J at 1/16 ms), and shrinks as the step does.
TEST(MujocoScene, TheEnergyResidualOverAnImpactShrinksWithTheStep) {
  std::ifstream f(std::string(LAGRANGE_SOURCE_DIR) + "/config/cartpole_mujoco_stops.yaml");
  const std::string scene((std::istreambuf_iterator<char>(f)), {});
  std::vector<double> eps;
  for (const int substeps : {1, 16}) {
    std::string text = scene;
    text.replace(text.find("{type: rk4}"), 11, "{type: rk4, substeps: " + std::to_string(substeps) + "}");
    const Scene s = ParseScene(text, std::string(LAGRANGE_SOURCE_DIR) + "/config/cartpole_substeps.yaml");
    Instance inst(s.instances[0]);
    for (int k = 0; k < 3000; ++k) ASSERT_EQ(inst.Step(s.period), nullptr);
    eps.push_back(std::abs(inst.energy_balance().residual()));
  }
  EXPECT_GT(eps[0], 1e-3);           // J: the impact shows at 1 ms
  EXPECT_LT(eps[1], eps[0] / 8.0);   // first order: 16 times smaller steps, about 16 times smaller
}

// Runs `runtime` through the loop for `ticks` ticks of a fake clock, its
// publisher draining every 0.1 s (within the ring) into `output`, whose
// subscribers get what was published as it goes.
void RunPublishing(Runtime& runtime, InProcessBus& output, int ticks) {
  testing::FakeClock clock;
  ReceiverStats stats;
  SpscRing<TickRecord> ring{256, runtime.MakeRecord()};
  Loop loop{runtime, clock, {1'000'000, OverrunPolicy::kSkip, 0}, ring};
  Publisher publisher{output, runtime, ring, loop, stats, -1, 1};
  std::atomic<bool> stop{false};
  for (int tick = 100; tick <= ticks; tick += 100) {  // drained every 0.1 s, within the ring
    loop.Run(stop, tick);
    publisher.Drain();
    while (output.Drain() > 0) {
    }
  }
}

// What lagranged publishes names MuJoCo's integrator, not lagrange's nearest:
// the status (lagrangectl status, watch) "mujoco-implicit x2", the telemetry
// "mujoco-implicit" with 2 substeps.
TEST(MujocoScene, TheStatusAndTelemetryNameMujocosIntegrator) {
  std::string text = PandaScene(kMujocoPlant, "    telemetry: true\n");
  text.replace(text.find("{type: rk4}"), 11, "{type: implicit, substeps: 2}");
  Runtime runtime(ParseScene(text, kLabel));
  InProcessBus output;
  std::optional<status_t> status;
  std::optional<telemetry_t> telemetry;
  output.Subscribe("LAGRANGE_STATUS", [&](std::string_view, const std::uint8_t* d, std::size_t n) {
    status_t m;
    if (m.decode(d, 0, static_cast<int>(n)) >= 0) status = m;
  });
  output.Subscribe("PANDA_TELEMETRY", [&](std::string_view, const std::uint8_t* d, std::size_t n) {
    telemetry_t m;
    if (m.decode(d, 0, static_cast<int>(n)) >= 0) telemetry = m;
  });
  RunPublishing(runtime, output, 500);
  ASSERT_TRUE(status && telemetry);
  EXPECT_EQ(status->instance_integrators, std::vector<std::string>{"mujoco-implicit x2"});
  EXPECT_EQ(telemetry->integrator, "mujoco-implicit");
  EXPECT_EQ(telemetry->substeps, 2);
  for (const auto& [type, name] :
       {std::pair{MujocoIntegrator::kEuler, "mujoco-euler"}, std::pair{MujocoIntegrator::kRk4, "mujoco-rk4"}}) {
    EXPECT_EQ(IntegratorDescription(IntegratorConfig{}, false, type), name);
  }
}

// What lagranged publishes on PANDA_FORCES for config/panda_mujoco_table.yaml
// (scene key forces: true), through the publisher to the bus and decoded:
// the constraint row and the contact, and rows that add up to M(q) q̈ at the
// q, q̈ of the same tick's state_t.
TEST(MujocoScene, PublishedForcesCarryTheConstraintRowAndTheContactAndAddUp) {
  std::ifstream in(std::string(LAGRANGE_SOURCE_DIR) + "/config/panda_mujoco_table.yaml");
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  text.replace(text.find("    integrator:"), 0, "    forces: true\n");
  const std::string label = std::string(LAGRANGE_SOURCE_DIR) + "/config/panda_mujoco_table_forces.yaml";
  Runtime runtime(ParseScene(text, label));
  InProcessBus output;
  std::optional<forces_t> forces;
  std::map<std::int64_t, state_t> states;
  output.Subscribe("PANDA_FORCES", [&](std::string_view, const std::uint8_t* d, std::size_t n) {
    forces_t m;
    if (CheckForcesPacket(d, n) == WireCheck::kOk && m.decode(d, 0, static_cast<int>(n)) >= 0) forces = m;
  });
  output.Subscribe("PANDA_STATE", [&](std::string_view, const std::uint8_t* d, std::size_t n) {
    state_t m;
    if (m.decode(d, 0, static_cast<int>(n)) >= 0) states[m.tick] = m;
  });
  RunPublishing(runtime, output, 3000);
  ASSERT_TRUE(forces.has_value());
  ASSERT_EQ(states.count(forces->tick), 1u);
  const state_t& s = states.at(forces->tick);
  EXPECT_TRUE(forces->constraint_on);
  ASSERT_EQ(forces->num_contacts, 1);
  EXPECT_EQ(forces->contacts_total, 1);
  const contact_t& c = forces->contacts[0];
  EXPECT_NEAR(std::abs(c.force[2]), 30.0, 0.1 * 30.0);  // pressing (settling: 1 s after the move)
  EXPECT_LT(c.distance, 0.0);
  const UrdfRobot robot = LoadUrdf(std::string(LAGRANGE_SOURCE_DIR) + "/config/robots/panda.urdf");
  const auto dynamics = MakeDynamics(UrdfPlantSpec(std::make_shared<UrdfRobot>(robot)), Method::kRecursive);
  const auto data = dynamics->MakeData();
  MatrixXd M(7, 7);
  dynamics->ComputeMassMatrix(*data, Eigen::Map<const VectorXd>(s.q.data(), 7), M);
  const VectorXd Mqdd = M * Eigen::Map<const VectorXd>(s.qdd.data(), 7);
  double worst = 0.0, largest = 0.0;
  for (std::size_t j = 0; j < 7; ++j) {
    const double sum = forces->tau_applied[j] + forces->disturbance[j] + forces->damping[j] + forces->friction[j] +
                       forces->limits[j] + forces->constraint[j] - forces->coriolis[j] - forces->gravity[j];
    worst = std::max(worst, std::abs(sum - Mqdd[static_cast<Eigen::Index>(j)]));
    largest = std::max(largest, std::abs(forces->constraint[j]));
  }
  EXPECT_GT(largest, 1.0);  // N·m: the table's share
  EXPECT_LT(worst, 1e-6 * largest);
}

TEST(MujocoScene, ShippedSceneLoadsAndRuns) {
  const Scene s = LoadScene(std::string(LAGRANGE_SOURCE_DIR) + "/config/panda_mujoco_minjerk.yaml");
  std::vector<Instance> instances;
  instances.emplace_back(s.instances[0]);
  EXPECT_TRUE(RunOffline(instances, s.period, 500, [](std::size_t, const Instance&) {}));
}

}  // namespace
}  // namespace lagrange
