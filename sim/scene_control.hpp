#pragma once
// Reading the control parts of a scene: controllers and setpoint trajectories;
// and the URDF files a scene names.

#include <map>
#include <memory>
#include <string>

#include "controllers/factory.hpp"
#include "plant/plant_factory.hpp"
#include "plant/urdf.hpp"
#include "sim/trajectory_config.hpp"
#include "sim/yaml_reader.hpp"

namespace lagrange {

// The robots one scene reads from URDF files (plant.file, a controller's
// model.file), each file read once. A relative path is relative to the
// scene file's directory.
class UrdfFiles {
 public:
  explicit UrdfFiles(const std::string& scene_file);
  // The robot in the file `node` names. Fails at `node` with LoadUrdf's
  // one-line message (the scene file, the key, then "URDF: ELEMENT: reason").
  // With options.floating_base, the file read on a free base (plant/urdf.hpp).
  std::shared_ptr<const UrdfRobot> Load(const YamlReader& node, const UrdfOptions& options = {});

 private:
  std::string dir_;
  std::map<std::pair<std::string, bool>, std::shared_ptr<const UrdfRobot>> loaded_;  // by resolved path, floating
};

// A controller run every `period` s on `plant` starting from q0 (n): both
// bound its gains (ComputeGainBounds); the instance's `integrator` is what a
// discrete-time LQR (design: discrete) is designed for. A urdf plant's
// `model: {file: ...}` is read through `urdf`.
ControllerConfig ReadController(const YamlReader& node, const PlantSpec& plant, double period, const VectorXd& q0,
                                const IntegratorConfig& integrator, UrdfFiles& urdf);
TrajectoryConfig ReadTrajectory(const YamlReader& node, int n);

// Sets a urdf spec's parameter from YAML: gravity: [gx, gy, gz] (m/s²) or
// mass_scale: a positive factor. Fails at `value` otherwise.
void SetUrdfParam(PlantSpec& spec, const std::string& key, const YamlReader& value);

}  // namespace lagrange
