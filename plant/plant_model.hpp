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
// of being held over the tick: a continuous-time (analog) control law. It may
// keep state (a controller's), so it is passed as a non-const pointer.
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
  const Dynamics& dynamics() const { return *dynamics_; }
  Effects& effects() { return effects_; }
  const Effects& effects() const { return effects_; }

  // (law, t, q, qd, tau_cmd) => qdd. `law` null: tau_cmd is held; otherwise
  // tau_cmd is ignored and the law's output at (t, q, qd) is used instead.
  // Inline: with no law and no force effect on (Effects::passes_command_through)
  // tau = tau_cmd, handed to the dynamics as it is; an integrator calls this
  // at every stage.
  void ComputeAcceleration(ControlLaw* law, double t, ConstVecRef q, ConstVecRef qd, ConstVecRef tau_cmd, VecRef qdd) {
    if (law == nullptr && effects_.passes_command_through()) {
      dynamics_->ComputeForwardDynamics(q, qd, tau_cmd, effects_.terms(), qdd);
      return;
    }
    ComputeAccelerationWithEffects(law, t, q, qd, tau_cmd, qdd);
  }
  // (t, q, qd, tau_cmd) => qdd with tau_cmd held.
  void ComputeAcceleration(double t, ConstVecRef q, ConstVecRef qd, ConstVecRef tau_cmd, VecRef qdd) {
    ComputeAcceleration(nullptr, t, q, qd, tau_cmd, qdd);
  }
  // (law, t, q, qd, tau_cmd) => tau, the effects' generalized force; `law` as above.
  void ComputeGeneralizedForce(ControlLaw* law, double t, ConstVecRef q, ConstVecRef qd, ConstVecRef tau_cmd,
                               VecRef tau);

  double KineticEnergy(ConstVecRef q, ConstVecRef qd) const;
  double PotentialEnergy(ConstVecRef q) const;
  double Energy(ConstVecRef q, ConstVecRef qd) const { return KineticEnergy(q, qd) + PotentialEnergy(q); }

  // Gravity and Coriolis counts from the dynamics, the rest from the effects.
  StageCounts counts() const;

 private:
  // ComputeAcceleration through the law and the effects' stages.
  void ComputeAccelerationWithEffects(ControlLaw* law, double t, ConstVecRef q, ConstVecRef qd, ConstVecRef tau_cmd,
                                      VecRef qdd);

  std::unique_ptr<Dynamics> dynamics_;
  Effects effects_;
  VectorXd tau_;      // scratch (n)
  VectorXd tau_law_;  // scratch (n)
};

}  // namespace lagrange
