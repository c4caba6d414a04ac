#include "daemon/instance.hpp"

namespace lagrange {

Instance::Instance(const InstanceConfig& config)
    : config_(config),
      model_(MakeDynamics(config.plant, config.method), config.effects),
      integrator_(MakeIntegrator(config.integrator, config.plant.num_dofs())),
      q_(config.q0),
      qd_(config.qd0),
      tau_(VectorXd::Zero(config.plant.num_dofs())) {}

bool Instance::Step(double dt, ConstVecRef tau_cmd) {
  model_.effects().Saturate(tau_cmd, tau_);
  const bool ok = integrator_->Advance(model_, t_, dt, tau_cmd, q_, qd_);
  t_ = static_cast<double>(++steps_) * dt;  // no accumulated round-off over long runs
  return ok;
}

void Instance::Reset() {
  t_ = 0.0;
  steps_ = 0;
  q_ = config_.q0;
  qd_ = config_.qd0;
  tau_.setZero();
}

}  // namespace lagrange
