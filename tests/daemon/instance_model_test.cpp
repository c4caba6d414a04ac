// The instance model (sim/instance_model.hpp): each fact about an instance
// is built once from the scene and every thread reads that one copy.

#include <gtest/gtest.h>

#include <string>

#include "daemon/runtime.hpp"
#include "sim/instance_model.hpp"
#include "sim/yaml_reader.hpp"
#include "tests/support/plant_cases.hpp"

namespace lagrange {
namespace {

Scene TwoControllerScene(const std::string& fallback) {
  return ParseScene(R"(
period: 0.002
instances:
  - name: arm
    plant: {type: arm2}
    controller: {type: external)" +
                        fallback + R"(}
    controllers:
      - {type: pd, kp: 10, kd: 1}
      - {type: gravity-compensation, kp: 10, kd: 1}
)",
                    "inline");
}

TEST(InstanceModel, TimeoutsAndFallbacksComeFromTheSceneAndTheTypesDefaultsOnce) {
  const Scene scene = TwoControllerScene("");
  const std::shared_ptr<const DaemonModel> model = BuildDaemonModel(scene);
  const InstanceModel& m = model->instances[0];
  EXPECT_EQ(m.setpoint_timeout, ToNanoseconds(InstanceConfig{}.setpoint_timeout));
  EXPECT_EQ(m.external_controller, 0);
  ASSERT_EQ(m.controllers.size(), 4u);  // external, pd, gravity-compensation, none
  EXPECT_EQ(m.controllers[3].name, "none");
  const ControllerModel& external = m.controllers[0];
  EXPECT_TRUE(external.external);
  EXPECT_EQ(external.torque_timeout, ToNanoseconds(ExternalOptions{}.torque_timeout));
  // No fallback named: the first gravity-compensation (or computed-torque) controller holds.
  EXPECT_EQ(external.fallback.kind, HoldBy::Kind::kController);
  EXPECT_EQ(external.fallback.controller, 2u);
  EXPECT_EQ(m.command_rules.controllers, (std::vector<std::string>{"external", "pd", "gravity-compensation", "none"}));
  EXPECT_EQ(m.state_timeout, 0) << "not an external plant";

  const InstanceModel brake = BuildInstanceModel(TwoControllerScene(", fallback: brake").instances[0]);
  EXPECT_EQ(brake.controllers[0].fallback.kind, HoldBy::Kind::kBrake);
  const InstanceModel pd = BuildInstanceModel(TwoControllerScene(", fallback: pd").instances[0]);
  EXPECT_EQ(pd.controllers[0].fallback.controller, 1u);
}

TEST(InstanceModel, TheEstopBrakeDefaultsToAFiftyMillisecondTimeConstantAtTheInitialPose) {
  const InstanceModel m = BuildInstanceModel(TwoControllerScene("").instances[0]);
  const MatrixXd M = testing::MassMatrixOf(m.config.plant, Method::kClosedForm, m.config.q0);
  EXPECT_LE((m.brake - 20.0 * M.diagonal()).norm(), 1e-12 * M.norm());
}

// The tick, and through the runtime the receive and publish threads, read one model.
TEST(InstanceModel, TheRuntimeAndItsInstancesShareTheOneModel) {
  const std::shared_ptr<const DaemonModel> model = BuildDaemonModel(TwoControllerScene(""), BuildOptions::Prefixed("P_"));
  Runtime runtime(model);
  EXPECT_EQ(&runtime.model(), model.get());
  EXPECT_EQ(&runtime.instance(0).instance_model(), &model->instances[0]);
  EXPECT_EQ(model->instances[0].channels.setpoint, "P_ARM_SETPOINT");
  EXPECT_EQ(model->instances[0].channels.torque_in, "P_ARM_TORQUE");
  EXPECT_EQ(model->status_channel, "P_LAGRANGE_STATUS");
  // The dynamics models are shared too: the instance's plant and its controllers use the model's.
  EXPECT_GE(model->instances[0].dynamics[static_cast<std::size_t>(Method::kClosedForm)].use_count(), 3);
}

}  // namespace
}  // namespace lagrange
