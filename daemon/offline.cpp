#include "daemon/offline.hpp"

#include "daemon/health.hpp"

namespace lagrange {

std::vector<OfflineFault> RunOfflineChecked(std::vector<Instance>& instances, double period, std::int64_t steps,
                                            const StepObserver& observe) {
  std::vector<OfflineFault> faults;
  std::vector<bool> healthy(instances.size(), true);
  std::vector<Instance::Saved> good;
  for (std::size_t i = 0; i < instances.size(); ++i) {
    good.push_back(instances[i].MakeSaved());
    observe(i, instances[i]);
  }
  StepEnergies energies;
  for (std::int64_t k = 0; k < steps; ++k) {
    for (std::size_t i = 0; i < instances.size(); ++i) {
      if (!healthy[i]) continue;
      Instance& inst = instances[i];
      const double max_energy = inst.instance_model().max_energy;
      const Instance::StepFailure step = inst.Step(period);
      if (const char* why = CheckStepHealth(inst, step, max_energy, inst.instance_model().residual_bound, energies)) {
        faults.push_back({i, inst.t(), why, max_energy});
        healthy[i] = false;
        inst.Restore(good[i]);
        continue;
      }
      inst.Save(good[i]);
      observe(i, inst);
    }
  }
  return faults;
}

const char* OfflineRefusal(const InstanceConfig& c) {
  if (c.external) return "its plant is external (measured over LCM): only lagranged runs it";
  if (c.controller.type == ControllerType::kExternal) {
    return "its controller is external (torques over LCM): only lagranged runs it";
  }
  return nullptr;
}

bool RunOffline(std::vector<Instance>& instances, double period, std::int64_t steps, const StepObserver& observe) {
  return RunOfflineChecked(instances, period, steps, observe).empty();
}

}  // namespace lagrange
