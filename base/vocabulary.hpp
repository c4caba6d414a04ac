#pragma once
// The wire's vocabulary: the names a scene, a command and a status use for
// integrators, effects, dynamics methods and controller types, and the
// numbers that size what the wire carries (joints, contacts, task axes). The
// plant, the controllers, the protocol and every front-end name these things
// by this one table, and the protocol (the bus's checks and its clients)
// needs no dynamics to check or word a command. The standard library alone.

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

namespace lagrange {

inline constexpr int kMaxDofs = 256;     // joints an instance may have; tested up to 64
inline constexpr int kMaxContacts = 32;  // contacts a forces record lists (forces_t.contacts)

// How the dynamics terms are derived.
enum class Method : std::uint8_t {
  kClosedForm,  // hand-derived M, C, G (pendulum, arm2, cartpole)
  kLagrangian,  // automatic differentiation of the energies T(q, qd), V(q)
  kRecursive,   // O(n) spatial recursions: RNEA, ABA, CRBA
};
std::string_view ToString(Method method);
std::optional<Method> ParseMethod(std::string_view name);
// "closed-form, lagrangian or recursive", for messages.
std::string MethodNames();

// The time integrators (plant/integrators.hpp).
enum class IntegratorType : std::uint8_t {
  kExplicitEuler,
  kSemiImplicitEuler,
  kRk4,
  kDormandPrince,
  kVariational,
};
std::string_view ToString(IntegratorType type);
std::optional<IntegratorType> ParseIntegratorType(std::string_view name);
// "explicit-euler|semi-implicit-euler|rk4|dopri5|variational"
std::string IntegratorTypeNames();

struct IntegratorConfig {
  IntegratorType type = IntegratorType::kRk4;
  int substeps = 1;           // equal sub-steps per call of Advance, >= 1
  double rtol = 1e-8;         // Dormand–Prince relative tolerance
  double atol = 1e-10;        // Dormand–Prince absolute tolerance
  int max_steps = 100000;     // Dormand–Prince internal steps per Step call
  // variational: Newton stops when |Δq|∞ <= tol·(1 + |q|∞); on a floating base a step fails when its
  // residual stops decreasing above tol times the step's momenta (plant/floating_integrator.hpp)
  double newton_tol = 1e-13;
  int newton_max_iterations = 30;
};

// Why a config cannot be used (a static string), or null: substeps 1..1000,
// rtol and atol finite and > 0, max_steps 1..10000000, newton_tol finite and
// > 0, newton_max_iterations 1..1000. The scene reader and the run-time
// integrator command apply it alike.
const char* CheckIntegratorConfig(const IntegratorConfig& config);

// The integrators of a MuJoCo plant, as MuJoCo 2.2.2 has them (mjtIntegrator).
enum class MujocoIntegrator : std::uint8_t {
  kEuler,     // mjINT_EULER: semi-implicit Euler (velocity first, then position with the new velocity)
  kRk4,       // mjINT_RK4: the classic 4th-order Runge–Kutta, the force held over the step
  kImplicit,  // mjINT_IMPLICIT: implicit in velocity (damping and the velocity derivatives of passive forces)
};
// "euler", "semi-implicit-euler" (lagrange's name for the same method), "rk4", "implicit".
std::optional<MujocoIntegrator> ParseMujocoIntegrator(std::string_view name);
std::string_view ToString(MujocoIntegrator integrator);
// "euler (= semi-implicit-euler), rk4, implicit"
inline constexpr char kMujocoIntegratorNames[] = "euler (= semi-implicit-euler), rk4, implicit";

// The effects by name, for run-time switching (Effects::SetEnabled, plant/effects.hpp) and the wire.
enum class EffectKind : std::uint8_t { kGravity, kCoriolis, kDamping, kFriction, kLimits, kSaturation, kDisturbance };
inline constexpr int kNumEffectKinds = 7;
// "gravity", "coriolis", "damping", "friction", "limits", "saturation", "disturbance"
std::string_view ToString(EffectKind kind);
std::optional<EffectKind> ParseEffectKind(std::string_view name);
// "gravity|coriolis|damping|friction|limits|saturation|disturbance"
std::string EffectKindNames();

// Which stages of a scene run, resolved once from its EffectsConfig (plant/effects.hpp).
struct EffectFlags {
  bool gravity = false;      // G(q)
  bool coriolis = false;     // C(q, qd) qd
  bool damping = false;      // −b∘qd
  bool friction = false;     // −Fc∘tanh(qd/v_s)
  bool limits = false;       // tau_lim(q, qd)
  bool disturbance = false;  // pushes configured (whether one acts depends on t)
  bool saturation = false;   // sat(tau_cmd); off: tau_cmd passes as it is

  bool on(EffectKind kind) const;
};

// The flag of `kind` in `flags` (an EffectFlags, const or not).
template <class Flags>
auto& FlagOf(Flags& flags, EffectKind kind) {
  switch (kind) {
    case EffectKind::kGravity: return flags.gravity;
    case EffectKind::kCoriolis: return flags.coriolis;
    case EffectKind::kDamping: return flags.damping;
    case EffectKind::kFriction: return flags.friction;
    case EffectKind::kLimits: return flags.limits;
    case EffectKind::kSaturation: return flags.saturation;
    case EffectKind::kDisturbance: return flags.disturbance;
  }
  return flags.gravity;  // unreachable for a valid kind
}

// The control laws (controllers/factory.hpp).
enum class ControllerType : std::uint8_t {
  kNone,                 // tau = 0
  kPd,                   // joint PD
  kGravityCompensation,  // G(q) [+ PD]
  kComputedTorque,       // M (qdd_d + Kd ė + Kp e) + C qd + G
  kCartPolePd,           // the article's cart-pole PD on the cart force
  kLqr,                  // LQR about an equilibrium (cart-pole: upright)
  kSwingUp,              // energy swing-up handing over to LQR
  kExternal,             // the latest torque streamed over LCM (torque_t) [+ G(q)]
  kCartesianImpedance,   // Jᵀ (K e + D ė) + C qd + G + P τ0 on one frame's pose (task_space.hpp)
  kOperationalSpace,     // Jᵀ Λ (ẍ_d + Kd ė + Kp e − J̇qd) + C qd + G + P τ0 (task_space.hpp)
  kMpc,                  // clamp(ū_k + K_k (x − x̄_k)) of a receding-horizon box-DDP plan (controllers/mpc.hpp)
};
std::string_view ToString(ControllerType type);
std::optional<ControllerType> ParseControllerType(std::string_view name);
std::string ControllerTypeNames();  // "none|pd|gravity-compensation|..."
// cartesian-impedance and operational-space: a frame's pose is their target,
// their gains are per task axis (kTaskDims), and they are TaskSpaceControllers.
bool IsTaskSpace(ControllerType type);

// A task-space controller's gains are per task axis, in this order (Gains::kp, kd of size 6).
inline constexpr int kTaskDims = 6;  // x, y, z (m), rx, ry, rz (rad)

}  // namespace lagrange
