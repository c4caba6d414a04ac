#pragma once
// A shipped scene (config/NAME) loaded for a test, its instances built, and
// run offline as lagrangectl simulate runs it: lagranged's health check at
// every step, a fault a test failure.

#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "sim/instance.hpp"
#include "sim/offline.hpp"
#include "sim/scene.hpp"

namespace lagrange::testing {

struct LoadedScene {
  Scene scene;
  std::vector<Instance> instances;
};

// config/`name` from the source tree, every instance built.
inline LoadedScene LoadShippedScene(const std::string& name) {
  LoadedScene l{LoadScene(std::string(LAGRANGE_SOURCE_DIR) + "/config/" + name), {}};
  for (const InstanceConfig& c : l.scene.instances) l.instances.emplace_back(c);
  return l;
}

// Runs every instance for `seconds` under the health check; `observe` sees each step.
inline void RunShippedScene(LoadedScene& l, double seconds, const StepObserver& observe) {
  const std::vector<OfflineFault> faults =
      RunOfflineChecked(l.instances, l.scene.period, std::llround(seconds / l.scene.period), observe);
  for (const OfflineFault& f : faults) ADD_FAILURE() << l.instances[f.index].name() << " faulted: " << f.reason;
}

}  // namespace lagrange::testing
