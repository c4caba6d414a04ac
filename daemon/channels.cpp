#include "daemon/channels.hpp"

#include <cctype>
#include <cstdlib>

namespace lagrange {

std::string InstanceChannel(const std::string& prefix, const std::string& instance, const char* suffix) {
  std::string upper = instance;
  for (char& ch : upper) ch = static_cast<char>(std::toupper(static_cast<unsigned char>(ch)));
  return prefix + upper + suffix;
}

ChannelNames MakeChannelNames(const std::vector<std::string>& instance_names, const std::string& prefix) {
  ChannelNames c;
  for (const std::string& name : instance_names) {
    c.state.push_back(InstanceChannel(prefix, name, kStateSuffix));
    c.setpoint.push_back(InstanceChannel(prefix, name, kSetpointSuffix));
    c.command.push_back(InstanceChannel(prefix, name, kCommandSuffix));
    c.reply.push_back(InstanceChannel(prefix, name, kReplySuffix));
  }
  c.status = prefix + kStatusChannel;
  return c;
}

std::string ResolveLcmUrl(const std::string& option) {
  if (!option.empty()) return option;
  if (const char* env = std::getenv("LCM_DEFAULT_URL"); env != nullptr && *env != '\0') return env;
  return kDefaultLcmUrl;
}

}  // namespace lagrange
