#pragma once
// Setpoints and the trajectory generators scenes, tests and demos use.
//
// A setpoint is the desired motion (q_d, qd_d, qdd_d), each (n), in the
// joint units of types.hpp. A trajectory yields one at any time t (s); it is
// built before the loop and Sample allocates nothing.

#include <memory>
#include <string_view>

#include "plant/types.hpp"

namespace lagrange {

struct Setpoint {
  VectorXd q;    // rad or m
  VectorXd qd;   // rad/s or m/s
  VectorXd qdd;  // rad/s² or m/s²

  explicit Setpoint(int n = 0) : q(VectorXd::Zero(n)), qd(VectorXd::Zero(n)), qdd(VectorXd::Zero(n)) {}
  int num_dofs() const { return static_cast<int>(q.size()); }
  bool AllFinite() const { return q.allFinite() && qd.allFinite() && qdd.allFinite(); }
};

class Trajectory {
 public:
  virtual ~Trajectory() = default;
  // t (s, time since the trajectory started) => setpoint.
  virtual void Sample(double t, Setpoint& out) const = 0;
  // Starts the motion over from (q, qd) (n each) where it started from the
  // scene's initial state: an external plant's controller starting on a
  // robot that is not where the scene assumed, as libfranka's motion
  // generators start from the measured state. What the scene fixed stays (a
  // hold's or a sine's explicit q or center, every target). Allocates nothing.
  virtual void StartFrom(ConstVecRef q, ConstVecRef qd) = 0;
  virtual std::string_view name() const = 0;
};

// q_d = q, at rest, forever; `follows_start`: StartFrom moves q there.
std::unique_ptr<Trajectory> MakeHold(const VectorXd& q, bool follows_start = false);

// q_d = from for t < at, target from t = at on; at rest.
std::unique_ptr<Trajectory> MakeStep(const VectorXd& from, const VectorXd& target, double at);

// q_d = center + amplitude ∘ sin(2π f t), with its derivatives. amplitude
// (rad or m), frequency f (Hz), center: each (n); `follows_start`: StartFrom
// moves the center there.
std::unique_ptr<Trajectory> MakeSine(const VectorXd& center, const VectorXd& amplitude, const VectorXd& frequency,
                                     bool follows_start = false);

// The minimum-jerk (quintic) path from (q0, qd0, qdd0) to (target, 0, 0) over
// `duration` s, then holding the target. With zero initial velocity and
// acceleration, q_d = q0 + (target − q0)(10 s³ − 15 s⁴ + 6 s⁵), s = t / duration.
std::unique_ptr<Trajectory> MakeMinimumJerk(const VectorXd& q0, const VectorXd& qd0, const VectorXd& qdd0,
                                            const VectorXd& target, double duration);

}  // namespace lagrange
