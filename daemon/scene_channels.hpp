#pragma once
// The channels of a scene: the names derived from its instances
// (protocol/channels.hpp) and the ones its external controllers and plants
// write themselves.

#include <string>

#include "daemon/scene.hpp"
#include "protocol/channels.hpp"

namespace lagrange {

// Every channel of a scene: the derived ones with the prefix, the ones the
// scene writes as written.
ChannelNames SceneChannelNames(const Scene& scene, const std::string& prefix);

}  // namespace lagrange
