#include "sim/offline.hpp"

#include <algorithm>
#include <array>
#include <limits>
#include <stdexcept>

#include "protocol/format.hpp"
#include "sim/health.hpp"
#include "sim/work_bound.hpp"

namespace lagrange {

std::optional<OfflineFault> CheckOfflineStep(std::size_t index, Instance& inst, Instance::StepFailure step,
                                             Instance::Saved& good, StepEnergies& energies) {
  const double max_energy = inst.instance_model().max_energy;
  if (const char* why = CheckStepHealth(inst, step, max_energy, inst.instance_model().residual_bound, energies)) {
    const OfflineFault fault{index, inst.t(), why, max_energy};
    inst.Restore(good);
    return fault;
  }
  inst.Save(good);
  return std::nullopt;
}

std::vector<OfflineFault> RunOfflineChecked(std::vector<Instance>& instances, double period, std::int64_t steps,
                                            const StepObserver& observe, const StepFunction& step) {
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
      const Instance::StepFailure outcome = step ? step(i, inst) : inst.Step(period);
      if (const std::optional<OfflineFault> fault = CheckOfflineStep(i, inst, outcome, good[i], energies)) {
        faults.push_back(*fault);
        healthy[i] = false;
        continue;
      }
      observe(i, inst);
    }
  }
  return faults;
}

std::string OfflineFaultText(const Instance& inst, const OfflineFault& f) {
  std::string text = inst.name() + " faulted at t = " + FormatDouble(f.t) + " s: " + f.reason;
  if (f.reason == kEnergyOutOfBound) text += ", |T + V| > " + FormatDouble(f.max_energy) + " J";
  if (f.reason == kResidualOutOfBound) {
    text += ", |ε| > " + FormatDouble(inst.instance_model().residual_bound.bound) + " J";
  }
  return text;
}

std::optional<std::string> OfflineMpcFailureText(const Instance& inst) {
  std::int64_t solves = 0, failed = 0;
  std::array<std::int64_t, kNumDdpStatuses> by_status{};
  for (std::size_t k = 0; k < inst.controller_names().size(); ++k) {
    const MpcController* mpc = inst.mpc_controller(k);
    if (mpc == nullptr) continue;
    solves += mpc->solves();
    failed += mpc->failed_solves();
    for (std::size_t s = 0; s < kNumDdpStatuses; ++s) by_status[s] += mpc->failed_solves(static_cast<DdpStatus>(s));
  }
  if (failed == 0) return std::nullopt;
  std::string text = inst.name() + ": " + std::to_string(failed) + " of " + std::to_string(solves) +
                     " mpc solves failed (";
  const char* separator = "";
  for (std::size_t s = 0; s < kNumDdpStatuses; ++s) {
    if (by_status[s] == 0) continue;
    text.append(separator).append(ToString(static_cast<DdpStatus>(s))).append(" ").append(std::to_string(by_status[s]));
    separator = ", ";
  }
  return text + "); offline the last usable plan is followed meanwhile (none yet: no force), where lagranged falls back";
}

const char* OfflineRefusal(const InstanceConfig& c) {
  if (c.external) return "its plant is external (measured over LCM): only lagranged runs it";
  if (c.controller.type == ControllerType::kExternal) {
    return "its controller is external (torques over LCM): only lagranged runs it";
  }
  return nullptr;
}

OfflineScene PrepareOfflineScene(const Scene& scene, const std::string& scene_label,
                                 const std::function<bool(std::size_t)>& steps_external_controller) {
  for (std::size_t i = 0; i < scene.instances.size(); ++i) {
    const InstanceConfig& c = scene.instances[i];
    const bool stepped = !c.external && steps_external_controller && steps_external_controller(i);
    if (const char* why = OfflineRefusal(c); why != nullptr && !stepped) {
      throw std::runtime_error(scene_label + ": instance " + c.name + " cannot run offline: " + why);
    }
  }
  // One rule with lagranged: a scene whose ticks would not fit its period
  // in real time is refused here too, with the same message.
  OfflineScene out;
  const std::shared_ptr<DaemonModel> model = BuildDaemonModel(scene);
  MeasureCosts(*model);
  out.model = model;
  if (const auto refusal = CheckWorkBounds(*out.model)) throw std::runtime_error(*refusal);
  out.period = scene.period;
  out.instances.reserve(out.model->instances.size());
  for (const InstanceModel& m : out.model->instances) {
    out.instances.emplace_back(std::shared_ptr<const InstanceModel>(out.model, &m));
  }
  return out;
}

bool RunOffline(std::vector<Instance>& instances, double period, std::int64_t steps, const StepObserver& observe) {
  return RunOfflineChecked(instances, period, steps, observe).empty();
}

namespace {
OfflineTaskRow NanTaskRow() {
  constexpr double kNan = std::numeric_limits<double>::quiet_NaN();
  return {Eigen::Vector3d::Constant(kNan), Eigen::Vector3d::Constant(kNan), Vector6d::Constant(kNan)};
}
}  // namespace

OfflineTaskRow TaskRowOf(const TaskSpaceController& task, bool computed) {
  if (!computed) return NanTaskRow();
  return {task.pose().position, task.commanded().pose.position, task.pose_error()};
}

BaseRow BaseRowOf(Instance& instance) {
  static_assert(kFreeFlyerNq + kFreeFlyerNv + 3 * 3 == kBaseStateWidth);
  BaseRow row;
  const Instance::BaseMotion b = instance.ComputeBaseMotion();
  double* out = row.data();
  const auto put = [&out](const auto& v) { out = std::copy(v.data(), v.data() + v.size(), out); };
  put(instance.floating_q().head<kFreeFlyerNq>());  // position, orientation
  put(instance.floating_v().head<kFreeFlyerNv>());  // linear, angular velocity
  for (const Eigen::Vector3d* v : {&b.com, &b.linear, &b.angular}) put(*v);
  return row;
}

const std::string& TaskFrameOf(const Instance& instance) {
  return instance.instance_model().controllers[instance.active_controller()].pose_rules.frame;
}

OfflineTaskRow TaskRowOf(Instance& instance, bool computed) {
  const std::size_t active = instance.active_controller();
  if (const TaskSpaceController* task = instance.task_space_controller(active)) return TaskRowOf(*task, computed);
  MpcController* mpc = instance.mpc_controller(active);
  if (!computed || mpc == nullptr || !mpc->has_frame()) return NanTaskRow();
  Pose pose, commanded;
  Vector6d error, twist;
  mpc->MeasureTask(instance.t(), instance.q(), instance.qd(), pose, commanded, error, twist);
  return {pose.position, commanded.position, error};
}

}  // namespace lagrange
