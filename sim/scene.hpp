#pragma once
// A scene: the plant instances lagranged (or lagrangectl simulate) runs,
// parsed once from YAML into typed structs and validated before anything runs.
// See README.md, "Scene reference", for every key.

#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "controllers/factory.hpp"
#include "plant/effects.hpp"
#include "plant/integrators.hpp"
#include "plant/plant_factory.hpp"
#include "plant/stepped_plant.hpp"
#include "sim/trajectory_config.hpp"

namespace lagrange {

// What an instance does when its streamed setpoints go stale.
enum class TimeoutBehaviour : std::uint8_t {
  kHoldPosition,  // q_d = q at the moment of the timeout, at rest; the controller keeps running
  kZeroTorque,    // tau = 0
};

// A plant outside lagranged (a robot driver, another simulator, another
// lagranged): its measured state comes in as state_t on state_channel, the
// controller's torque goes out as torque_t on torque_channel, each used
// exactly as written (never prefixed). The instance's plant spec is then the
// model the controller and the published energies use.
struct ExternalPlantConfig {
  std::string state_channel;
  std::string torque_channel;
  double state_timeout = 0.01;  // s: no fresh measured state for this long stops the instance (watchdog)
  // Lock the loop's phase to the measured state's arrival: each tick then
  // starts phase_lag after the state it answers arrived (the deadline moves
  // by at most kMaxPhaseStep per tick), instead of anywhere within a period.
  bool phase_lock = false;
  double phase_lag = 2e-4;  // s
};

// An external plant's state is measured: a scene's `integrator` and the
// integrator command are refused with this.
inline constexpr char kExternalNotIntegrated[] =
    "an external plant is not integrated by lagranged (its state is measured)";

// plant: {type: mujoco, file: F, model: {...}}: MuJoCo steps the plant
// (plant/mujoco_plant.hpp), the MJCF or URDF file F as MuJoCo loads it; the
// instance's plant spec is then lagrange's model of it, for the controllers
// (by default the URDF F itself; an MJCF needs `model:`, as an external plant).
// With floating_base: true, MuJoCo's first free joint is the robot's base
// (MujocoOptions::floating_base) and the model, a URDF, is read on a free
// base into InstanceConfig::floating, as a urdf plant's floating_base is; an
// MJCF without a free joint is refused.
struct MujocoPlantConfig {
  std::string file;  // as resolved (relative to the scene's directory)
  MujocoIntegrator integrator = MujocoIntegrator::kRk4;
  int substeps = 1;
  std::shared_ptr<const SteppedPlantModel> model;  // loaded once, at period / substeps
  VectorXd lower, upper;  // (n) its joints' ranges where MuJoCo limits them, ∓inf elsewhere: the default setpoint limits
};

// A mujoco plant's integrator and effects are MuJoCo's: the scene's keys and
// the run-time commands are refused with these.
inline constexpr char kMujocoIntegrated[] =
    "a mujoco plant is integrated by MuJoCo (its integrator is the scene's: euler, rk4 or implicit)";
inline constexpr char kMujocoEffects[] =
    "a mujoco plant's effects are MuJoCo's (contacts, joint limits, damping, friction loss from its file)";

// plant: {type: urdf, file: F, floating_base: true}: the robot of F on a free
// base (Pinocchio's free-flyer root; plant/floating_dynamics.hpp), integrated
// on its configuration manifold by lagrange (plant/floating_integrator.hpp).
// The instance's `plant` spec is then the same robot with its base bolted at
// the world origin (FixedBaseOf): the joints' model, which names and counts
// them (n), bounds their setpoints and carries their effects; the instance's
// q and qd (and state_t's) are the joints, and the base's pose and twist
// lead the full state q (nq = n + 7) and v (nv = n + 6) that the floating
// model steps (README, "Floating base").
struct FloatingBaseConfig {
  std::shared_ptr<const UrdfRobot> robot;  // F read with UrdfOptions{.floating_base = true}
  // The base's initial pose and twist: initial.base_q (p (m), then the unit
  // quaternion x, y, z, w; 7) and initial.base_v (v_b (m/s), ω_b (rad/s), base axes; 6).
  VectorXd q0 = (VectorXd(kFreeFlyerNq) << 0, 0, 0, 0, 0, 0, 1).finished();
  VectorXd v0 = VectorXd::Zero(kFreeFlyerNv);
};

// What a floating base refuses, in the words the scene reader and the
// run-time commands share.
// A floating base's unit quaternion may be given off unit by this much (a
// printed one's round-off: a scene's initial.base_q, Python's set_state); it is then normalised.
inline constexpr double kQuaternionNormTolerance = 1e-6;
// A floating base's pose (p, then the quaternion x, y, z, w; 7) with its quaternion normalised in place when it is
// within kQuaternionNormTolerance of unit: true; otherwise false, the pose unchanged (each reader words the refusal).
bool NormaliseBaseQuaternion(VecRef base_q);

inline constexpr char kFloatingIntegrators[] =
    "a floating base is integrated on its manifold by explicit-euler, semi-implicit-euler, rk4 or variational only";
inline constexpr char kFloatingMethod[] =
    "a floating base steps by the recursive algorithms only (its Lagrangian path, FloatingLagrangian, is the "
    "O(nv²) reference, not a stepper)";

// The robot with its floating base bolted at the world origin: the joints
// alone, as a fixed-base tree (the base's inertia dropped).
std::shared_ptr<const UrdfRobot> FixedBaseOf(const UrdfRobot& floating);
// The floating tree an instance simulates: the robot's, with the spec's
// gravity and mass_scale (the base's mass and inertia scaled too).
RigidTree FloatingTreeOf(const FloatingBaseConfig& floating, const UrdfParams& params);

// energy_balance: {bound: J, on_exceed: warn|fault}. The energy-balance
// residual ε (plant/energy_balance.hpp; telemetry_t.energy_residual) is the
// one sign that an integrator is making or losing energy while the state
// stays finite; |ε| above `bound` either warns (the instance runs on, and the
// status's instance_reasons say it exceeds) or faults the instance as a
// diverging plant does (last good state, zero torque, until reset).
enum class OnResidualExceeded : std::uint8_t { kWarn, kFault };
struct EnergyBalanceBound {
  double bound = std::numeric_limits<double>::infinity();  // J, > 0; +inf: none
  OnResidualExceeded on_exceed = OnResidualExceeded::kWarn;
};

// The scene's default estop_dwell, s: the default brake (20/s × diag M) takes
// about e^-10 of the speed off in it.
inline constexpr double kDefaultEstopDwell = 0.5;
// The longest estop_dwell a scene may ask, s.
inline constexpr double kMaxEstopDwell = 3600.0;

struct InstanceConfig {
  std::string name;  // [a-z][a-z0-9_]*, unique in the scene
  PlantSpec plant;
  Method method = Method::kClosedForm;
  VectorXd q0;   // initial positions (n)
  VectorXd qd0;  // initial velocities (n)
  EffectsConfig effects;
  IntegratorConfig integrator;
  ControllerConfig controller;               // active at start
  std::vector<ControllerConfig> alternates;  // more controllers a command may switch to
  VectorXd torque_limits;                    // (n), applied after every controller; +inf: none
  TrajectoryConfig setpoint;
  VectorXd setpoint_lower, setpoint_upper;  // (n) a streamed q_d outside is rejected; default the joint limits or ±inf
  double setpoint_timeout = 0.5;            // s: streamed setpoints older than this, or none for this long, time out
  // A task-space controller's pose targets (<NAME>_POSE): the box their
  // positions must lie in, world frame, m (±inf: unbounded).
  Eigen::Vector3d workspace_lower = Eigen::Vector3d::Constant(-std::numeric_limits<double>::infinity());
  Eigen::Vector3d workspace_upper = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  TimeoutBehaviour on_timeout = TimeoutBehaviour::kHoldPosition;
  std::optional<double> max_energy;             // J: |T + V| above this faults the instance (default DefaultMaxEnergy)
  std::optional<EnergyBalanceBound> energy_balance;  // a bound on |ε| (none by default)
  std::optional<VectorXd> estop_damping;        // (n) brake B during an emergency stop (default 20/s × diag M(q0))
  // s: an emergency stop lasts at least this long before a clear_estop can end it, however many clears
  // arrive (a flood cannot shorten it); 0: only a clear in the estop's own tick is refused.
  double estop_dwell = kDefaultEstopDwell;
  std::optional<ExternalPlantConfig> external;  // set: the plant is outside; `plant` is its model
  std::optional<MujocoPlantConfig> mujoco;      // set: MuJoCo steps the plant; `plant` is its model
  std::optional<FloatingBaseConfig> floating;   // set: the plant's base is free; `plant` is its joints' model
  bool telemetry = true;                        // keep the energy balance and publish <NAME>_TELEMETRY every tick
  bool forces = false;  // publish <NAME>_FORCES from the start (a command may turn it on or off)
};

struct Scene {
  std::string file;         // where it was loaded from
  std::string description;  // free text
  double period = 1e-3;     // s, the tick (and offline step) length
  std::vector<InstanceConfig> instances;
  // bus: {key_file: PATH}: the shared secret that signs the bus (protocol/signing.hpp),
  // relative to the scene file's directory; "" for none. --bus-key and
  // $LAGRANGE_BUS_KEY_FILE take precedence. Read only by lagranged, when it starts.
  std::string bus_key_file;
  // bus: {domain: NAME}: the domain signatures are bound to (protocol/signing.hpp); "" for
  // the bus's own (udpm://GROUP:PORT). --bus-domain and $LAGRANGE_BUS_DOMAIN take precedence.
  std::string bus_domain;
};

// The instance's configured controllers in controller-index order: the
// scene's `controller`, then its `controllers` (Instance adds `none` after them).
std::vector<const ControllerConfig*> ControllerConfigs(const InstanceConfig& config);
// The instance's external controller, if it configures one (each type at most once).
struct ExternalControllerRef {
  int index = -1;  // its controller index; -1: none
  const ControllerConfig* config = nullptr;
};
ExternalControllerRef ExternalControllerOf(const InstanceConfig& config);
// J: an instance's bound on |T + V| (the health rule's, sim/health.hpp): the
// scene's max_energy, else the plant's default (DefaultMaxEnergy).
inline double MaxEnergy(const InstanceConfig& config) {
  return config.max_energy.value_or(DefaultMaxEnergy(config.plant));
}

// Throw ConfigError (sim/yaml_reader.hpp) naming file, line, key and reason.
Scene LoadScene(const std::string& path);
// The instance's initial trajectory.
std::unique_ptr<Trajectory> MakeTrajectory(const InstanceConfig& config);
Scene ParseScene(const std::string& yaml_text, const std::string& file_label);

}  // namespace lagrange
