#pragma once
// A plant instance as the integrators see it: its dynamics (by one method)
// under the scene's effects.
//
//   (t, q, qd, tau_cmd) => qdd = M⁻¹ (tau − [C qd] − [G]),
//   tau = the effects' generalized force (plant/effects.hpp)
//
// Energies: E = T + V, with V the gravity potential when gravity is on plus
// the joint-limit springs' energy; along the vector field
// dE/dt = qdᵀ (sat(tau_cmd) + pushes) − DissipatedPower.

#include <memory>

#include "plant/dynamics.hpp"
#include "plant/effects.hpp"

namespace lagrange {

class PlantModel {
 public:
  PlantModel(std::unique_ptr<Dynamics> dynamics, EffectsConfig effects);

  int num_dofs() const { return dynamics_->num_dofs(); }
  Dynamics& dynamics() { return *dynamics_; }
  Effects& effects() { return effects_; }
  const Effects& effects() const { return effects_; }

  // (t, q, qd, tau_cmd) => qdd.
  void ComputeAcceleration(double t, ConstVecRef q, ConstVecRef qd, ConstVecRef tau_cmd, VecRef qdd);
  // (t, q, qd, tau_cmd) => tau, the effects' generalized force.
  void ComputeGeneralizedForce(double t, ConstVecRef q, ConstVecRef qd, ConstVecRef tau_cmd, VecRef tau);

  double KineticEnergy(ConstVecRef q, ConstVecRef qd);
  double PotentialEnergy(ConstVecRef q);
  double Energy(ConstVecRef q, ConstVecRef qd) { return KineticEnergy(q, qd) + PotentialEnergy(q); }

  // Gravity and Coriolis counts from the dynamics, the rest from the effects.
  StageCounts counts() const;

 private:
  std::unique_ptr<Dynamics> dynamics_;
  Effects effects_;
  VectorXd tau_;  // scratch (n)
};

}  // namespace lagrange
