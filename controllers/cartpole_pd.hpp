#pragma once
// The article's cart-pole PD exercise: a PD on both coordinates, applied as
// the cart force.

#include <vector>

#include "controllers/controller.hpp"

namespace lagrange {

// Law:    u = Kp_x (x_d − x) + Kd_x (ẋ_d − ẋ) + Kp_θ wrap(θ_d − θ) + Kd_θ (θ̇_d − θ̇);
//         tau = (u, 0).
//         Balancing upright needs Kp_θ, Kd_θ > 0 and Kp_x, Kd_x < 0: the cart
//         first moves away from its target to tip the pole back toward it.
// Gains:  kp = (Kp_x N/m, Kp_θ N/rad), kd = (Kd_x N·s/m, Kd_θ N·s/rad), any sign.
//         Bounded through the cart's force channel (ComputeGainBounds): with
//         M_xx = M(q0)_00 the mass the force accelerates and h the tick,
//         |Kp_j| <= M_xx / h² and |Kd_j| <= 2 M_xx / h.
// Inputs: q = (x, θ), qd; setpoint (q_d, qd_d).
// Output: tau (2).
// State:  none.
class CartPolePdController final : public Controller {
 public:
  CartPolePdController(std::vector<JointType> joints, VectorXd torque_limits, Gains gains);
  std::string_view name() const override { return "cartpole-pd"; }
  Gains gains() const override { return gains_; }
  bool has_gains() const override { return true; }

 protected:
  void ComputeLaw(double t, ConstVecRef q, ConstVecRef qd, const Setpoint& sp, VecRef tau) override;
  void ApplyGains(const Gains& gains) override;

 private:
  Gains gains_;
};

}  // namespace lagrange
