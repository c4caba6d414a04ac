#pragma once
// The controller contract.
//
// Inputs:  t (s), measured q, qd (n each), setpoint (q_d, qd_d, qdd_d).
// Output:  tau (n), N·m or N, after the torque limits: |tau_i| <= limit_i.
// Faults:  a controller never outputs a non-finite number. If its law yields
//          one, Compute returns false and tau is all zeros; the caller treats
//          the instance as faulted.
// State:   any internal state is reset by Reset().
//
// Controllers are math only: no I/O, no threads. Those that need M, C or G
// call their own plant model instance (its parameters may differ from the
// simulated plant's); they never re-derive the dynamics. Every buffer is
// allocated at construction: Compute allocates nothing.

#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <utility>

#include "controllers/trajectory.hpp"
#include "plant/dynamics.hpp"
#include "plant/effects.hpp"

namespace lagrange {

// e = desired − measured, wrapped to (−π, π] when `wrap` (a joint that turns
// freely: the short way round is the right way), else the plain difference.
double JointError(bool wrap, double desired, double measured);
// The same with wrap = (type is revolute): the error of a joint without stops.
double JointError(JointType type, double desired, double measured);

// Which joints' errors wrap (n): a revolute joint whose stops `limits` leave
// unbounded on both sides (lower = −inf and upper = +inf, or no limits at
// all) turns freely and wraps; a revolute joint with a finite stop on either
// side, and every prismatic joint, does not: its setpoint is reached the way
// the stops allow, however far (a Panda's ±2.9 rad joint from −2 to +2 goes
// through 0, not through the stop at −2.9).
std::vector<bool> WrappedJoints(const std::vector<JointType>& joints, const std::optional<JointLimits>& limits);

// Proportional and derivative gains, one per joint (or per state for
// LQR-family controllers, or per task axis for task-space ones).
struct Gains {
  VectorXd kp;
  VectorXd kd;
};

// What gains a controller accepts: sizes n, finite, a sign rule, and upper
// bounds |Kp_i| <= kp_max_i, |Kd_i| <= kd_max_i that come from the tick h
// (a law evaluated once per h under zero-order hold cannot use more; each
// controller's header states its rule). Computed once at configure time
// (ComputeGainBounds, controllers/factory.hpp); +inf where there is no bound.
//
// A rule may give a second box, per joint (PD on a robot whose joints' inertias
// differ widely, see ComputeGainBounds): kp is accepted within either box, and
// so is kd, each on its own.
struct GainBounds {
  bool any_sign = false;  // false: every gain >= 0
  VectorXd kp_max;        // (n), the units of Kp
  VectorXd kd_max;        // (n), the units of Kd
  std::string kp_rule;    // how kp_max was derived, for messages: "Kp·h² <= 1 at h = 0.001 s"
  std::string kd_rule;
  VectorXd kp_max_per_joint;  // (n) the second box; empty: none
  VectorXd kd_max_per_joint;  // (n)
  std::string kp_rule_per_joint;
  std::string kd_rule_per_joint;
  // The gains are per task axis (x, y, z, rx, ry, rz: a task-space
  // controller's, controllers/task_space.hpp), not per joint: kp_max and
  // kd_max then have 6 entries.
  bool task_axes = false;

  // How many gains: one per joint, or 6 with task_axes.
  int num_dofs() const { return static_cast<int>(kp_max.size()); }
  // Non-negative gains of any size on n joints.
  static GainBounds Unbounded(int n);
  // Non-negative gains of any size on the 6 task axes.
  static GainBounds UnboundedTask();
};

// The first way `gains` break `bounds`, found without allocating.
struct GainFault {
  enum class Kind : std::uint8_t { kSize, kNotFinite, kSign, kAboveBound } kind;
  bool kd;    // in kd (else kp)
  int index;  // the offending gain (kAboveBound), else -1
};
std::optional<GainFault> FindGainFault(const Gains& gains, const GainBounds& bounds);
// "kp: expected ..." for a fault FindGainFault found in `gains`.
std::string DescribeGainFault(const GainFault& fault, const Gains& gains, const GainBounds& bounds);

class Controller {
 public:
  // torque_limits (n): |tau_i| <= limit_i after the law; +inf for none.
  Controller(std::vector<JointType> joints, VectorXd torque_limits);
  virtual ~Controller() = default;
  Controller(const Controller&) = delete;
  Controller& operator=(const Controller&) = delete;

  int num_dofs() const { return static_cast<int>(joints_.size()); }
  const std::vector<JointType>& joint_types() const { return joints_; }
  // Which joints' errors wrap to (−π, π] (WrappedJoints); default: the
  // revolute ones. Set once at configure time by MakeController (from
  // ControllerConfig::wrap); throws std::invalid_argument unless n entries.
  const std::vector<bool>& wrapped_joints() const { return wrap_; }
  void set_wrapped_joints(std::vector<bool> wrap);
  const VectorXd& torque_limits() const { return torque_limits_; }
  virtual std::string_view name() const = 0;

  // (t, q, qd, setpoint) => tau, limited. False (tau = 0) when the law is not finite.
  bool Compute(double t, ConstVecRef q, ConstVecRef qd, const Setpoint& sp, VecRef tau);
  // The same for a robot on a floating base, whose pose and twist are given
  // too: base_q (7: p (m), quaternion x, y, z, w) and base_v (6: v_b (m/s),
  // ω_b (rad/s), base axes), the free-flyer conventions (plant/rigid_tree.hpp).
  // A law that needs them reads them (the stance PD, controllers/stance_pd.hpp);
  // every other law ignores them and acts on the joints as Compute does.
  bool Compute(double t, ConstVecRef base_q, ConstVecRef base_v, ConstVecRef q, ConstVecRef qd, const Setpoint& sp,
               VecRef tau);
  virtual void Reset() {}

  // Replaces the gains without allocating (safe in the tick). False, and
  // nothing changed, when the controller has no gains or they break its
  // gain_bounds(); CheckGains (controllers/factory.hpp) says why, off the tick.
  bool SetGains(const Gains& gains);
  virtual Gains gains() const { return {}; }
  virtual bool has_gains() const { return false; }

  // The gains this controller accepts (default: non-negative, unbounded).
  // Set once at configure time by MakeController; read-only afterwards, so
  // another thread may read it while the loop runs.
  const GainBounds& gain_bounds() const { return gain_bounds_; }
  void set_gain_bounds(GainBounds bounds) { gain_bounds_ = std::move(bounds); }

 protected:
  virtual void ComputeLaw(double t, ConstVecRef q, ConstVecRef qd, const Setpoint& sp, VecRef tau) = 0;
  // The law on a floating base (Compute's second form); default: the joints' law, the base ignored.
  virtual void ComputeFloatingLaw(double t, ConstVecRef /*base_q*/, ConstVecRef /*base_v*/, ConstVecRef q,
                                  ConstVecRef qd, const Setpoint& sp, VecRef tau) {
    ComputeLaw(t, q, qd, sp, tau);
  }
  // Copies gains that passed gain_bounds() into the law, without allocating.
  virtual void ApplyGains(const Gains&) {}
  // Joint i's error q_d − q under wrapped_joints().
  double Error(int i, double desired, double measured) const {
    return JointError(static_cast<bool>(wrap_[static_cast<std::size_t>(i)]), desired, measured);
  }

 private:
  // tau within the torque limits; false (tau = 0) when it is not finite.
  bool Limit(VecRef tau) const;

  std::vector<JointType> joints_;
  std::vector<bool> wrap_;  // (n)
  VectorXd torque_limits_;
  GainBounds gain_bounds_;
};

}  // namespace lagrange
