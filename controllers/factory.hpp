#pragma once
// Typed controller configuration (what a scene's `controller:` becomes) and
// the factory that builds a controller, with its model (shared with the
// plant's where it is the same) and data of its own, before the loop starts.

#include <memory>
#include <optional>
#include <string>
#include <span>
#include <string_view>
#include <vector>

#include "base/vocabulary.hpp"
#include "controllers/cartpole_pd.hpp"
#include "controllers/controller.hpp"
#include "controllers/external_controller.hpp"
#include "controllers/joint_controllers.hpp"
#include "controllers/mpc.hpp"
#include "controllers/stance_pd.hpp"
#include "controllers/swing_up.hpp"
#include "controllers/task_space.hpp"
#include "plant/integrators.hpp"
#include "plant/plant_factory.hpp"

namespace lagrange {

// ControllerType, its names and IsTaskSpace: base/vocabulary.hpp.

struct LqrOptions {
  std::optional<VectorXd> equilibrium;       // q0; default: the cart-pole's upright (0, π)
  std::optional<std::vector<int>> actuated;  // default: the cart for a cart-pole, else every joint
  MatrixXd Q;                                // (2n x 2n); empty: identity
  MatrixXd R;                                // (m x m); empty: identity
  // Scene key design: continuous (false: K from the continuous Riccati
  // equation of the exact linearisation, held over the tick) or discrete
  // (true: from the discrete one of the tick itself, x⁺ = A x + B u by the
  // instance's integrator and period: ControllerConfig::integrator, period).
  bool discrete = false;
};

// An external controller: torques come over LCM from a program of the user's.
struct ExternalOptions {
  double torque_timeout = 0.05;  // s: no fresh torque for this long sends the instance to hold
  std::string torque_channel;    // as written in the scene; "" for <PREFIX><NAME>_TORQUE
  // Who holds the instance in hold-position: a configured controller's name,
  // or "brake" (τ = −B q̇, the emergency-stop brake); nullopt: the first
  // configured gravity-compensation or computed-torque controller, else brake.
  std::optional<std::string> fallback;
  // Add G(q) from the controller's model to the streamed torque, as Franka's
  // FCI does: the client then commands the torque beyond gravity.
  bool compensate_gravity = false;
};

struct ControllerConfig {
  ControllerType type = ControllerType::kNone;
  // kp, kd (n each; 6 each for a task-space type, per task axis x, y, z, rx,
  // ry, rz); empty where a type does not use them. A cartesian-impedance
  // config may leave kd empty: the controller is then built with
  // D_i = 2 ζ sqrt(K_i Λ_ii(q0)), ζ = task.damping_ratio, Λ its model's.
  Gains gains;
  PdOptions pd;    // pd and gravity-compensation
  StanceOptions stance;  // pd on a floating base: gravity_compensation: stance (controllers/stance_pd.hpp)
  LqrOptions lqr;  // lqr and swing-up's balancer
  SwingUpOptions swing_up;
  ExternalOptions external;
  TaskSpaceOptions task;  // cartesian-impedance and operational-space
  MpcOptions mpc;         // mpc (controllers/mpc.hpp)
  // The controller's own model: the plant's spec with these changes (a
  // model error), and its derivation method (default: the fastest).
  std::optional<PlantSpec> model;
  std::optional<Method> model_method;
  // Evaluate the law at every integrator stage (a continuous-time, analog
  // controller) instead of once per tick with the torque held (a digital one).
  // Not for swing-up, which keeps a mode.
  bool continuous = false;
  // Where the law runs, for its gain bounds (ComputeGainBounds): the tick h,
  // s, the law is held over, and the plant's initial q (n; empty: q = 0).
  // The scene loader sets the scene's period and the instance's initial q.
  double period = 1e-3;
  VectorXd q0;
  // The instance's integrator (type, substeps), for a discrete-time LQR
  // design (LqrOptions::discrete); the scene loader sets it.
  IntegratorConfig integrator;
  // Which joints' errors wrap to (−π, π] (WrappedJoints, controllers/
  // controller.hpp), n flags; empty: every revolute joint's. The instance
  // sets it from its plant's joints and its effects.limits (Instance), so a
  // joint with a stop is driven the way the stop allows.
  std::vector<bool> wrap;
};

// Checks a config against the plant: the type suits the plant (cart-pole
// controllers need a cart-pole, task-space ones a robot of 6 joints or more
// with the frame), gain sizes, signs and bounds (ComputeGainBounds; a
// task-space posture task's as a joint PD's, under null_space), Q and R
// shapes and definiteness, a task-space trajectory and singularity damping.
// Returns "key: what was expected".
std::optional<std::string> ValidateController(const ControllerConfig& config, const PlantSpec& plant);

// Why a controller of `type` cannot run a robot on a floating base (a static
// string, one line), or null when it can: pd and none act on the joints alone
// and leave the base to the physics. The laws that invert the dynamics need
// every degree of freedom actuated, and the base's six are not; gravity
// compensation needs the ground's contact forces to hold the base up (pd's
// gravity_compensation: stance computes them: controllers/stance_pd.hpp).
const char* FloatingBaseRefusal(ControllerType type);

// The gains a controller of this type accepts on `plant`, held over a tick of
// `period` s from the initial q0 (n): the rules in joint_controllers.hpp,
// cartpole_pd.hpp and task_space.hpp. Types without gains get n unbounded entries.
//   computed-torque                Kp_i <= 1/h²,        Kd_i <= 2/h        (1/s², 1/s)
//   pd, gravity-compensation       Kp_i <= w_i/h²,      Kd_i <= 2 w_i/h    (N·m/rad, N·m·s/rad)
//                                  with w_i = λmin(M) for every joint, or (the per-joint box, for
//                                  n >= 2) w_i = M_ii/λmax(M⁻¹ diag M): kp within either, kd within either
//   cartpole-pd (any sign)         |Kp_j| <= M_xx/h²,   |Kd_j| <= 2M_xx/h
//   operational-space              Kp_i <= 1/h²,        Kd_i <= 2/h        (1/s², 1/s; per task axis)
//   cartesian-impedance            K_i <= Λ_ii/(c h²),  D_i <= 2Λ_ii/(c h) (N/m or N·m/rad, N·s/m or N·m·s/rad)
//                                  with Λ = Λ(q0) the frame's task inertia (task_space.hpp; the
//                                  config's frame, the default for this overload) and c = λmax(Λ⁻¹ diag Λ)
// with M = M(q0) of the plant (and Λ the plant's): both PD boxes are evaluated at q0 only (the
// instance's initial q, or 0), and M changes with q, so they are exact there
// and approximate elsewhere; the per-joint box is the more pose-sensitive.
// The per-joint box is left out (empty) when M(q0) is not positive definite
// (its Cholesky factorisation fails) or c is not finite and positive.
GainBounds ComputeGainBounds(ControllerType type, const PlantSpec& plant, const VectorXd& q0, double period);
// The same from a config's own period and q0. A continuous controller (the
// law at every integrator stage) is not held over the tick: only the sizes,
// finiteness and signs bind it, and its stiffness is the integrator's matter
// (sub-steps or the variational integrator; tests/daemon/stiff_cases_test.cpp).
GainBounds ComputeGainBounds(const ControllerConfig& config, const PlantSpec& plant);

// True for the types whose gains (kp, kd) a scene sets and a command may change.
bool HasGains(ControllerType type);

// Why `gains` cannot be given to a controller of this type with these bounds
// (Controller::gain_bounds()), or nullopt when they can: the messages for a
// refused Controller::SetGains. Above a bound the message names it, e.g.
// "kp[0]: expected |gain| <= 1e+06 (Kp·h² <= 1 at h = 0.001 s), got 1e+07".
std::optional<std::string> CheckGains(ControllerType type, const Gains& gains, const GainBounds& bounds);
// The same for gains as a command carries them: kp and kd of one size (CommandRules::check_gains).
std::optional<std::string> CheckGains(ControllerType type, std::span<const double> kp, std::span<const double> kd,
                                      const GainBounds& bounds);
// Sizes, finiteness and signs only, without the tick's bounds. Prefer the
// overload above with the controller's gain_bounds().
std::optional<std::string> CheckGains(ControllerType type, int n, const Gains& gains);

// Builds the controller with its gain bounds (ComputeGainBounds(config,
// plant)) and its wrapped joints (config.wrap). Throws std::invalid_argument with the message ValidateController
// would give. torque_limits (n), +inf for none. A controller that needs a
// model and does not change the plant's (no `model`) shares the plant's
// model for its method from `plant_models` when one is built there (the
// instance builds every method once); otherwise it builds its own. Either
// way it evaluates through data of its own. `plant_effects`, the instance's
// effects: what of them an optimiser models (mpc: MpcEffects). `floating`:
// the robot on its floating base, when the plant's base is free (the stance
// PD's model; a stance config without it throws).
std::unique_ptr<Controller> MakeController(const ControllerConfig& config, const PlantSpec& plant,
                                           const VectorXd& torque_limits, const MethodModels& plant_models = {},
                                           const EffectsConfig& plant_effects = {},
                                           std::shared_ptr<const FloatingDynamics> floating = nullptr);

}  // namespace lagrange
