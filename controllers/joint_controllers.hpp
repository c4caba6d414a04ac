#pragma once
// Joint-space controllers: PD, gravity compensation, computed torque.
// Error e = q_d − q (angles wrapped to (−π, π]), ė = qd_d − qd.

#include <memory>

#include "controllers/controller.hpp"

namespace lagrange {

struct PdOptions {
  bool velocity_feedforward = true;       // ė = qd_d − qd (else −qd: pure damping)
  bool acceleration_feedforward = false;  // add M(q) qdd_d from the controller's model
  bool gravity_compensation = false;      // add G(q) from the controller's model
};

// Law:    tau = Kp e + Kd ė [+ M(q) qdd_d] [+ G(q)]
// Gains:  Kp_i N·m/rad (N/m), Kd_i N·m·s/rad (N·s/m), >= 0. Bounded by what a
//         law held over the tick h can use (ComputeGainBounds): with w_i
//         either λ, the smallest eigenvalue of M(q0) (kg·m² or kg) at the
//         initial state, for every joint, or M_ii(q0) / λmax(M⁻¹ diag M)
//         per joint (gains within either box are accepted),
//           Kp_i <= w_i / h²,   Kd_i <= 2 w_i / h,
//         so every mode of M⁻¹Kp h² and M⁻¹Kd h stays within 1 and 2, the
//         limits of the computed-torque law below. (A per-joint M_ii alone
//         is not enough: the coupling of M gives M⁻¹ diag(M) eigenvalues
//         above 1, 6.9 for the default arm at (π/4, 0).) At the bound itself
//         the discrete loop is marginally stable; it is where a PD stops
//         being usable, not a tuning.
// Inputs: q, qd; setpoint (q_d, qd_d, qdd_d).
// Output: tau (n).
// State:  none.
// `model` may be null when neither model term is on.
class PdController final : public Controller {
 public:
  PdController(std::vector<JointType> joints, VectorXd torque_limits, Gains gains, PdOptions options,
               std::shared_ptr<const Dynamics> model);
  std::string_view name() const override;
  Gains gains() const override { return gains_; }
  bool has_gains() const override { return true; }

 protected:
  void ComputeLaw(double t, ConstVecRef q, ConstVecRef qd, const Setpoint& sp, VecRef tau) override;
  void ApplyGains(const Gains& gains) override;

 private:
  Gains gains_;
  PdOptions options_;
  std::shared_ptr<const Dynamics> model_;  // shared, immutable (plant/dynamics.hpp)
  std::unique_ptr<DynamicsData> data_;     // this controller's data for it
  MatrixXd M_;
  VectorXd e_, term_;
};

// Law:    tau = M(q) (qdd_d + Kd ė + Kp e) + C(q, qd) qd + G(q),
//         evaluated as the model's inverse dynamics at the commanded acceleration.
//         With an exact model the error obeys ë + Kd ė + Kp e = 0.
// Gains:  Kp_i 1/s², Kd_i 1/s, >= 0. Bounded by the tick h with no plant mass
//         (ComputeGainBounds): Kp_i h² <= 1 and Kd_i h <= 2. The error held
//         over one tick is e⁺ = (1 − Kp h²/2) e + (1 − Kd h/2) h ė,
//         h ė⁺ = −Kp h² e + (1 − Kd h) h ė: Kd h = 2 puts an eigenvalue at −1
//         (the loop rings at the tick rate) and Kp h² beyond O(1) overshoots
//         the setpoint in one tick.
// Inputs: q, qd; setpoint (q_d, qd_d, qdd_d).
// Output: tau (n).
// State:  none. The model's parameters may differ from the plant's.
class ComputedTorqueController final : public Controller {
 public:
  ComputedTorqueController(std::vector<JointType> joints, VectorXd torque_limits, Gains gains,
                           std::shared_ptr<const Dynamics> model);
  std::string_view name() const override { return "computed-torque"; }
  Gains gains() const override { return gains_; }
  bool has_gains() const override { return true; }

 protected:
  void ComputeLaw(double t, ConstVecRef q, ConstVecRef qd, const Setpoint& sp, VecRef tau) override;
  void ApplyGains(const Gains& gains) override;

 private:
  Gains gains_;
  std::shared_ptr<const Dynamics> model_;  // shared, immutable (plant/dynamics.hpp)
  std::unique_ptr<DynamicsData> data_;     // this controller's data for it
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
