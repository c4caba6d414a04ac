#include "controllers/joint_controllers.hpp"

#include <stdexcept>

namespace lagrange {

PdController::PdController(std::vector<JointType> joints, VectorXd torque_limits, Gains gains, PdOptions options,
                           std::shared_ptr<const Dynamics> model)
    : Controller(std::move(joints), std::move(torque_limits)),
      gains_(std::move(gains)),
      options_(options),
      model_(std::move(model)),
      data_(model_ ? model_->MakeData() : nullptr),
      M_(num_dofs(), num_dofs()),
      e_(num_dofs()),
      term_(num_dofs()) {
  if (auto fault = FindGainFault(gains_, gain_bounds())) {
    throw std::invalid_argument(DescribeGainFault(*fault, gains_, gain_bounds()));
  }
  if ((options_.acceleration_feedforward || options_.gravity_compensation) && !model_) {
    throw std::invalid_argument("PD with model terms needs a model");
  }
}

std::string_view PdController::name() const { return options_.gravity_compensation ? "gravity-compensation" : "pd"; }

void PdController::ApplyGains(const Gains& gains) {
  gains_.kp = gains.kp;
  gains_.kd = gains.kd;
}

void PdController::ComputeLaw(double, ConstVecRef q, ConstVecRef qd, const Setpoint& sp, VecRef tau) {
  for (int i = 0; i < num_dofs(); ++i) {
    const double e = Error(i, sp.q[i], q[i]);
    const double edot = (options_.velocity_feedforward ? sp.qd[i] : 0.0) - qd[i];
    tau[i] = gains_.kp[i] * e + gains_.kd[i] * edot;
  }
  if (options_.acceleration_feedforward) {
    model_->ComputeMassMatrix(*data_, q, M_);
    tau.noalias() += M_ * sp.qdd;
  }
  if (options_.gravity_compensation) {
    model_->ComputeGravityForce(*data_, q, term_);
    tau += term_;
  }
}

ComputedTorqueController::ComputedTorqueController(std::vector<JointType> joints, VectorXd torque_limits, Gains gains,
                                                   std::shared_ptr<const Dynamics> model)
    : Controller(std::move(joints), std::move(torque_limits)),
      gains_(std::move(gains)),
      model_(std::move(model)),
      data_(model_ ? model_->MakeData() : nullptr),
      a_(num_dofs()) {
  if (auto fault = FindGainFault(gains_, gain_bounds())) {
    throw std::invalid_argument(DescribeGainFault(*fault, gains_, gain_bounds()));
  }
  if (!model_) throw std::invalid_argument("computed torque needs a model");
}

void ComputedTorqueController::ApplyGains(const Gains& gains) {
  gains_.kp = gains.kp;
  gains_.kd = gains.kd;
}

void ComputedTorqueController::ComputeLaw(double, ConstVecRef q, ConstVecRef qd, const Setpoint& sp, VecRef tau) {
  // a = qdd_d + Kd ė + Kp e, then tau = M a + C qd + G by the model's inverse dynamics.
  for (int i = 0; i < num_dofs(); ++i) {
    const double e = Error(i, sp.q[i], q[i]);
    a_[i] = sp.qdd[i] + gains_.kd[i] * (sp.qd[i] - qd[i]) + gains_.kp[i] * e;
  }
  model_->ComputeInverseDynamics(*data_, q, qd, a_, DynamicsTerms{}, tau);
}

}  // namespace lagrange
