// The quadruped standing on MuJoCo's ground (config/quadruped_mujoco_stand.yaml):
// a mujoco plant whose free joint is the floating base, under pd with
// gravity_compensation: stance. Offline (the sim library): the A1 dropped
// 0.1 m lands, settles at its standing height, stays upright with its four
// feet on the ground carrying its weight; a tick allocates nothing; what
// such a scene cannot be is refused in one line.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>

#include "controllers/stance_pd.hpp"
#include "plant/floating_dynamics.hpp"
#include "plant/mujoco_plant.hpp"
#include "sim/instance.hpp"
#include "sim/scene.hpp"
#include "sim/yaml_reader.hpp"
#include "tests/support/alloc_counter.hpp"

namespace lagrange {
namespace {

const std::string kScene = std::string(LAGRANGE_SOURCE_DIR) + "/config/quadruped_mujoco_stand.yaml";
const std::string kStandLabel = std::string(LAGRANGE_SOURCE_DIR) + "/config/mujoco_stand_test.yaml";
const char* const kFeet[] = {"FR_foot", "FL_foot", "RR_foot", "RL_foot"};

// m: the trunk's origin with the legs at the posture (thigh 0.9, calf −1.8
// rad; links of 0.2 m) and the 0.02 m foot spheres on the ground at z = 0.
const double kStandingHeight = 2 * 0.2 * std::cos(0.9) + 0.02;
constexpr double kHeightTolerance = 5e-3;  // m: MuJoCo's soft contact lets the feet sink a little
constexpr double kTiltTolerance = 0.01;    // rad: the trunk's z axis from the world's
constexpr double kSettledBand = 2e-3;      // m: settled once the trunk stays this close to its height
constexpr double kSettleTime = 1.5;        // s: from here on it stands
constexpr double kRunTime = 3.0;           // s
constexpr double kMass = 13.74;            // kg: the A1 (config/robots/a1.urdf)
constexpr double kG = 9.81;

// The angle between the trunk's z axis and the world's, from q's quaternion (x, y, z, w).
double Tilt(const VectorXd& fq) {
  const double x = fq[3], y = fq[4];
  return std::acos(std::clamp(1.0 - 2.0 * (x * x + y * y), -1.0, 1.0));
}

TEST(MujocoStand, TheA1DroppedOntoTheGroundLandsAndStandsAtItsHeight) {
  const Scene scene = LoadScene(kScene);
  Instance inst(scene.instances.front());
  ASSERT_TRUE(inst.floating_base());
  ASSERT_NE(inst.stepped_plant(), nullptr);
  const double start_z = inst.floating_q()[2];
  EXPECT_NEAR(start_z, kStandingHeight + 0.1, 1e-4);
  const FloatingDynamics& model = *inst.instance_model().floating;
  const std::unique_ptr<FloatingData> data = model.MakeData();
  const std::vector<std::string> frames = model.tree().frame_names();
  double settled_at = 0.0;  // s: the last time it was outside kSettledBand
  double lowest = start_z, worst_height = 0.0, worst_tilt = 0.0, worst_foot = 0.0, worst_weight = 0.0;
  const auto steps = static_cast<std::int64_t>(std::llround(kRunTime / scene.period));
  for (std::int64_t k = 0; k < steps; ++k) {
    ASSERT_EQ(inst.Step(scene.period), nullptr) << "t = " << inst.t();
    const VectorXd& fq = inst.floating_q();
    ASSERT_TRUE(fq.allFinite() && inst.floating_v().allFinite()) << "t = " << inst.t();
    lowest = std::min(lowest, fq[2]);
    if (std::abs(fq[2] - kStandingHeight) > kSettledBand) settled_at = inst.t();
    if (inst.t() < kSettleTime) continue;
    worst_height = std::max(worst_height, std::abs(fq[2] - kStandingHeight));
    worst_tilt = std::max(worst_tilt, Tilt(fq));
    model.ComputeFramePlacements(*data, fq);
    double weight = 0.0;
    for (const char* foot : kFeet) {
      const auto f = static_cast<int>(std::find(frames.begin(), frames.end(), foot) - frames.begin());
      worst_foot = std::max(worst_foot, std::abs(data->frame_position(f).z() - 0.02));  // the sphere on the ground
      weight += MujocoContactForce(*inst.stepped_plant(), foot)->z();
    }
    worst_weight = std::max(worst_weight, std::abs(weight - kMass * kG));
  }
  EXPECT_LT(lowest, kStandingHeight);  // it fell the 0.1 m and landed
  EXPECT_LT(worst_height, kHeightTolerance);
  EXPECT_LT(worst_tilt, kTiltTolerance);
  EXPECT_LT(worst_foot, kHeightTolerance);
  EXPECT_LT(worst_weight, 0.01 * kMass * kG);  // the four feet carry its weight
  EXPECT_LT(settled_at, kSettleTime);
  EXPECT_LT(inst.floating_v().norm(), 1e-2);  // at rest: v (m/s, rad/s), the joints' rates included
  const auto* stance = dynamic_cast<const StancePdController*>(&inst.controller());
  ASSERT_NE(stance, nullptr);
  EXPECT_EQ(stance->contact_count(), 4);
  // The README's figures ("Floating base").
  RecordProperty("standing_height_m", std::to_string(kStandingHeight));
  RecordProperty("final_height_m", std::to_string(inst.floating_q()[2]));
  RecordProperty("worst_height_error_after_1_5_s_m", std::to_string(worst_height));
  RecordProperty("lowest_m", std::to_string(lowest));
  RecordProperty("settle_time_s", std::to_string(settled_at));
  RecordProperty("worst_tilt_after_1_5_s_rad", std::to_string(worst_tilt));
  RecordProperty("worst_weight_error_after_1_5_s_N", std::to_string(worst_weight));
  RecordProperty("final_speed", std::to_string(inst.floating_v().norm()));
}

TEST(MujocoStand, ATickAllocatesNothing) {
  const Scene scene = LoadScene(kScene);
  Instance inst(scene.instances.front());
  for (int k = 0; k < 400; ++k) ASSERT_EQ(inst.Step(scene.period), nullptr);  // landed: every foot in the law
  testing::AllocationCounter counter;
  for (int k = 0; k < 50; ++k) ASSERT_EQ(inst.Step(scene.period), nullptr);
  EXPECT_EQ(counter.count(), 0);
}

std::string StandSceneError(const std::string& text) {
  try {
    ParseScene(text, kStandLabel);
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "";
}

std::string StandScene(const std::string& plant, const std::string& controller) {
  return "instances:\n  - name: a1\n    plant: " + plant +
         "\n    initial: {q: [0, 0.9, -1.8, 0, 0.9, -1.8, 0, 0.9, -1.8, 0, 0.9, -1.8]}\n    controller: " + controller +
         "\n";
}

constexpr char kStance[] = "{type: pd, kp: 60, kd: 2, gravity_compensation: stance, feet: [FR_foot, FL_foot]}";

TEST(MujocoStand, AFloatingBaseOnAnMjcfWithoutAFreeJointIsRefused) {
  const std::string error = StandSceneError(
      StandScene("{type: mujoco, file: robots/panda_table.xml, floating_base: true, model: {type: urdf, "
                 "file: robots/a1.urdf}}",
                 kStance));
  EXPECT_NE(error.find(kStandLabel + ":3:"), std::string::npos) << error;
  EXPECT_NE(error.find("instances[0].plant.file: "), std::string::npos) << error;
  EXPECT_NE(error.find("panda_table.xml: expected a free joint for lagrange's floating base, got none"),
            std::string::npos)
      << error;
}

TEST(MujocoStand, AFloatingBaseNeedsAUrdfModel) {
  const std::string error = StandSceneError(
      StandScene("{type: mujoco, file: robots/a1.xml, floating_base: true, model: {type: pendulum}}", kStance));
  EXPECT_NE(error.find("instances[0].plant.model.type: expected urdf: a floating base's model is a URDF"),
            std::string::npos)
      << error;
}

TEST(MujocoStand, AStanceOnTheA1WithItsBaseFixedIsRefused) {
  // Without floating_base, the MJCF's free joint is a loose body and the A1's model is bolted down.
  const std::string error = StandSceneError(
      StandScene("{type: mujoco, file: robots/a1.xml, model: {type: urdf, file: robots/a1.urdf}}", kStance));
  EXPECT_NE(error.find("instances[0].controller.gravity_compensation: expected none on a fixed base"),
            std::string::npos)
      << error;
}

// lagrange's own floating base keeps an energy balance (FloatingBalance.*); one MuJoCo steps does not yet.
TEST(MujocoStand, AnEnergyBalanceOnAFloatingBaseMujocoStepsIsRefused) {
  const std::string error = StandSceneError(
      StandScene("{type: mujoco, file: robots/a1.xml, floating_base: true, model: {type: urdf, file: robots/a1.urdf}}",
                 kStance) +
      "    energy_balance: {bound: 1}\n");
  EXPECT_NE(error.find("instances[0].energy_balance: expected no energy_balance for a floating base MuJoCo steps"),
            std::string::npos)
      << error;
}

TEST(MujocoStand, AnUnknownFootIsRefusedNamingTheFrames) {
  const std::string error = StandSceneError(
      StandScene("{type: mujoco, file: robots/a1.xml, floating_base: true, model: {type: urdf, file: robots/a1.urdf}}",
                 "{type: pd, kp: 60, kd: 2, gravity_compensation: stance, feet: [FR_foot, paw]}"));
  EXPECT_NE(error.find("instances[0].controller.feet: expected frames of the robot ("), std::string::npos) << error;
  EXPECT_NE(error.find("FL_foot"), std::string::npos) << error;
  EXPECT_NE(error.find("got 'paw'"), std::string::npos) << error;
}

}  // namespace
}  // namespace lagrange
