#pragma once
// Running a scene offline: every instance from its initial state under its
// scene controller and trajectory, as fast as the machine goes, under the
// daemon's health rule (sim/health.hpp) after every step.

#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "protocol/log_records.hpp"
#include "sim/instance.hpp"
#include "sim/instance_model.hpp"

namespace lagrange {

struct StepEnergies;  // sim/health.hpp

// Called at t = 0 and after every healthy step with the instance's index.
using StepObserver = std::function<void(std::size_t index, Instance& instance)>;

// An instance that failed the health check.
struct OfflineFault {
  std::size_t index = 0;         // the instance
  double t = 0.0;                // s: the time the failed step reached
  const char* reason = nullptr;  // as lagranged reports it (static string)
  double max_energy = 0.0;       // J: the instance's bound on |T + V|
};

// "NAME faulted at t = T s: REASON" and the bound it left, for a message.
std::string OfflineFaultText(const Instance& instance, const OfflineFault& fault);

// "NAME: K of S mpc solves failed (line-search-failed 2, diverged 1); ..."
// when an mpc controller of the instance had solves that failed, with the
// status words lagranged's status gives them ("the mpc solve failed: ...");
// nullopt when none failed. Offline a failed plan is not taken: the last
// usable one is followed (none yet: no force), where lagranged hands the
// instance to its fallback.
std::optional<std::string> OfflineMpcFailureText(const Instance& instance);

// Why an instance cannot run offline (null when it can): an external plant
// or an external controller needs the bus, so only lagranged runs them.
const char* OfflineRefusal(const InstanceConfig& config);

// A scene's instances, built for an offline run as lagrangectl simulate and
// the Python module (lagrange.simulate, lagrange.Instance) build them: the
// daemon's model (costs measured, as lagranged measures them) and one Instance
// per scene instance, in scene order.
struct OfflineScene {
  std::shared_ptr<const DaemonModel> model;
  std::vector<Instance> instances;  // reserved once: never reallocated
  double period = 0.0;              // s
};
// Throws std::runtime_error, one line, when an instance cannot run offline
// ("SCENE: instance NAME cannot run offline: " + OfflineRefusal) or the
// scene's ticks would not fit its period in real time (CheckWorkBounds, the
// daemon's rule and message). `steps_external_controller(i)`: instance i's
// external controller gets its torques from the caller (a Python controller
// stepping it), so that alone does not refuse it.
OfflineScene PrepareOfflineScene(const Scene& scene, const std::string& scene_label,
                                 const std::function<bool(std::size_t)>& steps_external_controller = {});

// How instance `index` takes one step; empty: Instance::Step(period), under
// its scene controller and trajectory. (The Python module steps an instance
// with a Python law's torque.)
using StepFunction = std::function<Instance::StepFailure(std::size_t index, Instance& instance)>;

// The daemon's health check (sim/health.hpp) of the step `instance` has
// just taken (`step`: its outcome): when it fails, the instance is put back
// to `good` and the fault returned; else `good` becomes its state.
std::optional<OfflineFault> CheckOfflineStep(std::size_t index, Instance& instance, Instance::StepFailure step,
                                             Instance::Saved& good, StepEnergies& energies);

// Runs `steps` steps of `period`. After every step the daemon's health check
// runs (non-finite torque or state, a failed integrator, |T + V| > max_energy,
// |ε| > energy_balance.bound under on_exceed: fault);
// an instance that fails it is never observed again: it is put back to its last
// healthy state and stops there, the others go on. Returns the faults in the
// order they happened (empty: every instance ran every step).
std::vector<OfflineFault> RunOfflineChecked(std::vector<Instance>& instances, double period, std::int64_t steps,
                                            const StepObserver& observe, const StepFunction& step = {});

// The same; true when no instance faulted.
bool RunOffline(std::vector<Instance>& instances, double period, std::int64_t steps, const StepObserver& observe);

// One row of an offline run's task space (lagrangectl simulate's FILE.task.csv,
// Python's SimulationResult.task): what the task-space controller's Compute
// that gave the row's tau measured and commanded, as lagranged's task_state_t
// publishes them with the same t; nan before the first Compute (`computed`
// false: the row at t = 0, whose tau is zero).
struct OfflineTaskRow {
  Eigen::Vector3d position;      // the frame's origin, m, world
  Eigen::Vector3d position_des;  // the commanded one
  Vector6d error;                // e = commanded ⊖ measured: m, then rad
};
OfflineTaskRow TaskRowOf(const TaskSpaceController& task, bool computed);

// One row of a floating base (lagrangectl simulate's base columns, Python's
// SimulationResult.base and Instance.base): base_state_t's arrays in
// kBaseStateArrays' order, as lagranged publishes them on <NAME>_BASE: the
// base's position (m) and orientation (x, y, z, w), its linear and angular
// velocity (base axes), the centre of mass (m, world), the linear momentum
// (N·s) and the angular momentum about the centre of mass (N·m·s), world
// axes (Instance::ComputeBaseMotion). Only for a floating base; no allocation.
using BaseRow = std::array<double, kBaseStateWidth>;
BaseRow BaseRowOf(Instance& instance);

// The frame the instance's active controller moves, as lagranged names it on
// <NAME>_TASK: a task-space controller's, or an mpc controller's with a frame
// cost; "" for any other (it has no task rows).
const std::string& TaskFrameOf(const Instance& instance);
// The active controller's task row (TaskFrameOf not ""), as lagranged's record
// has it: a task-space controller's as above; an mpc controller's frame at
// the instance's state and time (its measured pose, the target its reference
// is at then, e = target ⊖ measured: MpcController::MeasureTask). nan before
// the first Compute (`computed` false). No allocation.
OfflineTaskRow TaskRowOf(Instance& instance, bool computed);

}  // namespace lagrange
