#include "daemon/scene_channels.hpp"

namespace lagrange {

ChannelNames SceneChannelNames(const Scene& scene, const std::string& prefix) {
  std::vector<std::string> names;
  for (const InstanceConfig& inst : scene.instances) names.push_back(inst.name);
  ChannelNames c = MakeChannelNames(names, prefix);
  for (std::size_t i = 0; i < scene.instances.size(); ++i) {
    const InstanceConfig& inst = scene.instances[i];
    if (const ExternalControllerRef external = ExternalControllerOf(inst); external.config != nullptr) {
      const std::string& written = external.config->external.torque_channel;
      c.torque_in[i] = written.empty() ? InstanceChannel(prefix, inst.name, kTorqueSuffix) : written;
    }
    if (inst.external) {
      c.measured_in[i] = inst.external->state_channel;
      c.torque_out[i] = inst.external->torque_channel;
    }
  }
  return c;
}

}  // namespace lagrange
