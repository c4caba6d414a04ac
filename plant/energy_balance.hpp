#pragma once
// The energy-balance residual: how far a simulated run is from the work
// theorem, tick by tick.
//
//   ε(t_k) = E(t_k) − E(0) − W(t_k),    E = T + V  (PlantModel::Energy)
//   W(t_k) = Σ_j h_j/2 (P_j(t_j) + P_j(t_j+1))        trapezoid rule per tick
//            (AddTickWithWork: a command held over tick j does exactly
//            tau_j·(q(t_j+1) − q(t_j)); only the rest goes through the rule)
//   P_j    = qdᵀ (tau_applied + disturbance + damping + friction + limits − limit_springs)
//
// (EffectForces' terms; NonConservativePower computes P). V holds gravity's
// potential (when gravity is on) and the limit springs' energy, so neither
// appears in P; the stops' dampers do. P_j is the power under tick j's command
// (held over the tick, or the ControlLaw along it): at a tick's start and end
// both, so a command that changes between ticks is never mixed into the tick
// before it. A held command costs one ComputeEffectForces per tick: the power
// at the next tick's start differs from this tick's end only by
// qdᵀ (tau_applied_next − tau_applied).
//
// What ε tells. Along the exact flow dE/dt = P (the plant is Lagrangian; see
// plant_model.hpp), so for exact integration ε is the trapezoid rule's error
// only, whatever the controller or the effects do: the work of the torque and
// of dissipation is taken out. What remains is
//   - the integrator's energy drift, O(h^p) or better for a method of order
//     p (RK4 on a free pendulum: h^4.8, 1e-12 J over 10 s at 1 ms);
//   - the quadrature error, −h³/12 P''(ξ) per tick, O(h²) over a run:
//     bounded in estimate by quadrature_bound(). When |ε| is well above
//     quadrature_bound(), the integrator is losing or making energy;
//   - the caller's own hold error, if its powers are not those of the command
//     actually held (taking a tick's end power with the next command adds
//     O(h qd Δtau) per tick).
// What ε cannot tell. Errors that keep the energy: a phase error (a pendulum
// late on its orbit), an error along a level set of E, momentum drift. A
// discontinuity inside a tick (a push that starts or ends mid-tick, a
// ControlLaw that saturates mid-tick) makes the trapezoid error O(h × jump),
// which quadrature_bound() does not bound. With the Coriolis terms switched
// off the plant is not Lagrangian (dE/dt gains ½ qdᵀ Ṁ qd) and ε grows by
// that power, not by any integration error.
//
// The quadrature bound. P'' of tick k is estimated from the last two ticks'
// slopes, each under its own command:
//   s_k = (P_k(t_k+1) − P_k(t_k)) / h_k,   P''_k ≈ (s_k − s_k−1) / (½ (h_k + h_k−1))
// which, when the command does not change, is the second difference of the
// last three power samples (/h² for equal ticks); jumps of the command
// between ticks cancel. quadrature_bound() = Σ_k |h_k³/12 P''_k| (the first
// tick takes the second's estimate). An estimate of the worst case, not a
// rigorous bound; measured (tests/plant/energy_balance_test.cpp):
//   - smooth P (no command, damping): it equals Σ_k |tick k's trapezoid error|
//     within 1 %; the signed ε is far smaller, since the composite error
//     telescopes to h²/12 (P'(T) − P'(0));
//   - a command held over each tick: consecutive slopes also differ by the
//     command's change (q̈ᵀ Δtau, O(h)), which is in neither tick's error, so
//     it runs high (6 × |ε| for arm2 under PD 20/2 at 1 ms);
//   - it needs ticks that resolve P: at ω h ≈ 0.2 (the same arm and law, as
//     a ControlLaw along 10 ms ticks) |ε| of an exact integration exceeded it
//     by 40 %; and a discontinuity inside a tick escapes it (see above).

#include <cstdint>

#include "plant/plant_model.hpp"

namespace lagrange {

// qdᵀ (tau_applied + disturbance + damping + friction + limits − limit_springs), W:
// the power of every force whose energy V does not hold.
double NonConservativePower(ConstVecRef qd, const EffectForces& forces);
// (q_end − q_start)ᵀ (the same forces), J: their work over a step that holds
// them (a floating base's joints' forces, held over each sub-step): exact,
// whatever the path. The stops' springs are left out as above (their energy is
// in V), so while a joint is past a stop the spring's hold error, O(k Δq²) per
// step, shows in ε.
double HeldWork(ConstVecRef q_start, ConstVecRef q_end, const EffectForces& forces);

class EnergyBalance {
 public:
  // Starts over at E(0) = energy, J: ε, W and the bound zero.
  void Reset(double energy);

  // The energy function changed under the run (an effect switched on or off:
  // V gained or lost a term): E is now `energy` at the same state. E(0) moves
  // by the jump, so ε, W and the bound run on continuously; the next tick
  // adds nothing to the bound (its power's slope before the switch is of
  // another function).
  void Rebase(double energy);

  // One tick of length h > 0, s: the non-conservative power at its start and
  // at its end under the tick's command, W, and the energy at its end, J.
  void AddTick(double h, double power_start, double power_end, double energy_end);
  // The same, with the command's work over the tick known exactly: a command
  // held over a tick does tau_applied·(q(t+h) − q(t)) whatever the path, J.
  // Only the rest's power (disturbance, damping, friction, the stops'
  // dampers) at the tick's start and end goes through the trapezoid rule and
  // into quadrature_bound(), so a held command adds no quadrature error: ε is
  // then the integrator's, down to round-off (RK4 on the swinging arm under
  // computed torque, 3 s at 1 ms: 7e-6 J by the trapezoid rule, 1e-11 J so).
  void AddTickWithWork(double h, double command_work, double rest_start, double rest_end, double energy_end);

  double residual() const { return energy_ - energy0_ - work_; }  // ε, J
  double energy_change() const { return energy_ - energy0_; }     // E − E(0), J
  double work() const { return work_; }                           // W, J
  double quadrature_bound() const { return quadrature_bound_; }   // J
  std::int64_t ticks() const { return ticks_; }

 private:
  double energy0_ = 0.0;
  double energy_ = 0.0;
  double work_ = 0.0;
  double quadrature_bound_ = 0.0;
  double last_slope_ = 0.0;   // W/s, the previous tick's
  double last_h_ = 0.0;       // s
  bool slope_known_ = false;  // last_slope_ is of the current power function (false after Rebase)
  std::int64_t ticks_ = 0;
};

}  // namespace lagrange
