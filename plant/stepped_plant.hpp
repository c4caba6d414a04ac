#pragma once
// A plant another simulator steps (MuJoCo: plant/mujoco_plant.hpp, library
// lagrange_mujoco): the instance hands it the applied joint force for one
// tick and reads the state back; lagrange's own dynamics model is then the
// controllers' only. Model and data apart, as everywhere: the model is loaded
// once (immutable, shared), each user makes its data once, holding every
// buffer a step needs, so Step allocates nothing.
//
//   (q, qd at t; tau held over the tick) => (q, qd, qdd at t + tick)
//
// Energies E = T + V as the simulator computes them (V: gravity and joint
// springs), and the work over the tick of every force but tau (damping,
// friction loss, joint limits, contacts), so that the energy balance of
// plant/energy_balance.hpp reads ε = E − E(0) − W with W = Σ tau·Δq + that.
// And each term of its equation of motion at the current state, from the
// simulator's own terms (ComputeForces), which add up to its M(q) qdd.

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "plant/plant_model.hpp"
#include "plant/types.hpp"

namespace lagrange {

class SteppedPlantData {
 public:
  virtual ~SteppedPlantData() = default;
  // Sets the state (n each) and evaluates it (energies, qdd under zero force); no allocation.
  virtual void SetState(ConstVecRef q, ConstVecRef qd) = 0;
  // (tau (n), N·m or N, held over the tick) => q, qd at the tick's end and
  // qdd there under tau (n each). Null, or why it failed (a static string: a
  // warning of the simulator, a state that is not finite); the outputs are
  // then left unchanged and the caller restores a good state (SetState).
  virtual const char* Step(ConstVecRef tau, VecRef q, VecRef qd, VecRef qdd) = 0;
  virtual double kinetic_energy() const = 0;    // J, at the current state
  virtual double potential_energy() const = 0;  // J, at the current state
  // J: the work over the last Step of every force but tau (non-conservative:
  // springs are in V), by the trapezoid rule over the simulator's steps.
  virtual double other_work() const = 0;
  // Every term of the equation of motion at the current state (after a Step
  // or SetState), as the simulator computed it there, so that they add up to
  // its M(q) qdd under the force it applied (EffectForces: gravity, coriolis,
  // damping, friction, limits, constraint; `active` and `constraint_on` say
  // which the model has) and its contacts. tau_cmd, tau_applied and the
  // effects the simulator has not (disturbance, saturation) are the caller's.
  // `out` sized for this plant; no allocation.
  virtual void ComputeForces(EffectForces& out) = 0;
};

class SteppedPlantModel {
 public:
  virtual ~SteppedPlantModel() = default;
  virtual int num_dofs() const = 0;
  virtual const std::vector<std::string>& joint_names() const = 0;  // in q order
  virtual std::unique_ptr<SteppedPlantData> MakeData() const = 0;
};

// MujocoIntegrator, its names: base/vocabulary.hpp.

}  // namespace lagrange
