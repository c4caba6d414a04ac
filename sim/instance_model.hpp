#pragma once
// One run's instances as lagranged runs them, model and data apart at the
// daemon's scale (as plant/dynamics.hpp is at the plant's): everything about
// an instance that is fixed before the loop is built once from the scene
// (BuildDaemonModel), immutable afterwards, and read by const reference by
// the receive thread, the tick and the publish thread. Each thread keeps only
// its own data: the tick its Instance (sim/instance.hpp) and mode
// (Runtime), the receiver its timelines and senders, the publisher its
// messages.

#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "controllers/factory.hpp"
#include "controllers/task_space.hpp"
#include "plant/floating_dynamics.hpp"
#include "protocol/channels.hpp"
#include "protocol/clock.hpp"
#include "protocol/command_check.hpp"
#include "protocol/setpoint_check.hpp"
#include "sim/scene.hpp"

namespace lagrange {

// Who keeps an external (or mpc) controller's instance in place while it holds
// (its torques, or plans, have not come yet, or lapsed).
struct HoldBy {
  enum class Kind : std::uint8_t {
    kController,  // a configured controller, `controller`: the named fallback or the first gravity-compensation or
                  // computed-torque one
    kBrake,       // τ = −B q̇, the emergency-stop brake
  } kind = Kind::kBrake;
  std::size_t controller = 0;  // kController: its index
};

// One of the controllers an instance can run, by index: the scene's
// `controller`, then its `controllers`, then `none` (unless the scene's is none).
struct ControllerModel {
  ControllerConfig config;  // as the scene gave it (wrap set from the instance's joints)
  std::string name;         // ToString(config.type): what commands and states call it
  GainBounds gain_bounds;   // what it accepts at the scene's period (ComputeGainBounds)
  // An external controller (type external): how long its torques stay fresh,
  // and who holds the instance while none is.
  bool external = false;
  Nanoseconds torque_timeout = 0;
  // An mpc controller (type mpc): its plans come from an optimiser thread
  // (lagranged) and it holds by `fallback` while it has none usable.
  bool mpc = false;
  HoldBy fallback;  // external or mpc: who holds
  // A task-space controller (cartesian-impedance, operational-space): what a
  // pose setpoint for it must satisfy, its frame's name resolved (the scene's
  // frame, or the robot's last); frame "" for every other type.
  PoseRules pose_rules;
};

struct InstanceModel {
  InstanceConfig config;  // as the scene gave it
  int num_dofs = 0;
  std::vector<std::string> joint_names;  // JointNamesOf, in q order, as in the file
  InstanceChannelNames channels;
  std::vector<ControllerModel> controllers;
  int external_controller = -1;  // the index of its external controller; -1: none
  // The plant's dynamics by every method it has, shared (immutable) with the
  // tick's Instance and its controllers.
  MethodModels dynamics;
  // A floating base's model (config.floating; FloatingTreeOf), shared alike; null for a fixed base.
  std::shared_ptr<const FloatingDynamics> floating;
  VectorXd torque_limits;            // (n), +inf where none
  VectorXd brake;                    // (n) B of the estop brake: the scene's estop_damping, else 20/s × diag M(q0)
  double max_energy = 0.0;           // J: |T + V| above this faults (MaxEnergy)
  EnergyBalanceBound residual_bound;  // the scene's energy_balance (bound +inf: none)
  Nanoseconds setpoint_timeout = 0;  // the scene's setpoint_timeout
  Nanoseconds estop_dwell = 0;       // the scene's estop_dwell: how long an estop lasts before a clear can end it
  Nanoseconds state_timeout = 0;     // an external plant's; 0: not external
  SetpointRules setpoint_rules;      // what the receiver accepts as a setpoint
  CommandRules command_rules;        // ... and as a command
  // Measured before the loop, by a pass over the built model (MeasureCosts,
  // sim/work_bound.hpp): one right-hand-side evaluation's cost by Method, s,
  // with every configured effect on; 0: not measured (nothing is then refused
  // for cost).
  std::array<double, kNumMethods> evaluation_s{};
  double tick_overhead_s = 0.0;  // the rest of its tick beyond the evaluations, s (MeasureTickOverheadSeconds)
  double forces_s = 0.0;         // computing its per-effect forces, s, while SET_FORCES is on (MeasureForcesSeconds)
  // A floating base lagrange integrates: evaluation_s is then its floating model's forward dynamics (nv), and
  // this one residual of the variational step on the manifold, s (MeasureFloatingResidualSeconds); 0 otherwise.
  double floating_residual_s = 0.0;
  // Its mpc controller's optimiser, off the tick: one DDP iteration of its plan, s (MeasureMpcIterationSeconds);
  // 0: no mpc controller, or not measured.
  double mpc_iteration_s = 0.0;

  const std::string& name() const { return config.name; }
  bool external_plant() const { return config.external.has_value(); }
  bool floating_base() const { return floating != nullptr; }
};

struct DaemonModel {
  std::string file;     // the scene's
  double period = 0.0;  // s
  std::string status_channel;
  std::vector<InstanceModel> instances;
};

struct BuildOptions {
  std::string channel_prefix;  // --channel-prefix
  // Given costs instead (by Method, s; the rest of a tick 0), for every
  // instance: tests that need the bound exact.
  std::optional<std::array<double, kNumMethods>> evaluation_s;

  static BuildOptions Prefixed(std::string prefix) {
    BuildOptions o;
    o.channel_prefix = std::move(prefix);
    return o;
  }
  static BuildOptions WithCosts(const std::array<double, kNumMethods>& seconds) {
    BuildOptions o;
    o.evaluation_s = seconds;
    return o;
  }
};

// One instance's model. Throws std::invalid_argument for a controller that
// cannot be built (ValidateController's message). Building one builds no
// Instance and times nothing: its costs are measured by a pass over the
// built model (MeasureCosts, sim/work_bound.hpp).
InstanceModel BuildInstanceModel(const InstanceConfig& config, const BuildOptions& options = {});

// The instance's first mpc controller, whose plans its channels and records
// are sized for (lagranged's tick and publisher): its index in m.controllers,
// or nullopt when it has none.
inline std::optional<std::size_t> FirstMpc(const InstanceModel& m) {
  for (std::size_t k = 0; k < m.controllers.size(); ++k) {
    if (m.controllers[k].mpc) return k;
  }
  return std::nullopt;
}
// Every instance of the scene, in order; mutable until it is shared (as
// const) with the threads of a run, so that MeasureCosts can fill it in.
std::shared_ptr<DaemonModel> BuildDaemonModel(const Scene& scene, const BuildOptions& options = {});

}  // namespace lagrange
