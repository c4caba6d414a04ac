// libFuzzer target: the scene parser. Any text is either refused with a
// ConfigError or becomes a scene whose instances build and run a few ticks;
// nothing else may escape, crash or trip a sanitizer.

#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>

#include "daemon/runtime.hpp"
#include "sim/scene.hpp"
#include "sim/yaml_reader.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace lagrange;
  Scene scene;
  try {
    scene = ParseScene(std::string(reinterpret_cast<const char*>(data), size), "fuzz.yaml");
  } catch (const ConfigError&) {
    return 0;  // refused, as it should be
  }
  int dofs = 0;
  for (const InstanceConfig& c : scene.instances) dofs += c.plant.num_dofs();
  if (dofs > 16) return 0;  // keep each run fast; size is covered by the unit tests
  std::unique_ptr<Runtime> runtime;
  try {
    runtime = std::make_unique<Runtime>(scene);  // LQR design may refuse a scene: lagranged reports it at start
  } catch (const std::invalid_argument&) {
    return 0;
  }
  TickRecord record = runtime->MakeRecord();
  for (int k = 1; k <= 20; ++k) runtime->Tick(k * 1'000'000, record);
  for (const InstanceRecord& r : record.instances) {
    if (!r.q.allFinite() || !r.qd.allFinite() || !r.tau.allFinite()) __builtin_trap();  // never publish non-finite
  }
  return 0;
}
