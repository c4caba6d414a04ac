#pragma once
// One user's plant as the integrators see it: its dynamics (by one method)
// under the scene's effects. The dynamics models are shared and immutable
// (plant/dynamics.hpp); a PlantModel holds its own data for each of them, the
// effects' switches and counts, and scratch: it is one thread's, as a
// Pinocchio Data or a MuJoCo mjData is.
//
//   (t, q, qd, tau_cmd) => qdd = M⁻¹ (tau − [C qd] − [G]),
//   tau = the effects' generalized force (plant/effects.hpp)
//
// Energies: E = T + V, with V the gravity potential when gravity is on plus
// the joint-limit springs' energy; along the vector field
// dE/dt = qdᵀ (sat(tau_cmd) + pushes) − DissipatedPower.

#include <array>
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

// One contact of a plant another simulator steps (MuJoCo), at the state its
// forces were read at; world frame. What forces_t.contacts carries.
struct ContactWrench {
  int geom1 = -1, geom2 = -1;                          // the simulator's geom ids
  double distance = 0.0;                               // m: between the surfaces, < 0 where they overlap
  Eigen::Vector3d position = Eigen::Vector3d::Zero();  // m: the contact point
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();    // unit, from geom1 towards geom2
  Eigen::Vector3d force = Eigen::Vector3d::Zero();     // N, on geom2 from geom1
  Eigen::Vector3d torque = Eigen::Vector3d::Zero();    // N·m, on geom2 from geom1, about `position`
};

// Each term of the equation of motion at one (t, q, qd, tau_cmd), separately,
// every vector (n) in N·m (revolute) or N (prismatic). Signed as the terms
// act on the joints, so that
//
//   M(q) qdd = tau_applied + disturbance + damping + friction + limits + constraint − coriolis − gravity
//
// which NetForce sums. `gravity` and `coriolis` keep the signs of the
// dynamics contract (G = ∂V/∂q, C qd; plant/dynamics.hpp), so they enter
// with a minus sign; every other term is the force itself:
//   gravity        G(q)
//   coriolis       C(q, qd) qd
//   damping        −b∘qd
//   friction       −Fc∘tanh(qd/v_s)
//   limits         tau_lim(q, qd), the stops' one-sided spring-damper
//   limit_springs  its spring part, −k × penetration (its energy is in V);
//                  limits − limit_springs is the stops' damping, power <= 0
//   constraint     a stepped plant's contacts and equality constraints, Jᵀ λ
//                  (SteppedPlantData::ComputeForces); zero for lagrange's plants
//   disturbance    Σ pushes acting at t
//   tau_cmd        the command: as given, or the ControlLaw's output
//   tau_applied    sat(tau_cmd); tau_cmd itself when saturation is off
// A term whose effect is off (see `active`, `constraint_on`) is zero and was
// not computed; tau_cmd and tau_applied are always filled. A stepped plant
// fills its rows from its simulator's own terms (plant/stepped_plant.hpp) and
// lists its contacts: the first kMaxContacts of `contacts_total`. Sized by
// the constructor, so filling it allocates nothing.
struct EffectForces {
  explicit EffectForces(int n);

  // (this) => M qdd (n), the sum above.
  void NetForce(VecRef out) const;

  VectorXd gravity, coriolis, damping, friction, limits, limit_springs, constraint, disturbance;
  VectorXd tau_cmd, tau_applied;
  EffectFlags active;          // the plant's Effects::flags() at the last fill (a stepped plant's: its simulator's)
  bool constraint_on = false;  // a stepped plant whose simulator has contacts or equality constraints
  int contacts_total = 0;      // the simulator's active contacts
  int num_contacts = 0;        // min(contacts_total, kMaxContacts): contacts[0 .. num_contacts)
  std::array<ContactWrench, kMaxContacts> contacts;
};

class PlantModel {
 public:
  // Throws std::invalid_argument for a null model.
  PlantModel(std::shared_ptr<const Dynamics> dynamics, EffectsConfig effects);

  int num_dofs() const { return dynamics_->num_dofs(); }
  // The method of the dynamics in use.
  Method method() const { return dynamics_->method(); }
  // Adds the same plant's dynamics by another method (built before the loop),
  // with data of its own, for SelectMethod. Throws std::invalid_argument when
  // it is null, its num_dofs differs or its method is already held.
  void AddDynamics(std::shared_ptr<const Dynamics> dynamics);
  bool HasMethod(Method method) const;
  // Switches to the held dynamics of `method`; allocation-free. False, with
  // nothing changed, when none is held.
  bool SelectMethod(Method method);
  // The dynamics in use and this plant's data for it.
  const Dynamics& dynamics() const { return *dynamics_; }
  DynamicsData& data() { return *data_; }
  Effects& effects() { return effects_; }
  const Effects& effects() const { return effects_; }

