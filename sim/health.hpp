#pragma once
// The health rule of one step, in one place for the tick (daemon/runtime.cpp)
// and the offline runner (sim/offline.cpp, lagrangectl simulate). A step is
// a fault, named by the first rule it breaks, when
//   1. the step itself failed: the controller's output was not finite, or the
//      integrator failed its tolerance (Instance::StepFailure);
//   2. q, q̇ or q̈ is not finite;
//   3. T + V is not finite or |T + V| > max_energy (J; the scene's default,
//      MaxEnergy in sim/scene.hpp);
//   4. the scene bounds the energy-balance residual with on_exceed: fault,
//      and |ε| > energy_balance.bound (J). (With on_exceed: warn, exceeding
//      it is no fault: ResidualExceeds tells the caller to say so.)
// The reasons are static strings, so the tick reports them without formatting.

#include <cmath>

#include "sim/instance.hpp"

namespace lagrange {

// Arrays, not pointers to literals: one object each in every translation
// unit, so a reason can be compared by address (identical literals need not
// share one, and do not under AddressSanitizer).
inline constexpr char kStateNotFinite[] = "the state became non-finite";
inline constexpr char kEnergyOutOfBound[] = "the energy left its bound (max_energy)";
inline constexpr char kResidualOutOfBound[] = "the energy-balance residual left its bound (energy_balance.bound)";

// The energies the check computes, for the caller to record (computed once per step).
struct StepEnergies {
  double kinetic = 0.0;    // J
  double potential = 0.0;  // J, including the joint limits' springs
};

// |ε| of the instance's energy balance above `bound.bound` (a non-finite ε
// too); never without a bound or a balance.
inline bool ResidualExceeds(const Instance& instance, const EnergyBalanceBound& bound) {
  return std::isfinite(bound.bound) && instance.accounting() &&
         !(std::abs(instance.energy_balance().residual()) <= bound.bound);
}

// (step outcome, q, q̇, q̈, T + V, ε) => the fault, or null when the step is healthy.
// Fills `energies` whenever the state is finite.
inline const char* CheckStepHealth(Instance& instance, Instance::StepFailure step, double max_energy,
                                   const EnergyBalanceBound& residual, StepEnergies& energies) {
  if (step != nullptr) return step;
  if (!instance.q().allFinite() || !instance.qd().allFinite() || !instance.qdd().allFinite()) return kStateNotFinite;
  energies.kinetic = instance.KineticEnergy();
  energies.potential = instance.PotentialEnergy();
  const double energy = energies.kinetic + energies.potential;
  if (!std::isfinite(energy) || std::abs(energy) > max_energy) return kEnergyOutOfBound;
  if (residual.on_exceed == OnResidualExceeded::kFault && ResidualExceeds(instance, residual)) return kResidualOutOfBound;
  return nullptr;
}

}  // namespace lagrange
