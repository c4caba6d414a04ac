#include "sim/instance.hpp"

namespace lagrange {
namespace {

constexpr IntegratorType kAllIntegrators[] = {IntegratorType::kExplicitEuler, IntegratorType::kSemiImplicitEuler,
                                              IntegratorType::kRk4, IntegratorType::kDormandPrince,
                                              IntegratorType::kVariational};
constexpr Method kAllMethods[] = {Method::kClosedForm, Method::kLagrangian, Method::kRecursive};

bool IsFloatingIntegrator(IntegratorType type) {
  return type == IntegratorType::kExplicitEuler || type == IntegratorType::kSemiImplicitEuler ||
         type == IntegratorType::kRk4 || type == IntegratorType::kVariational;
}

}  // namespace

Instance::Instance(const InstanceConfig& config)
    : Instance(std::make_shared<const InstanceModel>(BuildInstanceModel(config))) {}

Instance::Instance(std::shared_ptr<const InstanceModel> model)
    : instance_model_(std::move(model)),
      external_(instance_model_->external_plant()),
      stepped_(instance_model_->config.mujoco ? instance_model_->config.mujoco->model->MakeData() : nullptr),
      model_(instance_model_->dynamics[static_cast<std::size_t>(instance_model_->config.method)],
             instance_model_->config.effects),
      trajectory_(MakeTrajectory(instance_model_->config)),
      q_(instance_model_->config.q0),
      qd_(instance_model_->config.qd0),
      qdd_(VectorXd::Zero(instance_model_->num_dofs)),
      tau_(VectorXd::Zero(instance_model_->num_dofs)),
      tau_cmd_(VectorXd::Zero(instance_model_->num_dofs)),
      q_des_(instance_model_->config.q0),
      setpoint_(instance_model_->num_dofs),
      ahead_(instance_model_->num_dofs),
      accounting_((instance_model_->config.telemetry || instance_model_->config.energy_balance) && !external_),
      forces_(instance_model_->num_dofs),
      q_start_(VectorXd::Zero(instance_model_->num_dofs)),
      qd_start_(VectorXd::Zero(instance_model_->num_dofs)),
      tau_start_(VectorXd::Zero(instance_model_->num_dofs)) {
  const InstanceModel& im = *instance_model_;
  const InstanceConfig& config = im.config;
  // Every method the plant has and every integrator type, so that switching
  // at run time builds nothing.
  for (const Method m : kAllMethods) {
    if (m != config.method && im.dynamics[static_cast<std::size_t>(m)]) {
      model_.AddDynamics(im.dynamics[static_cast<std::size_t>(m)]);
    }
  }
  for (const IntegratorType type : kAllIntegrators) {
    IntegratorConfig c = config.integrator;
    c.type = type;
    integrators_.push_back(MakeIntegrator(c, num_dofs()));
  }
  integrator_ = integrators_[static_cast<std::size_t>(config.integrator.type)].get();
  if (im.floating) {
    floating_ = im.floating.get();
    fdata_ = floating_->MakeData();
    for (const IntegratorType type : kAllIntegrators) {
      IntegratorConfig c = config.integrator;
      c.type = type;
      fintegrators_.push_back(IsFloatingIntegrator(type) ? std::make_unique<FloatingIntegrator>(c, *floating_)
                                                         : nullptr);
    }
    fintegrator_ = fintegrators_[static_cast<std::size_t>(config.integrator.type)].get();
    fsubsteps_ = config.integrator.substeps;
    fq_.resize(floating_->num_q());
    fq_ << config.floating->q0, q_;
    fv_.resize(floating_->num_v());
    fv_ << config.floating->v0, qd_;
    ftau_ = VectorXd::Zero(floating_->num_v());
    fa_ = VectorXd::Zero(floating_->num_v());
    fzero_ = VectorXd::Zero(floating_->num_v());
    fbias_ = VectorXd::Zero(floating_->num_v());
    fjc_ = MatrixXd::Zero(3, floating_->num_v());
    if (stepped_) {  // MuJoCo steps the whole state; its rows of every effect, nv, before the joints' are taken
      accounting_ = false;
      ftau_.setZero();
      fforces_ = std::make_unique<EffectForces>(floating_->num_v());
    }
  }
  for (const ControllerModel& c : im.controllers) {
    controllers_.push_back(
        MakeController(c.config, config.plant, im.torque_limits, im.dynamics, config.effects, im.floating));
    continuous_.push_back(c.config.continuous);
  }
  for (const auto& c : controllers_) {
    scene_gains_.push_back(c->gains());
    externals_.push_back(dynamic_cast<ExternalController*>(c.get()));
    mpcs_.push_back(dynamic_cast<MpcController*>(c.get()));
    task_spaces_.push_back(dynamic_cast<TaskSpaceController*>(c.get()));
  }
  SampleTrajectory(setpoint_);
  q_des_ = setpoint_.q;
  SetSteppedState();
  ComputeAcceleration(0.0, tau_);
  ResetBalance();
}

void Instance::SetSteppedState() {
  if (!stepped_) return;
  if (floating_) {
    stepped_->SetState(fq_, fv_);
  } else {
    stepped_->SetState(q_, qd_);
  }
}

void Instance::ComputeAcceleration(double t, ConstVecRef tau_cmd) {
  if (!floating_) {
    model_.ComputeAcceleration(t, q_, qd_, tau_cmd, qdd_);
    return;
  }
  const int n = num_dofs();
  ftau_.head<kFreeFlyerNv>().setZero();  // the base is unactuated
  model_.effects().ComputeGeneralizedForce(t, q_, qd_, tau_cmd, ftau_.tail(n));
  floating_->ComputeForwardDynamics(*fdata_, fq_, fv_, ftau_, model_.effects().terms(), fa_);
  qdd_ = fa_.tail(n);
}

Instance::StepFailure Instance::StepFloating(double dt, ConstVecRef tau_cmd) {
  const int n = num_dofs();
  const double h = dt / fsubsteps_;
  ftau_.head<kFreeFlyerNv>().setZero();
  double work = 0.0;  // J: of the joints' forces but the stops' springs (their energy is in V)
  bool ok = true;
  const IntegratorStats before = fintegrator_->stats();
  for (int k = 0; k < fsubsteps_; ++k) {
    // The joints' force, the command through every effect, held over the sub-step: its work is Δqᵀ of it.
    model_.ComputeEffectForces(nullptr, t_ + k * h, q_, qd_, tau_cmd, forces_, /*conservative=*/false);
    forces_.NetForce(ftau_.tail(n));
    q_start_ = q_;
    ok = fintegrator_->Step(h, ftau_, model_.effects().terms(), fq_, fv_) && ok;
    q_ = fq_.tail(n);
    qd_ = fv_.tail(n);
    work += HeldWork(q_start_, q_, forces_);
  }
  const IntegratorStats& after = fintegrator_->stats();
  fwork_ = IntegratorWork{.steps = after.steps - before.steps,
                          .evaluations = after.evaluations - before.evaluations,
                          .accepted = after.accepted - before.accepted,
                          .rejected = after.rejected - before.rejected,
                          .newton_iterations = after.newton_iterations - before.newton_iterations,
                          .failures = after.failures - before.failures,
                          .step = h};
  t_ = static_cast<double>(++steps_) * dt;
  ComputeAcceleration(t_, tau_cmd);
  AccountHeld(dt, work);
  return ok && fq_.allFinite() && fv_.allFinite() ? nullptr : kIntegratorFailed;
}

Instance::BaseMotion Instance::ComputeBaseMotion() {
  BaseMotion out;
  out.com = floating_->ComputeCenterOfMass(*fdata_, fq_, fjc_);
  const spatial::Force h = floating_->ComputeMomentum(*fdata_, fq_, fv_);  // angular about the world origin
  out.linear = h.f;
  out.angular = h.n - out.com.cross(h.f);  // carried to the centre of mass
  return out;
}

void Instance::ResetBalance() {
  balance_.Reset(KineticEnergy() + PotentialEnergy());
  rest_power_ = power_end_ = 0.0;
  if (accounting_ && !stepped_) ComputePowers();
}

void Instance::ComputePowers() {
  model_.ComputeEffectForces(nullptr, t_, q_, qd_, tau_cmd_, forces_, /*conservative=*/false);
  power_end_ = NonConservativePower(qd_, forces_);
  rest_power_ = power_end_ - qd_.dot(forces_.tau_applied);
}

// The tick just integrated ran from (q_start_, qd_start_) under tau_cmd_:
// held, its applied force's work is tau·Δq exactly (`held`); a law's
// (tau_applied_start at the start, the law's output at the end) goes through
// the trapezoid rule with the rest's. The rest's power (damping, friction,
// stops, pushes: functions of the state and t) at the start is the previous
// end's; at the end it is computed afresh. A non-finite end (the health
// check then faults the step) adds nothing.
void Instance::Account(double dt, ConstVecRef tau_applied_start, bool held) {
  if (!accounting_) return;
  model_.ComputeEffectForces(nullptr, t_, q_, qd_, tau_cmd_, forces_, /*conservative=*/false);
  const double power_end = NonConservativePower(qd_, forces_);
  const double rest_end = power_end - qd_.dot(forces_.tau_applied);
  const double energy = ComputeEnergies();
  if (!std::isfinite(power_end) || !std::isfinite(energy)) return;
  energies_cached_ = true;
  if (held) {
    balance_.AddTickWithWork(dt, tau_applied_start.dot(q_ - q_start_), rest_power_, rest_end, energy);
  } else {
    balance_.AddTick(dt, rest_power_ + qd_start_.dot(tau_applied_start), power_end, energy);
  }
  power_end_ = power_end;
  rest_power_ = rest_end;
}

// Every force was held over each sub-step, so W gains its exact work and nothing goes through the trapezoid rule.
void Instance::AccountHeld(double dt, double held_work) {
  if (!accounting_) return;
  ComputePowers();  // the power at the tick's end, under its command
  const double energy = ComputeEnergies();
  if (!std::isfinite(held_work) || !std::isfinite(energy)) return;
  energies_cached_ = true;
  balance_.AddTickWithWork(dt, held_work, 0.0, 0.0, energy);
}

double Instance::ComputeEnergies() {
  if (floating_) {
    kinetic_ = floating_->ComputeKineticEnergy(*fdata_, fq_, fv_);
    potential_ = FloatingPotentialEnergy();
  } else {
    kinetic_ = model_.KineticEnergy(q_, qd_);
    potential_ = model_.PotentialEnergy(q_);
  }
  return kinetic_ + potential_;
}

double Instance::FloatingPotentialEnergy() {
  const double springs = model_.effects().LimitPotentialEnergy(q_);
  return model_.effects().terms().gravity ? floating_->ComputePotentialEnergy(*fdata_, fq_) + springs : springs;
}

void Instance::ComputeForces(EffectForces& out) {
  if (!stepped_) {
    // A floating base's gravity and Coriolis terms are the floating model's, not the joints' model's.
    model_.ComputeEffectForces(nullptr, t_, q_, qd_, tau_cmd_, out, /*conservative=*/floating_ == nullptr);
    if (floating_) ComputeFloatingBiasRows(out);
    return;
  }
  // The simulator's own terms at the state it holds, under the force it applied (tau_).
  if (fforces_) {
    ComputeFloatingSteppedForces(out);
  } else {
    stepped_->ComputeForces(out);
  }
  out.tau_cmd = tau_cmd_;
  out.tau_applied = tau_;
  out.active.saturation = model_.effects().flags().saturation;
  out.active.disturbance = false;
  out.disturbance.setZero();
}

// (q, v) => G(q) and C(q, v) v of the whole robot (nv, by the floating model's RNEA at a = 0), the joints' rows
// kept; each only when its effect is on (off: zeros, not computed).
void Instance::ComputeFloatingBiasRows(EffectForces& out) {
  const int n = num_dofs();
  if (out.active.gravity) {
    floating_->ComputeInverseDynamics(*fdata_, fq_, fv_, fzero_, {.gravity = true, .coriolis = false}, fbias_);
    out.gravity = fbias_.tail(n);
  }
  if (out.active.coriolis) {
    floating_->ComputeInverseDynamics(*fdata_, fq_, fv_, fzero_, {.gravity = false, .coriolis = true}, fbias_);
    out.coriolis = fbias_.tail(n);
  }
}

// A floating base's: MuJoCo's rows (nv) at the state it holds, the joints' kept (the base's six are no joint's).
void Instance::ComputeFloatingSteppedForces(EffectForces& out) {
  EffectForces& full = *fforces_;
  stepped_->ComputeForces(full);
  const int n = num_dofs();
  out.gravity = full.gravity.tail(n);
  out.coriolis = full.coriolis.tail(n);
  out.damping = full.damping.tail(n);
  out.friction = full.friction.tail(n);
  out.limits = full.limits.tail(n);
  out.limit_springs = full.limit_springs.tail(n);
  out.constraint = full.constraint.tail(n);
  out.active = full.active;
  out.constraint_on = full.constraint_on;
  out.contacts_total = full.contacts_total;
  out.num_contacts = full.num_contacts;
  out.contacts = full.contacts;
}

const char* Instance::CheckIntegrator(const IntegratorConfig& config) const {
  if (external_) return kExternalNotIntegrated;
  if (stepped_) return kMujocoIntegrated;
  if (floating_ && !IsFloatingIntegrator(config.type)) return kFloatingIntegrators;
  if (config.type == IntegratorType::kVariational && !model_.effects().flags().coriolis) {
    return kVariationalNeedsCoriolis;
  }
  return CheckIntegratorConfig(config);
}

const char* Instance::SetIntegrator(const IntegratorConfig& config) {
  if (const char* refused = CheckIntegrator(config)) return refused;
  Integrator& target = *integrators_[static_cast<std::size_t>(config.type)];
  if (const char* refused = target.Reconfigure(config)) return refused;
  integrator_ = &target;
  if (floating_) {
    fintegrator_ = fintegrators_[static_cast<std::size_t>(config.type)].get();
    fintegrator_->Reconfigure(config);
    fsubsteps_ = config.substeps;
  }
  return nullptr;
}

const char* Instance::SetEffect(EffectKind kind, bool on) {
  if (stepped_) return kMujocoEffects;
  if (kind == EffectKind::kCoriolis && !on && !external_ && integrator_->type() == IntegratorType::kVariational) {
    return kVariationalNeedsCoriolis;
  }
  if (!model_.effects().SetEnabled(kind, on)) return NotConfiguredReason(kind);
  energies_cached_ = false;  // V may have gained or lost a term; q̈ follows at the next step
  if (!accounting_) return nullptr;
  // V may have gained or lost a term, and the rest's power changed with the effects.
  balance_.Rebase(KineticEnergy() + PotentialEnergy());
  ComputePowers();
  return nullptr;
}

const char* Instance::SetMethod(Method method) {
  if (floating_ && method != Method::kRecursive) return kFloatingMethod;
  if (!model_.SelectMethod(method)) return NoMethodReason(config().plant.type(), method);
  return nullptr;  // q̈ follows at the next step
}

void Instance::SampleTrajectory(Setpoint& out) const { trajectory_->Sample(t_ - trajectory_start_, out); }

void Instance::SampleTrajectoryAhead(double dt, MatrixXd& q, MatrixXd& qd) {
  for (Eigen::Index k = 0; k < q.cols(); ++k) {
    trajectory_->Sample(t_ - trajectory_start_ + static_cast<double>(k) * dt, ahead_);
    q.col(k) = ahead_.q;
    qd.col(k) = ahead_.qd;
  }
}

void Instance::RestartTrajectory() {
  trajectory_->StartFrom(q_, qd_);
  trajectory_start_ = t_;
}

Instance::StepFailure Instance::StepPlant(double dt) {
  q_start_ = q_;
  StepFailure failed = nullptr;  // the state unchanged when it failed
  if (floating_) {               // the base unactuated: MuJoCo's contacts and gravity move it
    const int n = num_dofs();
    ftau_.tail(n) = tau_;
    failed = stepped_->Step(ftau_, fq_, fv_, fa_);
    q_ = fq_.tail(n);
    qd_ = fv_.tail(n);
    qdd_ = fa_.tail(n);
  } else {
    failed = stepped_->Step(tau_, q_, qd_, qdd_);
  }
  t_ = static_cast<double>(++steps_) * dt;
  if (failed) return failed;
  if (accounting_) {
    // The command held over the tick does tau·Δq exactly; the rest's work is the simulator's sum.
    balance_.AddTickWithWork(dt, tau_.dot(q_ - q_start_) + stepped_->other_work(), 0.0, 0.0,
                             KineticEnergy() + PotentialEnergy());
    power_end_ = qd_.dot(tau_);
  }
  return nullptr;
}

Instance::StepFailure Instance::Integrate(double dt, ConstVecRef tau_cmd) {
  model_.effects().Saturate(tau_cmd, tau_);
  energies_cached_ = false;
  if (stepped_) return StepPlant(dt);
  if (floating_) return StepFloating(dt, tau_cmd);
  q_start_ = q_;
  qd_start_ = qd_;
  const bool ok = external_ || integrator_->Advance(model_, t_, dt, tau_cmd, q_, qd_);
  t_ = static_cast<double>(++steps_) * dt;  // no accumulated round-off over long runs
  model_.ComputeAcceleration(t_, q_, qd_, tau_cmd, qdd_);
  if (!external_) Account(dt, tau_, /*held=*/true);
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
  energies_cached_ = false;
  q_start_ = q_;
  qd_start_ = qd_;
  if (accounting_) {  // the law's applied force at the start, under this tick's setpoint (the first stage's)
    stage_law_.Compute(t_, q_, qd_, tau_cmd_);
    model_.effects().Saturate(tau_cmd_, tau_start_);
  }
  const bool ok = integrator_->Advance(model_, &stage_law_, t_, dt, tau_cmd_, q_, qd_);
  t_ = static_cast<double>(++steps_) * dt;
  model_.ComputeAcceleration(&stage_law_, t_, q_, qd_, tau_cmd_, qdd_);
  stage_law_.Compute(t_, q_, qd_, tau_cmd_);
  model_.effects().Saturate(tau_cmd_, tau_);
  Account(dt, tau_start_, /*held=*/false);
  if (!stage_law_.ok) return kControllerNotFinite;  // the cause, even when the integrator then failed too
  return ok ? nullptr : kIntegratorFailed;
}

Instance::StepFailure Instance::Step(double dt, const Setpoint& setpoint) { return Step(dt, setpoint, active_); }

Instance::StepFailure Instance::Step(double dt, const Setpoint& setpoint, std::size_t index) {
  q_des_ = setpoint.q;
  if (continuous_[index] && !external_ && !stepped_ && !floating_) return IntegrateContinuous(dt, setpoint, *controllers_[index]);
  Controller& law = *controllers_[index];
  const bool controlled =
      floating_ ? law.Compute(t_, fq_.head<kFreeFlyerNq>(), fv_.head<kFreeFlyerNv>(), q_, qd_, setpoint, tau_cmd_)
                : law.Compute(t_, q_, qd_, setpoint, tau_cmd_);
  const StepFailure integrated = Integrate(dt, tau_cmd_);
  return controlled ? integrated : kControllerNotFinite;
}

Instance::StepFailure Instance::Step(double dt) {
  SampleTrajectory(setpoint_);
  // An mpc plan made this step follows the trajectory ahead over its horizon.
  if (MpcController* mpc = mpcs_[active_]; mpc != nullptr && mpc->plan_due(t_)) {
    MpcController::Reference& ahead = mpc->NextReference();
    SampleTrajectoryAhead(mpc->ddp_model()->dt(), ahead.q, ahead.qd);
  }
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
  out.balance = balance_;
  out.rest_power = rest_power_;
  out.power_end = power_end_;
  out.floating_q = fq_;
  out.floating_v = fv_;
}

void Instance::Restore(const Saved& saved) {
  energies_cached_ = false;
  steps_ = saved.steps;
  t_ = saved.t;
  q_ = saved.q;
  qd_ = saved.qd;
  qdd_.setZero();
  tau_.setZero();
  tau_cmd_.setZero();  // frozen under zero torque: nothing of the undone step is left
  fq_ = saved.floating_q;
  fv_ = saved.floating_v;
  SetSteppedState();
  balance_ = saved.balance;
  rest_power_ = saved.rest_power;
  power_end_ = saved.power_end;
}

void Instance::SetState(ConstVecRef q, ConstVecRef qd) {
  PlaceJoints(q, qd);
  SettleAtNewState();
}

void Instance::SetBaseState(ConstVecRef base_q, ConstVecRef base_v) {
  PlaceBase(base_q, base_v);
  SettleAtNewState();
}

void Instance::SetState(ConstVecRef q, ConstVecRef qd, ConstVecRef base_q, ConstVecRef base_v) {
  PlaceJoints(q, qd);
  PlaceBase(base_q, base_v);
  SettleAtNewState();
}

void Instance::PlaceJoints(ConstVecRef q, ConstVecRef qd) {
  q_ = q;
  qd_ = qd;
  energies_cached_ = false;
  if (floating_) {  // the joints moved; the base stays where it is
    fq_.tail(num_dofs()) = q_;
    fv_.tail(num_dofs()) = qd_;
  }
}

void Instance::PlaceBase(ConstVecRef base_q, ConstVecRef base_v) {
  eigen_assert(floating_ && base_q.size() == kFreeFlyerNq && base_v.size() == kFreeFlyerNv &&
               "SetBaseState: a floating base's pose (7) and twist (6)");
  fq_.head<kFreeFlyerNq>() = base_q;  // the joints stay where they are
  fv_.head<kFreeFlyerNv>() = base_v;
  energies_cached_ = false;
}

void Instance::SettleAtNewState() {
  SetSteppedState();
  ComputeAcceleration(t_, tau_cmd_);  // as a step ends: its command, through the effects
  if (!accounting_) return;
  balance_.Rebase(KineticEnergy() + PotentialEnergy());
  if (!stepped_) ComputePowers();
}

std::vector<std::string> Instance::controller_names() const {
  std::vector<std::string> names;
  for (const ControllerModel& c : instance_model_->controllers) names.push_back(c.name);
  return names;
}

void Instance::SelectController(std::size_t index) {
  active_ = index;
  controllers_[index]->Reset();
}

std::optional<std::string> Instance::SelectController(std::string_view name) {
  for (std::size_t i = 0; i < controllers_.size(); ++i) {
    if (controllers_[i]->name() != name) continue;
    SelectController(i);
    return std::nullopt;
  }
  std::string list;
  for (const auto& c : controllers_) list += (list.empty() ? "" : ", ") + std::string(c->name());
  return "unknown controller '" + std::string(name) + "' for " + config().name + " (available: " + list + ")";
}

void Instance::Reset() {
  energies_cached_ = false;
  t_ = 0.0;
  steps_ = 0;
  q_ = config().q0;
  qd_ = config().qd0;
  tau_.setZero();
  tau_cmd_.setZero();
  for (std::size_t i = 0; i < controllers_.size(); ++i) {
    if (scene_gains_[i].kp.size() > 0) controllers_[i]->SetGains(scene_gains_[i]);
  }
  active_ = 0;
  controller().Reset();
  RestartTrajectory();  // from the scene's initial state at t = 0, as built
  SampleTrajectory(setpoint_);
  q_des_ = setpoint_.q;
  if (floating_) {
    fq_ << config().floating->q0, q_;
    fv_ << config().floating->v0, qd_;
  }
  SetSteppedState();
  ComputeAcceleration(0.0, tau_);
  ResetBalance();
}

}  // namespace lagrange
