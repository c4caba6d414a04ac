// Scenes with URDF robots: the file is read relative to the scene, its
// <limit> and <dynamics> become the instance's stops, torque limits, damping
// and friction unless the scene says otherwise, a controller's model may be
// another file or a mass scale, and every bad input is one line naming the
// scene file, the key and what is wrong.

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <limits>

#include "sim/instance.hpp"
#include "sim/scene.hpp"
#include "sim/yaml_reader.hpp"
#include "tests/support/plant_cases.hpp"

namespace lagrange {
namespace {

namespace fs = std::filesystem;
constexpr double kInf = std::numeric_limits<double>::infinity();

// Two joints: j1 revolute about y with every property, j2 continuous with an effort limit only.
constexpr char kTwoJoints[] = R"(<?xml version="1.0"?>
<robot name="two">
  <link name="base"/>
  <joint name="j1" type="revolute">
    <parent link="base"/>
    <child link="l1"/>
    <origin xyz="0 0 0.1" rpy="0 0 0"/>
    <axis xyz="0 1 0"/>
    <limit lower="-1.5" upper="1.5" effort="20" velocity="2"/>
    <dynamics damping="0.3" friction="0.1"/>
  </joint>
  <link name="l1">
    <inertial>
      <origin xyz="0.2 0 0" rpy="0 0 0"/>
      <mass value="1.0"/>
      <inertia ixx="0.001" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/>
    </inertial>
  </link>
  <joint name="j2" type="continuous">
    <parent link="l1"/>
    <child link="l2"/>
    <origin xyz="0.4 0 0" rpy="0 0 0"/>
    <axis xyz="0 1 0"/>
    <limit effort="5" velocity="3"/>
  </joint>
  <link name="l2">
    <inertial>
      <origin xyz="0.15 0 0" rpy="0 0 0"/>
      <mass value="0.5"/>
      <inertia ixx="0.0005" ixy="0" ixz="0" iyy="0.004" iyz="0" izz="0.004"/>
    </inertial>
  </link>
</robot>
)";

// One joint, for a model of the wrong size.
constexpr char kOneJoint[] = R"(<?xml version="1.0"?>
<robot name="one">
  <link name="base"/>
  <joint name="j1" type="revolute">
    <parent link="base"/>
    <child link="l1"/>
    <axis xyz="0 1 0"/>
    <limit lower="-1" upper="1" effort="20" velocity="2"/>
  </joint>
  <link name="l1">
    <inertial>
      <origin xyz="0.2 0 0" rpy="0 0 0"/>
      <mass value="1.0"/>
      <inertia ixx="0.001" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/>
    </inertial>
  </link>
</robot>
)";

// A joint type lagrange does not take.
constexpr char kFloating[] = R"(<?xml version="1.0"?>
<robot name="floating">
  <link name="base"/>
  <joint name="free" type="floating">
    <parent link="base"/>
    <child link="l1"/>
  </joint>
  <link name="l1">
    <inertial>
      <mass value="1.0"/>
      <inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/>
    </inertial>
  </link>
</robot>
)";

class UrdfScene : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("lagrange_urdf_scene_" + std::to_string(::getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir_ / "robots");
    fs::create_directories(dir_ / "scenes");
    Write("robots/two.urdf", kTwoJoints);
    Write("robots/one.urdf", kOneJoint);
    Write("robots/floating.urdf", kFloating);
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path Write(const std::string& name, const std::string& text) {
    const fs::path p = dir_ / name;
    std::ofstream(p) << text;
    return p;
  }
  // A scene file in scenes/ with one instance `robot` on ../robots/two.urdf, plus `extra` lines.
  fs::path Scene(const std::string& plant_extra, const std::string& extra = "") {
    return Write("scenes/scene.yaml", "instances:\n  - name: robot\n    plant: {type: urdf, file: ../robots/two.urdf" +
                                          plant_extra + "}\n" + extra);
  }
  // The one-line error of loading `scene`.
  static std::string ErrorOf(const fs::path& scene) {
    try {
      LoadScene(scene.string());
    } catch (const ConfigError& e) {
      EXPECT_EQ(e.file(), scene.string());
      return e.what();
    }
    ADD_FAILURE() << scene << " was accepted";
    return "";
  }
  fs::path dir_;
};

