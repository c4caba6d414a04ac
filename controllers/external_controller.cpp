#include "controllers/external_controller.hpp"

#include <stdexcept>

namespace lagrange {

ExternalController::ExternalController(std::vector<JointType> joints, VectorXd torque_limits,
                                       std::shared_ptr<const Dynamics> model, bool compensate_gravity)
    : Controller(std::move(joints), std::move(torque_limits)),
      model_(std::move(model)),
      data_(model_ ? model_->MakeData() : nullptr),
      compensate_gravity_(compensate_gravity),
      tau_ext_(VectorXd::Zero(num_dofs())),
      g_(VectorXd::Zero(num_dofs())) {
  if (compensate_gravity_ && !model_) throw std::invalid_argument("compensate_gravity needs a model");
}

void ExternalController::ComputeLaw(double, ConstVecRef q, ConstVecRef, const Setpoint&, VecRef tau) {
  tau = tau_ext_;
  if (!compensate_gravity_) return;
  model_->ComputeGravityForce(*data_, q, g_);
  tau += g_;
}

}  // namespace lagrange
