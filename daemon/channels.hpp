#pragma once
// LCM channel names, written once for lagranged and lagrangectl: instance
// `arm` uses ARM_STATE, ARM_SETPOINT, ARM_COMMAND and ARM_REPLY; the daemon
// publishes LAGRANGE_STATUS. A prefix P is prepended to every channel, so
// several daemons share one bus.

#include <string>
#include <vector>

namespace lagrange {

inline constexpr const char* kStateSuffix = "_STATE";
inline constexpr const char* kSetpointSuffix = "_SETPOINT";
inline constexpr const char* kCommandSuffix = "_COMMAND";
inline constexpr const char* kReplySuffix = "_REPLY";
inline constexpr const char* kStatusChannel = "LAGRANGE_STATUS";

// prefix + instance in upper case + suffix, e.g. ("", "arm", "_STATE") → "ARM_STATE".
std::string InstanceChannel(const std::string& prefix, const std::string& instance, const char* suffix);

struct ChannelNames {
  std::vector<std::string> state, setpoint, command, reply;  // one per instance
  std::string status;
};

ChannelNames MakeChannelNames(const std::vector<std::string>& instance_names, const std::string& prefix);

// The default LCM URL when neither --lcm-url nor LCM_DEFAULT_URL is given.
inline constexpr const char* kDefaultLcmUrl = "udpm://239.255.76.67:7667?ttl=0";

// --lcm-url if given, else $LCM_DEFAULT_URL, else kDefaultLcmUrl.
std::string ResolveLcmUrl(const std::string& option);

}  // namespace lagrange