TEST_F(UrdfScene, TheFileIsReadRelativeToTheScenesDirectoryWhateverTheWorkingDirectory) {
  const fs::path scene = Scene("");
  const fs::path cwd = fs::current_path();
  fs::current_path("/");
  const lagrange::Scene loaded = LoadScene(scene.string());
  fs::current_path(cwd);
  ASSERT_EQ(loaded.instances.size(), 1u);
  const InstanceConfig& robot = loaded.instances[0];
  EXPECT_EQ(robot.plant.type(), PlantType::kUrdf);
  EXPECT_EQ(robot.plant.num_dofs(), 2);
  EXPECT_EQ(robot.method, Method::kRecursive);  // the fastest exact path: no closed form
  EXPECT_EQ(JointNamesOf(robot.plant), (std::vector<std::string>{"j1", "j2"}));
  const auto& p = std::get<UrdfParams>(robot.plant.params);
  EXPECT_TRUE(fs::equivalent(p.file, dir_ / "robots/two.urdf")) << p.file;
  EXPECT_EQ(p.gravity, Eigen::Vector3d(0.0, 0.0, -9.81));
  EXPECT_EQ(p.mass_scale, 1.0);
}

TEST_F(UrdfScene, LimitsEffortDampingAndFrictionComeFromTheUrdf) {
  const InstanceConfig robot = LoadScene(Scene("").string()).instances[0];
  ASSERT_TRUE(robot.effects.limits);
  EXPECT_EQ(robot.effects.limits->lower, (VectorXd(2) << -1.5, -kInf).finished());  // j2 is continuous
  EXPECT_EQ(robot.effects.limits->upper, (VectorXd(2) << 1.5, kInf).finished());
  EXPECT_EQ(robot.effects.limits->stiffness, JointLimits{}.stiffness);
  EXPECT_EQ(robot.effects.limits->damping, JointLimits{}.damping);
  EXPECT_EQ(robot.torque_limits, (VectorXd(2) << 20.0, 5.0).finished());
  ASSERT_TRUE(robot.effects.damping);
  EXPECT_EQ(*robot.effects.damping, (VectorXd(2) << 0.3, 0.0).finished());
  ASSERT_TRUE(robot.effects.friction);
  EXPECT_EQ(robot.effects.friction->coulomb, (VectorXd(2) << 0.1, 0.0).finished());
  EXPECT_EQ(robot.effects.friction->velocity_scale, CoulombFriction{}.velocity_scale);
  EXPECT_FALSE(robot.effects.saturation);
  // Streamed setpoints are held to the joint limits, as for any plant with stops.
  EXPECT_EQ(robot.setpoint_lower, robot.effects.limits->lower);
  EXPECT_EQ(robot.setpoint_upper, robot.effects.limits->upper);
}

TEST_F(UrdfScene, TheScenesOwnKeysTakePrecedenceKeyByKeyAndOffSwitchesAnEffectOff) {
  InstanceConfig robot = LoadScene(Scene("", R"(    effects:
      damping: 0.5
      friction: {velocity_scale: 0.05}
      limits: {stiffness: 500}
    torque_limits: [10, 8]
)")
                                       .string())
                             .instances[0];
  EXPECT_EQ(*robot.effects.damping, VectorXd::Constant(2, 0.5));
  EXPECT_EQ(robot.effects.friction->coulomb, (VectorXd(2) << 0.1, 0.0).finished());  // the URDF's, kept
  EXPECT_EQ(robot.effects.friction->velocity_scale, 0.05);
  EXPECT_EQ(robot.effects.limits->lower[0], -1.5);  // the URDF's, kept
  EXPECT_EQ(robot.effects.limits->stiffness, 500.0);
  EXPECT_EQ(robot.torque_limits, (VectorXd(2) << 10.0, 8.0).finished());

  robot =
      LoadScene(
          Scene("", "    effects: {damping: off, friction: off, limits: {lower: [-1, -2], upper: [1, 2]}}\n").string())
          .instances[0];
  EXPECT_FALSE(robot.effects.damping);
  EXPECT_FALSE(robot.effects.friction);
  EXPECT_EQ(robot.effects.limits->lower, (VectorXd(2) << -1.0, -2.0).finished());

  robot = LoadScene(Scene("", "    effects: {limits: off}\n").string()).instances[0];
  EXPECT_FALSE(robot.effects.limits);
  EXPECT_TRUE(std::isinf(robot.setpoint_upper[0]));
}

