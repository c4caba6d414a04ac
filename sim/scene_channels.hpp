#pragma once
// The channels an instance of a scene reads and writes: the derived ones
// (protocol/channels.hpp) under the run's --channel-prefix, and the ones the
// scene writes (an external controller's torque_channel, an external plant's
// state_channel and torque_channel), used exactly as written.

#include <string>
#include <vector>

#include "protocol/channels.hpp"
#include "sim/scene.hpp"

namespace lagrange {

InstanceChannelNames SceneChannelNames(const InstanceConfig& instance, const std::string& prefix);
// Every instance's, in the scene's order.
std::vector<InstanceChannelNames> SceneChannelNames(const Scene& scene, const std::string& prefix);

}  // namespace lagrange
