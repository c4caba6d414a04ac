#include "daemon/instance.hpp"

namespace lagrange {

Instance::Instance(const InstanceConfig& config)
    : config_(config),
      external_(config.external.has_value()),
      model_(MakeDynamics(config.plant, config.method), config.effects),
      integrator_(MakeIntegrator(config.integrator, config.plant.num_dofs())),
      trajectory_(MakeTrajectory(config)),
      q_(config.q0),
      qd_(config.qd0),
      qdd_(VectorXd::Zero(config.plant.num_dofs())),
      tau_(VectorXd::Zero(config.plant.num_dofs())),
      tau_cmd_(VectorXd::Zero(config.plant.num_dofs())),
      q_des_(config.q0),
      setpoint_(config.plant.num_dofs()) {
  const VectorXd& limits = config.torque_limits.size() == num_dofs()
                               ? config.torque_limits
                               : VectorXd::Constant(num_dofs(), std::numeric_limits<double>::infinity());
  // A joint with a stop is driven the way the stop allows; only free revolute joints wrap.
  const std::vector<bool> wrap = WrappedJoints(JointTypesOf(config.plant), config.effects.limits);
  const auto make = [&](ControllerConfig c) {
    c.wrap = wrap;
    return MakeController(c, config.plant, limits);
  };
  controllers_.push_back(make(config.controller));
  continuous_.push_back(config.controller.continuous);
  for (const ControllerConfig& c : config.alternates) {
    controllers_.push_back(make(c));
    continuous_.push_back(c.continuous);
  }
  if (config.controller.type != ControllerType::kNone) {
    controllers_.push_back(make(ControllerConfig{}));
    continuous_.push_back(false);
  }
  for (const auto& c : controllers_) {
    scene_gains_.push_back(c->gains());
    externals_.push_back(dynamic_cast<ExternalController*>(c.get()));
  }
  SampleTrajectory(setpoint_);
  q_des_ = setpoint_.q;
  model_.ComputeAcceleration(0.0, q_, qd_, tau_, qdd_);
}

void Instance::SampleTrajectory(Setpoint& out) const { trajectory_->Sample(t_, out); }

Instance::StepFailure Instance::Integrate(double dt, ConstVecRef tau_cmd) {
  model_.effects().Saturate(tau_cmd, tau_);
  const bool ok = external_ || integrator_->Advance(model_, t_, dt, tau_cmd, q_, qd_);
  t_ = static_cast<double>(++steps_) * dt;  // no accumulated round-off over long runs
  model_.ComputeAcceleration(t_, q_, qd_, tau_cmd, qdd_);
  return ok ? nullptr : kIntegratorFailed;
}

void Instance::StageLaw::Bind(Controller& controller, const Setpoint& setpoint) {
  controller_ = &controller;
  setpoint_ = &setpoint;
  ok = true;
}

void Instance::StageLaw::Compute(double t, ConstVecRef q, ConstVecRef qd, VecRef tau_cmd) {
  ok = controller_->Compute(t, q, qd, *setpoint_, tau_cmd) && ok;
}

// (setpoint) => the law at every stage of the sub-steps; tau reported at the new state.
Instance::StepFailure Instance::IntegrateContinuous(double dt, const Setpoint& setpoint, Controller& law) {
  stage_law_.Bind(law, setpoint);
  const bool ok = integrator_->Advance(model_, &stage_law_, t_, dt, tau_cmd_, q_, qd_);
  t_ = static_cast<double>(++steps_) * dt;
  model_.ComputeAcceleration(&stage_law_, t_, q_, qd_, tau_cmd_, qdd_);
  stage_law_.Compute(t_, q_, qd_, tau_cmd_);
  model_.effects().Saturate(tau_cmd_, tau_);
  if (!stage_law_.ok) return kControllerNotFinite;  // the cause, even when the integrator then failed too
  return ok ? nullptr : kIntegratorFailed;
}

Instance::StepFailure Instance::Step(double dt, const Setpoint& setpoint) { return Step(dt, setpoint, active_); }

Instance::StepFailure Instance::Step(double dt, const Setpoint& setpoint, std::size_t index) {
  q_des_ = setpoint.q;
  if (continuous_[index] && !external_) return IntegrateContinuous(dt, setpoint, *controllers_[index]);
  const bool controlled = controllers_[index]->Compute(t_, q_, qd_, setpoint, tau_cmd_);
  const StepFailure integrated = Integrate(dt, tau_cmd_);
  return controlled ? integrated : kControllerNotFinite;
}

Instance::StepFailure Instance::Step(double dt) {
  SampleTrajectory(setpoint_);
  return Step(dt, setpoint_);
}

Instance::StepFailure Instance::StepWithTorque(double dt, ConstVecRef tau_cmd) {
  tau_cmd_ = tau_cmd;
  return Integrate(dt, tau_cmd_);
}

void Instance::Save(Saved& out) const {
  out.steps = steps_;
  out.t = t_;
  out.q = q_;
  out.qd = qd_;
}

void Instance::Restore(const Saved& saved) {
  steps_ = saved.steps;
  t_ = saved.t;
  q_ = saved.q;
  qd_ = saved.qd;
  qdd_.setZero();
  tau_.setZero();
}

std::vector<std::string> Instance::controller_names() const {
  std::vector<std::string> names;
  for (const auto& c : controllers_) names.emplace_back(c->name());
  return names;
}

void Instance::SelectController(std::size_t index) {
  active_ = index;
  controllers_[index]->Reset();
}

std::vector<ControllerType> Instance::controller_types() const {
  std::vector<ControllerType> types = {config_.controller.type};
  for (const ControllerConfig& c : config_.alternates) types.push_back(c.type);
  if (config_.controller.type != ControllerType::kNone) types.push_back(ControllerType::kNone);
  return types;
}

std::optional<std::string> Instance::SelectController(std::string_view name) {
  for (std::size_t i = 0; i < controllers_.size(); ++i) {
    if (controllers_[i]->name() != name) continue;
    SelectController(i);
    return std::nullopt;
  }
  std::string list;
  for (const auto& c : controllers_) list += (list.empty() ? "" : ", ") + std::string(c->name());
  return "unknown controller '" + std::string(name) + "' for " + config_.name + " (available: " + list + ")";
}

void Instance::Reset() {
  t_ = 0.0;
  steps_ = 0;
  q_ = config_.q0;
  qd_ = config_.qd0;
  tau_.setZero();
  tau_cmd_.setZero();
  for (std::size_t i = 0; i < controllers_.size(); ++i) {
    if (scene_gains_[i].kp.size() > 0) controllers_[i]->SetGains(scene_gains_[i]);
  }
  active_ = 0;
  controller().Reset();
  SampleTrajectory(setpoint_);
  q_des_ = setpoint_.q;
  model_.ComputeAcceleration(0.0, q_, qd_, tau_, qdd_);
}

}  // namespace lagrange