TEST_F(UrdfScene, GravityAndTheControllersModelAreTheScenes) {
  const InstanceConfig robot = LoadScene(Scene(", gravity: [0, -9.81, 0]", R"(    controller:
      type: gravity-compensation
      model: {params: {mass_scale: 1.05}}
    controllers:
      - {type: computed-torque, kp: 100, kd: 20, model: {file: ../robots/two.urdf, params: {gravity: [0, 0, -9.7]}}}
)")
                                             .string())
                                   .instances[0];
  const auto& plant = std::get<UrdfParams>(robot.plant.params);
  EXPECT_EQ(plant.gravity, Eigen::Vector3d(0.0, -9.81, 0.0));
  ASSERT_TRUE(robot.controller.model);
  const auto& heavier = std::get<UrdfParams>(robot.controller.model->params);
  EXPECT_EQ(heavier.mass_scale, 1.05);
  EXPECT_EQ(heavier.gravity, plant.gravity);  // the plant's, unless the model says otherwise
  EXPECT_EQ(heavier.robot, plant.robot);      // one file, read once
  const auto& other = std::get<UrdfParams>(robot.alternates[0].model->params);
  EXPECT_EQ(other.gravity, Eigen::Vector3d(0.0, 0.0, -9.7));
  EXPECT_EQ(other.robot, plant.robot);
  // The controller's G is its model's: 5 % heavier than the plant's.
  const VectorXd q = (VectorXd(2) << 0.3, -0.4).finished();
  VectorXd G(2), Gm(2);
  G = testing::GravityOf(robot.plant, Method::kRecursive, q);
  Gm = testing::GravityOf(*robot.controller.model, Method::kRecursive, q);
  EXPECT_LE((Gm - 1.05 * G).norm(), 1e-12 * G.norm());
}

TEST_F(UrdfScene, BadInputIsOneLineNamingTheSceneFileTheKeyAndWhatIsWrong) {
  struct Case {
    std::string plant_extra, extra;
    std::string expected;  // after "scene.yaml:LINE:COLUMN: "
  };
  const std::string robots = (dir_ / "robots").string();
  const std::vector<Case> cases = {
      {", gravity: [0, -9.81]", "", "instances[0].plant.gravity: expected [gx, gy, gz] (three finite numbers, m/s²)"},
      {", gravity: [0, 0, down]", "", "instances[0].plant.gravity[2]: expected a finite number, got 'down'"},
      {", gravity: -9.81", "", "instances[0].plant.gravity: expected [gx, gy, gz] (three finite numbers, m/s²)"},
      {", params: {mass_scale: 0}", "", "instances[0].plant.params.mass_scale: expected a positive number"},
      {", params: {m1: 2}", "",
       "instances[0].plant.params.m1: unknown parameter for urdf (expected one of gravity, mass_scale)"},
      {", method: closed-form", "",
       "instances[0].plant.method: urdf has no closed-form path (expected lagrangian or recursive)"},
      {", links: 3", "",
       "instances[0].plant.links: unknown key (expected one of: type, file, gravity, method, params, floating_base)"},
      {"", "    controller: {type: gravity-compensation, model: {file: ../robots/one.urdf}}\n",
       "instances[0].controller.model.file: " + robots + "/one.urdf has 1 moving joint; expected 2 like the plant's"},
      {"", "    controller: {type: pd, kp: 1, kd: 1, model: {params: {mass_scale: -1}}}\n",
       "instances[0].controller.model.params.mass_scale: expected a positive number"},
      {"", "    controller: {type: swing-up}\n",
       "instances[0].controller.type: swing-up needs a cartpole plant, got urdf"},
      {"", "    controller: {type: lqr}\n",
       "instances[0].controller: equilibrium: expected the configuration to balance about (one value per joint)"},
      {"", "    torque_limits: [1, 2, 3]\n", "instances[0].torque_limits: expected 2 values (one per joint), got 3"},
  };
  for (const Case& c : cases) {
    const fs::path scene = Scene(c.plant_extra, c.extra);
    const std::string what = ErrorOf(scene);
    EXPECT_EQ(what.rfind(scene.string() + ":", 0), 0u) << what;
    EXPECT_NE(what.find(": " + c.expected), std::string::npos) << "got: " << what << "\nexpected: " << c.expected;
    EXPECT_EQ(what.find('\n'), std::string::npos) << what;
  }
}

