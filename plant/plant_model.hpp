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

// A commanded generalized force evaluated at every integrator stage instead
// of being held over the tick: a continuous-time (analog) control law.
class ControlLaw {
 public:
  virtual ~ControlLaw() = default;
  // (t, q, qd) => tau_cmd (n). Must not allocate.
  virtual void Compute(double t, ConstVecRef q, ConstVecRef qd, VecRef tau_cmd) = 0;
};

class PlantModel {
 public:
  PlantModel(std::unique_ptr<Dynamics> dynamics, EffectsConfig effects);

  int num_dofs() const { return dynamics_->num_dofs(); }
  Dynamics& dynamics() { return *dynamics_; }
  Effects& effects() { return effects_; }
  const Effects& effects() const { return effects_; }

  // (t, q, qd, tau_cmd) => qdd. With a control law set, tau_cmd is ignored and
  // the law's output at (t, q, qd) is used instead.
  void ComputeAcceleration(double t, ConstVecRef q, ConstVecRef qd, ConstVecRef tau_cmd, VecRef qdd);
  // (t, q, qd, tau_cmd) => tau, the effects' generalized force.
  void ComputeGeneralizedForce(double t, ConstVecRef q, ConstVecRef qd, ConstVecRef tau_cmd, VecRef tau);

  double KineticEnergy(ConstVecRef q, ConstVecRef qd);
  double PotentialEnergy(ConstVecRef q);
  double Energy(ConstVecRef q, ConstVecRef qd) { return KineticEnergy(q, qd) + PotentialEnergy(q); }

  // Gravity and Coriolis counts from the dynamics, the rest from the effects.
  StageCounts counts() const;

  // Evaluate `law` at every stage from now on (null: hold tau_cmd). Not owned.
  void SetControlLaw(ControlLaw* law) { law_ = law; }

 private:
  std::unique_ptr<Dynamics> dynamics_;
  Effects effects_;
  ControlLaw* law_ = nullptr;
  VectorXd tau_;      // scratch (n)
  VectorXd tau_law_;  // scratch (n)
};

}  // namespace lagrange
