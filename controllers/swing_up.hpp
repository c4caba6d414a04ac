#pragma once
// Energy-based swing-up for a cart-pole (Åström & Furuta, 2000), handing over
// to a balancing controller (LQR) near upright.
//
// Law (swing-up mode), with the pole energy about its pivot
//   E = ½ M_θθ θ̇² + V(q),  E_up = V at upright (θ = π),
// and since dE/dt = −M_xθ θ̇ ẍ along the pole's own dynamics:
//   ẍ_d = sat_amax( k_E (E − E_up) sign(θ̇ cos θ) − k_x x − k_v ẋ )
// (sign(0) = +1 when the pole hangs at rest, so it starts from the bottom).
// The cart force that yields ẍ_d is found from the model's M, C qd and G
// (collocated partial feedback linearisation):
//   θ̈ = −(M_θx ẍ_d + c_θ + G_θ) / M_θθ,   u = M_xx ẍ_d + M_xθ θ̈ + c_x + G_x.
// Hand-over: balance once |wrap(θ − π)| < switch_angle and |θ̇| < switch_rate;
// back to swing-up if |wrap(θ − π)| > 2 switch_angle.
// Inputs: q = (x, θ), qd; the setpoint's x_d is passed to the balancer.
// Output: tau = (u, 0).
// State:  the mode (swinging or balancing); Reset() returns to swinging.

#include <memory>

#include "controllers/controller.hpp"

namespace lagrange {

struct SwingUpOptions {
  double energy_gain = 20.0;  // k_E, 1/(J·s)·m/s² scale: ẍ per joule of energy error
  double max_accel = 8.0;     // a_max, m/s²
  double cart_gain = 0.5;     // k_x, 1/s²
  double cart_damping = 1.0;  // k_v, 1/s
  double switch_angle = 0.3;  // rad
  double switch_rate = 2.0;   // rad/s
};

class SwingUpController final : public Controller {
 public:
  SwingUpController(std::vector<JointType> joints, VectorXd torque_limits, SwingUpOptions options,
                    std::shared_ptr<const Dynamics> model, std::unique_ptr<Controller> balancer);
  std::string_view name() const override { return "swing-up"; }
  void Reset() override { balancing_ = false; }
  bool balancing() const { return balancing_; }

 protected:
  void ComputeLaw(double t, ConstVecRef q, ConstVecRef qd, const Setpoint& sp, VecRef tau) override;

 private:
  SwingUpOptions options_;
  std::shared_ptr<const Dynamics> model_;  // shared, immutable (plant/dynamics.hpp)
  std::unique_ptr<DynamicsData> data_;     // this controller's data for it
  std::unique_ptr<Controller> balancer_;
  double energy_up_ = 0.0;
  bool balancing_ = false;
  MatrixXd M_;
  VectorXd c_, G_;
};

}  // namespace lagrange