TEST_F(UrdfScene, AMissingOrInvalidUrdfIsTheScenesErrorAtItsFileKey) {
  const fs::path missing =
      Write("scenes/missing.yaml", "instances:\n  - {name: r, plant: {type: urdf, file: nope.urdf}}\n");
  std::string what = ErrorOf(missing);
  EXPECT_EQ(what.rfind(missing.string() + ":2:", 0), 0u) << what;
  // LoadUrdf's own line, with the reason the file could not be opened.
  EXPECT_NE(what.find(": instances[0].plant.file: " + (dir_ / "scenes/nope.urdf").string() +
                      ": file: cannot be opened (No such file or directory)"),
            std::string::npos)
      << what;

  const fs::path floating =
      Write("scenes/floating.yaml", "instances:\n  - {name: r, plant: {type: urdf, file: ../robots/floating.urdf}}\n");
  what = ErrorOf(floating);
  // The scene's position and key, then LoadUrdf's own line: "FILE: ELEMENT: reason".
  EXPECT_EQ(what.rfind(floating.string() + ":2:", 0), 0u) << what;
  EXPECT_NE(what.find(": instances[0].plant.file: " + (dir_ / "robots/floating.urdf").string() + ": "),
            std::string::npos)
      << what;
  EXPECT_NE(what.find("type 'floating' makes a floating-base robot"), std::string::npos) << what;
  EXPECT_EQ(what.find('\n'), std::string::npos) << what;

  const fs::path no_file = Write("scenes/no_file.yaml", "instances:\n  - {name: r, plant: {type: urdf}}\n");
  EXPECT_NE(ErrorOf(no_file).find("instances[0].plant: missing key 'file'"), std::string::npos);
  const fs::path pendulum =
      Write("scenes/pendulum.yaml", "instances:\n  - {name: r, plant: {type: pendulum, file: x.urdf}}\n");
  EXPECT_NE(ErrorOf(pendulum).find("instances[0].plant.file: unknown key (expected one of: type, method, params)"),
            std::string::npos);
}

// A locked joint (lower == upper, which the loader accepts) gets no stop: a
// stop of zero width is not one a finite spring can hold. The scene's own
// stops are applied before the merged limits are checked, and a bad pair
// names its joint.
TEST_F(UrdfScene, ALockedJointGetsNoStopAndTheScenesLimitsApplyBeforeTheCheck) {
  std::string locked = kTwoJoints;
  const std::string stops = R"(lower="-1.5" upper="1.5")";
  locked.replace(locked.find(stops), stops.size(), R"(lower="0.2" upper="0.2")");
  Write("robots/locked.urdf", locked);
  const auto scene = [&](const std::string& extra) {
    return Write("scenes/locked.yaml",
                 "instances:\n  - name: robot\n    plant: {type: urdf, file: ../robots/locked.urdf}\n" + extra);
  };
  InstanceConfig robot = LoadScene(scene("").string()).instances[0];
  EXPECT_FALSE(robot.effects.limits);  // j1 locked, j2 continuous: no stops at all
  robot = LoadScene(scene("    effects: {limits: off}\n").string()).instances[0];
  EXPECT_FALSE(robot.effects.limits);
  robot = LoadScene(scene("    effects: {limits: {lower: [0.1, -.inf], upper: [0.3, .inf]}}\n").string()).instances[0];
  ASSERT_TRUE(robot.effects.limits);
  EXPECT_EQ(robot.effects.limits->lower[0], 0.1);
  EXPECT_EQ(robot.effects.limits->upper[0], 0.3);
  const std::string what = ErrorOf(scene("    effects: {limits: {lower: [0.1, 0.5], upper: [0.3, 0.5]}}\n"));
  EXPECT_NE(what.find("effects.limits: expected lower < upper for joint 'j2', got 0.5 and 0.5"), std::string::npos)
      << what;
  EXPECT_EQ(what.find("index"), std::string::npos) << what;
}

