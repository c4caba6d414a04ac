#pragma once
// Running a scene offline: every instance from its initial state under its
// scene controller and trajectory, as fast as the machine goes.

#include <cstdint>
#include <functional>
#include <vector>

#include "daemon/instance.hpp"

namespace lagrange {

// Called at t = 0 and after every step with the instance's index.
using StepObserver = std::function<void(std::size_t index, Instance& instance)>;

// Runs `steps` steps of `period`. Returns false if a controller faulted, an
// integrator failed its tolerance or a state became non-finite; that
// instance stops there, the others go on.
bool RunOffline(std::vector<Instance>& instances, double period, std::int64_t steps, const StepObserver& observe);

}  // namespace lagrange
