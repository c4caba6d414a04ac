// Scenes with an external plant or an external controller: what the loader
// refuses, with the file, the key and what was expected, and the channels
// such a scene reads and writes (SceneChannelNames, CheckChannelNames).

#include <gtest/gtest.h>

#include <string>

#include "protocol/channels.hpp"
#include "sim/instance_model.hpp"
#include "sim/scene.hpp"
#include "sim/scene_channels.hpp"
#include "sim/yaml_reader.hpp"

namespace lagrange {
namespace {

constexpr const char* kFile = "external.yaml";

// An external plant instance `name` (an arm2 model) reading ARM_STATE and
// writing ARM_TORQUE; `plant_extra` lines go into plant:, `instance_extra`
// lines into the instance, `controller` is the instance's controller map.
std::string ExternalArmScene(const std::string& plant_extra = "", const std::string& instance_extra = "",
                             const std::string& controller = "{type: computed-torque, kp: 100, kd: 20}",
                             const std::string& name = "arm_controller") {
  std::string text = "period: 0.001\ninstances:\n";
  text += "  - name: " + name + "\n";
  text +=
      "    plant:\n"
      "      type: external\n"
      "      model: {type: arm2}\n"
      "      state_channel: ARM_STATE\n"
      "      torque_channel: ARM_TORQUE\n";
  text += plant_extra;
  text += "    controller: " + controller + "\n";
  return text + instance_extra;
}

// A simulated arm2 `arm` whose controller map is `controller`; `extra` lines go into the instance.
std::string SimulatedArmScene(const std::string& controller, const std::string& extra = "") {
  std::string text = "period: 0.001\ninstances:\n  - name: arm\n    plant: {type: arm2}\n";
  text += "    controller: " + controller + "\n";
  return text + extra;
}

// The error ParseScene gives for `text`, or "" when it accepts it.
std::string ErrorOf(const std::string& text) {
  try {
    ParseScene(text, kFile);
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.file(), kFile);
    return e.what();
  }
  return "";
}

// "external.yaml:LINE:COLUMN: <key>: <message>" with the key path and message given.
::testing::AssertionResult Refused(const std::string& error, const std::string& key_and_message) {
  if (error.empty()) return ::testing::AssertionFailure() << "accepted; expected " << key_and_message;
  if (error.rfind(std::string(kFile) + ":", 0) != 0) {
    return ::testing::AssertionFailure() << "does not name the file: " << error;
  }
  if (error.find(": " + key_and_message) == std::string::npos) {
    return ::testing::AssertionFailure() << "got: " << error << "\nexpected: " << key_and_message;
  }
  return ::testing::AssertionSuccess();
}

// ------------------------------------------------------------------ external plant

TEST(ExternalPlantScene, TheShapeOfAValidOneIsReadIntoItsConfig) {
  const Scene scene = ParseScene(ExternalArmScene("      state_timeout: 0.02\n"), kFile);
  ASSERT_TRUE(scene.instances[0].external);
  const ExternalPlantConfig& e = *scene.instances[0].external;
  EXPECT_EQ(e.state_channel, "ARM_STATE");
  EXPECT_EQ(e.torque_channel, "ARM_TORQUE");
  EXPECT_NEAR(e.state_timeout, 0.02, 1e-15);
  EXPECT_EQ(scene.instances[0].plant.num_dofs(), 2);  // the model's
}

TEST(ExternalPlantScene, AnIntegratorIsRefused) {
  EXPECT_TRUE(Refused(ErrorOf(ExternalArmScene("", "    integrator: {type: rk4}\n")),
                      "instances[0].integrator: an external plant is not integrated by lagranged"));
}

TEST(ExternalPlantScene, AnExternalControllerIsRefused) {
  EXPECT_TRUE(Refused(ErrorOf(ExternalArmScene("", "", "{type: external}")),
                      "instances[0].controller.type: an external plant's controller runs in lagranged "
                      "(expected another type)"));
  // Nor as an alternate a command could switch to.
  EXPECT_TRUE(Refused(ErrorOf(ExternalArmScene("", "    controllers: [{type: external}]\n")),
                      "instances[0].controllers[0].type: an external plant's controller runs in lagranged"));
}

TEST(ExternalPlantScene, AContinuousControllerIsRefused) {
  EXPECT_TRUE(Refused(ErrorOf(ExternalArmScene("", "", "{type: computed-torque, kp: 100, kd: 20, continuous: true}")),
                      "instances[0].controller.continuous: an external plant's controller runs once per tick "
                      "on the measured state"));
}

TEST(ExternalPlantScene, AMissingStateChannelIsRefused) {
  const std::string text =
      "instances:\n"
      "  - name: arm_controller\n"
      "    plant: {type: external, model: {type: arm2}, torque_channel: ARM_TORQUE}\n";
  EXPECT_TRUE(Refused(ErrorOf(text), "instances[0].plant: missing key 'state_channel'"));
}

TEST(ExternalPlantScene, AStateChannelEqualToTheTorqueChannelIsRefused) {
  const std::string text =
      "instances:\n"
      "  - name: arm_controller\n"
      "    plant: {type: external, model: {type: arm2}, state_channel: ARM, torque_channel: ARM}\n";
  EXPECT_TRUE(Refused(ErrorOf(text), "instances[0].plant.torque_channel: expected a channel other than state_channel"));
}

TEST(ExternalPlantScene, AChannelNameWithASpaceOrOf64BytesIsRefused) {
  const std::string text =
      "instances:\n"
      "  - name: arm_controller\n"
      "    plant: {type: external, model: {type: arm2}, state_channel: 'ARM STATE', torque_channel: ARM_TORQUE}\n";
  EXPECT_TRUE(Refused(ErrorOf(text),
                      "instances[0].plant.state_channel: expected an LCM channel name of printable "
                      "ASCII without spaces, got 'ARM STATE'"));
  const std::string longest(63, 'T'), too_long(64, 'T');
  const std::string with_torque =
      "instances:\n"
      "  - name: arm_controller\n"
      "    plant: {type: external, model: {type: arm2}, state_channel: ARM_STATE, torque_channel: ";
  EXPECT_EQ(ErrorOf(with_torque + longest + "}\n"), "");
  EXPECT_TRUE(Refused(ErrorOf(with_torque + too_long + "}\n"),
                      "instances[0].plant.torque_channel: expected an LCM channel name of 1 to 63 bytes, got 64"));
}

TEST(ExternalPlantScene, AStateTimeoutBelowTwoTicksIsRefused) {
  EXPECT_TRUE(Refused(ErrorOf(ExternalArmScene("      state_timeout: 0.0019\n")),
                      "instances[0].plant.state_timeout: expected at least two ticks (0.002 s)"));
  EXPECT_EQ(ErrorOf(ExternalArmScene("      state_timeout: 0.002\n")), "");
}

// ------------------------------------------------------------------ external controller

TEST(ExternalControllerScene, ATorqueTimeoutBelowTwoTicksIsRefused) {
  EXPECT_TRUE(Refused(ErrorOf(SimulatedArmScene("{type: external, torque_timeout: 0.0015}")),
                      "instances[0].controller.torque_timeout: expected at least two ticks (0.002 s)"));
  EXPECT_EQ(ErrorOf(SimulatedArmScene("{type: external, torque_timeout: 0.002}")), "");
}

TEST(ExternalControllerScene, AChannelNameWithASpaceIsRefused) {
  EXPECT_TRUE(Refused(ErrorOf(SimulatedArmScene("{type: external, torque_channel: 'MY TORQUE'}")),
                      "instances[0].controller.torque_channel: expected an LCM channel name of printable ASCII "
                      "without spaces, got 'MY TORQUE'"));
}

TEST(ExternalControllerScene, AFallbackNamingAnUnconfiguredControllerIsRefused) {
  EXPECT_TRUE(Refused(
      ErrorOf(SimulatedArmScene("{type: external, fallback: pd}", "    controllers: [{type: gravity-compensation}]\n")),
      "instances[0].controller.fallback: expected brake or one of this instance's controllers "
      "(gravity-compensation), got 'pd'"));
  // With no other controller, brake is the only choice.
  EXPECT_TRUE(Refused(ErrorOf(SimulatedArmScene("{type: external, fallback: computed-torque}")),
                      "instances[0].controller.fallback: expected brake, got 'computed-torque'"));
}

TEST(ExternalControllerScene, AFallbackOfBrakeOrAConfiguredControllerIsAccepted) {
  const Scene brake = ParseScene(SimulatedArmScene("{type: external, fallback: brake}"), kFile);
  EXPECT_EQ(brake.instances[0].controller.external.fallback, "brake");
  const Scene named = ParseScene(
      SimulatedArmScene("{type: external, fallback: pd}", "    controllers: [{type: pd, kp: 50, kd: 5}]\n"), kFile);
  EXPECT_EQ(named.instances[0].controller.external.fallback, "pd");
}

// ------------------------------------------------------------------ channels

TEST(ExternalChannels, ExplicitChannelsAreUsedAsWrittenAndDerivedOnesArePrefixed) {
  const Scene plant = ParseScene(ExternalArmScene(), kFile);
  const InstanceChannelNames c = SceneChannelNames(plant, "CTRL_")[0];
  EXPECT_EQ(c.measured_in, "ARM_STATE");
  EXPECT_EQ(c.torque_out, "ARM_TORQUE");
  EXPECT_EQ(c.torque_in, "");
  EXPECT_EQ(c.state, "CTRL_ARM_CONTROLLER_STATE");
  EXPECT_EQ(c.setpoint, "CTRL_ARM_CONTROLLER_SETPOINT");
  EXPECT_EQ(c.command, "CTRL_ARM_CONTROLLER_COMMAND");
  EXPECT_EQ(c.reply, "CTRL_ARM_CONTROLLER_REPLY");
  EXPECT_EQ(BuildDaemonModel(plant, BuildOptions::Prefixed("CTRL_"))->status_channel, "CTRL_LAGRANGE_STATUS");

  const InstanceChannelNames derived =
      SceneChannelNames(ParseScene(SimulatedArmScene("{type: external}"), kFile), "SIM_")[0];
  EXPECT_EQ(derived.torque_in, "SIM_ARM_TORQUE");
  EXPECT_EQ(derived.measured_in, "");
  EXPECT_EQ(derived.torque_out, "");
  const InstanceChannelNames written =
      SceneChannelNames(ParseScene(SimulatedArmScene("{type: external, torque_channel: MY_TORQUE}"), kFile), "SIM_")[0];
  EXPECT_EQ(written.torque_in, "MY_TORQUE");
}

// An external plant named like the arm it controls reads ARM_STATE, which it
// would publish itself without a prefix.
TEST(ExternalChannels, AnInputEqualToAnOwnOutputIsRefusedUntilAPrefixSeparatesThem) {
  const Scene scene = ParseScene(ExternalArmScene("", "", "{type: computed-torque, kp: 100, kd: 20}", "arm"), kFile);
  EXPECT_EQ(CheckChannelNames(SceneChannelNames(scene, ""), StatusChannel("")),
            "arm reads its state_channel from ARM_STATE, which this lagranged publishes (arm's state): "
            "give it another --channel-prefix");
  EXPECT_EQ(CheckChannelNames(SceneChannelNames(scene, "CTRL_"), StatusChannel("CTRL_")), "");
}

// Torques on another instance's setpoint channel, or a measured state on its
// command channel, would only ever be decode errors: refused before the loop.
// Two external plants may read one measured state.
TEST(ExternalChannels, TwoInputsOnOneChannelAreRefusedUnlessBothAreMeasuredStates) {
  const auto check = [](const std::string& arm_controller, const std::string& ext_state) {
    const Scene scene = ParseScene(R"(
period: 0.001
instances:
  - name: arm
    plant: {type: arm2}
    controller: )" + arm_controller + R"(
  - name: leg
    plant: {type: arm2}
    controller: {type: pd, kp: 10, kd: 1}
  - name: ext
    plant: {type: external, model: {type: arm2}, state_channel: )" +
                                       ext_state + R"(, torque_channel: OUT_A}
    controller: {type: pd, kp: 10, kd: 1}
  - name: ext2
    plant: {type: external, model: {type: arm2}, state_channel: ROBOT_STATE, torque_channel: OUT_B}
    controller: {type: pd, kp: 10, kd: 1}
)",
                                   kFile);
    return CheckChannelNames(SceneChannelNames(scene, ""), StatusChannel(""));
  };
  EXPECT_EQ(check("{type: external, torque_channel: LEG_SETPOINT}", "ROBOT_STATE"),
            "arm reads its torques and leg its setpoints from the same channel LEG_SETPOINT");
  EXPECT_EQ(check("{type: external}", "LEG_COMMAND"),
            "leg reads its commands and ext its state_channel from the same channel LEG_COMMAND");
  EXPECT_EQ(check("{type: external}", "ROBOT_STATE"), "");  // ext and ext2 share one measured state
}

TEST(ExternalChannels, TheShippedTwoProcessScenesFitTogetherAsTheirCommentsSay) {
  const std::string dir = std::string(LAGRANGE_SOURCE_DIR) + "/config/";
  const Scene plant = LoadScene(dir + "arm_external_plant.yaml");
  const Scene controller = LoadScene(dir + "arm_external_controller.yaml");
  const std::vector<InstanceChannelNames> p = SceneChannelNames(plant, "");
  const std::vector<InstanceChannelNames> c = SceneChannelNames(controller, "CTRL_");
  EXPECT_EQ(CheckChannelNames(p, StatusChannel("")), "");
  EXPECT_EQ(CheckChannelNames(c, StatusChannel("CTRL_")), "");
  EXPECT_EQ(c[0].measured_in, p[0].state);     // the controller reads the plant's state
  EXPECT_EQ(p[0].torque_in, c[0].torque_out);  // and the plant takes the controller's torque
}

}  // namespace
}  // namespace lagrange
