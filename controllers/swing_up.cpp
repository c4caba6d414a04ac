#include "controllers/swing_up.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>

namespace lagrange {

SwingUpController::SwingUpController(std::vector<JointType> joints, VectorXd torque_limits, SwingUpOptions options,
                                     std::shared_ptr<const Dynamics> model, std::unique_ptr<Controller> balancer)
    : Controller(std::move(joints), std::move(torque_limits)),
      options_(options),
      model_(std::move(model)),
      data_(model_ ? model_->MakeData() : nullptr),
      balancer_(std::move(balancer)),
      M_(2, 2),
      c_(2),
      G_(2) {
  if (num_dofs() != 2 || joint_types()[0] != JointType::kPrismatic || joint_types()[1] != JointType::kRevolute) {
    throw std::invalid_argument("swing-up needs a cart-pole: a prismatic cart joint and a revolute pole joint");
  }
  if (!model_ || !balancer_) throw std::invalid_argument("swing-up needs a model and a balancing controller");
  VectorXd up(2);
  up << 0.0, std::numbers::pi;
  energy_up_ = model_->ComputePotentialEnergy(*data_, up);
}

void SwingUpController::ComputeLaw(double t, ConstVecRef q, ConstVecRef qd, const Setpoint& sp, VecRef tau) {
  const double off_upright = std::abs(JointError(JointType::kRevolute, std::numbers::pi, q[1]));
  if (!balancing_ && off_upright < options_.switch_angle && std::abs(qd[1]) < options_.switch_rate) {
    balancing_ = true;
  } else if (balancing_ && off_upright > 2.0 * options_.switch_angle) {
    balancing_ = false;
  }
  if (balancing_) {
    // The balancer applies its own limits; Compute here only re-checks them.
    if (!balancer_->Compute(t, q, qd, sp, tau)) tau.setConstant(std::numeric_limits<double>::quiet_NaN());
    return;
  }
  model_->ComputeMassMatrix(*data_, q, M_);
  model_->ComputeCoriolisForce(*data_, q, qd, c_);
  model_->ComputeGravityForce(*data_, q, G_);
  const double energy = 0.5 * M_(1, 1) * qd[1] * qd[1] + model_->ComputePotentialEnergy(*data_, q);
  const double pump = qd[1] * std::cos(q[1]);
  const double direction = pump >= 0.0 ? 1.0 : -1.0;
  const double accel = options_.energy_gain * (energy - energy_up_) * direction - options_.cart_gain * q[0] -
                       options_.cart_damping * qd[0];
  const double xdd = std::clamp(accel, -options_.max_accel, options_.max_accel);
  const double thdd = -(M_(1, 0) * xdd + c_[1] + G_[1]) / M_(1, 1);
  tau[0] = M_(0, 0) * xdd + M_(0, 1) * thdd + c_[0] + G_[0];
  tau[1] = 0.0;
}

}  // namespace lagrange
