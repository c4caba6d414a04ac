#pragma once
// Running a scene offline: every instance from its initial state under its
// scene controller and trajectory, as fast as the machine goes, under the
// daemon's health rule (daemon/health.hpp) after every step.

#include <cstdint>
#include <functional>
#include <vector>

#include "daemon/instance.hpp"

namespace lagrange {

// Called at t = 0 and after every healthy step with the instance's index.
using StepObserver = std::function<void(std::size_t index, Instance& instance)>;

// An instance that failed the health check.
struct OfflineFault {
  std::size_t index = 0;         // the instance
  double t = 0.0;                // s: the time the failed step reached
  const char* reason = nullptr;  // as lagranged reports it (static string)
  double max_energy = 0.0;       // J: the instance's bound on |T + V|
};

// Why an instance cannot run offline (null when it can): an external plant
// or an external controller needs the bus, so only lagranged runs them.
const char* OfflineRefusal(const InstanceConfig& config);

// Runs `steps` steps of `period`. After every step the daemon's health check
// runs (non-finite torque or state, a failed integrator, |T + V| > max_energy,
// |ε| > energy_balance.bound under on_exceed: fault);
// an instance that fails it is never observed again: it is put back to its last
// healthy state and stops there, the others go on. Returns the faults in the
// order they happened (empty: every instance ran every step).
std::vector<OfflineFault> RunOfflineChecked(std::vector<Instance>& instances, double period, std::int64_t steps,
                                            const StepObserver& observe);

// The same; true when no instance faulted.
bool RunOffline(std::vector<Instance>& instances, double period, std::int64_t steps, const StepObserver& observe);

}  // namespace lagrange
