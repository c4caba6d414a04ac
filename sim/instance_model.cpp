#include "sim/instance_model.hpp"

#include <limits>
#include <span>
#include <stdexcept>
#include <utility>
#include <variant>

#include "plant/frame_speed.hpp"
#include "plant/urdf.hpp"
#include "sim/scene_channels.hpp"

namespace lagrange {
namespace {

// The fallback of an external controller: the named one, "brake", or the
// first gravity-compensation or computed-torque controller, else the brake.
HoldBy FallbackOf(const std::vector<ControllerModel>& controllers, const std::optional<std::string>& name) {
  for (std::size_t k = 0; k < controllers.size(); ++k) {
    const ControllerType type = controllers[k].config.type;
    const bool named = name && *name != "brake" && controllers[k].name == *name;
    const bool model_based =
        !name && (type == ControllerType::kGravityCompensation || type == ControllerType::kComputedTorque);
    if (named || model_based) return {HoldBy::Kind::kController, k};
  }
  return {HoldBy::Kind::kBrake, 0};
}

// The fastest the frame `frame` of `spec`'s robot can move within its joints'
// velocity limits (plant/frame_speed.hpp): a URDF's <limit velocity> (none,
// or 0, which some files write for "unspecified": unbounded, as
// UrdfTorqueLimits reads effort) and, for a prismatic joint's travel, its
// <limit lower upper>. The built-in plants have no velocity limits: unbounded.
FrameSpeedBound FrameSpeedOf(const PlantSpec& spec, int frame) {
  const auto* urdf = std::get_if<UrdfParams>(&spec.params);
  if (urdf == nullptr || !urdf->robot) return {};
  const UrdfRobot& robot = *urdf->robot;
  const int n = robot.tree.num_dofs();
  const double inf = std::numeric_limits<double>::infinity();
  VectorXd speed(n), lower(n), upper(n);
  for (int d = 0; d < n; ++d) {
    const UrdfJointProperties& p = robot.properties[static_cast<std::size_t>(d)];
    speed[d] = p.velocity && *p.velocity > 0.0 ? *p.velocity : inf;
    lower[d] = p.lower.value_or(-inf);
    upper[d] = p.upper.value_or(inf);
  }
  return MaxFrameSpeed(robot.tree, frame, speed, lower, upper);
}

std::vector<ControllerModel> ControllersOf(const InstanceConfig& config) {
  // A joint with a stop is driven the way the stop allows; only free revolute joints wrap.
  // A mujoco plant's stops are MuJoCo's joint ranges.
  const std::optional<JointLimits> stops =
      config.mujoco ? std::optional<JointLimits>(JointLimits{config.mujoco->lower, config.mujoco->upper})
                    : config.effects.limits;
  const std::vector<bool> wrap = WrappedJoints(JointTypesOf(config.plant), stops);
  std::vector<ControllerConfig> configs;
  for (const ControllerConfig* c : ControllerConfigs(config)) configs.push_back(*c);
  if (config.controller.type != ControllerType::kNone) configs.emplace_back();  // none, to switch to
  std::vector<ControllerModel> controllers;
  for (ControllerConfig& c : configs) {
    c.wrap = wrap;
    if (auto error = ValidateController(c, config.plant)) throw std::invalid_argument(*error);
    ControllerModel m;
    m.name = std::string(ToString(c.type));
    m.gain_bounds = ComputeGainBounds(c, config.plant);
    m.external = c.type == ControllerType::kExternal;
    m.torque_timeout = m.external ? ToNanoseconds(c.external.torque_timeout) : 0;
    m.config = std::move(c);
    controllers.push_back(std::move(m));
  }
  for (ControllerModel& m : controllers) {
    m.mpc = m.config.type == ControllerType::kMpc;
    if (m.external) m.fallback = FallbackOf(controllers, m.config.external.fallback);
    if (m.mpc) m.fallback = FallbackOf(controllers, m.config.mpc.fallback);
  }
  // Pose setpoints: the frame each task-space controller (or mpc with a frame) moves, within the scene's workspace.
  for (ControllerModel& m : controllers) {
    const bool mpc_frame = m.mpc && !m.config.mpc.frame.empty();
    if (!IsTaskSpace(m.config.type) && !mpc_frame) continue;
    // The frames of the controller's own model, as MakeController finds its frame.
    const Kinematics kinematics(MakeRigidTree(m.config.model ? *m.config.model : config.plant));
    const std::optional<int> frame =
        mpc_frame ? MpcFrame(m.config.mpc, kinematics) : FindTaskFrame(kinematics, m.config.task.frame);
    if (!frame) throw std::logic_error("a validated task-space controller's frame is not the robot's");
    m.pose_rules.frame = kinematics.frame_names()[static_cast<std::size_t>(*frame)];
    m.pose_rules.lower = config.workspace_lower;
    m.pose_rules.upper = config.workspace_upper;
    const FrameSpeedBound fastest = FrameSpeedOf(m.config.model ? *m.config.model : config.plant, *frame);
    m.pose_rules.max_linear_speed = fastest.linear;
    m.pose_rules.max_angular_speed = fastest.angular;
  }
  return controllers;
}

// B: the scene's, else a 50 ms time constant per joint at q0 (20/s × diag M(q0)).
VectorXd BrakeOf(const InstanceConfig& config, const Dynamics& dynamics) {
  if (config.estop_damping) return *config.estop_damping;
  const int n = dynamics.num_dofs();
  MatrixXd M(n, n);
  dynamics.ComputeMassMatrix(*dynamics.MakeData(), config.q0, M);
  return 20.0 * M.diagonal();
}

CommandRules CommandRulesOf(const InstanceModel& m) {
  CommandRules rules;
  rules.instance = m.name();
  rules.n = m.num_dofs;
  std::vector<ControllerType> types;
  std::vector<GainBounds> bounds;  // what each controller can use at the scene's period
  for (const ControllerModel& c : m.controllers) {
    rules.controllers.push_back(c.name);
    rules.gain_counts.push_back(c.gain_bounds.num_dofs());
    rules.gains_per_task_axis.push_back(c.gain_bounds.task_axes);
    types.push_back(c.config.type);
    bounds.push_back(c.gain_bounds);
  }
  // The bounds are the instance's, checked here where its controllers are (CheckGains).
  rules.check_gains = [types = std::move(types), bounds = std::move(bounds)](std::size_t c, std::span<const double> kp,
                                                                             std::span<const double> kd) {
    return CheckGains(types[c], kp, kd, bounds[c]);
  };
  rules.integrator = m.config.integrator;
  return rules;
}

}  // namespace

InstanceModel BuildInstanceModel(const InstanceConfig& config, const BuildOptions& options) {
  InstanceModel m;
  m.config = config;
  m.num_dofs = config.plant.num_dofs();
  m.joint_names = JointNamesOf(config.plant);
  m.channels = SceneChannelNames(config, options.channel_prefix);
  m.controllers = ControllersOf(config);
  m.external_controller = ExternalControllerOf(config).index;
  m.dynamics = MakeMethodModels(config.plant);
  if (config.floating) {
    m.floating = std::make_shared<const FloatingDynamics>(
        FloatingTreeOf(*config.floating, std::get<UrdfParams>(config.plant.params)));
  }
  m.torque_limits = config.torque_limits.size() == m.num_dofs
                        ? config.torque_limits
                        : VectorXd::Constant(m.num_dofs, std::numeric_limits<double>::infinity());
  m.brake = BrakeOf(config, *m.dynamics[static_cast<std::size_t>(config.method)]);
  m.max_energy = MaxEnergy(config);
  m.residual_bound = config.energy_balance.value_or(EnergyBalanceBound{});
  m.setpoint_timeout = ToNanoseconds(config.setpoint_timeout);
  m.estop_dwell = ToNanoseconds(config.estop_dwell);
  m.state_timeout = config.external ? ToNanoseconds(config.external->state_timeout) : 0;
  m.setpoint_rules = SetpointRules{m.num_dofs, config.setpoint_lower, config.setpoint_upper};
  m.command_rules = CommandRulesOf(m);
  if (options.evaluation_s) m.evaluation_s = *options.evaluation_s;
  return m;
}

std::shared_ptr<DaemonModel> BuildDaemonModel(const Scene& scene, const BuildOptions& options) {
  auto model = std::make_shared<DaemonModel>();
  model->file = scene.file;
  model->period = scene.period;
  model->status_channel = StatusChannel(options.channel_prefix);
  for (const InstanceConfig& c : scene.instances) model->instances.push_back(BuildInstanceModel(c, options));
  return model;
}

}  // namespace lagrange
