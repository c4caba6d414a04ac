#include "protocol/channels.hpp"

#include "plant/escape.hpp"

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
    c.telemetry.push_back(InstanceChannel(prefix, name, kTelemetrySuffix));
    c.forces.push_back(InstanceChannel(prefix, name, kForcesSuffix));
  }
  c.torque_in.assign(instance_names.size(), "");
  c.measured_in.assign(instance_names.size(), "");
  c.torque_out.assign(instance_names.size(), "");
  c.status = prefix + kStatusChannel;
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

std::string CheckChannelNames(const ChannelNames& c, const std::vector<std::string>& names) {
  // Every output, with who publishes it.
  std::vector<std::pair<std::string, std::string>> outputs;
  for (std::size_t i = 0; i < names.size(); ++i) {
    outputs.emplace_back(c.state[i], names[i] + "'s state");
    outputs.emplace_back(c.reply[i], names[i] + "'s replies");
    if (i < c.telemetry.size()) outputs.emplace_back(c.telemetry[i], names[i] + "'s telemetry");
    if (i < c.forces.size()) outputs.emplace_back(c.forces[i], names[i] + "'s forces");
    if (!c.torque_out[i].empty()) outputs.emplace_back(c.torque_out[i], names[i] + "'s torque_channel");
  }
  outputs.emplace_back(c.status, "the status");
  for (std::size_t a = 0; a < outputs.size(); ++a) {
    for (std::size_t b = a + 1; b < outputs.size(); ++b) {
      if (outputs[a].first == outputs[b].first) {
        return "channel " + outputs[a].first + " would carry both " + outputs[a].second + " and " +
               outputs[b].second;
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
  for (std::size_t i = 0; i < names.size(); ++i) {
    for (const auto& [channel, what] : {std::pair{&c.setpoint[i], "setpoints"}, std::pair{&c.command[i], "commands"},
                                        std::pair{&c.torque_in[i], "torques"},
                                        std::pair{&c.measured_in[i], "state_channel"}}) {
      if (!channel->empty()) inputs.push_back({channel, i, what});
    }
  }
  for (const Input& in : inputs) {
    for (const auto& [out, who] : outputs) {
      if (*in.channel == out) {
        return names[in.instance] + " reads its " + std::string(in.what) + " from " + out +
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
      return names[x.instance] + " reads its " + std::string(x.what) + " and " + names[y.instance] + " its " +
             std::string(y.what) + " from the same channel " + *x.channel;
    }
  }
  return "";
}

std::string ResolveLcmUrl(const std::string& option) {
  if (!option.empty()) return option;
  if (const char* env = std::getenv("LCM_DEFAULT_URL"); env != nullptr && *env != '\0') return env;
  return kDefaultLcmUrl;
}

}  // namespace lagrange
