#include "daemon/offline.hpp"

#include <algorithm>

namespace lagrange {

bool RunOffline(std::vector<Instance>& instances, double period, std::int64_t steps, const StepObserver& observe) {
  std::vector<bool> healthy(instances.size(), true);
  for (std::size_t i = 0; i < instances.size(); ++i) observe(i, instances[i]);
  for (std::int64_t k = 0; k < steps; ++k) {
    for (std::size_t i = 0; i < instances.size(); ++i) {
      if (!healthy[i]) continue;
      Instance& inst = instances[i];
      const bool ok = inst.Step(period);
      healthy[i] = ok && inst.q().allFinite() && inst.qd().allFinite();
      observe(i, inst);
    }
  }
  return std::all_of(healthy.begin(), healthy.end(), [](bool h) { return h; });
}

}  // namespace lagrange
