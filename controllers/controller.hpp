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

#include "controllers/setpoint.hpp"
#include "plant/dynamics.hpp"

namespace lagrange {

// Angle error wrapped to (−π, π] for revolute joints; plain difference for prismatic ones.
double JointError(JointType type, double desired, double measured);

// Proportional and derivative gains, one per joint (or per state for LQR-family controllers).
struct Gains {
  VectorXd kp;
  VectorXd kd;
};

class Controller {
 public:
  // torque_limits (n): |tau_i| <= limit_i after the law; +inf for none.
  Controller(std::vector<JointType> joints, VectorXd torque_limits);
  virtual ~Controller() = default;
  Controller(const Controller&) = delete;
  Controller& operator=(const Controller&) = delete;

  int num_dofs() const { return static_cast<int>(joints_.size()); }
  const std::vector<JointType>& joint_types() const { return joints_; }
  const VectorXd& torque_limits() const { return torque_limits_; }
  virtual std::string_view name() const = 0;

  // (t, q, qd, setpoint) => tau, limited. False (tau = 0) when the law is not finite.
  bool Compute(double t, ConstVecRef q, ConstVecRef qd, const Setpoint& sp, VecRef tau);
  virtual void Reset() {}

  // Replaces the gains without allocating (safe in the tick). False, and
  // nothing changed, when the controller has no gains or they do not fit;
  // CheckGains (controllers/factory.hpp) says why, off the tick.
  virtual bool SetGains(const Gains& gains);
  virtual Gains gains() const { return {}; }

 protected:
  virtual void ComputeLaw(double t, ConstVecRef q, ConstVecRef qd, const Setpoint& sp, VecRef tau) = 0;

 private:
  std::vector<JointType> joints_;
  VectorXd torque_limits_;
};

// Checks PD gains for n joints: sizes n, finite, >= 0.
std::optional<std::string> CheckJointGains(const Gains& gains, int n);
// The same check without a message, and without allocating.
bool ValidJointGains(const Gains& gains, int n);

}  // namespace lagrange