  // (law, t, q, qd, tau_cmd) => qdd. `law` null: tau_cmd is held; otherwise
  // tau_cmd is ignored and the law's output at (t, q, qd) is used instead.
  // Inline: with no law and no force effect on (Effects::passes_command_through)
  // tau = tau_cmd, handed to the dynamics as it is; an integrator calls this
  // at every stage.
  void ComputeAcceleration(ControlLaw* law, double t, ConstVecRef q, ConstVecRef qd, ConstVecRef tau_cmd, VecRef qdd) {
    if (law == nullptr && effects_.passes_command_through()) {
      dynamics_->ComputeForwardDynamics(*data_, q, qd, tau_cmd, effects_.terms(), qdd);
      return;
    }
    ComputeAccelerationWithEffects(law, t, q, qd, tau_cmd, qdd);
  }
  // (t, q, qd, tau_cmd) => qdd with tau_cmd held.
  void ComputeAcceleration(double t, ConstVecRef q, ConstVecRef qd, ConstVecRef tau_cmd, VecRef qdd) {
    ComputeAcceleration(nullptr, t, q, qd, tau_cmd, qdd);
  }
  // (t, q, qd, tau_cmd) => qdd (n) and its exact derivatives ∂qdd/∂q,
  // ∂qdd/∂qd and ∂qdd/∂tau_cmd (n x n each), tau_cmd held (no ControlLaw),
  // through the effects that are on (their diagonal derivatives and kinks:
  // plant/effects.hpp) and the dynamics' terms:
  //   ∂qdd/∂q   = ∂FD/∂q  + M⁻¹ diag(∂tau/∂q)
  //   ∂qdd/∂qd  = ∂FD/∂qd + M⁻¹ diag(∂tau/∂qd)
  //   ∂qdd/∂tau_cmd = M⁻¹ diag(∂tau/∂tau_cmd)
  // with FD's derivatives at the effects' tau (Dynamics::
  // ComputeForwardDynamicsDerivatives). Allocates nothing.
  void ComputeAccelerationDerivatives(double t, ConstVecRef q, ConstVecRef qd, ConstVecRef tau_cmd, VecRef qdd,
                                      MatRef dqdd_dq, MatRef dqdd_dqd, MatRef dqdd_dtau);

  // (law, t, q, qd, tau_cmd) => tau, the effects' generalized force; `law` as above.
  void ComputeGeneralizedForce(ControlLaw* law, double t, ConstVecRef q, ConstVecRef qd, ConstVecRef tau_cmd,
                               VecRef tau);

  // (law, t, q, qd, tau_cmd) => out, every term of the equation of motion
  // separately (see EffectForces); `law` as in ComputeAcceleration. Runs each
  // active stage once, counted in counts(); an effect that is off is not
  // evaluated and its term is set to zero. Allocates nothing; `out` must be
  // sized for this plant. A law is called once more, at (t, q, qd): one with
  // state sees that call.
  // `conservative` false: gravity and coriolis are neither evaluated nor
  // counted (left zero) even when on, what the energy balance needs
  // (NonConservativePower); `active` still reports the flags.
  void ComputeEffectForces(ControlLaw* law, double t, ConstVecRef q, ConstVecRef qd, ConstVecRef tau_cmd,
                           EffectForces& out, bool conservative = true);
  // The same with tau_cmd held.
  void ComputeEffectForces(double t, ConstVecRef q, ConstVecRef qd, ConstVecRef tau_cmd, EffectForces& out) {
    ComputeEffectForces(nullptr, t, q, qd, tau_cmd, out);
  }

  double KineticEnergy(ConstVecRef q, ConstVecRef qd);
  double PotentialEnergy(ConstVecRef q);
  double Energy(ConstVecRef q, ConstVecRef qd) { return KineticEnergy(q, qd) + PotentialEnergy(q); }

  // Gravity and Coriolis counts from every held dynamics (and
  // ComputeEffectForces), the rest from the effects.
  StageCounts counts() const;

 private:
  // ComputeAcceleration through the law and the effects' stages.
  void ComputeAccelerationWithEffects(ControlLaw* law, double t, ConstVecRef q, ConstVecRef qd, ConstVecRef tau_cmd,
                                      VecRef qdd);

  // Every held method's model and this plant's data for it.
  struct Held {
    std::shared_ptr<const Dynamics> dynamics;
    std::unique_ptr<DynamicsData> data;
  };
  const Dynamics* dynamics_;      // the one in use, one of all_
  DynamicsData* data_ = nullptr;  // its data
  std::vector<Held> all_;
  Effects effects_;
  VectorXd tau_;             // scratch (n)
  VectorXd tau_law_;         // scratch (n)
  VectorXd dtau_dq_, dtau_dqd_, dtau_dcmd_;  // the effects' diagonal derivatives (n each)
  StageCounts term_counts_;  // gravity and Coriolis terms ComputeEffectForces evaluated
};

}  // namespace lagrange
