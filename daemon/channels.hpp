#pragma once
// LCM channel names: instance `arm` uses ARM_STATE, ARM_SETPOINT and
// ARM_COMMAND; the daemon publishes LAGRANGE_STATUS. A prefix P is prepended
// to every channel, so several daemons share one bus.

#include <string>
#include <vector>

namespace lagrange {

struct ChannelNames {
  std::vector<std::string> state, setpoint, command;  // one per instance
  std::string status;
};

ChannelNames MakeChannelNames(const std::vector<std::string>& instance_names, const std::string& prefix);

// The default LCM URL when neither --lcm-url nor LCM_DEFAULT_URL is given.
inline constexpr const char* kDefaultLcmUrl = "udpm://239.255.76.67:7667?ttl=0";

// --lcm-url if given, else $LCM_DEFAULT_URL, else kDefaultLcmUrl.
std::string ResolveLcmUrl(const std::string& option);

}  // namespace lagrange
