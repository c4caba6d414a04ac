#include "controllers/factory.hpp"

#include <Eigen/Eigenvalues>
#include <numbers>
#include <stdexcept>

#include "controllers/lqr.hpp"

namespace lagrange {
namespace {

constexpr ControllerType kAllControllers[] = {
    ControllerType::kNone,           ControllerType::kPd,         ControllerType::kGravityCompensation,
    ControllerType::kComputedTorque, ControllerType::kCartPolePd, ControllerType::kLqr,
    ControllerType::kSwingUp,
};

bool IsCartPoleOnly(ControllerType t) {
  return t == ControllerType::kCartPolePd || t == ControllerType::kSwingUp;
}

std::unique_ptr<Dynamics> ControllerModel(const ControllerConfig& c, const PlantSpec& plant) {
  const PlantSpec& spec = c.model ? *c.model : plant;
  return MakeDynamics(spec, c.model_method.value_or(FastestMethod(spec.type())));
}

VectorXd Equilibrium(const LqrOptions& o, const PlantSpec& plant) {
  if (o.equilibrium) return *o.equilibrium;
  VectorXd q0 = VectorXd::Zero(plant.num_dofs());
  if (plant.type() == PlantType::kCartPole) q0[1] = std::numbers::pi;
  return q0;
}

std::vector<int> Actuated(const LqrOptions& o, const PlantSpec& plant) {
  if (o.actuated) return *o.actuated;
  if (plant.type() == PlantType::kCartPole) return {0};
  std::vector<int> all(static_cast<std::size_t>(plant.num_dofs()));
  for (int i = 0; i < plant.num_dofs(); ++i) all[static_cast<std::size_t>(i)] = i;
  return all;
}

std::optional<std::string> ValidateLqr(const LqrOptions& o, const PlantSpec& plant) {
  const int n = plant.num_dofs();
  if (!o.equilibrium && plant.type() != PlantType::kCartPole) {
    return std::string("equilibrium: expected the configuration to balance about (one value per joint)");
  }
  if (o.equilibrium && o.equilibrium->size() != n) {
    return "equilibrium: expected " + std::to_string(n) + " values (one per joint), got " +
           std::to_string(o.equilibrium->size());
  }
  const std::vector<int> act = Actuated(o, plant);
  if (act.empty()) return std::string("actuated: expected at least one joint");
  for (int j : act) {
    if (j < 0 || j >= n) return "actuated: expected joint indices from 0 to " + std::to_string(n - 1);
  }
  const int m = static_cast<int>(act.size());
  if (o.Q.size() > 0) {
    if (o.Q.rows() != 2 * n || o.Q.cols() != 2 * n) {
      return "Q: expected " + std::to_string(2 * n) + " x " + std::to_string(2 * n) + " (state (q, qd))";
    }
    if ((o.Q - o.Q.transpose()).norm() > 1e-12 * o.Q.norm() ||
        Eigen::SelfAdjointEigenSolver<MatrixXd>(o.Q).eigenvalues().minCoeff() < 0.0) {
      return std::string("Q: expected a symmetric positive semi-definite matrix");
    }
  }
  if (o.R.size() > 0) {
    if (o.R.rows() != m || o.R.cols() != m) {
      return "R: expected " + std::to_string(m) + " x " + std::to_string(m) + " (one per actuated joint)";
    }
    if ((o.R - o.R.transpose()).norm() > 1e-12 * o.R.norm() ||
        Eigen::SelfAdjointEigenSolver<MatrixXd>(o.R).eigenvalues().minCoeff() <= 0.0) {
      return std::string("R: expected a symmetric positive definite matrix");
    }
  }
  return std::nullopt;
}

std::unique_ptr<Controller> MakeLqr(const ControllerConfig& c, const PlantSpec& plant, const VectorXd& limits) {
  const int n = plant.num_dofs();
  auto model = ControllerModel(c, plant);
  const std::vector<int> act = Actuated(c.lqr, plant);
  const int m = static_cast<int>(act.size());
  const LinearModel lin = Linearize(*model, Equilibrium(c.lqr, plant), act);
  const MatrixXd Q = c.lqr.Q.size() > 0 ? c.lqr.Q : MatrixXd::Identity(2 * n, 2 * n);
  const MatrixXd R = c.lqr.R.size() > 0 ? c.lqr.R : MatrixXd::Identity(m, m);
  const LqrResult lqr = LinearQuadraticRegulator(lin.A, lin.B, Q, R);
  return std::make_unique<StateFeedbackController>("lqr", model->joint_types(), limits, act, lqr.K, lin.u0);
}

}  // namespace

std::string_view ToString(ControllerType type) {
  switch (type) {
    case ControllerType::kNone: return "none";
    case ControllerType::kPd: return "pd";
    case ControllerType::kGravityCompensation: return "gravity-compensation";
    case ControllerType::kComputedTorque: return "computed-torque";
    case ControllerType::kCartPolePd: return "cartpole-pd";
    case ControllerType::kLqr: return "lqr";
    case ControllerType::kSwingUp: return "swing-up";
  }
  return "?";
}

std::optional<ControllerType> ParseControllerType(std::string_view name) {
  for (ControllerType t : kAllControllers) {
    if (ToString(t) == name) return t;
  }
  return std::nullopt;
}

std::string ControllerTypeNames() {
  std::string names;
  for (ControllerType t : kAllControllers) {
    if (!names.empty()) names += '|';
    names += ToString(t);
  }
  return names;
}

std::optional<std::string> CheckGains(ControllerType type, int n, const Gains& gains) {
  switch (type) {
    case ControllerType::kPd:
    case ControllerType::kGravityCompensation:
    case ControllerType::kComputedTorque: return CheckJointGains(gains, n);
    case ControllerType::kCartPolePd:
      if (gains.kp.size() != n || gains.kd.size() != n || !gains.kp.allFinite() || !gains.kd.allFinite()) {
        return "kp, kd: expected " + std::to_string(n) + " finite gains each, (x, θ)";
      }
      return std::nullopt;
    case ControllerType::kNone:
    case ControllerType::kLqr:
    case ControllerType::kSwingUp: break;
  }
  return std::string(ToString(type)) + " has no adjustable gains";
}

std::optional<std::string> ValidateController(const ControllerConfig& c, const PlantSpec& plant) {
  const int n = plant.num_dofs();
  if (IsCartPoleOnly(c.type) && plant.type() != PlantType::kCartPole) {
    return "type: " + std::string(ToString(c.type)) + " needs a cartpole plant, got " +
           std::string(ToString(plant.type()));
  }
  if (c.model) {
    if (c.model->type() != plant.type() || c.model->num_dofs() != n) {
      return std::string("model: expected the plant's type and size");
    }
    if (auto err = ValidatePlantSpec(*c.model)) return "model.params." + err->key + ": " + err->message;
  }
  if (c.model_method && !HasMethod(c.model ? c.model->type() : plant.type(), *c.model_method)) {
    return std::string("model.method: ") + std::string(ToString(plant.type())) + " has no " +
           std::string(ToString(*c.model_method)) + " path";
  }
  const bool has_gains = c.type == ControllerType::kPd || c.type == ControllerType::kGravityCompensation ||
                         c.type == ControllerType::kComputedTorque || c.type == ControllerType::kCartPolePd;
  if (has_gains) {
    if (auto err = CheckGains(c.type, n, c.gains)) return err;
  }
  if (c.type == ControllerType::kLqr || c.type == ControllerType::kSwingUp) {
    if (auto err = ValidateLqr(c.lqr, plant)) return err;
  }
  if (c.continuous && c.type == ControllerType::kSwingUp) {
    return std::string("continuous: swing-up keeps a mode and runs once per tick");
  }
  if (c.type == ControllerType::kSwingUp) {
    const SwingUpOptions& s = c.swing_up;
    for (const auto& [key, v] : {std::pair{"energy_gain", s.energy_gain}, std::pair{"max_accel", s.max_accel},
                                 std::pair{"switch_angle", s.switch_angle}, std::pair{"switch_rate", s.switch_rate}}) {
      if (!(std::isfinite(v) && v > 0.0)) return std::string(key) + ": expected a positive number";
    }
    if (!(s.cart_gain >= 0.0) || !(s.cart_damping >= 0.0)) return std::string("cart_gain, cart_damping: expected >= 0");
  }
  return std::nullopt;
}

std::unique_ptr<Controller> MakeController(const ControllerConfig& c, const PlantSpec& plant,
                                           const VectorXd& torque_limits) {
  if (auto err = ValidateController(c, plant)) throw std::invalid_argument(*err);
  const std::vector<JointType> joints = JointTypesOf(plant);
  switch (c.type) {
    case ControllerType::kNone: return std::make_unique<ZeroController>(joints, torque_limits);
    case ControllerType::kPd:
    case ControllerType::kGravityCompensation: {
      PdOptions options = c.pd;
      options.gravity_compensation = c.type == ControllerType::kGravityCompensation;
      const bool needs_model = options.gravity_compensation || options.acceleration_feedforward;
      return std::make_unique<PdController>(joints, torque_limits, c.gains, options,
                                            needs_model ? ControllerModel(c, plant) : nullptr);
    }
    case ControllerType::kComputedTorque:
      return std::make_unique<ComputedTorqueController>(joints, torque_limits, c.gains, ControllerModel(c, plant));
    case ControllerType::kCartPolePd: return MakeCartPolePd(joints, torque_limits, c.gains);
    case ControllerType::kLqr: return MakeLqr(c, plant, torque_limits);
    case ControllerType::kSwingUp:
      return std::make_unique<SwingUpController>(joints, torque_limits, c.swing_up, ControllerModel(c, plant),
                                                 MakeLqr(c, plant, torque_limits));
  }
  throw std::invalid_argument("unknown controller");
}

}  // namespace lagrange
