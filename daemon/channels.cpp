#include "daemon/channels.hpp"

#include <cctype>
#include <cstdlib>

namespace lagrange {

ChannelNames MakeChannelNames(const std::vector<std::string>& instance_names, const std::string& prefix) {
  ChannelNames c;
  for (const std::string& name : instance_names) {
    std::string upper = name;
    for (char& ch : upper) ch = static_cast<char>(std::toupper(static_cast<unsigned char>(ch)));
    c.state.push_back(prefix + upper + "_STATE");
    c.setpoint.push_back(prefix + upper + "_SETPOINT");
    c.command.push_back(prefix + upper + "_COMMAND");
  }
  c.status = prefix + "LAGRANGE_STATUS";
  return c;
}

std::string ResolveLcmUrl(const std::string& option) {
  if (!option.empty()) return option;
  if (const char* env = std::getenv("LCM_DEFAULT_URL"); env != nullptr && *env != '\0') return env;
  return kDefaultLcmUrl;
}

}  // namespace lagrange
