#pragma once
// A scene: the plant instances lagranged (or lagrangectl simulate) runs,
// parsed once from YAML into typed structs and validated before anything runs.
// See README.md, "Scene reference", for every key.

#include <string>
#include <vector>

#include "plant/effects.hpp"
#include "plant/integrators.hpp"
#include "plant/plant_spec.hpp"

namespace lagrange {

struct InstanceConfig {
  std::string name;  // [a-z][a-z0-9_]*, unique in the scene
  PlantSpec plant;
  Method method = Method::kClosedForm;
  VectorXd q0;   // initial positions (n)
  VectorXd qd0;  // initial velocities (n)
  EffectsConfig effects;
  IntegratorConfig integrator;
};

struct Scene {
  std::string file;         // where it was loaded from
  std::string description;  // free text
  double period = 1e-3;     // s, the tick (and offline step) length
  std::vector<InstanceConfig> instances;
};

// Throw ConfigError (daemon/yaml_reader.hpp) naming file, line, key and reason.
Scene LoadScene(const std::string& path);
Scene ParseScene(const std::string& yaml_text, const std::string& file_label);

}  // namespace lagrange
