#pragma once
// Reading the control parts of a scene: controllers and setpoint trajectories.

#include "daemon/scene.hpp"
#include "daemon/yaml_reader.hpp"

namespace lagrange {

// A controller run every `period` s on `plant` starting from q0 (n): both
// bound its gains (ComputeGainBounds).
ControllerConfig ReadController(const YamlReader& node, const PlantSpec& plant, double period, const VectorXd& q0);
TrajectoryConfig ReadTrajectory(const YamlReader& node, int n);

}  // namespace lagrange
