#include "plant/plant_model.hpp"

#include <utility>

namespace lagrange {

PlantModel::PlantModel(std::unique_ptr<Dynamics> dynamics, EffectsConfig effects)
    : dynamics_(std::move(dynamics)),
      effects_(std::move(effects), dynamics_->num_dofs()),
      tau_(dynamics_->num_dofs()),
      tau_law_(dynamics_->num_dofs()) {}

void PlantModel::ComputeAccelerationWithEffects(ControlLaw* law, double t, ConstVecRef q, ConstVecRef qd,
                                                ConstVecRef tau_cmd, VecRef qdd) {
  if (law == nullptr) {
    effects_.ComputeGeneralizedForce(t, q, qd, tau_cmd, tau_);
  } else {
    law->Compute(t, q, qd, tau_law_);
    if (effects_.passes_command_through()) {  // tau is the law's output as it is
      dynamics_->ComputeForwardDynamics(q, qd, tau_law_, effects_.terms(), qdd);
      return;
    }
    effects_.ComputeGeneralizedForce(t, q, qd, tau_law_, tau_);
  }
  dynamics_->ComputeForwardDynamics(q, qd, tau_, effects_.terms(), qdd);
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

double PlantModel::KineticEnergy(ConstVecRef q, ConstVecRef qd) const { return dynamics_->ComputeKineticEnergy(q, qd); }

double PlantModel::PotentialEnergy(ConstVecRef q) const {
  double v = effects_.LimitPotentialEnergy(q);
  if (effects_.config().gravity) v += dynamics_->ComputePotentialEnergy(q);
  return v;
}

StageCounts PlantModel::counts() const {
  StageCounts c = effects_.counts();
  c.gravity = dynamics_->counts().gravity;
  c.coriolis = dynamics_->counts().coriolis;
  return c;
}

}  // namespace lagrange
