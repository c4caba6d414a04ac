#pragma once
// Joint-space controllers: PD, gravity compensation, computed torque.
// Error e = q_d − q (angles wrapped to (−π, π]), ė = qd_d − qd.

#include <memory>

#include "controllers/controller.hpp"

namespace lagrange {

struct PdOptions {
  bool velocity_feedforward = true;      // ė = qd_d − qd (else −qd: pure damping)
  bool acceleration_feedforward = false; // add M(q) qdd_d from the controller's model
  bool gravity_compensation = false;     // add G(q) from the controller's model
};

// Law:    tau = Kp e + Kd ė [+ M(q) qdd_d] [+ G(q)]
// Inputs: q, qd; setpoint (q_d, qd_d, qdd_d).
// Output: tau (n).
// State:  none.
// `model` may be null when neither model term is on.
class PdController final : public Controller {
 public:
  PdController(std::vector<JointType> joints, VectorXd torque_limits, Gains gains, PdOptions options,
               std::unique_ptr<Dynamics> model);
  std::string_view name() const override;
  bool SetGains(const Gains& gains) override;
  Gains gains() const override { return gains_; }

 protected:
  void ComputeLaw(double t, ConstVecRef q, ConstVecRef qd, const Setpoint& sp, VecRef tau) override;

 private:
  Gains gains_;
  PdOptions options_;
  std::unique_ptr<Dynamics> model_;
  MatrixXd M_;
  VectorXd e_, term_;
};

// Law:    tau = M(q) (qdd_d + Kd ė + Kp e) + C(q, qd) qd + G(q),
//         evaluated as the model's inverse dynamics at the commanded acceleration.
//         With an exact model the error obeys ë + Kd ė + Kp e = 0.
// Inputs: q, qd; setpoint (q_d, qd_d, qdd_d).
// Output: tau (n).
// State:  none. The model's parameters may differ from the plant's.
class ComputedTorqueController final : public Controller {
 public:
  ComputedTorqueController(std::vector<JointType> joints, VectorXd torque_limits, Gains gains,
                           std::unique_ptr<Dynamics> model);
  std::string_view name() const override { return "computed-torque"; }
  bool SetGains(const Gains& gains) override;
  Gains gains() const override { return gains_; }

 protected:
  void ComputeLaw(double t, ConstVecRef q, ConstVecRef qd, const Setpoint& sp, VecRef tau) override;

 private:
  Gains gains_;
  std::unique_ptr<Dynamics> model_;
  VectorXd a_;
};

// Law: tau = 0. For free-running plants.
class ZeroController final : public Controller {
 public:
  ZeroController(std::vector<JointType> joints, VectorXd torque_limits)
      : Controller(std::move(joints), std::move(torque_limits)) {}
  std::string_view name() const override { return "none"; }

 protected:
  void ComputeLaw(double, ConstVecRef, ConstVecRef, const Setpoint&, VecRef tau) override { tau.setZero(); }
};

}  // namespace lagrange
