#include "plant/plant_model.hpp"

#include <stdexcept>
#include <string>
#include <utility>

namespace lagrange {

namespace {

const Dynamics& NonNull(const std::shared_ptr<const Dynamics>& dynamics) {
  if (dynamics == nullptr) throw std::invalid_argument("PlantModel: expected dynamics, got null");
  return *dynamics;
}

}  // namespace

PlantModel::PlantModel(std::shared_ptr<const Dynamics> dynamics, EffectsConfig effects)
    : dynamics_(&NonNull(dynamics)),
      effects_(std::move(effects), dynamics_->num_dofs()),
      tau_(dynamics_->num_dofs()),
      tau_law_(dynamics_->num_dofs()),
      dtau_dq_(dynamics_->num_dofs()),
      dtau_dqd_(dynamics_->num_dofs()),
      dtau_dcmd_(dynamics_->num_dofs()) {
  all_.push_back({std::move(dynamics), dynamics_->MakeData()});
  data_ = all_.back().data.get();
}

void PlantModel::AddDynamics(std::shared_ptr<const Dynamics> dynamics) {
  NonNull(dynamics);
  // The scratch above is sized (n): every held dynamics must share it.
  if (dynamics->num_dofs() != num_dofs()) {
    throw std::invalid_argument("AddDynamics: expected " + std::to_string(num_dofs()) + " degrees of freedom, got " +
                                std::to_string(dynamics->num_dofs()));
  }
  if (HasMethod(dynamics->method())) {
    throw std::invalid_argument("AddDynamics: the " + std::string(ToString(dynamics->method())) +
                                " method is already held");
  }
  auto data = dynamics->MakeData();
  all_.push_back({std::move(dynamics), std::move(data)});
}

bool PlantModel::HasMethod(Method method) const {
  for (const Held& h : all_) {
    if (h.dynamics->method() == method) return true;
  }
  return false;
}

bool PlantModel::SelectMethod(Method method) {
  for (const Held& h : all_) {
    if (h.dynamics->method() == method) {
      dynamics_ = h.dynamics.get();
      data_ = h.data.get();
      return true;
    }
  }
  return false;
}

EffectForces::EffectForces(int n)
    : gravity(VectorXd::Zero(n)),
      coriolis(VectorXd::Zero(n)),
      damping(VectorXd::Zero(n)),
      friction(VectorXd::Zero(n)),
      limits(VectorXd::Zero(n)),
      limit_springs(VectorXd::Zero(n)),
      constraint(VectorXd::Zero(n)),
      disturbance(VectorXd::Zero(n)),
      tau_cmd(VectorXd::Zero(n)),
      tau_applied(VectorXd::Zero(n)) {}

void EffectForces::NetForce(VecRef out) const {
  for (int i = 0; i < out.size(); ++i) {
    out[i] = tau_applied[i] + disturbance[i] + damping[i] + friction[i] + limits[i] + constraint[i] - coriolis[i] -
             gravity[i];
  }
}

void PlantModel::ComputeAccelerationWithEffects(ControlLaw* law, double t, ConstVecRef q, ConstVecRef qd,
                                                ConstVecRef tau_cmd, VecRef qdd) {
  if (law == nullptr) {
    effects_.ComputeGeneralizedForce(t, q, qd, tau_cmd, tau_);
  } else {
    law->Compute(t, q, qd, tau_law_);
    if (effects_.passes_command_through()) {  // tau is the law's output as it is
      dynamics_->ComputeForwardDynamics(*data_, q, qd, tau_law_, effects_.terms(), qdd);
      return;
    }
    effects_.ComputeGeneralizedForce(t, q, qd, tau_law_, tau_);
  }
  dynamics_->ComputeForwardDynamics(*data_, q, qd, tau_, effects_.terms(), qdd);
}

void PlantModel::ComputeAccelerationDerivatives(double t, ConstVecRef q, ConstVecRef qd, ConstVecRef tau_cmd,
                                                VecRef qdd, MatRef dqdd_dq, MatRef dqdd_dqd, MatRef dqdd_dtau) {
  if (effects_.passes_command_through()) {
    dynamics_->ComputeForwardDynamicsDerivatives(*data_, q, qd, tau_cmd, effects_.terms(), qdd, dqdd_dq, dqdd_dqd,
                                                 dqdd_dtau);
    return;
  }
  effects_.ComputeGeneralizedForce(t, q, qd, tau_cmd, tau_);
  effects_.ComputeGeneralizedForceDerivatives(q, qd, tau_cmd, dtau_dq_, dtau_dqd_, dtau_dcmd_);
  dynamics_->ComputeForwardDynamicsDerivatives(*data_, q, qd, tau_, effects_.terms(), qdd, dqdd_dq, dqdd_dqd,
                                               dqdd_dtau);
  // dqdd_dtau is M⁻¹ here; its columns scaled by each diagonal.
  for (int j = 0; j < num_dofs(); ++j) {
    if (dtau_dq_[j] != 0.0) dqdd_dq.col(j) += dtau_dq_[j] * dqdd_dtau.col(j);
    if (dtau_dqd_[j] != 0.0) dqdd_dqd.col(j) += dtau_dqd_[j] * dqdd_dtau.col(j);
    dqdd_dtau.col(j) *= dtau_dcmd_[j];
  }
}

void PlantModel::ComputeGeneralizedForce(ControlLaw* law, double t, ConstVecRef q, ConstVecRef qd, ConstVecRef tau_cmd,
                                         VecRef tau) {
  if (law == nullptr) {
    effects_.ComputeGeneralizedForce(t, q, qd, tau_cmd, tau);
    return;
  }
  law->Compute(t, q, qd, tau_law_);
  effects_.ComputeGeneralizedForce(t, q, qd, tau_law_, tau);
}

// (law, t, q, qd, tau_cmd) => (G, C qd, each effect's force, tau_cmd, sat(tau_cmd)).
void PlantModel::ComputeEffectForces(ControlLaw* law, double t, ConstVecRef q, ConstVecRef qd, ConstVecRef tau_cmd,
                                     EffectForces& out, bool conservative) {
  eigen_assert(out.tau_applied.size() == num_dofs());
  const EffectFlags& on = effects_.flags();
  out.active = on;
  if (law == nullptr) {
    out.tau_cmd = tau_cmd;
  } else {
    law->Compute(t, q, qd, out.tau_cmd);
  }
  effects_.Saturate(out.tau_cmd, out.tau_applied);
  out.gravity.setZero();
  if (conservative && on.gravity) {
    dynamics_->ComputeGravityForce(*data_, q, out.gravity);
    ++term_counts_.gravity;
  }
  out.coriolis.setZero();
  if (conservative && on.coriolis) {
    dynamics_->ComputeCoriolisForce(*data_, q, qd, out.coriolis);
    ++term_counts_.coriolis;
  }
  // The effects' stages add to a zero term and return at their top when off.
  out.disturbance.setZero();
  effects_.AddDisturbance(t, out.disturbance);
  out.damping.setZero();
  effects_.AddDamping(qd, out.damping);
  out.friction.setZero();
  effects_.AddFriction(qd, out.friction);
  out.limits.setZero();
  out.limit_springs.setZero();
  effects_.AddLimits(q, qd, out.limits, out.limit_springs);
  out.constraint.setZero();  // lagrange's plants have no constraints (their stops are the limits)
  out.constraint_on = false;
  out.contacts_total = out.num_contacts = 0;
}

double PlantModel::KineticEnergy(ConstVecRef q, ConstVecRef qd) {
  return dynamics_->ComputeKineticEnergy(*data_, q, qd);
}

double PlantModel::PotentialEnergy(ConstVecRef q) {
  double v = effects_.LimitPotentialEnergy(q);
  if (effects_.terms().gravity) v += dynamics_->ComputePotentialEnergy(*data_, q);
  return v;
}

StageCounts PlantModel::counts() const {
  // Summed over every held dynamics: a stage counts whichever method ran it.
  StageCounts c = effects_.counts();
  c.gravity = term_counts_.gravity;
  c.coriolis = term_counts_.coriolis;
  for (const Held& h : all_) {
    c.gravity += h.data->counts().gravity;
    c.coriolis += h.data->counts().coriolis;
  }
  return c;
}

}  // namespace lagrange