// A mass_scale that overflows the inertias is refused at its own key, not
// later when the dynamics are built.
TEST_F(UrdfScene, AMassScaleThatOverflowsTheInertiasIsRefusedAtItsKey) {
  const std::string what = ErrorOf(Scene(", params: {mass_scale: 1e308}"));
  EXPECT_NE(what.find("instances[0].plant.params.mass_scale: expected a factor from 1e-06 to 1e+06, got 1e+308"),
            std::string::npos)
      << what;
  const std::string model = ErrorOf(Scene("",
                                          "    controller: {type: gravity-compensation, model: {params: "
                                          "{mass_scale: 1e308}}}\n"));
  EXPECT_NE(model.find("model.params.mass_scale: expected a factor from 1e-06 to 1e+06, got 1e+308"), std::string::npos)
      << model;
}

// `model: {file: ...}` takes the plant's gravity, not its mass_scale: the
// other file's own masses unless the model's params scale them.
TEST_F(UrdfScene, AModelFileInheritsThePlantsGravityButNotItsMassScale) {
  const InstanceConfig robot = LoadScene(Scene(", gravity: [0, -9.81, 0], params: {mass_scale: 2}", R"(    controller:
      type: gravity-compensation
      model: {file: ../robots/two.urdf}
    controllers:
      - {type: computed-torque, kp: 100, kd: 20, model: {file: ../robots/two.urdf, params: {mass_scale: 3}}}
)")
                                             .string())
                                   .instances[0];
  const auto& plant = std::get<UrdfParams>(robot.plant.params);
  ASSERT_EQ(plant.mass_scale, 2.0);
  const auto& own = std::get<UrdfParams>(robot.controller.model->params);
  EXPECT_EQ(own.mass_scale, 1.0);
  EXPECT_EQ(own.gravity, plant.gravity);
  EXPECT_EQ(std::get<UrdfParams>(robot.alternates[0].model->params).mass_scale, 3.0);
  // The model's G is half the plant's (the file's masses, not twice them).
  const VectorXd q = (VectorXd(2) << 0.3, -0.4).finished();
  VectorXd G(2), Gm(2);
  G = testing::GravityOf(robot.plant, Method::kRecursive, q);
  Gm = testing::GravityOf(*robot.controller.model, Method::kRecursive, q);
  EXPECT_LE((2.0 * Gm - G).norm(), 1e-12 * G.norm());
}

// The instance's controllers wrap only the joints its stops leave free: on
// two.urdf j1 (stops at ±1.5) is driven the plain difference, j2
// (continuous) the short way; `limits: off` frees j1 too.
TEST_F(UrdfScene, TheInstancesControllersWrapOnlyJointsWithoutStops) {
  const std::string control = "    controller: {type: pd, kp: 1, kd: 0.1}\n";
  Instance stopped(LoadScene(Scene("", control).string()).instances[0]);
  EXPECT_EQ(stopped.controller().wrapped_joints(), (std::vector<bool>{false, true}));
  Instance free(LoadScene(Scene("", control + "    effects: {limits: off}\n").string()).instances[0]);
  EXPECT_EQ(free.controller().wrapped_joints(), (std::vector<bool>{true, true}));
}

}  // namespace
}  // namespace lagrange
