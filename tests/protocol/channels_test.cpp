// Channel names (protocol/channels.hpp): derived from the instance's name in
// upper case under a prefix, a name a scene may write, and which LCM URL is
// used. Scenes' own channels and the conflicts between them are
// tests/daemon/external_scene_test's.

#include "protocol/channels.hpp"

#include <gtest/gtest.h>
#include <stdlib.h>

#include <string>

namespace lagrange {
namespace {

TEST(Channels, AnInstancesChannelsAreItsNameInUpperCaseUnderThePrefix) {
  EXPECT_EQ(InstanceChannel("", "arm", kStateSuffix), "ARM_STATE");
  EXPECT_EQ(InstanceChannel("LEFT_", "chain_7", kSetpointSuffix), "LEFT_CHAIN_7_SETPOINT");
  const InstanceChannelNames arm = DerivedChannelNames("P_", "arm"), pole = DerivedChannelNames("P_", "pole");
  EXPECT_EQ(arm.command, "P_ARM_COMMAND");
  EXPECT_EQ(pole.command, "P_POLE_COMMAND");
  EXPECT_EQ(pole.reply, "P_POLE_REPLY");
  EXPECT_EQ(arm.state, "P_ARM_STATE");
  EXPECT_EQ(arm.setpoint, "P_ARM_SETPOINT");
  EXPECT_EQ(arm.telemetry, "P_ARM_TELEMETRY");
  EXPECT_EQ(pole.forces, "P_POLE_FORCES");
  EXPECT_EQ(arm.pose, "P_ARM_POSE");
  EXPECT_EQ(arm.task, "P_ARM_TASK");
  EXPECT_EQ(StatusChannel("P_"), "P_LAGRANGE_STATUS");
  EXPECT_EQ(arm.torque_in, "");  // a scene's to name
  EXPECT_EQ(arm.measured_in, "");
  EXPECT_EQ(arm.torque_out, "");
}

TEST(Channels, AWrittenNameIsOneTo63PrintableBytesWithoutSpaces) {
  EXPECT_EQ(CheckChannelName("MY_TORQUE"), "");
  EXPECT_EQ(CheckChannelName(std::string(63, 'X')), "");
  EXPECT_EQ(CheckChannelName(""), "expected an LCM channel name of 1 to 63 bytes, got 0");
  EXPECT_EQ(CheckChannelName(std::string(64, 'X')), "expected an LCM channel name of 1 to 63 bytes, got 64");
  EXPECT_EQ(CheckChannelName("A B"), "expected an LCM channel name of printable ASCII without spaces, got 'A B'");
  EXPECT_EQ(CheckChannelName("A\nB"), "expected an LCM channel name of printable ASCII without spaces, got 'A\\nB'");
}

TEST(Channels, TheUrlIsTheOptionElseTheEnvironmentElseTheDefault) {
  const char* saved = getenv("LCM_DEFAULT_URL");
  const std::string restore = saved ? saved : "";
  unsetenv("LCM_DEFAULT_URL");
  EXPECT_EQ(ResolveLcmUrl(""), kDefaultLcmUrl);
  setenv("LCM_DEFAULT_URL", "udpm://239.255.76.67:7001?ttl=0", 1);
  EXPECT_EQ(ResolveLcmUrl(""), "udpm://239.255.76.67:7001?ttl=0");
  EXPECT_EQ(ResolveLcmUrl("udpm://239.255.76.67:7002?ttl=0"), "udpm://239.255.76.67:7002?ttl=0");
  if (saved) {
    setenv("LCM_DEFAULT_URL", restore.c_str(), 1);
  } else {
    unsetenv("LCM_DEFAULT_URL");
  }
}

}  // namespace
}  // namespace lagrange
