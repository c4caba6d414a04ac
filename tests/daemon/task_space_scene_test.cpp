// Task-space controllers in scenes: the shipped scenes run offline as
// lagrangectl simulate runs them (config/panda_cartesian_impedance.yaml holds
// its target pose, config/ur5_circle.yaml tracks its circle), a bad key is
// one line naming the scene file, the key and what was expected, a gain
// command takes one gain per task axis with the joint controllers' checks,
// and the tick may set a pose target without allocating.

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "protocol/command_check.hpp"
#include "sim/instance.hpp"
#include "sim/offline.hpp"
#include "sim/scene.hpp"
#include "sim/yaml_reader.hpp"
#include "tests/support/alloc_counter.hpp"
#include "tests/support/lcm_messages.hpp"
#include "tests/support/shipped_scene.hpp"

namespace lagrange {
namespace {

namespace fs = std::filesystem;

using Loaded = testing::LoadedScene;
Loaded Load(const std::string& name) { return testing::LoadShippedScene(name); }
void RunChecked(Loaded& l, double seconds, const StepObserver& observe) { testing::RunShippedScene(l, seconds, observe); }

// The flange moves 15 cm over 2 s and holds its target pose; the law's
// slowest mode (sqrt(K/Λ) ≈ 8 rad/s along the heaviest axis, critically
// damped) has settled it within 0.1 mm and 1 mrad by 4 s, and it stays.
TEST(TaskSpaceScenes, PandaUnderCartesianImpedanceHoldsItsTargetPose) {
  Loaded l = Load("panda_cartesian_impedance.yaml");
  Instance& panda = l.instances[0];
  const TaskSpaceController* task = panda.task_space_controller(0);
  ASSERT_NE(task, nullptr);
  EXPECT_EQ(task->frame_name(), "panda_link8");
  EXPECT_EQ(panda.task_space_controller(1), nullptr);  // gravity-compensation
  const Pose target = *l.scene.instances[0].controller.task.trajectory.target;
  double position = 0.0, angle = 0.0, moved = 0.0;
  Pose start;
  RunChecked(l, 6.0, [&](std::size_t, Instance& inst) {
    const TaskSpaceController& t = *inst.task_space_controller(0);
    if (inst.steps() == 1) start = t.pose();
    moved = std::max(moved, (t.pose().position - start.position).norm());
    if (inst.t() < 4.0) return;
    const Vector6d e = PoseError(target, t.pose());
    position = std::max(position, e.head<3>().norm());
    angle = std::max(angle, e.tail<3>().norm());
  });
  EXPECT_NEAR(panda.t(), 6.0, 1e-9);
  EXPECT_LT(position, 1e-4);
  EXPECT_LT(angle, 1e-3);
  EXPECT_GT(moved, 0.14);  // it went there
  EXPECT_LT(panda.qd().cwiseAbs().maxCoeff(), 1e-4);
}

// The flange runs round its circle (radius 0.1 m, 0.25 Hz) with the
// operational-space law's error at the zero-order hold's size (measured
// 4.6e-6 m and 4.8e-5 rad over two turns), bounded as the controller test's
// UR5 circle (tests/controllers/task_space_test.cpp): 5e-5 m and 2e-4 rad;
// the torque stays within the URDF's effort limits.
TEST(TaskSpaceScenes, Ur5UnderOperationalSpaceControlTracksItsCircle) {
  Loaded l = Load("ur5_circle.yaml");
  Instance& ur5 = l.instances[0];
  ASSERT_NE(ur5.task_space_controller(0), nullptr);
  double position = 0.0, angle = 0.0, span = 0.0;
  Eigen::Vector3d first = Eigen::Vector3d::Constant(std::nan(""));
  RunChecked(l, 8.0, [&](std::size_t, Instance& inst) {
    const TaskSpaceController& t = *inst.task_space_controller(0);
    if (inst.steps() == 0) return;
    if (!first.allFinite()) first = t.pose().position;
    position = std::max(position, t.pose_error().head<3>().norm());
    angle = std::max(angle, t.pose_error().tail<3>().norm());
    span = std::max(span, (t.pose().position - first).norm());
    EXPECT_TRUE((inst.tau().cwiseAbs().array() <= inst.instance_model().torque_limits.array()).all());
  });
  EXPECT_LT(position, 5e-5);
  EXPECT_LT(angle, 2e-4);
  EXPECT_GT(span, 0.199);
}

// Steps under a task-space controller, with pose targets set between them as
// the tick would (a streamed target, a move), a reset and a gain change,
// allocate nothing.
TEST(TaskSpaceScenes, StepsAndPoseTargetsAllocateNothing) {
  for (const char* file : {"panda_cartesian_impedance.yaml", "ur5_circle.yaml"}) {
    Loaded l = Load(file);
    Instance& inst = l.instances[0];
    const double period = l.scene.period;
    inst.Step(period);
    TaskSpaceController& task = *inst.task_space_controller(0);
    PoseSetpoint target;
    target.pose = task.pose();
    target.pose.position.z() += 0.01;
    const Gains gains = task.gains();
    bool ok = true;
    std::int64_t allocations = 0;
    {
      testing::AllocationCounter counter;
      for (int k = 0; k < 100; ++k) {
        if (k == 10) task.SetPoseTarget(target);
        if (k == 40) task.MoveTo(target.pose, 0.2);
        if (k == 70) inst.Reset();
        if (k == 80) ok = task.SetGains(gains) && ok;
        ok = inst.Step(period) == nullptr && ok;
      }
      allocations = counter.count();
    }
    EXPECT_EQ(allocations, 0) << file;
    EXPECT_TRUE(ok) << file;
  }
}

// A gain command for a task-space controller carries 6 gains (x, y, z, rx,
// ry, rz), checked against its bounds with the joint controllers' messages.
TEST(TaskSpaceScenes, AGainCommandTakesOneGainPerTaskAxisWithinTheTasksBounds) {
  Loaded l = Load("panda_cartesian_impedance.yaml");
  const InstanceModel& m = l.instances[0].instance_model();
  const CommandRules& rules = m.command_rules;
  command_t out;
  auto check = [&](std::vector<double> kp, std::vector<double> kd) {
    const auto bytes = testing::Encode(
        testing::MakeCommand(command_t::SET_GAINS, 1, 1, "cartesian-impedance", std::move(kp), std::move(kd)));
    return CheckCommand(bytes.data(), bytes.size(), rules, 0, out);
  };
  CommandVerdict v = check(std::vector<double>(7, 1.0), std::vector<double>(7, 0.1));
  EXPECT_EQ(v.kind, CommandVerdict::Kind::kRejected);
  EXPECT_EQ(v.reason, "gains: num_gains is 7, expected 6 (one per task axis: x, y, z, rx, ry, rz)");
  v = check({600, 600, 600, 30, 30, 30}, {40, 40, 40, 0.5, 0.5, 0.5});
  EXPECT_EQ(v.kind, CommandVerdict::Kind::kAccepted) << v.reason;
  const GainBounds& b = m.controllers[0].gain_bounds;
  v = check({600, 600, 600, 30, 30, 10.0 * b.kp_max[5]}, {40, 40, 40, 0.5, 0.5, 0.5});
  EXPECT_EQ(v.kind, CommandVerdict::Kind::kRejected);
  EXPECT_EQ(v.reason.rfind("gains for cartesian-impedance: kp[5]: expected |gain| <= ", 0), 0u) << v.reason;
  EXPECT_NE(v.reason.find("(K_i·h²·c/Λ_ii <= 1 at h = 0.001 s"), std::string::npos) << v.reason;
  // The gravity-compensation alternate still takes one per joint.
  const auto bytes = testing::Encode(testing::MakeCommand(command_t::SET_GAINS, 2, 1, "gravity-compensation",
                                                          std::vector<double>(7, 1.0), std::vector<double>(7, 0.1)));
  EXPECT_EQ(CheckCommand(bytes.data(), bytes.size(), rules, 0, out).kind, CommandVerdict::Kind::kAccepted);
}

class TaskSpaceSceneErrors : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("lagrange_task_scene_" + std::to_string(::getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  // The one-line error of a Panda scene with `controller` (YAML, indented under the instance).
  std::string ErrorOf(const std::string& plant, const std::string& controller) {
    const fs::path scene = dir_ / "scene.yaml";
    std::ofstream(scene) << "instances:\n  - name: robot\n    plant: " << plant << "\n    controller:\n" << controller;
    try {
      LoadScene(scene.string());
    } catch (const ConfigError& e) {
      const std::string what = e.what();
      EXPECT_EQ(what.rfind(scene.string() + ":", 0), 0u) << what;
      EXPECT_EQ(what.find('\n'), std::string::npos) << what;
      return what;
    }
    ADD_FAILURE() << controller << " was accepted";
    return "";
  }
  fs::path dir_;
};

TEST_F(TaskSpaceSceneErrors, BadInputIsOneLineNamingTheSceneFileTheKeyAndWhatIsExpected) {
  const std::string panda = "{type: urdf, file: " LAGRANGE_SOURCE_DIR "/config/robots/panda.urdf}";
  struct Case {
    std::string plant, controller, expected;
  };
  const std::string impedance = "      type: cartesian-impedance\n      stiffness: 500\n";
  const std::string osc = "      type: operational-space\n      kp: 100\n      kd: 20\n";
  const std::vector<Case> cases = {
      {panda, impedance + "      frame: panda_hand\n",
       "instances[0].controller.frame: expected a frame of the robot (panda_link0, panda_link1, panda_link2, "
       "panda_link3, panda_link4, panda_link5, panda_link6, panda_link7, panda_link8), got 'panda_hand'"},
      {panda, "      type: cartesian-impedance\n      stiffness: [1, 2, 3]\n",
       "instances[0].controller.stiffness: expected 6 values (x, y, z, rx, ry, rz), one for all, or {translational: "
       "..., rotational: ...}, got 3 values"},
      {panda, "      type: cartesian-impedance\n      stiffness: {translational: 500, angular: 30}\n",
       "instances[0].controller.stiffness.angular: unknown key (expected one of: translational, rotational)"},
      {panda, impedance + "      damping: 10\n      damping_ratio: 0.7\n",
       "instances[0].controller.damping: expected damping or damping_ratio, not both"},
      {panda, "      type: cartesian-impedance\n      stiffness: [1e9, 500, 500, 30, 30, 30]\n",
       "instances[0].controller.stiffness[0]: expected |gain| <= "},
      {panda, "      type: operational-space\n      kp: 100\n", "instances[0].controller: missing key 'kd'"},
      {panda, "      type: operational-space\n      kp: 2e6\n      kd: 20\n",
       "instances[0].controller.kp[0]: expected |gain| <= 1e+06, got 2e+06 (Kp·h² <= 1 at h = 0.001 s)"},
      {panda, osc + "      null_space: {kp: [1, 2]}\n",
       "instances[0].controller.null_space.kp: expected 7 values (one per joint), got 2"},
      {panda, osc + "      trajectory: {type: spiral}\n",
       "instances[0].controller.trajectory.type: expected hold, min-jerk or circle, got 'spiral'"},
      {panda, osc + "      trajectory: {type: min-jerk, duration: 1}\n",
       "instances[0].controller.trajectory: missing key 'target'"},
      {panda, osc + "      trajectory: {type: hold, target: {position: [0.4, 0, 0.5], orientation: [1, 1, 0, 0]}}\n",
       "instances[0].controller.trajectory.target.orientation: expected a unit quaternion [w, x, y, z]"},
      {panda, osc + "      trajectory: {type: circle, center: [0.1, 0, 0.1], frequency: 0.2}\n",
       "instances[0].controller.trajectory.center: expected an offset perpendicular to the normal (in the circle's "
       "plane)"},
      {panda, osc + "      singularity: {threshold: 0}\n",
       "instances[0].controller.singularity.threshold: expected a positive number"},
      {"{type: arm2}", osc,
       "instances[0].controller.type: operational-space needs a robot of at least 6 joints (a frame's 6-D pose), got "
       "2"},
  };
  for (const Case& c : cases) {
    const std::string what = ErrorOf(c.plant, c.controller);
    EXPECT_NE(what.find(": " + c.expected), std::string::npos) << "got: " << what << "\nexpected: " << c.expected;
  }
}

}  // namespace
}  // namespace lagrange
