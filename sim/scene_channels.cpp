#include "sim/scene_channels.hpp"

namespace lagrange {

InstanceChannelNames SceneChannelNames(const InstanceConfig& inst, const std::string& prefix) {
  InstanceChannelNames c = DerivedChannelNames(prefix, inst.name);
  if (!inst.floating) c.base.clear();  // only a floating base publishes one
  if (const ExternalControllerRef external = ExternalControllerOf(inst); external.config != nullptr) {
    const std::string& written = external.config->external.torque_channel;
    c.torque_in = written.empty() ? InstanceChannel(prefix, inst.name, kTorqueSuffix) : written;
  }
  if (inst.external) {
    c.measured_in = inst.external->state_channel;
    c.torque_out = inst.external->torque_channel;
  }
  return c;
}

std::vector<InstanceChannelNames> SceneChannelNames(const Scene& scene, const std::string& prefix) {
  std::vector<InstanceChannelNames> all;
  for (const InstanceConfig& inst : scene.instances) all.push_back(SceneChannelNames(inst, prefix));
  return all;
}

}  // namespace lagrange
