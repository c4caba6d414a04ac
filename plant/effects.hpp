#pragma once
// Effects a scene switches on or off. An effect that is off is never
// evaluated: each stage returns at its top when off and counts its runs.
//
// The generalized force on the joints besides gravity and Coriolis terms:
//   tau = sat(tau_cmd) + Σ pushes(t) − b∘qd − Fc∘tanh(qd/v_s) + tau_lim(q, qd)
//
//   sat        actuator saturation: clamp(tau_cmd, −tau_max, tau_max)
//   pushes     external generalized force: tau_push on [start, start + duration)
//   b          viscous joint damping, N·m·s/rad (N·s/m for prismatic joints)
//   Fc, v_s    Coulomb friction magnitude (N·m or N) regularised by tanh with
//              velocity scale v_s (rad/s or m/s): 76 % of Fc at |qd| = v_s,
//              99.9 % at 4 v_s; smooth, so every integrator can take it
//   tau_lim    joint limits as a stiff one-sided spring-damper (not a hard
//              stop): past the upper limit, tau = min(0, −k (q − upper) − d qd),
//              past the lower, tau = max(0, −k (q − lower) − d qd); it pushes out
//              and never pulls the joint into the stop
//
// Derivatives (ComputeGeneralizedForceDerivatives): every effect acts joint by
// joint, so ∂tau/∂q, ∂tau/∂qd and ∂tau/∂tau_cmd are diagonal:
//   sat        1 where |tau_cmd| <= tau_max (the bound itself included: the
//              clamp returns tau_cmd there), 0 beyond
//   pushes     none (they depend on t alone)
//   damping    −b on ∂/∂qd
//   friction   −(Fc/v_s)(1 − tanh²(qd/v_s)) on ∂/∂qd: smooth, exact everywhere
//              (its largest, −Fc/v_s, at qd = 0)
//   limits     −k on ∂/∂q and −d on ∂/∂qd where the stop pushes (past it, and
//              its force strictly nonzero); 0 elsewhere, at the kinks too: on
//              the limit itself and where the damper would pull, the force is
//              the zero branch and so is its derivative

#include <optional>
#include <vector>

#include "base/vocabulary.hpp"
#include "plant/types.hpp"

namespace lagrange {

struct CoulombFriction {
  VectorXd coulomb;              // Fc (n), >= 0
  double velocity_scale = 0.01;  // v_s, > 0
};

struct JointLimits {
  VectorXd lower;            // (n), rad or m; -inf for none
  VectorXd upper;            // (n), rad or m; +inf for none
  double stiffness = 1.0e4;  // k, N·m/rad (N/m), > 0
  double damping = 50.0;     // d, N·m·s/rad (N·s/m), >= 0
};

struct Push {
  double start = 0.0;     // s
  double duration = 0.0;  // s, > 0
  VectorXd tau;           // (n), N·m or N
};

// The effects by name (EffectKind) and which of them run (EffectFlags): base/vocabulary.hpp.
// Why `kind` cannot be switched on: its parameters are not given (a static
// string; the scene reader says it of effects.off, the effect command of "on").
const char* NotConfiguredReason(EffectKind kind);

struct EffectsConfig {
  bool gravity = true;
  bool coriolis = true;
  std::optional<VectorXd> damping;  // b (n), >= 0
  std::optional<CoulombFriction> friction;
  std::optional<JointLimits> limits;
  std::optional<VectorXd> saturation;  // tau_max (n), > 0
  std::vector<Push> disturbance;       // empty: off
  // Effects whose parameters are given above but which start off; a command
  // (Effects::SetEnabled) may turn them on. Scene key effects.off.
  std::vector<EffectKind> off;

  DynamicsTerms terms() const { return {gravity, coriolis}; }
};

// A problem with one effect key: `message` reads "expected ..., got ...".
struct EffectsError {
  std::string key;
  std::string message;
};

// Checks sizes against n and every range above, and that `off` names only
// Configured effects.
std::optional<EffectsError> ValidateEffects(const EffectsConfig& config, int n);

class Effects {
 public:
  Effects(EffectsConfig config, int n);

  const EffectsConfig& config() const { return config_; }
  // What is on now: the config's effects, less config().off, as switched since.
  DynamicsTerms terms() const { return terms_; }
  const EffectFlags& flags() const { return flags_; }

  // Whether `kind` can be switched on: gravity and Coriolis always; the
  // others when the config gives their parameters (disturbance: a push).
  bool Configured(EffectKind kind) const;
  // Turns one effect on or off at run time: flags(), terms() and
  // passes_command_through() follow, and every stage, DissipatedPower and
  // LimitPotentialEnergy obey the new flags. Allocates nothing. False, with
  // nothing changed, when turning on an effect that is not Configured (or for
  // a kind out of range).
  bool SetEnabled(EffectKind kind, bool on);
  // True when no stage below is on (no saturation, pushes, damping, friction
  // or limits): tau = tau_cmd exactly, and nothing here needs to run.
  bool passes_command_through() const { return passes_command_through_; }

  // (t, q, qd, tau_cmd) => tau, the sum above.
  void ComputeGeneralizedForce(double t, ConstVecRef q, ConstVecRef qd, ConstVecRef tau_cmd, VecRef tau);

  // (q, qd, tau_cmd) => the diagonals of ∂tau/∂q, ∂tau/∂qd and ∂tau/∂tau_cmd
  // (n each) of ComputeGeneralizedForce, as above: each effect that is on
  // adds its part; nothing is counted. Allocates nothing.
  void ComputeGeneralizedForceDerivatives(ConstVecRef q, ConstVecRef qd, ConstVecRef tau_cmd, VecRef dtau_dq,
                                          VecRef dtau_dqd, VecRef dtau_dcmd) const;

  // The stages, each adding its term to tau (saturation writes it).
  void Saturate(ConstVecRef tau_cmd, VecRef tau);
  void AddDisturbance(double t, VecRef tau);
  void AddDamping(ConstVecRef qd, VecRef tau);
  void AddFriction(ConstVecRef qd, VecRef tau);
  void AddLimits(ConstVecRef q, ConstVecRef qd, VecRef tau);
  // The same, also adding the limits' spring part, −k × penetration past a
  // stop (the force whose energy LimitPotentialEnergy is), to `springs`.
  // tau_lim − spring is what the one-sided damper does: it never adds energy.
  void AddLimits(ConstVecRef q, ConstVecRef qd, VecRef tau, VecRef springs);

  // Power taken out by damping, friction and the limits' dampers, W (>= 0).
  double DissipatedPower(ConstVecRef q, ConstVecRef qd) const;
  // Energy stored in the limit springs, J.
  double LimitPotentialEnergy(ConstVecRef q) const;

  const StageCounts& counts() const { return counts_; }

 private:
  EffectsConfig config_;
  DynamicsTerms terms_;  // flags_.gravity and flags_.coriolis
  EffectFlags flags_;    // resolved from config_ once, then as SetEnabled switched
  bool passes_command_through_;
  StageCounts counts_;
};

}  // namespace lagrange
