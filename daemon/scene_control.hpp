#pragma once
// Reading the control parts of a scene: controllers and setpoint trajectories.

#include "daemon/scene.hpp"
#include "daemon/yaml_reader.hpp"

namespace lagrange {

ControllerConfig ReadController(const YamlReader& node, const PlantSpec& plant);
TrajectoryConfig ReadTrajectory(const YamlReader& node, int n);

}  // namespace lagrange
