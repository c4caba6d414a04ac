#pragma once
// LCM channel names, written once for lagranged and lagrangectl: instance
// `arm` uses ARM_STATE, ARM_SETPOINT, ARM_COMMAND, ARM_REPLY, ARM_TELEMETRY,
// ARM_FORCES, ARM_POSE, ARM_TASK, ARM_MPC and (a floating base) ARM_BASE; the daemon
// publishes LAGRANGE_STATUS. A prefix P is prepended to every channel, so
// several daemons share one bus.

#include <cstddef>
#include <string>
#include <vector>

namespace lagrange {

inline constexpr const char* kStateSuffix = "_STATE";
inline constexpr const char* kSetpointSuffix = "_SETPOINT";
inline constexpr const char* kCommandSuffix = "_COMMAND";
inline constexpr const char* kReplySuffix = "_REPLY";
inline constexpr const char* kTorqueSuffix = "_TORQUE";
inline constexpr const char* kTelemetrySuffix = "_TELEMETRY";
inline constexpr const char* kForcesSuffix = "_FORCES";
inline constexpr const char* kPoseSuffix = "_POSE";  // pose setpoints in (pose_setpoint_t)
inline constexpr const char* kTaskSuffix = "_TASK";  // the commanded frame out (task_state_t)
inline constexpr const char* kMpcSuffix = "_MPC";    // an mpc controller's plans out (mpc_t)
inline constexpr const char* kBaseSuffix = "_BASE";  // a floating base's pose, twist and momentum out (base_state_t)
inline constexpr const char* kStatusChannel = "LAGRANGE_STATUS";

// prefix + instance in upper case + suffix, e.g. ("", "arm", "_STATE") → "ARM_STATE".
std::string InstanceChannel(const std::string& prefix, const std::string& instance, const char* suffix);

// One instance's channels.
struct InstanceChannelNames {
  std::string instance;  // its name, for messages
  std::string state, setpoint, command, reply, telemetry, forces, pose, task, mpc;
  std::string base;  // a floating base's (derived always; a scene clears it for a fixed base: SceneChannelNames)
  // "" where the instance has none:
  std::string torque_in;    // an external controller's torques (derived, or as the scene wrote it)
  std::string measured_in;  // an external plant's measured state (as written)
  std::string torque_out;   // an external plant's torque command (as written)
};

// The derived names of instance `instance` under `prefix` (torque_in,
// measured_in, torque_out ""; a scene's own names are the daemon's to add).
InstanceChannelNames DerivedChannelNames(const std::string& prefix, const std::string& instance);
// The status channel under `prefix`.
inline std::string StatusChannel(const std::string& prefix) { return prefix + kStatusChannel; }

// Why one run's channels cannot work (an input that is one of this run's
// outputs, an output two instances share), or "" when they can.
std::string CheckChannelNames(const std::vector<InstanceChannelNames>& instances, const std::string& status);
// A channel name a scene may write: 1-63 bytes of printable ASCII without
// spaces. "" when valid, else what was expected.
std::string CheckChannelName(const std::string& channel);

// An instance name a scene may give: 1-48 bytes, [a-z][a-z0-9_]* (sim/scene's rule, and what a client
// follows of the names a status gives).
inline constexpr std::size_t kMaxInstanceNameBytes = 48;
bool IsInstanceName(const std::string& name);

// The default LCM URL when neither --lcm-url nor LCM_DEFAULT_URL is given.
inline constexpr const char* kDefaultLcmUrl = "udpm://239.255.76.67:7667?ttl=0";

// --lcm-url if given, else $LCM_DEFAULT_URL, else kDefaultLcmUrl.
std::string ResolveLcmUrl(const std::string& option);

}  // namespace lagrange
