#include "protocol/channels.hpp"

#include "base/escape.hpp"

#include <algorithm>
#include <cctype>
#include <cstdlib>

namespace lagrange {

std::string InstanceChannel(const std::string& prefix, const std::string& instance, const char* suffix) {
  std::string upper = instance;
  for (char& ch : upper) ch = static_cast<char>(std::toupper(static_cast<unsigned char>(ch)));
  return prefix + upper + suffix;
}

InstanceChannelNames DerivedChannelNames(const std::string& prefix, const std::string& instance) {
  InstanceChannelNames c;
  c.instance = instance;
  c.state = InstanceChannel(prefix, instance, kStateSuffix);
  c.setpoint = InstanceChannel(prefix, instance, kSetpointSuffix);
  c.command = InstanceChannel(prefix, instance, kCommandSuffix);
  c.reply = InstanceChannel(prefix, instance, kReplySuffix);
  c.telemetry = InstanceChannel(prefix, instance, kTelemetrySuffix);
  c.forces = InstanceChannel(prefix, instance, kForcesSuffix);
  c.pose = InstanceChannel(prefix, instance, kPoseSuffix);
  c.task = InstanceChannel(prefix, instance, kTaskSuffix);
  c.mpc = InstanceChannel(prefix, instance, kMpcSuffix);
  c.base = InstanceChannel(prefix, instance, kBaseSuffix);
  return c;
}

std::string CheckChannelName(const std::string& channel) {
  if (channel.empty() || channel.size() > 63) {
    return "expected an LCM channel name of 1 to 63 bytes, got " + std::to_string(channel.size());
  }
  for (const char ch : channel) {
    if (ch <= ' ' || ch > '~') {
      return "expected an LCM channel name of printable ASCII without spaces, got '" + Escape(channel, 64) + "'";
    }
  }
  return "";
}

std::string CheckChannelNames(const std::vector<InstanceChannelNames>& instances, const std::string& status) {
  // Every output, with who publishes it.
  std::vector<std::pair<std::string, std::string>> outputs;
  for (const InstanceChannelNames& c : instances) {
    outputs.emplace_back(c.state, c.instance + "'s state");
    outputs.emplace_back(c.reply, c.instance + "'s replies");
    outputs.emplace_back(c.telemetry, c.instance + "'s telemetry");
    outputs.emplace_back(c.forces, c.instance + "'s forces");
    if (!c.task.empty()) outputs.emplace_back(c.task, c.instance + "'s task state");
    if (!c.mpc.empty()) outputs.emplace_back(c.mpc, c.instance + "'s plans");
    if (!c.base.empty()) outputs.emplace_back(c.base, c.instance + "'s base state");
    if (!c.torque_out.empty()) outputs.emplace_back(c.torque_out, c.instance + "'s torque_channel");
  }
  outputs.emplace_back(status, "the status");
  for (std::size_t a = 0; a < outputs.size(); ++a) {
    for (std::size_t b = a + 1; b < outputs.size(); ++b) {
      if (outputs[a].first == outputs[b].first) {
        return "channel " + outputs[a].first + " would carry both " + outputs[a].second + " and " + outputs[b].second;
      }
    }
  }
  // Every input, with the instance that reads it.
  struct Input {
    const std::string* channel;
    std::size_t instance;
    std::string_view what;
  };
  std::vector<Input> inputs;
  for (std::size_t i = 0; i < instances.size(); ++i) {
    const InstanceChannelNames& c = instances[i];
    for (const auto& [channel, what] :
         {std::pair{&c.setpoint, "setpoints"}, std::pair{&c.command, "commands"}, std::pair{&c.torque_in, "torques"},
          std::pair{&c.measured_in, "state_channel"}, std::pair{&c.pose, "pose setpoints"}}) {
      if (!channel->empty()) inputs.push_back({channel, i, what});
    }
  }
  for (const Input& in : inputs) {
    for (const auto& [out, who] : outputs) {
      if (*in.channel == out) {
        return instances[in.instance].instance + " reads its " + std::string(in.what) + " from " + out +
               ", which this lagranged publishes (" + who + "): give it another --channel-prefix";
      }
    }
  }
  // One channel, one kind of message for one instance; two external plants may share a measured state.
  for (std::size_t a = 0; a < inputs.size(); ++a) {
    for (std::size_t b = a + 1; b < inputs.size(); ++b) {
      const Input& x = inputs[a];
      const Input& y = inputs[b];
      if (*x.channel != *y.channel || (x.what == "state_channel" && y.what == "state_channel")) continue;
      return instances[x.instance].instance + " reads its " + std::string(x.what) + " and " +
             instances[y.instance].instance + " its " + std::string(y.what) + " from the same channel " + *x.channel;
    }
  }
  return "";
}

bool IsInstanceName(const std::string& name) {
  if (name.empty() || name.size() > kMaxInstanceNameBytes || !(name[0] >= 'a' && name[0] <= 'z')) return false;
  return std::all_of(name.begin(), name.end(),
                     [](char c) { return (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_'; });
}

std::string ResolveLcmUrl(const std::string& option) {
  if (!option.empty()) return option;
  if (const char* env = std::getenv("LCM_DEFAULT_URL"); env != nullptr && *env != '\0') return env;
  return kDefaultLcmUrl;
}

}  // namespace lagrange
