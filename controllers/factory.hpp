#pragma once
// Typed controller configuration (what a scene's `controller:` becomes) and
// the factory that builds a controller, with its own model instance, before
// the loop starts.

#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "controllers/controller.hpp"
#include "controllers/joint_controllers.hpp"
#include "controllers/swing_up.hpp"
#include "plant/plant_spec.hpp"

namespace lagrange {

enum class ControllerType : std::uint8_t {
  kNone,                 // tau = 0
  kPd,                   // joint PD
  kGravityCompensation,  // G(q) [+ PD]
  kComputedTorque,       // M (qdd_d + Kd ė + Kp e) + C qd + G
  kCartPolePd,           // the article's cart-pole PD on the cart force
  kLqr,                  // LQR about an equilibrium (cart-pole: upright)
  kSwingUp,              // energy swing-up handing over to LQR
};

std::string_view ToString(ControllerType type);
std::optional<ControllerType> ParseControllerType(std::string_view name);
std::string ControllerTypeNames();  // "none|pd|gravity-compensation|..."

struct LqrOptions {
  std::optional<VectorXd> equilibrium;  // q0; default: the cart-pole's upright (0, π)
  std::optional<std::vector<int>> actuated;  // default: the cart for a cart-pole, else every joint
  MatrixXd Q;  // (2n x 2n); empty: identity
  MatrixXd R;  // (m x m); empty: identity
};

struct ControllerConfig {
  ControllerType type = ControllerType::kNone;
  Gains gains;            // kp, kd (n each); empty where a type does not use them
  PdOptions pd;           // pd and gravity-compensation
  LqrOptions lqr;         // lqr and swing-up's balancer
  SwingUpOptions swing_up;
  // The controller's own model: the plant's spec with these changes (a
  // model error), and its derivation method (default: the fastest).
  std::optional<PlantSpec> model;
  std::optional<Method> model_method;
  // Evaluate the law at every integrator stage (a continuous-time, analog
  // controller) instead of once per tick with the torque held (a digital one).
  // Not for swing-up, which keeps a mode.
  bool continuous = false;
};

// Checks a config against the plant: the type suits the plant (cart-pole
// controllers need a cart-pole), gain sizes and signs, Q and R shapes and
// definiteness. Returns "key: what was expected".
std::optional<std::string> ValidateController(const ControllerConfig& config, const PlantSpec& plant);

// Why `gains` cannot be given to a controller of this type on n joints, or
// nullopt when they can (the messages for Controller::SetGains).
std::optional<std::string> CheckGains(ControllerType type, int n, const Gains& gains);

// Builds the controller. Throws std::invalid_argument with the message
// ValidateController would give. torque_limits (n), +inf for none.
std::unique_ptr<Controller> MakeController(const ControllerConfig& config, const PlantSpec& plant,
                                           const VectorXd& torque_limits);

}  // namespace lagrange
